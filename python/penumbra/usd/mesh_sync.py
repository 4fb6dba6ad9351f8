"""Reading dirty tracked meshes into the delegate, one aspect at a time across all of them.

Plain meshes' data is read in columns (:func:`~penumbra.usd.mesh.push_plain_meshes`), a chunk
at a time, the others' mesh by mesh (:func:`~penumbra.usd.mesh.sync_mesh_data`); transforms are
computed a chunk at a time; bindings resolve in one batch and acquire their materials from the
:class:`~.material_registry.MaterialRegistry`.
"""

from __future__ import annotations

from collections.abc import Callable

from pxr import Sdf, Usd

from .core_batch import CHUNK, CoreBatch
from .inherited import InheritedState
from .material import bound_materials
from .material_registry import MaterialRegistry
from .mesh import Authored, is_plain, push_plain_meshes, sync_mesh_data
from .motion import XformCaches, transforms_samples
from .prim_sync import SyncSettings
from .ray_visibility import ShownSender
from .render_pass import RenderPassCollections
from .sampling import SampleReader
from .skinning import SkelCaches
from .subset_bindings import SubsetBindings, read_subset_bindings, warn_subset_bindings
from .tracking import Dirty, Flush, TrackedPrim, set_flag


def authored(inherited: InheritedState, prim: Usd.Prim, path: Sdf.Path) -> Authored:
    """What ``prim`` (at ``path``) authors, and the constant primvars it inherits."""
    return Authored(inherited.authored(prim, path), inherited.inherited_primvars(prim, path))


