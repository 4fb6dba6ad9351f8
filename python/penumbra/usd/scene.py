"""The USD scene delegate: mirrors a stage into a ``penumbra._core.RenderDelegate``.

Like Hydra's UsdImaging delegate it inserts one delegate prim per supported USD prim (prim ids
are USD paths; lights and cameras inside native prototypes as instance proxies), pushes their
data at a time code, and afterwards pushes only what changed:

* stage edits arrive as ``Usd.Notice.ObjectsChanged`` and are queued; :meth:`SceneDelegate.update`
  re-reads only the affected aspects of the affected prims (:mod:`.tracking`: an ancestor's
  transform or visibility edit reaches its whole subtree, a shader edit re-sends its material, a
  structural change re-populates the changed subtree);
* a new frame or shutter (see :class:`~penumbra.usd.sampling.Shutter`) re-reads only the
  aspects whose inputs might vary with time (which includes motion over the shutter: moving
  transforms, deforming points, points with velocities); cameras are re-read when the shutter's
  offsets or the depth-of-field switch change.

Which prims are rendered, as what, is :mod:`.classification`'s; each kind is read by its syncer
(:mod:`.prim_sync` for cameras and lights, :mod:`.mesh_sync` for meshes, :mod:`.points_sync`
for points, :mod:`.curves_sync` for curves, :mod:`.volumes_sync` for volumes), materials by the
:class:`~.material_registry.MaterialRegistry`. Implicit surfaces (Sphere, Cube, Cylinder, Cone,
Capsule, Plane) are tessellated and tracked as meshes (see :mod:`.implicit`). Meshes, points,
curves, volumes and cameras move over the shutter (transform, points, lens); lights keep their
transform at the frame.

Meshes inside native prototypes are not instance proxies here: :mod:`.native_instancing` syncs
each once and places its copies with an instancer rprim (sharing its BVH); point instancers are
:mod:`.point_instancers`'. Both use this delegate's materials and hear of the same stage edits.
"""

from __future__ import annotations

import gc
from collections.abc import Iterable, Iterator
from contextlib import contextmanager

from pxr import Sdf, Usd, UsdGeom

from ..errors import warn
from .classification import CURVES, VOLUME, Classifier
from .core_batch import CoreBatch
from .cryptomatte_names import cryptomatte_names
from .curves_sync import CurvesSync
from .inherited import InheritedState
from .linking import Linking
from .material_registry import MaterialRegistry
from .mesh import data_might_vary
from .mesh_sync import MeshSync, authored
from .motion import XformCaches
from .native_instancing import NativeInstancing
from .point_instancers import PointInstancerDelegate
from .points_sync import PointsSync
from .prim_sync import CameraSync, LightSync, PrimSync, SyncSettings
from .render_pass import RenderPassCollections
from .sampling import Shutter
from .settings import FilmWindow
from .tracking import ChangeTracker, Dirty, aspects
from .volumes_sync import VolumeSync

DEFAULT_PURPOSES = ("default", "proxy")
"""usdrecord's default: the "default" purpose plus "proxy"."""

_LIGHT = "light"  # the syncer of every kind not in the table: the light types
_RPRIMS = ("mesh", "points", CURVES, VOLUME)  # the kinds inserted as rprims, the others as sprims
_LINKED = ("mesh", "points", CURVES, VOLUME)  # the kinds light and shadow linking classify


