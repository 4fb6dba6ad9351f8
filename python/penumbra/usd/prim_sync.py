"""Reading dirty tracked prims into the delegate, one syncer per kind of prim.

A flush hands each syncer the dirty prims of its kind (:class:`~.tracking.Flush`, in path
order) with what they are read for (:class:`SyncSettings`): :class:`CameraSync` and
:class:`LightSync` here read sprims one by one through :func:`~.camera.sync_camera` and
:func:`~.lights.sync_light`; :class:`~.mesh_sync.MeshSync` reads meshes in batches.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from pxr import Sdf, Usd, UsdLux

from .camera import sync_camera
from .core_batch import CoreBatch
from .inherited import InheritedState
from .lights import light_transform, sync_light, uneven_scale_problem
from .motion import XformCaches, transform_samples
from .render_pass import RenderPassCollections
from .sampling import SampleReader, Shutter
from .settings import FilmWindow
from .tracking import Dirty, Flush, TrackedPrim, set_flag


@dataclass(frozen=True)
class SyncSettings:
    """What an update reads prims for."""

    time: Usd.TimeCode  # the frame
    shutter: Shutter  # the interval moving prims (meshes, cameras) are sampled over
    depth_of_field: bool  # False: cameras are pinholes
    dome_light_visibility: bool  # False: dome lights are hidden from camera rays
    film_windows: dict[str, FilmWindow]  # camera path → part of its film the image covers


class PrimSync(Protocol):
    """Reads the dirty aspects of tracked prims of one kind (inserted in the delegate) and
    queues them in a batch."""

    def sync(
        self, prims: Flush, settings: SyncSettings, xform_caches: XformCaches, batch: CoreBatch
    ) -> None: ...


class OneByOneSync:
    """Prims read one by one (cameras, lights, points): their data, transforms and visibility
    queued."""

    moving = False  # sampled over the shutter (else at the frame)

    def __init__(self, core, render_pass: RenderPassCollections | None, inherited: InheritedState):
        self.core = core
        self.render_pass = render_pass
        self._inherited = inherited

    def sync(
        self, prims: Flush, settings: SyncSettings, xform_caches: XformCaches, batch: CoreBatch
    ) -> None:
        for n, path in enumerate(prims.paths):
            self._sync_prim(
                path, prims.ids[n], prims.prims[n], prims.records[n], prims.bits[n], settings,
                xform_caches, batch,
            )

    def _read(
        self, path: Sdf.Path, path_str: str, prim: Usd.Prim, reader: SampleReader,
        settings: SyncSettings,
    ) -> bool:
        """Push the prim's data; ``False`` when it is unusable."""
        raise NotImplementedError

    def _placement(self, prim: Usd.Prim, matrices: np.ndarray) -> np.ndarray:
        """The transform samples the delegate places ``prim`` by: its local-to-world ones."""
        return matrices

    def _placement_reads_data(self, prim: Usd.Prim) -> bool:
        """Whether :meth:`_placement` of ``prim`` depends on its data (an edit of the data
        then sends the transform again)."""
        return False

    def _sync_prim(
        self,
        path: Sdf.Path,
        path_str: str,
        prim: Usd.Prim,
        record: TrackedPrim,
        bits: int,
        settings: SyncSettings,
        xform_caches: XformCaches,
        batch: CoreBatch,
    ) -> None:
        """Read the aspects ``bits`` of the tracked prim at ``path`` (delegate id ``path_str``)
        and queue them in ``batch``."""
        shutter = settings.shutter if self.moving else Shutter(settings.time)
        if bits & Dirty.DATA and self._placement_reads_data(prim):
            bits |= Dirty.TRANSFORM
        if bits & Dirty.DATA:
            reader = SampleReader(settings.time, shutter)
            if not self._read(path, path_str, prim, reader, settings):
                self.core.remove_prim(path_str)
                record.in_core = False
                return
            record.varying = set_flag(record.varying, Dirty.DATA, reader.varying)
        if bits & Dirty.TRANSFORM:
            batch.set_transform(
                path_str, self._placement(prim, transform_samples(prim, shutter, xform_caches))
            )
            record.varying &= ~Dirty.TRANSFORM
            record.unknown |= Dirty.TRANSFORM
        if bits & Dirty.VISIBILITY:
            passes = self.render_pass
            visible, might_vary = self._inherited.visibility(prim, path)
            batch.set_visible(path_str, visible and (passes is None or passes.rendered(path)))
            record.varying = set_flag(record.varying, Dirty.VISIBILITY, might_vary)


class CameraSync(OneByOneSync):
    """UsdGeomCameras, sampled over the shutter."""

    moving = True

    def _read(
        self, path: Sdf.Path, path_str: str, prim: Usd.Prim, reader: SampleReader,
        settings: SyncSettings,
    ) -> bool:
        return sync_camera(
            self.core, prim, reader, settings.depth_of_field, settings.film_windows.get(path_str)
        )


class LightSync(OneByOneSync):
    """UsdLux lights, read at the frame; noted in ``emitters``."""

    def __init__(
        self,
        core,
        render_pass: RenderPassCollections | None,
        inherited: InheritedState,
        warn: Callable[[str], None],
        emitters: set[Sdf.Path],
    ):
        super().__init__(core, render_pass, inherited)
        self._warn = warn
        self._emitters = emitters

    def _read(
        self, path: Sdf.Path, path_str: str, prim: Usd.Prim, reader: SampleReader,
        settings: SyncSettings,
    ) -> bool:
        sync_light(self.core, prim, reader, self._warn, settings.dome_light_visibility)
        self._emitters.add(path)
        return True

    def _placement_reads_data(self, prim: Usd.Prim) -> bool:
        return prim.IsA(UsdLux.DomeLight_1)  # its poleAxis turns its texture

    def _placement(self, prim: Usd.Prim, matrices: np.ndarray) -> np.ndarray:
        first = matrices if np.ndim(matrices) == 2 else matrices[0]
        if (problem := uneven_scale_problem(prim, first)) is not None:
            self._warn(problem)
        return light_transform(prim, matrices)
