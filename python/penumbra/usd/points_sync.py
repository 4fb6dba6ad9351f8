"""Reading dirty tracked UsdGeomPoints into the delegate's points rprims, prim by prim: their
data (:func:`~.points.sync_points_data`), transforms and positions over the shutter,
visibility (and render-pass visibility) and material binding, acquired from the
:class:`~.material_registry.MaterialRegistry` as meshes' are."""

from __future__ import annotations

from collections.abc import Callable

from pxr import Sdf, Usd

from .core_batch import CoreBatch
from .inherited import InheritedState
from .material import bound_materials
from .material_registry import MaterialRegistry
from .motion import XformCaches
from .points import sync_points_data
from .prim_sync import OneByOneSync, SyncSettings
from .ray_visibility import ShownSender
from .render_pass import RenderPassCollections
from .sampling import SampleReader
from .skinning import SkelCaches
from .tracking import Dirty, Flush


class PointsSync(OneByOneSync):
    """UsdGeomPoints, sampled over the shutter."""

    moving = True

    def __init__(
        self,
        core,
        warn: Callable[[str], None],
        render_pass: RenderPassCollections | None,
        inherited: InheritedState,
        materials: MaterialRegistry,
    ):
        super().__init__(core, render_pass, inherited)
        self._warn = warn
        self._materials = materials
        self._shown = ShownSender(core, render_pass, inherited)
        self._skel_caches = SkelCaches()  # of the sync under way

    def sync(
        self, prims: Flush, settings: SyncSettings, xform_caches: XformCaches, batch: CoreBatch
    ) -> None:
        self._skel_caches = SkelCaches()  # the skeletons may have changed since the last sync
        super().sync(prims, settings, xform_caches, batch)
        binding = [
            n
            for n, bits in enumerate(prims.bits)
            if bits & Dirty.BINDING and prims.records[n].in_core
        ]
        for n, material in zip(binding, bound_materials([prims.prims[n] for n in binding])):
            record = prims.records[n]
            material_id = self._materials.bind(prims.paths[n], record.material, material)
            record.material = "" if material is None else str(material)
            batch.set_mesh_material(prims.ids[n], material_id)
        for n, path in enumerate(prims.paths):
            if prims.bits[n] & Dirty.VISIBILITY and prims.records[n].in_core:
                self._shown.send(prims.ids[n], prims.prims[n], path)

    def _read(
        self, path: Sdf.Path, path_str: str, prim: Usd.Prim, reader: SampleReader,
        settings: SyncSettings,
    ) -> bool:
        return sync_points_data(self.core, prim, reader, self._warn, path_str, self._skel_caches)