class MeshSync:
    """Meshes (and what is read as one, :func:`~penumbra.usd.mesh.reads_as_mesh`): their data,
    transforms over the shutter, visibility and material binding; those with UsdLuxMeshLightAPI
    are noted in ``emitters``."""

    def __init__(
        self,
        core,
        warn: Callable[[str], None],
        render_pass: RenderPassCollections | None,
        inherited: InheritedState,
        materials: MaterialRegistry,
        emitters: set[Sdf.Path],
    ):
        self.core = core
        self.render_pass = render_pass
        self._warn = warn
        self._inherited = inherited
        self._materials = materials
        self._emitters = emitters
        self._shown = ShownSender(core, render_pass, inherited)
        self._skel_caches = SkelCaches()  # of the sync under way

    def sync(
        self, meshes: Flush, settings: SyncSettings, xform_caches: XformCaches, batch: CoreBatch
    ) -> None:
        """Read the dirty aspects of tracked ``meshes`` (in the delegate: inserted by the
        flush) and queue them in ``batch``. A new mesh is visible and unbound in the delegate:
        those values are not sent again."""
        self._skel_caches = SkelCaches()  # the skeletons may have changed since the last sync
        plain: list[int] = []
        general: list[int] = []
        known_authored: dict[int, Authored] = {}
        for n, path in enumerate(meshes.paths):
            if not meshes.bits[n] & Dirty.DATA:
                continue
            record, prim = meshes.records[n], meshes.prims[n]
            # A mesh's variability is found out at the first new time (the scene delegate's
            # _find_variability); one known to vary reads through queries kept from one time to
            # the next.
            if record.varying & Dirty.DATA and record.queries is None:
                record.queries = {}
            known = known_authored[n] = authored(self._inherited, prim, path)
            if (
                record.queries is None
                and not settings.shutter.blurred
                and not known.inherited_primvars
                and is_plain(known.names)
                and prim.GetTypeName() == "Mesh"
            ):
                plain.append(n)
            else:
                general.append(n)
        removed = self._sync_data(meshes, plain, general, known_authored, settings, batch)
        self._sync_transforms(meshes, removed, settings, xform_caches, batch)
        self._sync_visibilities(meshes, removed, batch)
        self._sync_bindings(meshes, removed, settings, batch)

    def _sync_data(
        self,
        meshes: Flush,
        plain: list[int],
        general: list[int],
        authored: dict[int, Authored],
        settings: SyncSettings,
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
                settings.time,
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
            if not self._sync_mesh_data(
                paths[n], ids[n], prims[n], records[n], authored[n], settings, batch
            ):
                removed.add(n)
        return removed

    def _sync_transforms(
        self,
        meshes: Flush,
        removed: set[int],
        settings: SyncSettings,
        xform_caches: XformCaches,
        batch: CoreBatch,
    ) -> None:
        """Queue the world transforms of the moved ``meshes``, a chunk at a time."""
        ids, prims, records, bits = meshes.ids, meshes.prims, meshes.records, meshes.bits
        moved = [n for n in range(len(ids)) if bits[n] & Dirty.TRANSFORM and n not in removed]
        for start in range(0, len(moved), CHUNK):
            chunk = moved[start : start + CHUNK]
            matrices = transforms_samples([prims[n] for n in chunk], settings.shutter, xform_caches)
            batch.set_transforms([ids[n] for n in chunk], matrices)
        for n in moved:
            records[n].varying &= ~Dirty.TRANSFORM
            records[n].unknown |= Dirty.TRANSFORM

    def _sync_visibilities(self, meshes: Flush, removed: set[int], batch: CoreBatch) -> None:
        """Queue the visibility (and render-pass and ray visibility) of ``meshes`` whose
        visibility is dirty; a new mesh's defaults, visible to every ray, are not sent."""
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
            self._shown.send(meshes.ids[n], meshes.prims[n], path)
            record = meshes.records[n]
            record.varying = set_flag(record.varying, Dirty.VISIBILITY, might_vary)

    def _sync_bindings(
        self, meshes: Flush, removed: set[int], settings: SyncSettings, batch: CoreBatch
    ) -> None:
        """Queue the material bindings of ``meshes`` whose binding is dirty, their subsets'
        among them; a new mesh that is unbound and has no subsets needs nothing sent."""
        binding = [n for n in range(len(meshes.paths)) if meshes.bits[n] & Dirty.BINDING]
        bound: list[Sdf.Path | None] = [None] * len(meshes.paths)
        for n, material in zip(binding, self._bound_materials(meshes.subset(binding))):
            bound[n] = material
        for n, path in enumerate(meshes.paths):
            if not meshes.bits[n] & Dirty.BINDING or n in removed:
                continue
            material, record, prim = bound[n], meshes.records[n], meshes.prims[n]
            new = meshes.new[n]
            if material is None and not record.material and new and not prim.GetChildrenNames():
                continue  # unbound here and in the delegate, and no subsets
            self._sync_binding(path, meshes.ids[n], record, prim, material, settings, batch, new)

    def _bound_materials(self, meshes: Flush) -> list[Sdf.Path | None]:
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

    def _sync_mesh_data(
        self,
        path: Sdf.Path,
        path_str: str,
        prim: Usd.Prim,
        record: TrackedPrim,
        authored: Authored,
        settings: SyncSettings,
        batch: CoreBatch,
    ) -> bool:
        """Read a mesh's data through the general path (:func:`~penumbra.usd.mesh.sync_mesh_data`);
        ``False`` when it is unusable, and then removed from the delegate."""
        queries = record.queries
        reader = SampleReader(settings.time, settings.shutter, queries is not None, queries)
        if not sync_mesh_data(
            batch, prim, reader, self._warn, path_str, authored, self._skel_caches
        ):
            self.core.remove_prim(path_str)
            record.in_core = False
            self._emitters.discard(path)
            return False
        if path_str in batch.mesh_lights:  # it has UsdLuxMeshLightAPI
            self._emitters.add(path)
        else:
            self._emitters.discard(path)
        record.varying = set_flag(record.varying, Dirty.DATA, reader.varying)
        if not reader.note_variability:
            record.unknown |= Dirty.DATA
        return True

    def _sync_binding(
        self,
        path: Sdf.Path,
        path_str: str,
        record: TrackedPrim,
        prim: Usd.Prim,
        material_path: Sdf.Path | None,
        settings: SyncSettings,
        batch: CoreBatch,
        new: bool,
    ) -> None:
        """Bind mesh ``path`` to ``material_path`` and its faces to its subsets' materials;
        ``new``: the mesh has just entered the delegate, unbound."""
        if prim.GetTypeName() == "Mesh":
            subsets = read_subset_bindings(prim, settings.time, self._warn)
        else:  # a gprim read as a mesh has no authored faces to bind
            warn_subset_bindings(prim, path, self._warn)
            subsets = SubsetBindings([])
        record.varying = set_flag(record.varying, Dirty.BINDING, subsets.varying)
        used = {material_path} | {binding.material for binding in subsets.bindings}
        self._materials.use(path, record.materials(), used - {None})
        record.material = str(material_path) if material_path is not None else ""
        record.subset_materials = tuple(str(binding.material) for binding in subsets.bindings)
        material_id = "" if material_path is None else self._materials.material_id(material_path)
        if material_id or not new:
            batch.set_mesh_material(path_str, material_id)
        if subsets.bindings or not new:
            batch.set_subset_materials(
                path_str,
                [(self._materials.material_id(b.material), b.faces) for b in subsets.bindings],
            )
