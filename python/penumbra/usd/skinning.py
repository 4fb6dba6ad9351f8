"""UsdSkel: meshes, curves and points deformed by a skeleton's animation and by blend shapes,
posed as UsdSkel poses them (usdrecord and Storm through UsdSkelImaging, ``UsdSkel.BakeSkinning``).

A point-based prim is skinned when it lies under a SkelRoot, is bound to a Skeleton
(``skel:skeleton``, on it or an ancestor) and has joint influences. Its points are deformed by
its blend shapes (the weights of the skeleton's SkelAnimation), then skinned in the skeleton's
space by usd-core's own implementation (linear or dual-quaternion, rigid bindings included),
then placed by the skeleton's local-to-world transform: a skinned prim's own transform is
ignored (UsdSkel's rule). The delegate places prims by their own transform, so the points are
sent in the prim's space: skeleton space through the skeleton's and the inverse of the prim's
transform at each time. A mesh's authored shading normals are carried along by each point's
skinning (its linear part, found by skinning three unit offsets). Over a shutter, the pose is
sampled at the times that include every authored key of the animation, its skinning attributes
and both transforms, and finer while points stray from the chords between samples.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdSkel, Vt

from .motion import ARC_TOLERANCE, point_samples, xform_sample_times
from .sampling import SampleReader, transform_might_vary

_INFLUENCES = "primvars:skel:jointIndices"
_SHAPES = "skel:blendShapes"
_POPULATE = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)


def find_skinning(
    prim: Usd.Prim,
    warn: Callable[[str], None],
    path: str,
    caches: SkelCaches | None = None,
    names: frozenset[str] | None = None,
    inherited: tuple[UsdGeom.Primvar, ...] = (),
) -> Skinning | None:
    """The skinning of point-based ``prim`` (authored property ``names`` and inherited constant
    primvars ``inherited``, when the caller knows them), or ``None`` when UsdSkel would not
    pose it: no joint influences of its own or inherited (a rigid binding) and no blend shapes,
    outside a SkelRoot, or bound to no usable Skeleton (warned). ``caches``: those of the
    caller's sync."""
    if names is None:
        posed = prim.HasAPI(UsdSkel.BindingAPI) or bool(
            UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance(_INFLUENCES[9:])
        )
    else:
        posed = _INFLUENCES in names or _SHAPES in names or any(
            primvar.GetName() == _INFLUENCES for primvar in inherited
        )
    return _skinning_of(prim, caches or SkelCaches(), warn, path) if posed else None


def skel_root(prim: Usd.Prim) -> Usd.Prim | None:
    """The nearest SkelRoot at or above ``prim``."""
    while prim and not prim.IsPseudoRoot():
        if prim.IsA(UsdSkel.Root):
            return prim
        prim = prim.GetParent()
    return None


class SkelCaches:
    """The UsdSkel caches of the SkelRoots met in one sync, each populated once (populating
    reads the joint influences of every prim below the root)."""

    def __init__(self) -> None:
        self._caches: dict[str, UsdSkel.Cache] = {}

    def cache(self, root: Usd.Prim) -> UsdSkel.Cache:
        key = str(root.GetPath())
        cache = self._caches.get(key)
        if cache is None:
            cache = self._caches[key] = UsdSkel.Cache()
            cache.Populate(UsdSkel.Root(root), _POPULATE)
        return cache


