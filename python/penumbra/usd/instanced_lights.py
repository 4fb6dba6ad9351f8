"""The lights in a point instancer's prototypes → one light sprim per copy.

Every copy of a prototype's light is a light of its own in the delegate (the light list, its
light tree and its sampling see each), read once from the prototype's light and placed where
its copy is at the frame (as lights are: they do not blur). Updates re-send a light's inputs
only when it was edited (or varies with time) and a copy's transform only when it moved. Dome
lights in prototypes are left out: a dome has no place to be copied to.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np
from pxr import Sdf, Usd

from .flattening import LightCopies
from .lights import light_transform, light_type, read_light, uneven_scale_problem
from .linking import leaves_something_out
from .sampling import SampleReader, Shutter


class InstancedLights:
    """The light sprims of one point instancer's copies; ids start with ``prefix`` (the
    instancer's path) and name the copy and the prototype's light."""

    def __init__(self, core, warn: Callable[[str], None], prefix: str):
        self.core = core
        self.warn = warn
        self.prefix = prefix
        self._sent: dict[str, np.ndarray] = {}  # light id → the transform sent
        self._types: dict[str, str] = {}  # light id → its sprim type
        self._varying: set[Sdf.Path] = set()  # prototype lights whose inputs might vary

    @property
    def varying(self) -> bool:
        """Whether some light's inputs might change with time."""
        return bool(self._varying)

    def update(
        self,
        copies: list[LightCopies],
        shutter: Shutter,
        stale: Iterable[Sdf.Path] = (),
        time_changed: bool = False,
    ) -> None:
        """Make the delegate hold exactly the lights of ``copies``: new ones inserted and read,
        those below a ``stale`` path (and, when ``time_changed``, those that vary) read again,
        moved ones placed again."""
        stale = list(stale)
        wanted: dict[str, tuple[LightCopies, int]] = {}
        for group in copies:
            if light_type(group.light) == "domeLight":
                self.warn(
                    f"{group.light.GetPath()}: dome lights in point-instancer prototypes are not "
                    "copied; skipped"
                )
                continue
            for copy in range(len(group.transforms)):
                light_id = f"{self.prefix}/lights/{group.prototype}/{copy}{group.path}"
                wanted[light_id] = (group, copy)
        for light_id in [i for i in self._types if i not in wanted]:
            self._remove(light_id)
        read: dict[Sdf.Path, dict] = {}  # each prototype light read once for all its copies
        unevenly_scaled: set[Sdf.Path] = set()  # said once for all its copies
        for light_id, (group, copy) in wanted.items():
            light, path = group.light, group.light.GetPath()
            sprim_type = light_type(light)
            if self._types.get(light_id) != sprim_type:  # new, or of another type now
                if light_id in self._types:
                    self._remove(light_id)
                self.core.insert_sprim(sprim_type, light_id)
                self._types[light_id] = sprim_type
            if (
                light_id not in self._sent
                or any(path.HasPrefix(p) or group.path.HasPrefix(p) for p in stale)
                or (time_changed and path in self._varying)
            ):
                if path not in read:
                    read[path] = self._read(light, shutter)
                self.core.set_light(light_id, **read[path])
            matrix = light_transform(light, group.transforms[copy])[0]
            sent = self._sent.get(light_id)
            if sent is None or not np.array_equal(sent, matrix):
                self.core.set_transform(light_id, np.ascontiguousarray(matrix))
                self._sent[light_id] = matrix
                problem = uneven_scale_problem(light, matrix)
                if problem is not None and path not in unevenly_scaled:
                    unevenly_scaled.add(path)
                    self.warn(f"{problem} (in its copies by {self.prefix})")

    def clear(self) -> None:
        for light_id in list(self._types):
            self._remove(light_id)
        self._varying.clear()

    def _remove(self, light_id: str) -> None:
        self.core.remove_prim(light_id)
        self._sent.pop(light_id, None)
        self._types.pop(light_id, None)

    def _read(self, light: Usd.Prim, shutter: Shutter) -> dict:
        """The inputs of a prototype's light (its warnings said once for all its copies)."""
        reader = SampleReader(shutter.frame)
        params = read_light(light, reader, self.warn)
        if reader.varying:
            self._varying.add(light.GetPath())
        else:
            self._varying.discard(light.GetPath())
        if leaves_something_out(light):
            self.warn(
                f"{light.GetPath()}: the light and shadow links of lights in point-instancer "
                "prototypes are not supported yet; its copies light and shadow everything"
            )
        return params
