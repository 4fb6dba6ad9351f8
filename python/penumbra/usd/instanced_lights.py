"""The lights in a point instancer's prototypes → one light sprim per copy.

Every copy of a prototype's light is a light of its own in the delegate (the light list, its
light tree and its sampling see each), read once from the prototype's light and placed where
its copy is. Updates re-send a light's inputs only when it was edited (or varies with time) and
a copy's transform only when it moved.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np
from pxr import Sdf, Usd

from .flattening import LightCopies
from .lights import light_transform, light_type, read_light
from .linking import leaves_something_out
from .sampling import SampleReader, Shutter


class InstancedLights:
    """The light sprims of one point instancer's copies; ids start with ``prefix`` (the
    instancer's path) and name the copy and the prototype's light."""

    def __init__(self, core, warn: Callable[[str], None], prefix: str):
        self.core = core
        self.warn = warn
        self.prefix = prefix
        self._sent: dict[str, np.ndarray] = {}  # light id → the transforms sent
        self._varying: set[Sdf.Path] = set()  # prototype lights whose inputs might vary

    def __len__(self) -> int:
        return len(self._sent)

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
            for copy in range(len(group.transforms)):
                wanted[f"{self.prefix}/lights/{copy}{group.light.GetPath()}"] = (group, copy)
        for light_id in [i for i in self._sent if i not in wanted]:
            self.core.remove_prim(light_id)
            del self._sent[light_id]
        read: dict[Sdf.Path, dict] = {}  # each prototype light read once for all its copies
        for light_id, (group, copy) in wanted.items():
            light, path = group.light, group.light.GetPath()
            new = light_id not in self._sent
            if new:
                self.core.insert_sprim(light_type(light), light_id)
            if (
                new
                or any(path.HasPrefix(p) for p in stale)
                or (time_changed and path in self._varying)
            ):
                if path not in read:
                    read[path] = self._read(light, shutter)
                self.core.set_light(light_id, **read[path])
            matrices = light_transform(light, group.transforms[copy])
            matrices = matrices[0] if len(matrices) == 1 else matrices
            sent = self._sent.get(light_id)
            if sent is None or sent.shape != matrices.shape or not np.array_equal(sent, matrices):
                self.core.set_transform(light_id, np.ascontiguousarray(matrices))
                self._sent[light_id] = matrices

    def clear(self) -> None:
        for light_id in self._sent:
            self.core.remove_prim(light_id)
        self._sent.clear()
        self._varying.clear()

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