class Skinning:
    """The skinning of one prim: its queries, its skeleton and its SkelAnimation's. Without
    joint influences (blend shapes alone) the prim keeps its own space and transform."""

    def __init__(
        self,
        prim: Usd.Prim,
        query: UsdSkel.SkinningQuery,
        skeleton: UsdSkel.SkeletonQuery,
        warn: Callable[[str], None],
        path: str,
    ) -> None:
        self.prim = prim
        self.query = query
        self.skeleton = skeleton
        self.joints = query.HasJointInfluences()
        self.animation = skeleton.GetAnimQuery()
        self.shapes = None
        if query.HasBlendShapes() and self.animation:
            self.shapes = UsdSkel.BlendShapeQuery(UsdSkel.BindingAPI(prim))
        self._warn = warn
        self._path = path
        # Its own skinning attributes (those authored: usd-core's GetTimeSamples fails on an
        # unauthored geomBindTransform).
        own = (
            query.GetJointIndicesPrimvar(), query.GetJointWeightsPrimvar(),
            query.GetGeomBindTransformAttr(), query.GetSkinningMethodAttr(),
            query.GetBlendShapesAttr(),
        )
        self._attributes = [
            attr for attr in (a.GetAttr() if isinstance(a, UsdGeom.Primvar) else a for a in own)
            if attr
        ]

    def _placing(self) -> list[Usd.Prim]:
        """The prims whose transforms place the points: the skeleton's and the prim's (the
        points are sent in the prim's space), or none without joints."""
        return [self.skeleton.GetPrim(), self.prim] if self.joints else []

    def might_vary(self) -> bool:
        """Whether the pose might change with time."""
        animation = self.animation
        return bool(
            (self.joints and animation and animation.JointTransformsMightBeTimeVarying())
            or (self.shapes and animation.BlendShapeWeightsMightBeTimeVarying())
            or any(attr.ValueMightBeTimeVarying() for attr in self._attributes)
            or any(transform_might_vary(prim) for prim in self._placing())
        )

    def key_times(self, interval: Gf.Interval) -> set[float]:
        """The authored keys inside ``interval`` of what poses the prim."""
        times: set[float] = set()
        for attr in self._attributes:
            times.update(attr.GetTimeSamplesInInterval(interval))
        if self.joints and self.animation:
            times.update(self.animation.GetJointTransformTimeSamplesInInterval(interval))
        if self.shapes:
            times.update(self.animation.GetBlendShapeWeightTimeSamplesInInterval(interval))
        for prim in self._placing():
            times.update(xform_sample_times(prim, interval))
        return times

    def to_prim_space(self, time: Usd.TimeCode) -> np.ndarray | None:
        """Skeleton space → the prim's space at ``time`` (row vectors, float64 (4, 4)); ``None``
        when the prim's transform is singular."""
        world = UsdGeom.XformCache(time)
        own = world.GetLocalToWorldTransform(self.prim)
        if abs(own.GetDeterminant()) < 1e-300:
            return None
        return np.array(world.GetLocalToWorldTransform(self.skeleton.GetPrim()) * own.GetInverse())

    def _drop_shapes(self, problem: str) -> None:
        """Pose without the blend shapes (as UsdSkel.BakeSkinning does), after one warning."""
        self._warn(f"{self._path}: its blend shapes cannot apply ({problem}); posed without them")
        self.shapes = None

    def _sub_shapes(self, time: Usd.TimeCode):
        """The sub-shape weights, blend shape indices and sub-shape indices at ``time``."""
        weights = self.animation.ComputeBlendShapeWeights(time)
        mapper = self.query.GetBlendShapeMapper()
        if mapper and not mapper.IsIdentity():
            weights = mapper.Remap(weights)
        return self.shapes.ComputeSubShapeWeights(weights)

    def pose(self, rest: Vt.Vec3fArray, time: Usd.TimeCode) -> np.ndarray | str:
        """``rest`` deformed by the blend shapes and skinned at ``time``, in the prim's space:
        float64 (N, 3); else what stops it."""
        points = Vt.Vec3fArray(rest)
        if self.shapes:
            shapes = self.shapes
            try:
                sub, shape_indices, sub_indices = self._sub_shapes(time)
                deformed = shapes.ComputeDeformedPoints(
                    sub, shape_indices, sub_indices, shapes.ComputeBlendShapePointIndices(),
                    shapes.ComputeSubShapePointOffsets(), points,
                )
            except RuntimeError as error:  # usd-core's errors (a target that is no BlendShape)
                deformed, problem = False, str(error).splitlines()[0]
            else:
                problem = "their offsets or point indices do not match the points"
            if not deformed:
                self._drop_shapes(problem)
                points = Vt.Vec3fArray(rest)
        if not self.joints:
            return np.asarray(points, dtype=np.float64)
        xforms = self.skeleton.ComputeSkinningTransforms(time)
        if not self.query.ComputeSkinnedPoints(xforms, points, time):
            return "its joint influences do not match its points or its skeleton's joints"
        to_prim = self.to_prim_space(time)
        if to_prim is None:
            return "its transform is singular"
        return np.asarray(points, dtype=np.float64) @ to_prim[:3, :3] + to_prim[3, :3]

    def normal_offsets(self, time: Usd.TimeCode, count: int) -> np.ndarray:
        """The blend shapes' weighted ``normalOffsets`` (of their in-betweens too) per point."""
        total = np.zeros((count, 3))
        if not self.shapes:
            return total
        shapes = self.shapes
        for weight, shape_index, sub_index in zip(*self._sub_shapes(time)):
            if weight == 0:
                continue
            shape = shapes.GetBlendShape(shape_index)
            inbetween = shapes.GetInbetween(sub_index)
            offsets = inbetween.GetNormalOffsets() if inbetween else shape.GetNormalOffsetsAttr().Get()
            if not offsets:
                continue
            offsets = np.asarray(offsets, dtype=np.float64)
            indices = shape.GetPointIndicesAttr().Get()
            points = np.asarray(indices, dtype=np.int64) if indices else np.arange(len(offsets))
            if len(points) == len(offsets) and (points.min() >= 0 and points.max() < count):
                np.add.at(total, points, weight * offsets)
        return total

    def normal_matrices(self, rest: np.ndarray, time: Usd.TimeCode) -> np.ndarray | None:
        """Per point, the matrix carrying a normal from the prim's rest space into its posed
        space (row vectors, (N, 3, 3)): linear skinning blends the joints' inverse transposes
        after the geomBindTransform's (as UsdSkel.SkinNormals does); dual-quaternion skinning
        turns each point by a rotation, found by skinning the three unit offsets."""
        time_xforms = self.skeleton.ComputeSkinningTransforms(time)
        count = len(rest)
        if self.query.GetSkinningMethod() == UsdSkel.Tokens.dualQuaternion:
            base = Vt.Vec3fArray.FromNumpy(rest)
            if not self.query.ComputeSkinnedPoints(time_xforms, base, time):
                return None
            origin = np.asarray(base, dtype=np.float64)
            rows = []
            for axis in np.eye(3, dtype=np.float32):
                moved = Vt.Vec3fArray.FromNumpy(rest + axis)
                if not self.query.ComputeSkinnedPoints(time_xforms, moved, time):
                    return None
                rows.append(np.asarray(moved, dtype=np.float64) - origin)
            with np.errstate(all="ignore"):
                return np.linalg.pinv(np.stack(rows, axis=1)).transpose(0, 2, 1)
        mapper = self.query.GetJointMapper()
        if mapper and not mapper.IsIdentity():
            time_xforms = mapper.RemapTransforms(time_xforms, Vt.Matrix4dArray())
        joints = np.array(time_xforms, dtype=np.float64).reshape(-1, 4, 4)[:, :3, :3]
        indices, weights = self.query.ComputeVaryingJointInfluences(count, time)
        per_point = self.query.GetNumInfluencesPerComponent()
        indices = np.asarray(indices, dtype=np.int64)
        if len(indices) != count * per_point or len(joints) == 0 or (
            len(indices) and (indices.min() < 0 or indices.max() >= len(joints))
        ):
            return None
        bind = np.array(self.query.GetGeomBindTransform(time), dtype=np.float64)[:3, :3]
        with np.errstate(all="ignore"):
            joint_normals = np.linalg.pinv(joints).transpose(0, 2, 1)
            blended = np.einsum(
                "nk,nkij->nij",
                np.asarray(weights, dtype=np.float64).reshape(count, per_point),
                joint_normals[indices.reshape(count, per_point)],
            )
            return np.linalg.pinv(bind).T @ blended


