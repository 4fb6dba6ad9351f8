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

from .motion import ARC_TOLERANCE
from .motion import xform_sample_times
from .sampling import SampleReader, transform_might_vary

_INFLUENCES = "primvars:skel:jointIndices"
_POPULATE = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)


def find_skinning(
    prim: Usd.Prim,
    warn: Callable[[str], None],
    path: str,
    caches: SkelCaches | None = None,
    names: frozenset[str] | None = None,
    inherited: tuple[UsdGeom.Primvar, ...] = (),
) -> Skinning | None:
    """The skinning of point-based ``prim`` (authored property ``names``, ``None`` if unknown;
    inherited constant primvars ``inherited``), or ``None`` when UsdSkel would not pose it: no
    joint influences of its own or inherited (a rigid binding), outside a SkelRoot, or bound to
    no usable Skeleton (warned). ``caches``: those of the caller's sync."""
    if names is None:
        influenced = prim.HasAPI(UsdSkel.BindingAPI)
    else:
        influenced = _INFLUENCES in names
    if influenced or any(primvar.GetName() == _INFLUENCES for primvar in inherited):
        return _skinning_of(prim, caches or SkelCaches(), warn, path)
    return None


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
    """The skinning of one prim: its queries, its skeleton and its SkelAnimation's."""

    def __init__(
        self, prim: Usd.Prim, query: UsdSkel.SkinningQuery, skeleton: UsdSkel.SkeletonQuery
    ) -> None:
        self.prim = prim
        self.query = query
        self.skeleton = skeleton
        self.animation = skeleton.GetAnimQuery()
        self.shapes = UsdSkel.BlendShapeQuery(UsdSkel.BindingAPI(prim)) if query.HasBlendShapes() else None

    def might_vary(self) -> bool:
        """Whether the pose might change with time."""
        animation = self.animation
        return bool(
            (animation and animation.JointTransformsMightBeTimeVarying())
            or (self.shapes and animation and animation.BlendShapeWeightsMightBeTimeVarying())
            or self.query.GetTimeSamples()
            or transform_might_vary(self.skeleton.GetPrim())
            or transform_might_vary(self.prim)
        )

    def key_times(self, interval: Gf.Interval) -> set[float]:
        """The authored keys inside ``interval`` of what poses the prim."""
        times = set(self.query.GetTimeSamplesInInterval(interval))
        if self.animation:
            times.update(self.animation.GetJointTransformTimeSamplesInInterval(interval))
            if self.shapes:
                times.update(self.animation.GetBlendShapeWeightTimeSamplesInInterval(interval))
        times.update(xform_sample_times(self.skeleton.GetPrim(), interval))
        times.update(xform_sample_times(self.prim, interval))
        return times

    def to_prim_space(self, time: Usd.TimeCode) -> np.ndarray | None:
        """Skeleton space → the prim's space at ``time`` (row vectors, float64 (4, 4)); ``None``
        when the prim's transform is singular."""
        world = UsdGeom.XformCache(time)
        own = world.GetLocalToWorldTransform(self.prim)
        if abs(own.GetDeterminant()) < 1e-300:
            return None
        return np.array(world.GetLocalToWorldTransform(self.skeleton.GetPrim()) * own.GetInverse())

    def skinned(self, rest: Vt.Vec3fArray, time: Usd.TimeCode) -> np.ndarray | None:
        """``rest`` deformed by the blend shapes and skinned at ``time``, in skeleton space:
        float64 (N, 3); ``None`` when usd-core cannot (mismatched influences or shapes)."""
        points = Vt.Vec3fArray(rest)
        if self.shapes and self.animation:
            weights = self.animation.ComputeBlendShapeWeights(time)
            mapper = self.query.GetBlendShapeMapper()
            if mapper and not mapper.IsIdentity():
                weights = mapper.Remap(weights)
            shapes = self.shapes
            sub, shape_indices, sub_indices = shapes.ComputeSubShapeWeights(weights)
            if not shapes.ComputeDeformedPoints(
                sub, shape_indices, sub_indices, shapes.ComputeBlendShapePointIndices(),
                shapes.ComputeSubShapePointOffsets(), points,
            ):
                return None
        xforms = self.skeleton.ComputeSkinningTransforms(time)
        if not self.query.ComputeSkinnedPoints(xforms, points, time):
            return None
        return np.asarray(points, dtype=np.float64)

    def linear_parts(self, rest: np.ndarray, time: Usd.TimeCode) -> np.ndarray | None:
        """Each point's skinning deformation, linear part (row vectors, (N, 3, 3)): the skinned
        offsets of the three unit vectors at the point (blend shapes translate, so they drop
        out; dual-quaternion skinning is a rotation and translation per point)."""
        xforms = self.skeleton.ComputeSkinningTransforms(time)
        base = Vt.Vec3fArray.FromNumpy(rest)
        if not self.query.ComputeSkinnedPoints(xforms, base, time):
            return None
        origin = np.asarray(base, dtype=np.float64)
        rows = []
        for axis in np.eye(3, dtype=np.float32):
            moved = Vt.Vec3fArray.FromNumpy(rest + axis)
            if not self.query.ComputeSkinnedPoints(xforms, moved, time):
                return None
            rows.append(np.asarray(moved, dtype=np.float64) - origin)
        return np.stack(rows, axis=1)


