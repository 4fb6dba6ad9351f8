"""UsdGeomPointInstancer → the render delegate's instancer rprims.

Each prototype mesh of a point instancer becomes a hidden mesh rprim (its geometry, read once)
and one instancer rprim holding the world transform of every copy: Embree then shares the
prototype's BVH among all copies, so memory grows with the number of instances, not with their
triangles. Transforms come from usd-core (``ComputeInstanceTransformsAtTime``: positions,
orientations, scales, the prototype's own transform), ``invisibleIds`` masks copies out, and
the instancer's world transform is applied on top. Over an open shutter, copies get motion
samples (``ComputeInstanceTransformsAtTimes``: authored samples of positions, orientations and
scales, and ``velocities``, ``accelerations`` and ``angularVelocities``), as do moving instancers.
Nested point instancers are not flattened yet.

Edits anywhere under an instancer (or its prototypes) re-sync that instancer.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np
from pxr import Sdf, Tf, Usd, UsdGeom

from .implicit import is_implicit
from .material import bound_material, read_material
from .mesh import sync_mesh_data
from .sampling import SampleReader, Shutter, changes_within, transform_might_vary


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
        self.shutter: Shutter | None = None
        self.time: Usd.TimeCode | None = None  # the frame
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

    def update(self, shutter: Shutter) -> None:
        """Re-sync every point instancer when anything they depend on changed, or the frame or
        shutter did."""
        if not self._dirty and shutter == self.shutter:
            return
        self.shutter = shutter
        self.time = shutter.frame
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
        for prim in found.values():
            self._sync(prim)

    def _remove(self, path: Sdf.Path) -> None:
        record = self._instancers.pop(path)
        # Instancers before their prototypes, then materials.
        for prim_id in sorted(record.core_prims, key=_removal_order):
            self.core.remove_prim(prim_id)

    def _sync(self, prim: Usd.Prim) -> None:
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
        times = self._motion_times(prim, instancer)
        samples = instancer.ComputeInstanceTransformsAtTimes(
            times,
            self.time,
            UsdGeom.PointInstancer.IncludeProtoXform,
            UsdGeom.PointInstancer.IgnoreMask,
        )
        # (N, K, 4, 4): each copy's transform at every sample time.
        local = np.stack([np.asarray(s, dtype=np.float64).reshape(-1, 4, 4) for s in samples], axis=1)
        if len(times) > 1 and not instancer.GetPositionsAttr().GetNumTimeSamples():
            # usd-core extrapolates velocities from time-sampled positions only; for positions
            # with a default value, move each copy's translation itself: p + v·Δ + ½·a·Δ².
            local = local[:, :1].repeat(len(times), axis=1)
            local[:, :, 3, :3] += self._default_position_offsets(instancer, times, len(indices))
        if len(local) != len(indices):
            self.warn(f"{path}: instance attributes do not match protoIndices; instances skipped")
            return
        mask = instancer.ComputeMaskAtTime(self.time)
        keep = np.asarray(mask, dtype=bool) if mask else np.ones(len(indices), dtype=bool)
        world = np.stack(
            [np.asarray(UsdGeom.XformCache(t).GetLocalToWorldTransform(prim)) for t in times]
        )
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
                # Broadcasting pairs each copy's k-th sample with the instancer's k-th.
                self._sync_prototype_mesh(record, path, root, mesh_prim, selected @ world, visible)

    def _default_position_offsets(
        self, instancer: UsdGeom.PointInstancer, times: list[Usd.TimeCode], count: int
    ) -> np.ndarray:
        """(N, K, 3) displacements from ``velocities`` (units/s) and ``accelerations``
        (units/s²) at the sample times, Δ = (t − frame) / timeCodesPerSecond."""
        seconds = np.array([(t.GetValue() - self.time.GetValue()) for t in times])
        seconds /= self.stage.GetTimeCodesPerSecond()
        offsets = np.zeros((count, len(times), 3))
        for attr, factor in ((instancer.GetVelocitiesAttr(), seconds), (instancer.GetAccelerationsAttr(), 0.5 * seconds**2)):
            value = attr.Get(self.time)
            if value is not None and len(value) == count:
                offsets += np.asarray(value, dtype=np.float64)[:, None, :] * factor[None, :, None]
            elif value:
                self.warn(f"{instancer.GetPath()}: {attr.GetName()} has {len(value)} values for {count} instances; ignored")
        return offsets

    def _motion_times(self, prim: Usd.Prim, instancer: UsdGeom.PointInstancer) -> list[Usd.TimeCode]:
        """The sample times of the copies: the frame alone unless something moves within the
        shutter, else a uniform grid holding the authored samples inside it."""
        shutter = self.shutter
        if not shutter.blurred:
            return [shutter.frame]
        interval = shutter.interval
        keyed = [
            instancer.GetPositionsAttr(),
            instancer.GetOrientationsAttr(),
            instancer.GetScalesAttr(),
        ]
        authored = [t for attr in keyed for t in attr.GetTimeSamplesInInterval(interval)]
        moving = any(changes_within(attr, interval) for attr in keyed) or transform_might_vary(prim)
        # Velocities move copies linearly; accelerations and angular velocities bend the path.
        curved = bool(instancer.GetAccelerationsAttr().Get(self.time)) or bool(
            instancer.GetAngularVelocitiesAttr().Get(self.time)
        )
        if bool(instancer.GetVelocitiesAttr().Get(self.time)) or curved:
            moving = True
        if not moving:
            return [shutter.frame]
        segments = shutter.segments(authored)
        if curved:
            segments = max(segments, min(4, shutter.max_segments))
        return shutter.times(segments)

    def _prototype_meshes(self, instancer: Sdf.Path, root: Usd.Prim) -> Iterable[Usd.Prim]:
        walk = iter(Usd.PrimRange(root, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
        for prim in walk:
            if prim.IsA(UsdGeom.PointInstancer):
                self.warn(f"{instancer}: nested point instancer {prim.GetPath()} is not supported yet")
                walk.PruneChildren()
            elif prim.IsA(UsdGeom.Mesh) or is_implicit(prim):
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
        if transforms.shape[1] == 1:
            transforms = transforms[:, 0]  # static copies
        self.core.set_instances(copies_id, mesh_id, np.ascontiguousarray(transforms))
        self.core.set_visible(copies_id, visible)


def _removal_order(prim_id: str) -> int:
    if "/instances/" in prim_id:
        return 0
    return 1 if "/prototypes/" in prim_id else 2