def _skinning_of(
    prim: Usd.Prim, caches: SkelCaches, warn: Callable[[str], None], path: str
) -> Skinning | None:
    """The skinning of ``prim``, which has joint influences or blend shapes (see
    :func:`find_skinning`)."""
    if prim.IsInPrototype():
        warn(
            f"{path}: a prim with joint influences inside an instance's prototype is rendered "
            "unskinned (skinning of instances is not supported)"
        )
        return None
    root = skel_root(prim)
    if root is None:  # as UsdSkel leaves it (UsdSkel.BakeSkinning's output keeps influences)
        return None
    cache = caches.cache(root)
    query = cache.GetSkinningQuery(prim)
    if not query or not query.HasJointInfluences() and not query.HasBlendShapes():
        return None
    skeleton = UsdSkel.BindingAPI(prim).GetInheritedSkeleton()
    skeleton_query = cache.GetSkelQuery(skeleton) if skeleton else None
    if not skeleton_query:
        warn(f"{path}: is bound to no usable Skeleton (skel:skeleton); rendered in its bind pose")
        return None
    if query.HasJointInfluences() and not skeleton_query.HasBindPose():
        warn(
            f"{path}: its Skeleton {skeleton.GetPath()} has no usable bind pose (bindTransforms, "
            "one per joint); rendered in its bind pose"
        )
        return None
    return Skinning(prim, query, skeleton_query, warn, path)