def _skinning_of(
    prim: Usd.Prim, caches: SkelCaches, warn: Callable[[str], None], path: str
) -> Skinning | None:
    """The skinning of ``prim``, which has joint influences (see :func:`find_skinning`)."""
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
    return Skinning(prim, query, skeleton_query)


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
    if skinning.might_vary():
        reader.depends_on_shutter()
    rest_array = Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(rest, dtype=np.float32))

    def posed(times: list[Usd.TimeCode]) -> list[np.ndarray] | None:
        samples = []
        for time in times:
            skinned = skinning.skinned(rest_array, time)
            to_prim = skinning.to_prim_space(time)
            if skinned is None or to_prim is None:
                problem = "its transform is singular" if to_prim is None else (
                    "its joint influences or blend shapes do not match its points or skeleton"
                )
                warn(f"{path}: cannot be skinned ({problem}); rendered in its bind pose")
                return None
            samples.append(skinned @ to_prim[:3, :3] + to_prim[3, :3])
        return samples

    if not (shutter.blurred and skinning.might_vary()):
        samples = posed([shutter.frame])
        return rest if samples is None else samples[0].astype(np.float32)
    # Joints turn on arcs between keys, which the delegate's linear steps cut: steps are halved
    # (up to the maximum) while a step's midpoint strays from its chord.
    segments = shutter.segments(skinning.key_times(shutter.interval))
    samples = posed(shutter.times(segments))
    while samples is not None and 2 * segments <= shutter.max_segments:
        finer = posed(shutter.times(2 * segments))
        if finer is None or _follow_chords(finer):
            break
        segments, samples = 2 * segments, finer
    if samples is None:
        return rest
    if all(np.array_equal(sample, samples[0]) for sample in samples[1:]):
        return samples[0].astype(np.float32)
    return np.asarray(samples, dtype=np.float32)


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
    """Authored ``normals`` (of ``interpolation``) carried by the skinning at ``time`` into the
    mesh's space: each by the inverse transpose of its point's deformation (a face's first
    point for uniform normals, point 0 for a constant one); unchanged where it cannot be."""
    parts = skinning.linear_parts(np.ascontiguousarray(rest, dtype=np.float32), time)
    to_prim = skinning.to_prim_space(time)
    if parts is None or to_prim is None:
        return normals
    if interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying):
        owners = np.arange(len(normals))
    elif interpolation == UsdGeom.Tokens.faceVarying:
        owners = face_vertex_indices
    elif interpolation == UsdGeom.Tokens.uniform:
        owners = face_vertex_indices[np.concatenate(([0], np.cumsum(face_vertex_counts)[:-1]))]
    else:
        owners = np.zeros(len(normals), dtype=np.int64)
    if len(owners) != len(normals) or (
        len(owners) and (owners.min() < 0 or owners.max() >= len(parts))
    ):
        return normals  # the delegate names the mismatch
    linear = parts[owners] @ to_prim[:3, :3]
    with np.errstate(all="ignore"):
        carried = np.einsum("nj,nkj->nk", normals, np.linalg.pinv(linear))
        lengths = np.linalg.norm(carried, axis=1, keepdims=True)
        carried = np.where(lengths > 0, carried / lengths, normals)
    return carried.astype(np.float32)
