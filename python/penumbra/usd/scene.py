"""The USD scene delegate: mirrors a stage into a ``penumbra._core.RenderDelegate``.

Like Hydra's UsdImaging delegate it inserts one delegate prim per supported USD prim (prim ids
are USD paths; lights and cameras inside native prototypes as instance proxies), pushes their
data at a time code, and afterwards pushes only what changed:

* stage edits arrive as ``Usd.Notice.ObjectsChanged`` and are queued; :meth:`SceneDelegate.update`
  re-reads only the affected aspects of the affected prims (an ancestor's transform or
  visibility edit reaches its whole subtree, a shader edit re-sends its material, a structural
  change re-populates the changed subtree);
* a new frame or shutter (see :class:`~penumbra.usd.sampling.Shutter`) re-reads only the
  aspects whose inputs might vary with time (which includes motion over the shutter: moving
  transforms, deforming points, points with velocities); cameras are re-read when the shutter's
  offsets or the depth-of-field switch change.

Implicit surfaces (Sphere, Cube, Cylinder, Cone, Capsule, Plane) are tessellated and tracked as
meshes (see :mod:`.implicit`). Meshes and cameras move over the shutter (transform, points,
lens); lights keep their transform at the frame.

Meshes inside native prototypes are not instance proxies here: :mod:`.native_instancing` syncs
each once and places its copies with an instancer rprim (sharing its BVH); it uses this
delegate's materials and hears of the same stage edits.
"""

from __future__ import annotations

import gc
import weakref
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

from pxr import Sdf, Tf, Usd, UsdGeom, UsdShade, UsdVol

from ..errors import warn
from .camera import sync_camera
from .implicit import is_implicit
from .lights import is_light, light_type, sync_light
from .core_batch import CHUNK, CoreBatch
from .material import bound_materials, has_subset_bindings, push_material, read_material
from .mesh import Authored, data_might_vary, is_plain, push_plain_meshes, sync_mesh_data
from .motion import XformCaches, transform_samples, transforms_samples
from .native_instancing import NativeInstancing
from .point_instancers import PointInstancerDelegate
from .render_pass import RenderPassCollections
from .inherited import Inherited, InheritedState
from .sampling import SampleReader, Shutter
from .settings import FilmWindow

DEFAULT_PURPOSES = ("default", "proxy")
"""usdrecord's default: the "default" purpose plus "proxy"."""


class Dirty:
    """The aspects of a prim that can be re-read independently: bits of a plain ``int`` (an
    ``enum.IntFlag`` costs microseconds per operation, which a sync of 100,000 prims feels)."""

    DATA = 1  # the prim's own attributes (geometry, camera, light inputs)
    TRANSFORM = 2
    VISIBILITY = 4
    BINDING = 8  # meshes: which material is bound
    ALL = DATA | TRANSFORM | VISIBILITY | BINDING


# Which aspects each kind of prim has.
_ASPECTS = {
    "mesh": Dirty.ALL,
    "camera": Dirty.DATA | Dirty.TRANSFORM,
}
_LIGHT_ASPECTS = Dirty.DATA | Dirty.TRANSFORM | Dirty.VISIBILITY
_MOVING_KINDS = frozenset({"mesh", "camera"})  # prims sampled over the shutter


@dataclass(slots=True)  # one per tracked prim: slots keep it small
class _Prim:
    """A tracked rprim or sprim."""

    kind: str  # the delegate's prim type: "mesh", "camera", "rectLight", ...
    in_core: bool = False  # False while the prim is unusable (e.g. a mesh without points)
    varying: int = 0  # aspects whose inputs might vary with time
    unknown: int = 0  # aspects whose variability is found out at the first new time
    # Meshes whose data varies: attribute queries reused at each new time (dropped on edits).
    queries: dict[str, Usd.AttributeQuery] | None = None
    material: str = ""  # meshes: id of the bound material ("" = none)


@dataclass
class _Material:
    """A material used by at least one tracked mesh."""

    users: set[Sdf.Path]
    sources: set[Sdf.Path]
    in_core: bool = False  # False when the material is unusable (not UsdPreviewSurface)
    varying: bool = False


