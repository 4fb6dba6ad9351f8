"""UsdGeomPointInstancer → the render delegate's instancer rprims.

Each prototype mesh of a point instancer becomes a hidden mesh rprim (its geometry, read once)
and one instancer rprim holding the world transform of every copy: Embree then shares the
prototype's BVH among all copies, so memory grows with the number of instances, not with their
triangles. Transforms come from usd-core (``ComputeInstanceTransformsAtTime``: positions,
orientations, scales, the prototype's own transform), ``invisibleIds`` masks copies out, and
the instancer's world transform is applied on top. Nested point instancers are not flattened yet.

Edits anywhere under an instancer (or its prototypes) re-sync that instancer.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np
from pxr import Sdf, Tf, Usd, UsdGeom, UsdShade

from .material import bound_material, read_material
from .mesh import sync_mesh_data
from .sampling import SampleReader


@dataclass
class _Instancer:
    """Delegate prims inserted for one point instancer."""

    core_prims: set[str] = field(default_factory=set)
    roots: set[Sdf.Path] = field(default_factory=set)  # the instancer and its prototypes


class PointInstancerDelegate:
    """Mirrors the point instancers of ``stage`` into ``core``."""

    def __init__(self, stage: Usd.Stage, core, purposes: Iterable[str], warn: Callable[[str], None]):
        self.stage = stage
        self.core = core
        self.purposes = frozenset(purposes) | {UsdGeom.Tokens.default_}
        self.warn = warn
        self.time: Usd.TimeCode | None = None
        self._instancers: dict[Sdf.Path, _Instancer] = {}
        self._dirty = True
        self._listener = Tf.Notice.Register(Usd.Notice.ObjectsChanged, self._on_changed, stage)

    def close(self) -> None:
        if self._listener is not None:
            self._listener.Revoke()
            self._listener = None

    def _on_changed(self, notice, _sender) -> None:
        changed = [*notice.GetResyncedPaths(), *notice.GetChangedInfoOnlyPaths()]
        roots = {root for record in self._instancers.values() for root in record.roots}
        if any(path.GetPrimPath().HasPrefix(root) for path in changed for root in roots) or any(
            not path.IsPropertyPath() for path in notice.GetResyncedPaths()
        ):
            self._dirty = True

    def update(self, time: Usd.TimeCode) -> None:
        """Re-sync every point instancer when anything they depend on changed, or the time did."""
        if not self._dirty and time == self.time:
            return
        self.time = time
        self._dirty = False
        found = {
            prim.GetPath(): prim
            for prim in Usd.PrimRange(
                self.stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
            )
            if prim.IsA(UsdGeom.PointInstancer)
        }
        for path in [p for p in self._instancers if p not in found]:
            self._remove(path)
        xform_cache = UsdGeom.XformCache(time)
        for path, prim in found.items():
            self._sync(prim, xform_cache)

    def _remove(self, path: Sdf.Path) -> None:
        record = self._instancers.pop(path)
        # Instancers before their prototypes, then materials.
        for prim_id in sorted(record.core_prims, key=_removal_order):
            self.core.remove_prim(prim_id)

    def _sync(self, prim: Usd.Prim, xform_cache: UsdGeom.XformCache) -> None:
        path = prim.GetPath()
        if path in self._instancers:
            self._remove(path)
        record = self._instancers[path] = _Instancer(roots={path})
        imageable = UsdGeom.Imageable(prim)
        if imageable.ComputePurpose() not in self.purposes:
            return
        visible = imageable.ComputeVisibility(self.time) != UsdGeom.Tokens.invisible
        instancer = UsdGeom.PointInstancer(prim)
        prototypes = instancer.GetPrototypesRel().GetForwardedTargets()
        indices = np.asarray(instancer.GetProtoIndicesAttr().Get(self.time) or [], dtype=np.int64)
        if len(prototypes) == 0 or len(indices) == 0:
            return
        bad = (indices < 0) | (indices >= len(prototypes))
        if bad.any():
            # usd-core computes no transform at all then; say so rather than render nothing.
            self.warn(
                f"{path}: {int(bad.sum())} protoIndices are out of range for "
                f"{len(prototypes)} prototypes; the instancer is skipped"
            )
            return
        local = np.asarray(
            instancer.ComputeInstanceTransformsAtTime(
                self.time,
                self.time,
                UsdGeom.PointInstancer.IncludeProtoXform,
                UsdGeom.PointInstancer.IgnoreMask,
            ),
            dtype=np.float64,
        ).reshape(-1, 4, 4)
        if len(local) != len(indices):
            self.warn(f"{path}: instance attributes do not match protoIndices; instances skipped")
            return
        mask = instancer.ComputeMaskAtTime(self.time)
        keep = np.asarray(mask, dtype=bool) if mask else np.ones(len(indices), dtype=bool)
        world = np.asarray(xform_cache.GetLocalToWorldTransform(prim), dtype=np.float64)
        for index, prototype_path in enumerate(prototypes):
            root = self.stage.GetPrimAtPath(prototype_path)
            if not root:
                self.warn(f"{path}: prototype {prototype_path} does not exist")
                continue
            record.roots.add(prototype_path)
            selected = local[keep & (indices == index)]
            if len(selected) == 0:
                continue
            for mesh_prim in self._prototype_meshes(path, root):
                self._sync_prototype_mesh(record, path, root, mesh_prim, selected @ world, visible)

    def _prototype_meshes(self, instancer: Sdf.Path, root: Usd.Prim) -> Iterable[Usd.Prim]:
        walk = iter(Usd.PrimRange(root, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
        for prim in walk:
            if prim.IsA(UsdGeom.PointInstancer):
                self.warn(f"{instancer}: nested point instancer {prim.GetPath()} is not supported yet")
                walk.PruneChildren()
            elif prim.IsA(UsdGeom.Mesh):
                imageable = UsdGeom.Imageable(prim)
                if imageable.ComputePurpose() in self.purposes and (
                    imageable.ComputeVisibility(self.time) != UsdGeom.Tokens.invisible
                ):
                    yield prim

    def _sync_prototype_mesh(
        self,
        record: _Instancer,
        instancer: Sdf.Path,
        root: Usd.Prim,
        mesh_prim: Usd.Prim,
        instance_to_world: np.ndarray,
        visible: bool,
    ) -> None:
        mesh_id = f"{instancer}/prototypes{mesh_prim.GetPath()}"
        self.core.insert_rprim("mesh", mesh_id)
        record.core_prims.add(mesh_id)
        if not sync_mesh_data(self.core, mesh_prim, SampleReader(self.time), self.warn, mesh_id):
            return
        self.core.set_visible(mesh_id, False)  # only its copies render
        material = bound_material(mesh_prim)
        if material:
            data = read_material(material, SampleReader(self.time), self.warn)
            if data is not None:
                material_id = f"{instancer}/materials{material.GetPath()}"
                if material_id not in record.core_prims:
                    self.core.insert_sprim("material", material_id)
                    self.core.set_material(material_id, data.params)
                    record.core_prims.add(material_id)
                self.core.set_mesh_material(mesh_id, material_id)
        # The mesh's transform within the prototype, then each copy's, then the instancer's.
        relative, _ = UsdGeom.XformCache(self.time).ComputeRelativeTransform(mesh_prim, root)
        copies_id = f"{instancer}/instances{mesh_prim.GetPath()}"
        self.core.insert_rprim("instancer", copies_id)
        record.core_prims.add(copies_id)
        transforms = np.asarray(relative, dtype=np.float64) @ instance_to_world
        self.core.set_instances(copies_id, mesh_id, np.ascontiguousarray(transforms))
        self.core.set_visible(copies_id, visible)


def _removal_order(prim_id: str) -> int:
    if "/instances/" in prim_id:
        return 0
    return 1 if "/prototypes/" in prim_id else 2
