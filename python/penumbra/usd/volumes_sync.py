"""Reading dirty tracked UsdVolVolumes into the delegate's volume rprims, prim by prim: their
fields and material (:func:`~.volumes.sync_volume_data`), transforms over the shutter and
visibility, as points' are (render passes decide whether a volume is rendered; their matte and
camera-visibility collections do not apply to volumes).

A volume's data is read from other prims too: its field prims and its bound material (read
whole into the volume's material, not through the surface material registry). The syncer hears
of stage edits (it is one of the change tracker's listeners) and names the volumes whose
dependencies were edited (:meth:`VolumeSync.take_affected`), so that they are read again; a
change of binding re-reads the volume's data."""

from __future__ import annotations

from collections.abc import Callable, Iterable

from pxr import Sdf, Usd

from .core_batch import CoreBatch
from .inherited import InheritedState
from .material import bound_material
from .motion import XformCaches
from .prim_sync import OneByOneSync, SyncSettings
from .render_pass import RenderPassCollections
from .sampling import SampleReader
from .tracking import Dirty, Flush
from .volumes import sync_volume_data, volume_dependencies


class VolumeSync(OneByOneSync):
    """UsdVolVolumes, placed over the shutter."""

    moving = True

    def __init__(
        self,
        core,
        warn: Callable[[str], None],
        render_pass: RenderPassCollections | None,
        inherited: InheritedState,
    ):
        super().__init__(core, render_pass, inherited)
        self._warn = warn
        self._dependencies: dict[Sdf.Path, set[Sdf.Path]] = {}  # volume → prims it was read from
        self._edited: set[Sdf.Path] = set()

    def sync(
        self, prims: Flush, settings: SyncSettings, xform_caches: XformCaches, batch: CoreBatch
    ) -> None:
        # The bound material is part of the volume's data.
        prims.bits = [bits | Dirty.DATA if bits & Dirty.BINDING else bits for bits in prims.bits]
        super().sync(prims, settings, xform_caches, batch)

    def _read(
        self, path: Sdf.Path, path_str: str, prim: Usd.Prim, reader: SampleReader,
        settings: SyncSettings,
    ) -> bool:
        material = bound_material(prim)
        self._dependencies[path] = volume_dependencies(prim, material)
        return sync_volume_data(self.core, prim, material, reader, self._warn, path_str)

    def note_changes(self, resynced: Iterable[Sdf.Path], changed: Iterable[Sdf.Path]) -> None:
        """Note the prims edited (a change tracker's listener)."""
        self._edited.update(path.GetPrimPath() for path in (*resynced, *changed))

    def take_affected(self) -> list[Sdf.Path]:
        """The volumes read from prims edited since the last call (at, below or above them)."""
        edited, self._edited = self._edited, set()
        if not edited:
            return []
        return sorted(
            volume
            for volume, dependencies in self._dependencies.items()
            if any(e.HasPrefix(d) or d.HasPrefix(e) for e in edited for d in dependencies)
        )

    def forget(self, path: Sdf.Path) -> None:
        """Volume ``path`` is no longer tracked."""
        self._dependencies.pop(path, None)