def _is_xform_property(name: str) -> bool:
    return name.startswith("xformOp:") or name == UsdGeom.Tokens.xformOpOrder


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
        self._prims: dict[Sdf.Path, _Prim] = {}
        self._materials: dict[Sdf.Path, _Material] = {}
        self._dirty: dict[Sdf.Path, int] = {}
        self._dirty_materials: set[Sdf.Path] = set()
        self._resynced: set[Sdf.Path] = set()
        self._prims_resynced = True  # since take_prims_resynced(); the stage is new to us
        # Prims found by the traversals of this update, for its flush (no second look-up), with
        # the inherited state of the meshes among them.
        self._found: dict[Sdf.Path, tuple[Usd.Prim, Inherited | None]] = {}
        self._changed: set[Sdf.Path] = set()
        self._unsupported: dict[str, list[Sdf.Path]] = {}
        self._roles: dict[str, str | None] = {}
        self._inherited = InheritedState()
        self._emitters: set[Sdf.Path] = set()  # synced lights and UsdLuxMeshLightAPI meshes
        self._warn = _OnceWarner()
        # Weak: a cycle through the helper would keep the stage alive until the next collection.
        self.materials = _SceneMaterials(weakref.proxy(self))
        """The one material registry, shared with native and point instancing."""
        self._native = NativeInstancing(
            stage, core, self.purposes, self._warn, self.materials, render_pass
        )
        self._point_instancers = PointInstancerDelegate(
            stage, core, self.purposes, warn, self.materials, render_pass
        )
        # The one listener: native and point instancing hear of edits from it.
        self._listener = Tf.Notice.Register(
            Usd.Notice.ObjectsChanged, self._on_objects_changed, stage
        )

    # ----------------------------------------------------------------------------------------
    # Public interface

    def close(self) -> None:
        """Stop listening to the stage."""
        if self._listener is not None:
            self._listener.Revoke()
            self._listener = None

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

    def _update(
        self,
        shutter: Shutter,
        depth_of_field: bool,
        dome_light_visibility: bool,
        film_windows: dict[str, FilmWindow] | None,
    ) -> None:
        if self.shutter is None:
            self.shutter, self.time, self.depth_of_field = shutter, shutter.frame, depth_of_field
            self.dome_light_visibility = dome_light_visibility
            self._resync(Sdf.Path.absoluteRootPath)
        self._process_notices()
        film_windows = film_windows or {}
        if film_windows != self.film_windows:
            for path in set(film_windows) | set(self.film_windows):
                if film_windows.get(path) != self.film_windows.get(path):
                    record = self._prims.get(Sdf.Path(path))
                    if record is not None and record.kind == "camera":
                        self._mark(Sdf.Path(path), Dirty.DATA)
            self.film_windows = film_windows
        if dome_light_visibility != self.dome_light_visibility:
            self.dome_light_visibility = dome_light_visibility
            for path, record in self._prims.items():
                if record.kind == "domeLight":
                    self._mark(path, Dirty.DATA)
        if shutter != self.shutter or depth_of_field != self.depth_of_field:
            time_changed = shutter != self.shutter
            lens_changed = depth_of_field != self.depth_of_field or (
                (shutter.open, shutter.close) != (self.shutter.open, self.shutter.close)
            )
            if shutter.frame != self.time:  # materials are read at the frame
                self._dirty_materials.update(
                    path for path, material in self._materials.items() if material.varying
                )
            if time_changed:
                self._find_variability()
            self.shutter, self.time, self.depth_of_field = shutter, shutter.frame, depth_of_field
            for path, record in self._prims.items():
                bits = record.varying if time_changed else 0
                if lens_changed and record.kind == "camera":
                    bits |= Dirty.DATA
                if bits:
                    self._mark(path, bits, edited=False)
        self._inherited.at(self.time)
        self._flush()
        self._inherited.forget()  # the stage may be edited before the next update
        self._native.update(shutter)
        self._point_instancers.update(shutter)
        self._report_unsupported()

    def _find_variability(self) -> None:
        """Find out which aspects of the prims synced without noting it might vary with time
        (a render of one frame never needs to know)."""
        for path, record in self._prims.items():
            if not record.unknown:
                continue
            prim = self.stage.GetPrimAtPath(path)
            if record.unknown & Dirty.DATA and data_might_vary(prim, self._authored(prim, path)):
                record.varying |= Dirty.DATA
            if record.unknown & Dirty.TRANSFORM and self._inherited.transform_might_vary(
                prim, path
            ):
                record.varying |= Dirty.TRANSFORM
            record.unknown = 0
        self._inherited.forget()

    def _authored(self, prim: Usd.Prim, path: Sdf.Path) -> Authored:
        inherited = self._inherited
        return Authored(inherited.authored(prim, path), inherited.inherited_primvars(prim, path))

    def has_lights(self) -> bool:
        """Whether the synced stage has lights of its own (UsdLux lights or meshes with
        UsdLuxMeshLightAPI), known without looking at its prims again."""
        return bool(self._emitters)

    def prim_kind(self, path: str) -> str | None:
        """The delegate prim type tracked at ``path`` (``None`` if untracked)."""
        record = self._prims.get(Sdf.Path(path))
        return record.kind if record else None

    # ----------------------------------------------------------------------------------------
    # Warnings

    def _report_unsupported(self) -> None:
        for type_name, paths in sorted(self._unsupported.items()):
            count = len(paths)
            noun = "prim" if count == 1 else "prims"
            warn(f"{count} {type_name} {noun} not supported yet, skipped (first: {min(paths)})")
        self._unsupported.clear()

    # ----------------------------------------------------------------------------------------
    # Classification

    def _classify(self, prim: Usd.Prim, path: Sdf.Path) -> tuple[str | None, Inherited | None]:
        """The delegate prim type for ``prim`` (at ``path``), or ``None`` when it is not
        rendered; with its inherited state when it is a mesh."""
        role = self._role_of_type(prim)
        if role in ("mesh", "unsupported"):
            if role == "mesh" and prim.IsInstanceProxy():
                return None, None  # natively instanced: NativeInstancing
            state = self._inherited.state(prim, path)
            if state.purpose not in self.purposes:
                return None, None
            if role == "mesh":
                return "mesh", state
        elif role is not None:
            return role, None  # a camera or a light
        if role == "unsupported" or is_light(prim):
            if role is not None or self._inherited.purpose(prim, path) in self.purposes:
                type_name = prim.GetTypeName() or "untyped"
                self._unsupported.setdefault(type_name, []).append(path)
        return None, None

    def _role_of_type(self, prim: Usd.Prim) -> str | None:
        """What prims of ``prim``'s type are (as UsdImaging finds its prim adapters by type
        name): "camera", a light type, "mesh" (meshes and implicit surfaces), "unsupported"
        (other gprims and volumes) or ``None``; decided once per type name by its schema."""
        type_name = prim.GetTypeName()
        if type_name in self._roles:
            return self._roles[type_name]
        role: str | None = None
        if prim.IsA(UsdGeom.Camera):
            role = "camera"
        elif (sprim_type := light_type(prim)) is not None:
            role = sprim_type
        elif prim.IsA(UsdGeom.Mesh) or is_implicit(prim):
            role = "mesh"
        elif prim.IsA(UsdGeom.Gprim) or prim.IsA(UsdVol.Volume):
            role = "unsupported"  # point instancers: PointInstancerDelegate
        self._roles[type_name] = role
        return role

    def _traverse(
        self, root: Usd.Prim
    ) -> Iterator[tuple[Sdf.Path, str, Usd.Prim, Inherited | None]]:
        """``(path, kind, prim, inherited state of a mesh)`` of the prims to render under
        ``root`` (instance proxies included; prototypes below a PointInstancer are not rendered
        on their own)."""
        if not root or any(p.IsA(UsdGeom.PointInstancer) for p in _ancestors(root)):
            return
        it = iter(Usd.PrimRange(root, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
        for prim in it:
            path = prim.GetPath()
            kind, state = self._classify(prim, path)
            if kind is not None:
                yield path, kind, prim, state
            elif prim.IsA(UsdGeom.PointInstancer):  # not a rendered kind itself
                it.PruneChildren()

    # ----------------------------------------------------------------------------------------
    # Change tracking

    def take_prims_resynced(self) -> bool:
        """Whether prims were resynced since the last call: their composition (variant
        selections, references, sublayers) may have changed."""
        resynced, self._prims_resynced = self._prims_resynced, False
        return resynced

    def _on_objects_changed(self, notice, _sender) -> None:
        resynced = notice.GetResyncedPaths()
        self._prims_resynced = self._prims_resynced or any(
            not path.IsPropertyPath() for path in resynced
        )
        self._resynced.update(resynced)
        self._changed.update(notice.GetChangedInfoOnlyPaths())

    def _instance_paths(self, path: Sdf.Path) -> Iterator[Sdf.Path]:
        """``path`` itself, or, inside a prototype, the corresponding paths in its instances."""
        root = path.GetPrefixes()[0] if path != Sdf.Path.absoluteRootPath else path
        prototype = self.stage.GetPrimAtPath(root)
        if not (prototype and prototype.IsPrototype()):
            yield path
            return
        for instance in prototype.GetInstances():
            yield from self._instance_paths(path.ReplacePrefix(root, instance.GetPath()))

    def _process_notices(self) -> None:
        self._native.note_changes(self._resynced, self._changed)
        self._point_instancers.note_changes(self._resynced, self._changed)
        resynced = {p for q in self._resynced for p in self._instance_paths(q)}
        changed = {p for q in self._changed for p in self._instance_paths(q)}
        self._resynced.clear()
        self._changed.clear()
        # A resynced property (created or removed) is an edit of that property.
        changed |= {p for p in resynced if p.IsPropertyPath()}
        prim_roots = sorted(p for p in resynced if not p.IsPropertyPath())
        roots: list[Sdf.Path] = []
        for path in prim_roots:  # sorted: an ancestor comes before its descendants
            if not roots or not path.HasPrefix(roots[-1]):
                roots.append(path)
        for root in roots:
            self._resync(root)
        for path in sorted(changed):
            self._on_changed(path)

    def _on_changed(self, path: Sdf.Path) -> None:
        """Mark what an edit of ``path`` (a property, or a prim's metadata) affects."""
        prim_path = path.GetPrimPath()
        name = path.name if path.IsPropertyPath() else ""
        if name == UsdGeom.Tokens.purpose:
            self._resync(prim_path)
            return
        for material_path, material in self._materials.items():
            if prim_path in material.sources:
                self._dirty_materials.add(material_path)
        if _is_xform_property(name):
            self._mark_subtree(prim_path, Dirty.TRANSFORM)
        elif name == UsdGeom.Tokens.visibility:
            self._mark_subtree(prim_path, Dirty.VISIBILITY)
        elif name.startswith("material:binding"):
            self._mark_subtree(prim_path, Dirty.BINDING)
        elif name.startswith("primvars:") and prim_path not in self._prims:
            self._mark_subtree(prim_path, Dirty.DATA)  # inherited constant primvars
        elif prim_path in self._prims:
            self._mark(prim_path, Dirty.DATA if name else Dirty.ALL)

    def _mark(self, path: Sdf.Path, bits: int, edited: bool = True) -> None:
        """Mark aspects ``bits`` of a tracked prim dirty; ``edited``: because the stage changed
        (rather than the time), which makes its attribute queries stale."""
        record = self._prims.get(path)
        if record is not None:
            if edited and bits & Dirty.DATA:
                record.queries = None
            self._dirty[path] = self._dirty.get(path, 0) | (bits & _aspects(record.kind))

    def _mark_subtree(self, root: Sdf.Path, bits: int) -> None:
        for path in self._tracked_under(root):
            self._mark(path, bits)

    def _tracked_under(self, root: Sdf.Path) -> list[Sdf.Path]:
        """The tracked prims at or below ``root``, found in time proportional to the subtree
        (an edit of one leaf prim costs no walk over every tracked prim)."""
        prim = self.stage.GetPrimAtPath(root)
        if not prim:
            return [path for path in self._prims if path.HasPrefix(root)]
        subtree = Usd.PrimRange(prim, Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate))
        return [p.GetPath() for p in subtree if p.GetPath() in self._prims]

    def _resync(self, root: Sdf.Path) -> None:
        """Re-populate the subtree at ``root``: remove what is gone, insert what is new, and
        re-read everything else in it."""
        wanted = {}
        for path, kind, prim, state in self._traverse(self.stage.GetPrimAtPath(root)):
            wanted[path] = kind
            self._found[path] = prim, state
        for path in [p for p in self._prims if p.HasPrefix(root)]:
            if wanted.get(path) != self._prims[path].kind:
                self._remove(path)
        for path, kind in wanted.items():
            if path in self._prims:
                self._mark(path, Dirty.ALL)
            else:  # new: marked as _mark would, without looking it up again
                self._prims[path] = _Prim(kind)
                self._dirty[path] = _aspects(kind)
        for material_path, material in self._materials.items():
            if material_path.HasPrefix(root) or any(s.HasPrefix(root) for s in material.sources):
                self._dirty_materials.add(material_path)
                for user in material.users:
                    self._mark(user, Dirty.BINDING)

    def _remove(self, path: Sdf.Path) -> None:
        record = self._prims.pop(path)
        self._dirty.pop(path, None)
        self._emitters.discard(path)
        if record.in_core:
            self.core.remove_prim(str(path))
        if record.material:
            self._release_material(Sdf.Path(record.material), path)

    # ----------------------------------------------------------------------------------------
    # Pushing data

    def _flush(self) -> None:
        while self._dirty or self._dirty_materials:
            xform_caches = XformCaches()
            dirty, self._dirty = self._dirty, {}
            found, self._found = self._found, {}
            tracked = [path for path in dirty if path in self._prims]
            ids = [str(path) for path in tracked]  # the delegate's prim ids
            order = sorted(range(len(tracked)), key=lambda n: path_order_key(ids[n]))
            paths = [tracked[n] for n in order]
            seen = [found.get(path) or (self.stage.GetPrimAtPath(path), None) for path in paths]
            todo = _Flush(
                paths=paths,
                ids=[ids[n] for n in order],
                prims=[prim for prim, _ in seen],
                states=[state for _, state in seen],
                records=[self._prims[path] for path in paths],
                bits=[dirty[path] for path in paths],
            )
            todo.new = [not record.in_core for record in todo.records]
            binding = [
                n
                for n, record in enumerate(todo.records)
                if record.kind == "mesh" and (todo.bits[n] & Dirty.BINDING or todo.new[n])
            ]
            todo.bound = [None] * len(paths)
            for n, material in zip(binding, self._bound_materials(todo.subset(binding))):
                todo.bound[n] = material
            entering_meshes = [
                todo.ids[n]
                for n, record in enumerate(todo.records)
                if todo.new[n] and record.kind == "mesh"
            ]
            self.core.insert_rprims("mesh", entering_meshes)
            for n, record in enumerate(todo.records):
                if todo.new[n]:
                    if record.kind != "mesh":
                        self.core.insert_sprim(record.kind, todo.ids[n])
                    record.in_core = True
                    todo.bits[n] = _aspects(record.kind)  # entering the delegate: everything
            batch = CoreBatch(self.core, self._warn)
            meshes = []
            for n, record in enumerate(todo.records):
                if record.kind == "mesh":
                    meshes.append(n)
                else:
                    self._sync_prim(
                        paths[n], todo.ids[n], todo.prims[n], todo.bits[n], xform_caches, batch
                    )
            self._sync_meshes(todo.subset(meshes), xform_caches, batch)
            batch.send()
            materials, self._dirty_materials = self._dirty_materials, set()
            for path in sorted(materials):
                if path in self._materials:
                    self._sync_material(path)

    def _bound_materials(self, meshes: _Flush) -> list[Sdf.Path | None]:
        """The materials bound to ``meshes``, computed in one batch for those that may have
        one."""
        binding = [
            n
            for n, (prim, path, state) in enumerate(zip(meshes.prims, meshes.paths, meshes.states))
            if (state or self._inherited.state(prim, path)).bindings
        ]
        bound: list[Sdf.Path | None] = [None] * len(meshes.paths)
        for n, material in zip(binding, bound_materials([meshes.prims[n] for n in binding])):
            bound[n] = material
        return bound

    def _sync_prim(
        self,
        path: Sdf.Path,
        path_str: str,
        prim: Usd.Prim,
        bits: int,
        xform_caches: XformCaches,
        batch: CoreBatch,
    ) -> None:
        """Read the aspects ``bits`` of the tracked camera or light at ``path`` (delegate id
        ``path_str``; in the delegate: inserted by :meth:`_flush`) and queue them in ``batch``."""
        record = self._prims[path]
        kind = record.kind
        shutter = self.shutter if kind in _MOVING_KINDS else Shutter(self.time)
        if bits & Dirty.DATA:
            reader = SampleReader(self.time, shutter)
            if kind == "camera":
                if not sync_camera(
                    self.core, prim, reader, self.depth_of_field, self.film_windows.get(path_str)
                ):
                    self.core.remove_prim(path_str)
                    record.in_core = False
                    return
            else:
                sync_light(self.core, prim, reader, self._warn, self.dome_light_visibility)
                self._emitters.add(path)
            record.varying = _set_flag(record.varying, Dirty.DATA, reader.varying)
        if bits & Dirty.TRANSFORM:
            batch.set_transform(path_str, transform_samples(prim, shutter, xform_caches))
            record.varying &= ~Dirty.TRANSFORM
            record.unknown |= Dirty.TRANSFORM
        if bits & Dirty.VISIBILITY:
            passes = self.render_pass
            visible, might_vary = self._inherited.visibility(prim, path)
            batch.set_visible(path_str, visible and (passes is None or passes.rendered(path)))
            record.varying = _set_flag(record.varying, Dirty.VISIBILITY, might_vary)

    def _sync_meshes(self, meshes: _Flush, xform_caches: XformCaches, batch: CoreBatch) -> None:
        """Read the dirty aspects of tracked ``meshes`` (in the delegate: inserted by
        :meth:`_flush`) and queue them in ``batch``, one aspect at a time across all of them:
        plain meshes' data is read in columns (:func:`~penumbra.usd.mesh.push_plain_meshes`),
        the others' mesh by mesh. A new mesh is visible and unbound in the delegate: those
        values are not sent again."""
        plain: list[int] = []
        general: list[int] = []
        authored: dict[int, Authored] = {}
        for n, path in enumerate(meshes.paths):
            if not meshes.bits[n] & Dirty.DATA:
                continue
            record, prim = meshes.records[n], meshes.prims[n]
            # A mesh's variability is found out at the first new time (_find_variability);
            # one known to vary reads through queries kept from one time to the next.
            if record.varying & Dirty.DATA and record.queries is None:
                record.queries = {}
            known = authored[n] = self._authored(prim, path)
            if (
                record.queries is None
                and not self.shutter.blurred
                and not known.inherited_primvars
                and is_plain(known.names)
                and prim.GetTypeName() == "Mesh"
            ):
                plain.append(n)
            else:
                general.append(n)
        removed = self._sync_data(meshes, plain, general, authored, batch)
        self._sync_transforms(meshes, removed, xform_caches, batch)
        self._sync_visibilities(meshes, removed, batch)
        self._sync_bindings(meshes, removed, batch)

    def _sync_data(
        self,
        meshes: _Flush,
        plain: list[int],
        general: list[int],
        authored: dict[int, Authored],
        batch: CoreBatch,
    ) -> set[int]:
        """Queue the data of ``meshes`` (indices into the flush's lists): the ``plain`` ones in
        columns, the ``general`` ones (and plain ones the fast path declined) mesh by mesh.
        Returns the indices of the meshes found unusable, which are removed from the delegate."""
        paths, ids, prims, records = meshes.paths, meshes.ids, meshes.prims, meshes.records
        pushed: list[bool] = []
        for start in range(0, len(plain), CHUNK):  # a chunk's values stay in the CPU's caches
            chunk = plain[start : start + CHUNK]
            pushed += push_plain_meshes(
                batch,
                [prims[n] for n in chunk],
                [authored[n].names for n in chunk],
                [ids[n] for n in chunk],
                self.time,
            )
        for n, usable in zip(plain, pushed):
            if usable:
                records[n].varying &= ~Dirty.DATA  # read without noting variability:
                records[n].unknown |= Dirty.DATA  # found out at the first new time
                self._emitters.discard(paths[n])
            else:
                general.append(n)
        removed = set()
        for n in sorted(general):
            if not self._sync_mesh_data(paths[n], ids[n], prims[n], records[n], authored[n], batch):
                removed.add(n)
        return removed

    def _sync_transforms(
        self, meshes: _Flush, removed: set[int], xform_caches: XformCaches, batch: CoreBatch
    ) -> None:
        """Queue the world transforms of the moved ``meshes``, a chunk at a time."""
        ids, prims, records, bits = meshes.ids, meshes.prims, meshes.records, meshes.bits
        moved = [n for n in range(len(ids)) if bits[n] & Dirty.TRANSFORM and n not in removed]
        for start in range(0, len(moved), CHUNK):
            chunk = moved[start : start + CHUNK]
            matrices = transforms_samples([prims[n] for n in chunk], self.shutter, xform_caches)
            batch.set_transforms([ids[n] for n in chunk], matrices)
        for n in moved:
            records[n].varying &= ~Dirty.TRANSFORM
            records[n].unknown |= Dirty.TRANSFORM

    def _sync_visibilities(self, meshes: _Flush, removed: set[int], batch: CoreBatch) -> None:
        """Queue the visibility (and render-pass visibility) of ``meshes`` whose visibility is
        dirty; a new mesh's default, visible, is not sent."""
        passes = self.render_pass
        for n, path in enumerate(meshes.paths):
            if not meshes.bits[n] & Dirty.VISIBILITY or n in removed:
                continue
            visible, might_vary = self._inherited.visibility(
                meshes.prims[n], path, meshes.states[n]
            )
            visible = visible and (passes is None or passes.rendered(path))
            if not visible or not meshes.new[n]:
                batch.set_visible(meshes.ids[n], visible)
            if passes is not None:
                shown = passes.visibility(path)
                self.core.set_pass_visibility(meshes.ids[n], shown.camera, shown.matte)
            record = meshes.records[n]
            record.varying = _set_flag(record.varying, Dirty.VISIBILITY, might_vary)

    def _sync_bindings(self, meshes: _Flush, removed: set[int], batch: CoreBatch) -> None:
        """Queue the material bindings of ``meshes`` whose binding is dirty; a new mesh that is
        unbound and has no subsets to warn about needs nothing sent."""
        for n, path in enumerate(meshes.paths):
            if not meshes.bits[n] & Dirty.BINDING or n in removed:
                continue
            material, record, prim = meshes.bound[n], meshes.records[n], meshes.prims[n]
            new = meshes.new[n]
            if material is None and not record.material and new and not prim.GetChildrenNames():
                continue  # unbound here and in the delegate, and no subsets to warn about
            self._sync_binding(path, meshes.ids[n], record, prim, material, batch, new)

    def _sync_mesh_data(
        self,
        path: Sdf.Path,
        path_str: str,
        prim: Usd.Prim,
        record: _Prim,
        authored: Authored,
        batch: CoreBatch,
    ) -> bool:
        """Read a mesh's data through the general path (:func:`~penumbra.usd.mesh.sync_mesh_data`);
        ``False`` when it is unusable, and then removed from the delegate."""
        queries = record.queries
        reader = SampleReader(self.time, self.shutter, queries is not None, queries)
        if not sync_mesh_data(batch, prim, reader, self._warn, path_str, authored):
            self.core.remove_prim(path_str)
            record.in_core = False
            self._emitters.discard(path)
            return False
        if path_str in batch.mesh_lights:  # it has UsdLuxMeshLightAPI
            self._emitters.add(path)
        else:
            self._emitters.discard(path)
        record.varying = _set_flag(record.varying, Dirty.DATA, reader.varying)
        if not reader.note_variability:
            record.unknown |= Dirty.DATA
        return True

    def _sync_binding(
        self,
        path: Sdf.Path,
        path_str: str,
        record: _Prim,
        prim: Usd.Prim,
        material_path: Sdf.Path | None,
        batch: CoreBatch,
        new: bool,
    ) -> None:
        """Bind mesh ``path`` to ``material_path``; ``new``: the mesh has just entered the
        delegate, unbound."""
        if prim.GetChildrenNames() and has_subset_bindings(prim):  # subsets are children
            self._warn(
                f"{path}: per-face material bindings (GeomSubsets) are not supported yet; "
                "the mesh's own binding is used"
            )
        old = Sdf.Path(record.material) if record.material else None
        if material_path != old:
            if old is not None:
                self._release_material(old, path)
            if material_path is not None:
                self._acquire_material(material_path, path)
        material_id = ""
        if material_path is not None and self._materials[material_path].in_core:
            material_id = str(material_path)
        record.material = str(material_path) if material_path is not None else ""
        if material_id or not new:
            batch.set_mesh_material(path_str, material_id)

    def _acquire_material(self, material_path: Sdf.Path, user: Sdf.Path) -> None:
        material = self._materials.get(material_path)
        if material is None:
            material = self._materials[material_path] = _Material(users=set(), sources=set())
            self._read_material(material_path, material)
        material.users.add(user)

    def _release_material(self, material_path: Sdf.Path, user: Sdf.Path) -> None:
        material = self._materials.get(material_path)
        if material is None:
            return
        material.users.discard(user)
        if not material.users:
            del self._materials[material_path]
            self._dirty_materials.discard(material_path)
            if material.in_core:
                self.core.remove_prim(str(material_path))

    def _sync_material(self, material_path: Sdf.Path) -> None:
        material = self._materials[material_path]
        was_in_core = material.in_core
        self._read_material(material_path, material)
        if material.in_core != was_in_core:
            for user in material.users:
                self._mark(user, Dirty.BINDING)
            self._native.invalidate()  # its meshes may use it

    def _read_material(self, material_path: Sdf.Path, material: _Material) -> None:
        """Read the material and insert, update or remove it in the delegate."""
        prim = self.stage.GetPrimAtPath(material_path)
        reader = SampleReader(self.time)
        data = None
        if prim and prim.IsA(UsdShade.Material):
            data = read_material(prim, reader, self._warn)
        material.varying = reader.varying
        path_str = str(material_path)
        if data is None:
            material.sources = {material_path}
            if material.in_core:
                self.core.remove_prim(path_str)
                material.in_core = False
            return
        material.sources = data.sources
        if not material.in_core:
            self.core.insert_sprim("material", path_str)
            material.in_core = True
        push_material(self.core, path_str, data, self._warn)


class _OnceWarner:
    """Warns once per distinct message for the life of a delegate."""

    def __init__(self) -> None:
        self._reported: set[str] = set()

    def __call__(self, message: str) -> None:
        if message not in self._reported:
            self._reported.add(message)
            warn(message)


class _SceneMaterials:
    """The scene delegate's materials, shared with the hidden meshes of native and point
    instancing (users named by their delegate ids)."""

    def __init__(self, scene: SceneDelegate):
        self._scene = scene

    def acquire(self, material: Sdf.Path, user: str) -> None:
        self._scene._acquire_material(material, Sdf.Path(user))

    def release(self, material: Sdf.Path, user: str) -> None:
        self._scene._release_material(material, Sdf.Path(user))

    def material_id(self, material: Sdf.Path) -> str:
        record = self._scene._materials.get(material)
        return str(material) if record is not None and record.in_core else ""


@dataclass
class _Flush:
    """The dirty tracked prims of one flush, as lists aligned by index."""

    paths: list[Sdf.Path]
    ids: list[str]
    prims: list[Usd.Prim]
    states: list[Inherited | None]  # meshes found by this update's traversals: their state
    records: list[_Prim]
    bits: list[int]  # the aspects to read
    new: list[bool] = field(default_factory=list)  # entering the delegate
    bound: list[Sdf.Path | None] = field(default_factory=list)  # meshes' bound materials

    def subset(self, indices: list[int]) -> _Flush:
        def pick(values: list) -> list:
            return [values[n] for n in indices] if values else []

        fields = (self.paths, self.ids, self.prims, self.states, self.records, self.bits)
        return _Flush(
            *(pick(v) for v in fields),
            new=pick(self.new),
            bound=pick(self.bound),
        )


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


def path_order_key(path: str) -> list[str]:
    """A sort key putting prim paths (as strings) in ``Sdf.Path`` order: name by name from the
    root, a parent before its children. Sorting by it is several times faster than comparing
    ``Sdf.Path`` objects from Python, and a flush inserts its prims in this order."""
    return path.split("/")


def _aspects(kind: str) -> int:
    return _ASPECTS.get(kind, _LIGHT_ASPECTS)


def _set_flag(flags: int, flag: int, on: bool) -> int:
    return flags | flag if on else flags & ~flag


def _ancestors(prim: Usd.Prim) -> Iterator[Usd.Prim]:
    prim = prim.GetParent()
    while prim and not prim.IsPseudoRoot():
        yield prim
        prim = prim.GetParent()