class SceneDelegate:
    """Mirrors ``stage`` into ``core`` (a ``penumbra._core.RenderDelegate``).

    ``purposes``: the UsdGeomImageable purposes whose geometry is rendered ("default" is always
    included). ``render_pass``: the collections of the UsdRenderPass rendered, if any.
    """

    def __init__(
        self,
        stage: Usd.Stage,
        core,
        purposes: Iterable[str] = DEFAULT_PURPOSES,
        render_pass: RenderPassCollections | None = None,
    ):
        self.stage = stage
        self.core = core
        self.render_pass = render_pass
        self.purposes = frozenset(purposes) | {UsdGeom.Tokens.default_}
        self.time: Usd.TimeCode | None = None
        self.shutter: Shutter | None = None
        self.depth_of_field = True
        self.dome_light_visibility = True
        self.film_windows: dict[str, FilmWindow] = {}
        self._warn = _OnceWarner()
        self._inherited = InheritedState(self._warn)
        self._emitters: set[Sdf.Path] = set()  # synced lights and UsdLuxMeshLightAPI meshes
        self._entered: list[Sdf.Path] = []  # prims inserted in the delegate since _relink
        self.materials = MaterialRegistry(stage, core, self._warn)
        """The one material registry, shared with native and point instancing."""
        self._linking = Linking(stage, core, self._warn)
        self._native = NativeInstancing(
            stage, core, self.purposes, self._warn, self.materials, render_pass, self._linking
        )
        self._point_instancers = PointInstancerDelegate(
            stage, core, self.purposes, warn, self.materials, render_pass, self._linking
        )
        self._classifier = Classifier(self.purposes, self._inherited)
        self._volumes = VolumeSync(core, self._warn, render_pass, self._inherited)
        # The one listener: native and point instancing and volumes hear of edits from it.
        self._tracker = ChangeTracker(
            stage,
            self._classifier,
            self.materials,
            [self._native, self._point_instancers, self._volumes, self._linking],
        )
        # Each kind of prim → its syncer, in the order a flush runs them.
        self._syncers: dict[str, PrimSync] = {
            "camera": CameraSync(core, render_pass, self._inherited),
            _LIGHT: LightSync(core, render_pass, self._inherited, self._warn, self._emitters),
            "mesh": MeshSync(
                core, self._warn, render_pass, self._inherited, self.materials, self._emitters
            ),
            "points": PointsSync(core, self._warn, render_pass, self._inherited, self.materials),
            CURVES: CurvesSync(core, self._warn, render_pass, self._inherited, self.materials),
            VOLUME: self._volumes,
        }

    # ----------------------------------------------------------------------------------------
    # Public interface

    def close(self) -> None:
        """Stop listening to the stage."""
        self._tracker.close()

    def update(
        self,
        shutter: Shutter,
        depth_of_field: bool = True,
        dome_light_visibility: bool = True,
        film_windows: dict[str, FilmWindow] | None = None,
    ) -> None:
        """Bring the delegate up to date with the stage over ``shutter`` (its frame, or the
        interval moving prims are sampled over); ``depth_of_field`` False makes cameras
        pinholes; ``dome_light_visibility`` False hides dome lights from camera rays;
        ``film_windows`` maps camera paths to the part of their film the image covers (the
        others show their whole aperture).

        The first call populates the delegate; later calls push only queued edits and, when
        the shutter differs from the last one, the time-varying aspects (and the cameras when
        its offsets or ``depth_of_field`` changed).
        """
        with _cyclic_gc_paused():
            self._update(shutter, depth_of_field, dome_light_visibility, film_windows)

    def has_lights(self) -> bool:
        """Whether the synced stage has lights of its own (UsdLux lights, in point-instancer
        prototypes too, or meshes with UsdLuxMeshLightAPI), known without looking at its prims
        again."""
        return (
            bool(self._emitters)
            or self._point_instancers.has_lights()
            or self._native.has_lights()
        )

    def prim_kind(self, path: str) -> str | None:
        """The delegate prim type tracked at ``path`` (``None`` if untracked)."""
        record = self._tracker.prims.get(Sdf.Path(path))
        return record.kind if record else None

    def cryptomatte_names(self, layers: Iterable[str]) -> dict[str, dict[str, list[str]]]:
        """For each Cryptomatte layer of ``layers``: delegate prim id → the names of its
        placements (:mod:`.cryptomatte_names`), for every mesh, points, curves and instancer
        rprim in the delegate."""
        layers = list(layers)
        if not layers:
            return {}
        placed = ("mesh", "points", CURVES)
        rprims = [
            (str(path), path)
            for path, record in self._tracker.prims.items()
            if record.kind in placed and record.in_core
        ]
        copies = [*self._native.copies(), *self._point_instancers.copies()]
        return cryptomatte_names(self.stage, rprims, copies, layers)

    def cryptomatte_subset_names(self) -> dict[str, list[str]]:
        """The Cryptomatte material name of each subset binding sent, by mesh id: the path of
        its material (usable or not, as a mesh's own binding is named)."""
        names = {
            str(path): list(record.subset_materials)
            for path, record in self._tracker.prims.items()
            if record.subset_materials and record.in_core
        }
        names.update(self._native.subset_names())
        names.update(self._point_instancers.subset_names())
        return names

    def take_prims_resynced(self) -> bool:
        """Whether prims were resynced since the last call: their composition (variant
        selections, references, sublayers) may have changed."""
        return self._tracker.take_prims_resynced()

    # ----------------------------------------------------------------------------------------

    def _update(
        self,
        shutter: Shutter,
        depth_of_field: bool,
        dome_light_visibility: bool,
        film_windows: dict[str, FilmWindow] | None,
    ) -> None:
        tracker, prims = self._tracker, self._tracker.prims
        if self.shutter is None:
            self.shutter, self.time, self.depth_of_field = shutter, shutter.frame, depth_of_field
            self.dome_light_visibility = dome_light_visibility
            self.materials.at(self.time)
            tracker.resync(Sdf.Path.absoluteRootPath)
        tracker.process_notices()
        for volume in self._volumes.take_affected():  # its field prims or material were edited
            tracker.mark(volume, Dirty.DATA)
        self._forget_removed()
        film_windows = film_windows or {}
        if film_windows != self.film_windows:
            for path in set(film_windows) | set(self.film_windows):
                if film_windows.get(path) != self.film_windows.get(path):
                    record = prims.get(Sdf.Path(path))
                    if record is not None and record.kind == "camera":
                        tracker.mark(Sdf.Path(path), Dirty.DATA)
            self.film_windows = film_windows
        if dome_light_visibility != self.dome_light_visibility:
            self.dome_light_visibility = dome_light_visibility
            for path, record in prims.items():
                if record.kind == "domeLight":
                    tracker.mark(path, Dirty.DATA)
        if shutter != self.shutter or depth_of_field != self.depth_of_field:
            time_changed = shutter != self.shutter
            lens_changed = depth_of_field != self.depth_of_field or (
                (shutter.open, shutter.close) != (self.shutter.open, self.shutter.close)
            )
            self.materials.at(shutter.frame)  # materials are read at the frame
            if time_changed:
                self._find_variability()
            self.shutter, self.time, self.depth_of_field = shutter, shutter.frame, depth_of_field
            for path, record in prims.items():
                bits = record.varying if time_changed else 0
                if lens_changed and record.kind == "camera":
                    bits |= Dirty.DATA
                if bits:
                    tracker.mark(path, bits, edited=False)
        self._inherited.at(self.time)
        self._flush(
            SyncSettings(
                self.time,
                self.shutter,
                self.depth_of_field,
                self.dome_light_visibility,
                self.film_windows,
            )
        )
        self._inherited.forget()  # the stage may be edited before the next update
        self._relink()
        self._native.update(shutter)
        self._point_instancers.update(shutter)
        self._linking.send()
        self._classifier.report_unsupported()

    def _relink(self) -> None:
        """Classify the placements for light and shadow linking: every one when the lights'
        links changed, else the rprims that entered the delegate in this update."""
        relinked = self._linking.refresh(self._emitters)
        prims = self._tracker.prims
        entered = [p for p in self._entered if p in prims and prims[p].in_core]
        self._entered = []
        if not relinked:
            self._linking.resend_slots(entered)  # lights (and mesh lights) inserted anew
        entered = [p for p in entered if prims[p].kind in _LINKED]
        if relinked:
            self._native.invalidate()
            self._point_instancers.relink()
            entered = [
                path
                for path, record in prims.items()
                if record.kind in _LINKED and record.in_core
            ]
        if self._linking.active or relinked:
            self._linking.classify_rprims(entered)

    def _find_variability(self) -> None:
        """Find out which aspects of the prims synced without noting it might vary with time
        (a render of one frame never needs to know)."""
        for path, record in self._tracker.prims.items():
            if not record.unknown:
                continue
            prim = self.stage.GetPrimAtPath(path)
            if record.unknown & Dirty.DATA and data_might_vary(
                prim, authored(self._inherited, prim, path)
            ):
                record.varying |= Dirty.DATA
            if record.unknown & Dirty.TRANSFORM and self._inherited.transform_might_vary(
                prim, path
            ):
                record.varying |= Dirty.TRANSFORM
            record.unknown = 0
        self._inherited.forget()

    def _forget_removed(self) -> None:
        """Take the prims no longer tracked out of the delegate."""
        for path, record in self._tracker.take_removed():
            self._emitters.discard(path)
            self._volumes.forget(path)
            self._linking.forget(path)
            if record.in_core:
                self.core.remove_prim(str(path))
            self.materials.use(path, record.materials(), set())

    def _flush(self, settings: SyncSettings) -> None:
        """Insert the new tracked prims, have each kind's syncer read their dirty aspects, and
        read the edited materials, until nothing is dirty."""
        while self._tracker.dirty or self.materials.dirty:
            xform_caches = XformCaches()
            todo = self._tracker.take_flush()
            for kind in _RPRIMS:
                entering = [
                    todo.ids[n]
                    for n, record in enumerate(todo.records)
                    if todo.new[n] and record.kind == kind
                ]
                if entering:
                    self.core.insert_rprims(kind, entering)
            by_syncer: dict[str, list[int]] = {name: [] for name in self._syncers}
            for n, record in enumerate(todo.records):
                if todo.new[n]:
                    if record.kind not in _RPRIMS:
                        self.core.insert_sprim(record.kind, todo.ids[n])
                    self._linking.forget(todo.paths[n])
                    self._entered.append(todo.paths[n])
                    record.in_core = True
                    todo.bits[n] = aspects(record.kind)  # entering the delegate: everything
                by_syncer[record.kind if record.kind in self._syncers else _LIGHT].append(n)
            batch = CoreBatch(self.core, self._warn)
            for name, syncer in self._syncers.items():
                if by_syncer[name]:
                    syncer.sync(todo.subset(by_syncer[name]), settings, xform_caches, batch)
            batch.send()
            rebind = self.materials.sync()
            for user in rebind:
                self._tracker.mark(user, Dirty.BINDING)
            if rebind:
                self._native.invalidate()  # its meshes may use them


class _OnceWarner:
    """Warns once per distinct message for the life of a delegate."""

    def __init__(self) -> None:
        self._reported: set[str] = set()

    def __call__(self, message: str) -> None:
        if message not in self._reported:
            self._reported.add(message)
            warn(message)


@contextmanager
def _cyclic_gc_paused() -> Iterator[None]:
    """Pause Python's cyclic garbage collector: a sync allocates objects by the hundred thousand
    (none of them in cycles), and each full collection would walk all of them again."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()