def skinned_points(
    skinning: Skinning,
    rest: np.ndarray,
    reader: SampleReader,
    warn: Callable[[str], None],
    path: str,
) -> np.ndarray:
    """The posed points of a skinned prim in its own space: float32 (N, 3), or (K, N, 3) over
    the reader's shutter when the pose changes within it; ``rest`` (with a warning) when
    usd-core cannot skin it."""
    shutter = reader.shutter
    varies = skinning.might_vary()
    if varies:
        reader.depends_on_shutter()
    rest_array = Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(rest, dtype=np.float32))

    def posed(times: list[Usd.TimeCode]) -> list[np.ndarray] | None:
        samples = []
        for time in times:
            points = skinning.pose(rest_array, time)
            if isinstance(points, str):
                warn(f"{path}: cannot be skinned ({points}); rendered in its bind pose")
                return None
            samples.append(points)
        return samples

    if not (shutter.blurred and varies):
        samples = posed([shutter.frame])
        return rest if samples is None else samples[0].astype(np.float32)
    # Joints turn on arcs between keys, which the delegate's linear steps cut: steps are halved
    # (up to the maximum) while a step's midpoint strays from its chord.
    segments = shutter.segments(skinning.key_times(shutter.interval))
    samples = posed(shutter.times(segments))
    while samples is not None and 2 * segments <= shutter.max_segments:
        middles = posed(shutter.times(2 * segments)[1::2])
        if middles is None:
            samples = None
            break
        finer = [point for pair in zip(samples, middles) for point in pair] + [samples[-1]]
        if _follow_chords(finer):
            break
        segments, samples = 2 * segments, finer
    if samples is None:
        return rest
    if all(np.array_equal(sample, samples[0]) for sample in samples[1:]):
        return samples[0].astype(np.float32)
    return np.asarray(samples, dtype=np.float32)


def positions_over_shutter(
    gprim: UsdGeom.PointBased,
    positions: np.ndarray,
    reader: SampleReader,
    warn: Callable[[str], None],
    path: str,
    caches: SkelCaches | None = None,
) -> np.ndarray:
    """The positions of curves or points ``gprim`` (``positions``: as read at the reader's
    time) for the delegate: posed when it is skinned (``caches``: those of the caller's sync),
    else sampled over an open shutter or along authored velocities
    (:func:`~.motion.point_samples`), else as read."""
    skinning = find_skinning(gprim.GetPrim(), warn, path, caches)
    if skinning is not None:
        return skinned_points(skinning, positions, reader, warn, path)
    if reader.shutter.blurred or gprim.GetVelocitiesAttr().HasAuthoredValue():
        return point_samples(gprim, positions, reader, warn, path)
    return positions


def _follow_chords(samples: list[np.ndarray]) -> bool:
    """Whether every odd sample of ``samples`` lies on the chord between its neighbours, within
    ARC_TOLERANCE of the step's length (a point's own)."""
    for k in range(1, len(samples) - 1, 2):
        before, middle, after = samples[k - 1], samples[k], samples[k + 1]
        chord = np.linalg.norm(after - before, axis=1)
        stray = np.linalg.norm(middle - 0.5 * (before + after), axis=1)
        if np.any(stray > ARC_TOLERANCE * chord + 1e-7 * (1 + np.abs(middle).max())):
            return False
    return True


def skinned_normals(
    skinning: Skinning,
    rest: np.ndarray,
    normals: np.ndarray,
    interpolation: str,
    face_vertex_indices: np.ndarray,
    face_vertex_counts: np.ndarray,
    time: Usd.TimeCode,
) -> np.ndarray:
    """Authored ``normals`` (of ``interpolation``) posed at ``time`` in the mesh's space, as
    UsdSkel.BakeSkinning poses them: per point, the blend shapes' normal offsets added (vertex
    and varying normals), then the point's skinning carries them (a face-varying normal by its
    face-vertex's point, a uniform one by its face's first point, a constant one by point 0);
    unchanged where that cannot be (mismatched counts, which the delegate names)."""
    if interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying):
        owners = np.arange(len(normals))
    elif interpolation == UsdGeom.Tokens.faceVarying:
        owners = np.asarray(face_vertex_indices, dtype=np.int64)
    elif interpolation == UsdGeom.Tokens.uniform:
        starts = np.concatenate(([0], np.cumsum(face_vertex_counts)[:-1])).astype(np.int64)
        owners = np.asarray(face_vertex_indices, dtype=np.int64)[starts]
    else:
        owners = np.zeros(len(normals), dtype=np.int64)
    count = len(rest)
    if len(owners) != len(normals) or (len(owners) and (owners.min() < 0 or owners.max() >= count)):
        return normals
    posed = np.asarray(normals, dtype=np.float64)
    if interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying):
        posed = posed + skinning.normal_offsets(time, count)
    if skinning.joints:
        matrices = skinning.normal_matrices(np.ascontiguousarray(rest, dtype=np.float32), time)
        to_prim = skinning.to_prim_space(time)
        if matrices is None or to_prim is None:
            return normals
        with np.errstate(all="ignore"):
            carry = matrices[owners] @ np.linalg.pinv(to_prim[:3, :3]).T
            posed = np.einsum("nj,nji->ni", posed, carry)
    with np.errstate(all="ignore"):
        lengths = np.linalg.norm(posed, axis=1, keepdims=True)
        posed = np.where(lengths > 0, posed / lengths, normals)
    return posed.astype(np.float32)
