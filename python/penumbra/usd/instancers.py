"""Instancing → the render delegate's instancer rprims.

Every instanced mesh — a mesh inside a UsdGeomPointInstancer prototype or inside a native USD
prototype (instanceable prims, see :mod:`.native_instancing`) — becomes one hidden mesh rprim per
material it is rendered with (its geometry, read once, from the prim that holds it) and one
instancer rprim holding the world transform of each of its copies: Embree shares the mesh's BVH
among all copies, so memory grows with the number of instances, not with their triangles.

Instancing nests: a prototype may hold instanceable prims and point instancers whose prototypes
hold more of them. :class:`Flattener` expands such a subtree into :class:`Leaf` s — meshes with
the transforms of all their copies relative to the subtree's root — composing the transforms
level by level, so that however deep a mesh is nested, its copies share its one BVH. Every
level is evaluated on one uniform grid of times over the shutter (the finest any moving level
of the subtree needs), so motion samples compose sample by sample.

Point instancer copies come from usd-core (``ComputeInstanceTransformsAtTimes``: positions,
orientations, scales, the prototype root's own transform), masked by ``invisibleIds``. usd-core
extrapolates ``velocities``/``accelerations`` only from time-sampled positions and
``angularVelocities`` only from time-sampled orientations; for default-valued ones Penumbra
moves and spins each copy itself (units per second, degrees per second: docs/design.md §3).

Per-instance primvars travel with the copies (:attr:`Leaf.primvars`, one row per copy): a point
instancer's vertex/varying primvars and the constant primvars of instances and instancers, which
the copied mesh inherits unless it authors the name itself. Nested levels compose outer-major,
the inner (nearer) level winning; a copy lacking a primvar others in its group have gets NaN,
which the delegate reads as "use the mesh's own".

:class:`InstancedMeshes` pushes grouped copies to the delegate and, on later updates, only what
changed (new or edited meshes, changed transforms). :class:`PointInstancerDelegate` mirrors the
point instancers that are not inside native prototypes (those are flattened with their
prototype); an edit under an instancer, its prototypes or the materials they use re-flattens
that instancer.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from pxr import Sdf, Tf, Usd, UsdGeom, UsdShade

from .implicit import is_implicit
from .material import bound_material, push_material, read_material
from .mesh import numeric_primvar, sync_mesh_data
from .motion import ACCELERATION_SEGMENTS, XformCaches, transform_samples
from .sampling import SampleReader, Shutter, changes_within, transform_might_vary

_MAX_STEP_SPIN = 90.0  # degrees a spinning copy may turn between two motion samples


# --------------------------------------------------------------------------------------------
# Flattening nested instancing


@dataclass
class Leaf:
    """Copies of one mesh below an expanded root."""

    mesh: Usd.Prim  # the prim holding the geometry (inside a USD prototype, or a plain prim)
    proxy: Sdf.Path  # where the copies' material binding resolves, in the root's namespace
    purpose: str | None  # the nearest purpose authored within the root; None: inherited
    transforms: np.ndarray  # float64 (M, K, 4, 4): mesh-to-root, K = 1 or the grid's samples
    # Per-copy primvars of enclosing point instancers: name → (M,) or (M, width) values.
    primvars: dict[str, np.ndarray] = field(default_factory=dict)


def nest_primvars(
    outer: dict[str, np.ndarray], inner: dict[str, np.ndarray], outer_count: int, inner_count: int
) -> dict[str, np.ndarray]:
    """Per-copy primvars of ``outer_count`` × ``inner_count`` nested copies (outer index major):
    an outer copy's value holds for all its inner copies; inner values, closer to the geometry,
    win."""
    nested = {name: np.repeat(values, inner_count, axis=0) for name, values in outer.items()}
    nested.update(
        {name: np.tile(values, (outer_count,) + (1,) * (values.ndim - 1)) for name, values in inner.items()}
    )
    return nested


def inherited_primvars(
    prim: Usd.Prim, reader: SampleReader, warn: Callable[[str], None]
) -> dict[str, np.ndarray]:
    """The constant numeric primvars that what is below ``prim`` (an instance) inherits from it
    and its ancestors: one row each."""
    result = {}
    for primvar in UsdGeom.PrimvarsAPI(prim).FindPrimvarsWithInheritance():
        if primvar.GetInterpolation() != UsdGeom.Tokens.constant:
            continue
        values = numeric_primvar(primvar, reader, warn, str(prim.GetPath()))
        if values is not None:
            result[primvar.GetPrimvarName()] = values[:1]
    return result


def primvar_names(mesh: Usd.Prim) -> set[str]:
    """The primvars ``mesh`` has itself or inherits within its prototype."""
    return {p.GetPrimvarName() for p in UsdGeom.PrimvarsAPI(mesh).FindPrimvarsWithInheritance()}


def outer_primvars(
    inherited: dict[str, np.ndarray], per_copy: dict[str, np.ndarray], mesh: Usd.Prim, count: int
) -> dict[str, np.ndarray]:
    """Primvars of ``count`` copies of ``mesh`` from what encloses them: ``inherited`` (one row,
    which the mesh's own primvars of the same name override, being nearer) under ``per_copy``
    (one row per copy, which override the mesh's)."""
    own = primvar_names(mesh) if inherited else set()
    result = {n: np.repeat(v, count, axis=0) for n, v in inherited.items() if n not in own}
    result.update(per_copy)
    return result


def combine_segments(a: int, b: int, limit: int) -> int:
    """The uniform steps of a grid holding an ``a``-step and a ``b``-step grid (0 = static),
    ``limit`` when that would be finer."""
    if not a or not b:
        return a or b
    both = math.lcm(a, b)
    return both if both <= limit else limit


class Flattener:
    """Expands instancing below a root into :class:`Leaf` s at one frame and shutter.

    ``varying`` becomes true once anything read (transforms, visibility, instancer attributes)
    might change with the frame or shutter. Expansions are cached, so a prototype instanced many
    times is expanded once.
    """

    def __init__(self, stage: Usd.Stage, shutter: Shutter, warn: Callable[[str], None]):
        self.stage = stage
        self.shutter = shutter
        self.warn = warn
        self.caches = XformCaches()
        self.varying = False
        self.roots: set[Sdf.Path] = set()  # every subtree expanded (for change tracking)
        self._segments: dict[Sdf.Path, int] = {}
        self._leaves: dict[tuple[Sdf.Path, int], list[Leaf]] = {}

    # Times and transforms

    def times(self, segments: int) -> list[Usd.TimeCode]:
        """The grid's times: the frame alone for 0 segments."""
        return self.shutter.times(segments) if segments else [self.shutter.frame]

    def motion_segments(self, prim: Usd.Prim) -> int:
        """Uniform steps the world transform of ``prim`` needs over the shutter (0: static)."""
        if not transform_might_vary(prim):
            return 0
        self.varying = True
        if not self.shutter.blurred:
            return 0
        samples = transform_samples(prim, self.shutter, self.caches)
        return len(samples) - 1 if samples.ndim == 3 else 0

    def world(self, prim: Usd.Prim, segments: int) -> np.ndarray:
        """(K, 4, 4) local-to-world transforms of ``prim`` on the grid."""
        return np.stack([np.asarray(self.caches.world(prim, t)) for t in self.times(segments)])

    def relative(self, prim: Usd.Prim, root: Usd.Prim, segments: int) -> np.ndarray:
        """(K, 4, 4) transforms of ``prim`` relative to ``root`` (whose own transform is
        excluded); K = 1 unless something between them moves."""
        moving = segments and any(
            UsdGeom.Xformable(p).TransformMightBeTimeVarying() for p in _up_to(prim, root)
        )
        matrices = self.world(prim, segments if moving else 0)
        if root.IsPseudoRoot() or root.IsPrototype():  # world = relative to the prototype
            return matrices
        return matrices @ np.linalg.inv(self.world(root, segments if moving else 0))

    # Motion needs

    def content_segments(self, root: Usd.Prim) -> int:
        """Uniform steps the moving transforms below ``root`` need (0: all static)."""
        path = root.GetPath()
        if path not in self._segments:
            self._segments[path] = 0  # guards against cycles of prototypes
            limit = self.shutter.max_segments
            total = 0
            for prim, kind in self._walk(root):
                if prim != root and UsdGeom.Xformable(prim):
                    total = combine_segments(total, self.motion_segments(prim), limit)
                if kind == "instance":
                    nested = self.content_segments(prim.GetPrototype())
                    total = combine_segments(total, nested, limit)
                elif kind == "point instancer":
                    total = combine_segments(total, self.point_instancer_segments(prim), limit)
                    for prototype in _prototype_roots(prim):
                        nested = self.content_segments(prototype)
                        total = combine_segments(total, nested, limit)
            self._segments[path] = total
        return self._segments[path]

    def point_instancer_segments(self, prim: Usd.Prim) -> int:
        """Uniform steps the copies of point instancer ``prim`` need (0: static): the authored
        samples of positions, orientations and scales inside the shutter; velocities move
        copies linearly, accelerations and angular velocities bend their paths."""
        instancer = UsdGeom.PointInstancer(prim)
        keyed = [
            instancer.GetPositionsAttr(),
            instancer.GetOrientationsAttr(),
            instancer.GetScalesAttr(),
        ]
        frame = self.shutter.frame
        velocities = instancer.GetVelocitiesAttr().Get(frame)
        accelerations = instancer.GetAccelerationsAttr().Get(frame)
        spins = instancer.GetAngularVelocitiesAttr().Get(frame)
        if velocities or accelerations or spins or any(
            attr.ValueMightBeTimeVarying()
            for attr in (*keyed, instancer.GetProtoIndicesAttr(), instancer.GetInvisibleIdsAttr())
        ):
            self.varying = True
        if not self.shutter.blurred:
            return 0
        interval = self.shutter.interval
        moving = any(changes_within(attr, interval) for attr in keyed)
        if not (moving or velocities or accelerations or spins):
            return 0
        segments = self.shutter.segments(
            t for attr in keyed for t in attr.GetTimeSamplesInInterval(interval)
        )
        if accelerations or spins:
            segments = max(segments, min(ACCELERATION_SEGMENTS, self.shutter.max_segments))
        if spins:  # keep each step's turn unambiguous for slerp
            rate = float(np.linalg.norm(np.asarray(spins, dtype=np.float64), axis=1).max())
            swept = rate * interval.size / self.stage.GetTimeCodesPerSecond()
            segments = max(segments, min(math.ceil(swept / _MAX_STEP_SPIN), self.shutter.max_segments))
        return segments

    # Expansion

    def expand(self, root: Usd.Prim, segments: int) -> list[Leaf]:
        """The meshes below ``root`` (``root`` included) with their transforms relative to it,
        at the grid of ``segments`` steps where they move."""
        if not self.content_segments(root):
            segments = 0
        key = (root.GetPath(), segments)
        if key not in self._leaves:
            self._leaves[key] = []  # guards against cycles of prototypes
            self.roots.add(root.GetPath())
            self._leaves[key] = list(self._expand(root, segments))
        return self._leaves[key]

    def _expand(self, root: Usd.Prim, segments: int) -> Iterator[Leaf]:
        stop = root.GetParent()
        for prim, kind in self._walk(root):
            if kind == "mesh":
                yield Leaf(
                    prim,
                    prim.GetPath(),
                    _authored_purpose(prim, stop),
                    self.relative(prim, root, segments)[None],
                )
            elif kind == "instance":
                yield from self._instance_leaves(prim, root, segments)
            elif kind == "point instancer":
                yield from self.point_instancer_leaves(prim, root, segments)

    def _instance_leaves(self, instance: Usd.Prim, root: Usd.Prim, segments: int) -> Iterator[Leaf]:
        prototype = instance.GetPrototype()
        placement = self.relative(instance, root, segments)
        purpose = _authored_purpose(instance, root.GetParent())
        reader = SampleReader(self.shutter.frame)
        inherited = inherited_primvars(instance, reader, self.warn)
        self.varying |= reader.varying
        for leaf in self.expand(prototype, segments):
            yield Leaf(
                leaf.mesh,
                leaf.proxy.ReplacePrefix(prototype.GetPath(), instance.GetPath()),
                leaf.purpose or purpose,
                leaf.transforms @ placement,
                nest_primvars(
                    outer_primvars(inherited, {}, leaf.mesh, 1), leaf.primvars, 1, len(leaf.transforms)
                ),
            )

    def point_instancer_leaves(self, prim: Usd.Prim, root: Usd.Prim, segments: int) -> Iterator[Leaf]:
        """The meshes of the prototypes of point instancer ``prim`` (below ``root``), one leaf
        per prototype mesh holding all its copies, relative to ``root``."""
        copies = self.point_instancer_copies(prim, segments)
        if not copies:
            return
        placement = self.relative(prim, root, segments)
        for prototype, transforms, primvars, inherited in copies:
            between = list(_up_to(prototype.GetParent(), prim))
            if any(_invisible(p, self) for p in between):
                continue
            purpose = _authored_purpose(prototype.GetParent(), root.GetParent())
            for leaf in self.expand(prototype, segments):
                # Each copy's k-th sample pairs with the mesh's and the instancer's k-th.
                composed = leaf.transforms[None] @ transforms[:, None]
                count, inner, samples = composed.shape[:3]
                yield Leaf(
                    leaf.mesh,
                    leaf.proxy,
                    leaf.purpose or purpose,
                    composed.reshape(count * inner, samples, 4, 4) @ placement,
                    nest_primvars(
                        outer_primvars(inherited, primvars, leaf.mesh, count),
                        leaf.primvars,
                        count,
                        inner,
                    ),
                )

    def point_instancer_copies(
        self, prim: Usd.Prim, segments: int
    ) -> list[tuple[Usd.Prim, np.ndarray, dict[str, np.ndarray], dict[str, np.ndarray]]]:
        """(prototype root, (N, K, 4, 4) copy transforms relative to the instancer, per-copy
        primvars, inherited primvars) for each prototype with visible copies; K = 1 unless the
        copies move."""
        instancer = UsdGeom.PointInstancer(prim)
        path = prim.GetPath()
        frame = self.shutter.frame
        prototypes = instancer.GetPrototypesRel().GetForwardedTargets()
        indices = np.asarray(instancer.GetProtoIndicesAttr().Get(frame) or [], dtype=np.int64)
        if len(indices) == 0:
            return []
        if len(prototypes) == 0:
            self.warn(f"{path}: {len(indices)} protoIndices but no prototypes; the instancer is skipped")
            return []
        bad = (indices < 0) | (indices >= len(prototypes))
        if bad.any():
            # usd-core computes no transform at all then; say so rather than render nothing.
            self.warn(
                f"{path}: {int(bad.sum())} protoIndices are out of range for "
                f"{len(prototypes)} prototypes; the instancer is skipped"
            )
            return []
        times = self.times(segments if self.point_instancer_segments(prim) else 0)
        samples = instancer.ComputeInstanceTransformsAtTimes(
            times,
            frame,
            UsdGeom.PointInstancer.IncludeProtoXform,
            UsdGeom.PointInstancer.IgnoreMask,
        )
        # (N, K, 4, 4): each copy's transform at every sample time.
        local = np.stack([np.asarray(s, dtype=np.float64).reshape(-1, 4, 4) for s in samples], axis=1)
        if len(local) != len(indices):
            self.warn(f"{path}: instance attributes do not match protoIndices; instances skipped")
            return []
        if len(times) > 1:
            local = self._default_valued_motion(instancer, local, times)
        mask = instancer.ComputeMaskAtTime(frame)
        keep = np.asarray(mask, dtype=bool) if mask else np.ones(len(indices), dtype=bool)
        primvars, inherited = self._instance_primvars(instancer, len(indices))
        copies = []
        for index, prototype_path in enumerate(prototypes):
            root = self.stage.GetPrimAtPath(prototype_path)
            if not root:
                self.warn(f"{path}: prototype {prototype_path} does not exist")
                continue
            self.roots.add(prototype_path)
            chosen = keep & (indices == index)
            if chosen.any():
                per_copy = {name: v[chosen] for name, v in primvars.items()}
                copies.append((root, local[chosen], per_copy, inherited))
        return copies

    def _instance_primvars(
        self, instancer: UsdGeom.PointInstancer, count: int
    ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """The instancer's numeric primvars: (per instance, one value each: vertex and varying
        ones, UsdGeomPointInstancer's per-instance primvars; inherited, one value: constant and
        uniform ones, which prototypes inherit unless they author the name themselves)."""
        path = str(instancer.GetPath())
        reader = SampleReader(self.shutter.frame)
        per_copy, inherited = {}, {}
        for primvar in UsdGeom.PrimvarsAPI(instancer).GetPrimvarsWithValues():
            name, interpolation = primvar.GetPrimvarName(), primvar.GetInterpolation()
            values = numeric_primvar(primvar, reader, self.warn, path)
            if values is None:
                continue
            if interpolation in (UsdGeom.Tokens.constant, UsdGeom.Tokens.uniform):
                inherited[name] = values[:1]
            elif len(values) == count:
                per_copy[name] = values
            else:
                self.warn(f"{path}: primvar {name} has {len(values)} values for {count} instances; ignored")
        self.varying |= reader.varying
        return per_copy, inherited

    def _default_valued_motion(
        self, instancer: UsdGeom.PointInstancer, local: np.ndarray, times: list[Usd.TimeCode]
    ) -> np.ndarray:
        """Copies moved by what usd-core leaves out: for default-valued orientations, a spin of
        ``angularVelocities`` (degrees/s, about the copy's position, after its orientation, as
        usd-core composes it); for default-valued positions, p + v·Δ + ½·a·Δ², with
        Δ = (t − frame) / timeCodesPerSecond."""
        frame = self.shutter.frame.GetValue()
        seconds = np.array([t.GetValue() - frame for t in times]) / self.stage.GetTimeCodesPerSecond()
        count = len(local)
        local = local.copy()
        if not instancer.GetOrientationsAttr().GetNumTimeSamples():
            spins = self._per_copy(instancer, instancer.GetAngularVelocitiesAttr(), count)
            if spins is not None:
                positions = self._per_copy(instancer, instancer.GetPositionsAttr(), count)
                origin = positions[:, None, :] if positions is not None else 0.0
                turn = spin_matrices(spins, seconds)  # (N, K, 3, 3), row-vector convention
                local[..., :3, :3] = local[..., :3, :3] @ turn
                local[..., 3, :3] = ((local[..., 3, :3] - origin)[..., None, :] @ turn)[..., 0, :] + origin
        if not instancer.GetPositionsAttr().GetNumTimeSamples():
            for attr, factor in (
                (instancer.GetVelocitiesAttr(), seconds),
                (instancer.GetAccelerationsAttr(), 0.5 * seconds**2),
            ):
                value = self._per_copy(instancer, attr, count)
                if value is not None:
                    local[:, :, 3, :3] += value[:, None, :] * factor[None, :, None]
        return local

    def _per_copy(self, instancer: UsdGeom.PointInstancer, attr: Usd.Attribute, count: int) -> np.ndarray | None:
        """(N, 3) values of ``attr`` at the frame; ``None`` (with a warning if authored with
        the wrong count) unless there is one per copy."""
        value = attr.Get(self.shutter.frame)
        if value is not None and len(value) == count:
            return np.asarray(value, dtype=np.float64).reshape(-1, 3)
        if value:
            self.warn(
                f"{instancer.GetPath()}: {attr.GetName()} has {len(value)} values for "
                f"{count} instances; ignored"
            )
        return None

    # Walking a subtree

    def _walk(self, root: Usd.Prim) -> Iterator[tuple[Usd.Prim, str]]:
        """``(prim, kind)`` below ``root`` (included) that instancing renders: "mesh",
        "instance" (an instanceable prim), "point instancer"; invisible subtrees skipped."""
        walk = iter(Usd.PrimRange(root, Usd.PrimDefaultPredicate))
        for prim in walk:
            if _invisible(prim, self):
                walk.PruneChildren()
                continue
            if prim.IsA(UsdGeom.PointInstancer):
                walk.PruneChildren()
                yield prim, "point instancer"
                continue
            if prim.IsA(UsdGeom.Mesh) or is_implicit(prim):
                yield prim, "mesh"
            if prim.IsInstance():
                yield prim, "instance"


def spin_matrices(angular_velocities: np.ndarray, seconds: np.ndarray) -> np.ndarray:
    """(N, K, 3, 3) rotations (row-vector convention, as Gf) by ``angular_velocities`` (N, 3),
    degrees per second about their own direction, over each of ``seconds`` (K,)."""
    rate = np.linalg.norm(angular_velocities, axis=1)
    axis = np.divide(
        angular_velocities, rate[:, None], out=np.zeros_like(angular_velocities), where=rate[:, None] > 0
    )
    angle = np.radians(rate[:, None] * seconds[None, :])  # (N, K)
    cos, sin = np.cos(angle)[..., None, None], np.sin(angle)[..., None, None]
    x, y, z = axis[:, 0], axis[:, 1], axis[:, 2]
    zero = np.zeros_like(x)
    # Rodrigues for row vectors: v·R = v cosθ + (k × v) sinθ + k (k·v)(1 − cosθ).
    cross = np.stack([np.stack([zero, z, -y], -1), np.stack([-z, zero, x], -1), np.stack([y, -x, zero], -1)], -2)
    outer = axis[:, :, None] * axis[:, None, :]
    eye = np.eye(3)
    return cos * eye + sin * cross[:, None] + (1 - cos) * outer[:, None]


def user_facing_path(prim: Usd.Prim) -> Sdf.Path:
    """The path of ``prim``, or for a prim inside a USD prototype, of its instance proxy in the
    first instance (prototype paths mean nothing to users)."""
    path = prim.GetPath()
    if not prim.IsInPrototype():
        return path
    root = prim.GetStage().GetPrimAtPath(path.GetPrefixes()[0])
    instances = root.GetInstances() if root else []
    if not instances:
        return path
    return user_facing_path(instances[0]).AppendPath(path.MakeRelativePath(root.GetPath()))


def _prototype_roots(prim: Usd.Prim) -> Iterator[Usd.Prim]:
    stage = prim.GetStage()
    for path in UsdGeom.PointInstancer(prim).GetPrototypesRel().GetForwardedTargets():
        root = stage.GetPrimAtPath(path)
        if root:
            yield root


def _up_to(prim: Usd.Prim, stop: Usd.Prim) -> Iterator[Usd.Prim]:
    """``prim`` and its ancestors below ``stop`` (exclusive; all the way up if ``stop`` is not
    an ancestor)."""
    while prim and not prim.IsPseudoRoot() and prim != stop:
        yield prim
        prim = prim.GetParent()


def _invisible(prim: Usd.Prim, flattener: Flattener) -> bool:
    """Whether ``prim`` itself is made invisible at the frame (noting time-varying visibility)."""
    imageable = UsdGeom.Imageable(prim)
    if not imageable:
        return False
    attr = imageable.GetVisibilityAttr()
    if attr.ValueMightBeTimeVarying():
        flattener.varying = True
    return attr.Get(flattener.shutter.frame) == UsdGeom.Tokens.invisible


def _authored_purpose(prim: Usd.Prim, stop: Usd.Prim) -> str | None:
    """The purpose authored nearest above ``prim`` (included) below ``stop``, if any: purpose
    is inherited from the nearest prim that authors one."""
    for p in _up_to(prim, stop):
        imageable = UsdGeom.Imageable(p)
        if imageable and imageable.GetPurposeAttr().HasAuthoredValue():
            return str(imageable.GetPurposeAttr().Get())
    return None


# --------------------------------------------------------------------------------------------
# Pushing grouped copies


class MaterialSource(Protocol):
    """Where instanced meshes get their material sprims (reference-counted by user id)."""

    def acquire(self, material: Sdf.Path, user: str) -> None: ...

    def release(self, material: Sdf.Path, user: str) -> None: ...

    def material_id(self, material: Sdf.Path) -> str:
        """The delegate id of the material, "" when it cannot be used."""
        ...


@dataclass
class Group:
    """All copies of one mesh rendered with one material."""

    mesh: Usd.Prim
    material: Sdf.Path | None
    transforms: list[np.ndarray] = field(default_factory=list)  # (N_i, K_i, 4, 4) each
    primvars: list[dict[str, np.ndarray]] = field(default_factory=list)  # N_i rows each

    def stacked(self) -> np.ndarray:
        """(N, 4, 4) for static copies, else (N, K, 4, 4) with static ones held over K."""
        samples = max(t.shape[1] for t in self.transforms)
        parts = [t if t.shape[1] == samples else t.repeat(samples, axis=1) for t in self.transforms]
        stacked = parts[0] if len(parts) == 1 else np.concatenate(parts)
        return np.ascontiguousarray(stacked[:, 0] if samples == 1 else stacked)

    def stacked_primvars(self) -> dict[str, np.ndarray]:
        """Per-copy primvars in the order of :meth:`stacked`; copies without a primvar others
        have get NaN, which tells the delegate to use the mesh's own value for them."""
        widths = {name: values.shape[1:] for part in self.primvars for name, values in part.items()}
        stacked = {}
        for name in sorted(widths):
            rows = [
                part.get(name, np.full((len(transforms),) + widths[name], np.nan, np.float32))
                for part, transforms in zip(self.primvars, self.transforms)
            ]
            stacked[name] = np.ascontiguousarray(np.concatenate(rows), dtype=np.float32)
        return stacked


GroupKey = tuple[Sdf.Path, Sdf.Path | None]


def group_leaves(
    groups: dict[GroupKey, Group],
    leaf: Leaf,
    material: Sdf.Path | None,
    transforms: np.ndarray,
    primvars: dict[str, np.ndarray],
) -> None:
    """Add ``transforms`` (copies of ``leaf``'s mesh bound to ``material``, with their per-copy
    ``primvars``) to ``groups``."""
    key = (leaf.mesh.GetPath(), material)
    group = groups.get(key)
    if group is None:
        group = groups[key] = Group(leaf.mesh, material)
    group.transforms.append(transforms)
    group.primvars.append(primvars)


@dataclass
class _Pushed:
    mesh_id: str
    instancer_id: str
    material_id: str | None = None  # None: not sent yet
    digest: bytes | None = None  # of the copies' transforms last sent (None: not sent)
    varying: bool = False  # the mesh's data might change with time
    usable: bool = True  # False when the mesh could not be read (no instancer then)


class InstancedMeshes:
    """Hidden mesh + instancer rprims for groups of copies, updated by difference: a mesh is
    re-read only when new, edited or time-varying; copies are re-sent only when they moved."""

    def __init__(self, core, warn: Callable[[str], None], materials: MaterialSource, prefix: str = ""):
        self.core = core
        self.warn = warn
        self.materials = materials
        self.prefix = prefix
        self._pushed: dict[GroupKey, _Pushed] = {}

    @property
    def varying(self) -> bool:
        """Whether any pushed mesh's data might change with time."""
        return any(p.varying for p in self._pushed.values())

    def ids(self) -> Iterator[str]:
        for pushed in self._pushed.values():
            yield pushed.mesh_id
            yield pushed.instancer_id

    def update(
        self,
        groups: dict[GroupKey, Group],
        shutter: Shutter,
        stale: Iterable[Sdf.Path] = (),
        time_changed: bool = False,
    ) -> None:
        """Make the delegate hold exactly ``groups``; meshes below any ``stale`` path (and
        time-varying ones when ``time_changed``) are read again."""
        stale = list(stale)
        for key in [k for k in self._pushed if k not in groups]:
            self._remove(key)
        for key in sorted(groups, key=str):
            group = groups[key]
            pushed = self._pushed.get(key)
            if pushed is None:
                pushed = self._pushed[key] = self._insert(key, group, shutter)
            elif (time_changed and pushed.varying) or any(key[0].HasPrefix(p) for p in stale):
                self._read_mesh(pushed, group, shutter)
            if not pushed.usable:
                continue
            material_id = self.materials.material_id(key[1]) if key[1] else ""
            if material_id != pushed.material_id:
                self.core.set_mesh_material(pushed.mesh_id, material_id)
                pushed.material_id = material_id
            transforms = group.stacked()
            primvars = group.stacked_primvars()
            digest = _digest(transforms, *primvars.values()) + str(sorted(primvars)).encode()
            if digest != pushed.digest:
                self.core.set_instances(pushed.instancer_id, pushed.mesh_id, transforms)
                self.core.set_instance_primvars(pushed.instancer_id, primvars)
                pushed.digest = digest

    def clear(self) -> None:
        for key in list(self._pushed):
            self._remove(key)

    def _insert(self, key: GroupKey, group: Group, shutter: Shutter) -> _Pushed:
        mesh_path, material = key
        suffix = f"/materials{material}" if material else ""
        pushed = _Pushed(
            mesh_id=f"{self.prefix}/prototypes{mesh_path}{suffix}",
            instancer_id=f"{self.prefix}/instances{mesh_path}{suffix}",
        )
        if material:
            self.materials.acquire(material, pushed.mesh_id)
        self.core.insert_rprim("mesh", pushed.mesh_id)
        self.core.insert_rprim("instancer", pushed.instancer_id)
        self._read_mesh(pushed, group, shutter)
        return pushed

    def _read_mesh(self, pushed: _Pushed, group: Group, shutter: Shutter) -> None:
        reader = SampleReader(shutter.frame, shutter)
        name = str(user_facing_path(group.mesh))

        def warn(message: str) -> None:  # name the prim the user knows, not the hidden id
            self.warn(message.replace(pushed.mesh_id, name))

        pushed.usable = sync_mesh_data(self.core, group.mesh, reader, warn, pushed.mesh_id)
        pushed.varying = reader.varying
        self.core.set_visible(pushed.mesh_id, False)  # only its copies render
        if not pushed.usable:  # no copies of an unreadable mesh
            self.core.set_instances(pushed.instancer_id, pushed.mesh_id, np.empty((0, 4, 4)))
            self.core.set_instance_primvars(pushed.instancer_id, {})
            pushed.digest = None
        pushed.material_id = None  # re-sent with the mesh

    def _remove(self, key: GroupKey) -> None:
        pushed = self._pushed.pop(key)
        self.core.remove_prim(pushed.instancer_id)  # copies before their prototype
        self.core.remove_prim(pushed.mesh_id)
        if key[1]:
            self.materials.release(key[1], pushed.mesh_id)


def _digest(*arrays: np.ndarray) -> bytes:
    """A fingerprint of copies' transforms (and primvars): cheaper to keep than a million
    matrices."""
    hasher = hashlib.blake2b(digest_size=16)
    for array in arrays:
        hasher.update(memoryview(np.ascontiguousarray(array)))
        hasher.update(bytes(str(array.shape), "ascii"))
    return hasher.digest()


# --------------------------------------------------------------------------------------------
# Point instancers


class _InstancerMaterials:
    """The material sprims of one point instancer's meshes, named below the instancer."""

    def __init__(self, stage: Usd.Stage, core, warn: Callable[[str], None], prefix: str):
        self.stage, self.core, self.warn, self.prefix = stage, core, warn, prefix
        self.time = Usd.TimeCode.Default()
        self._users: dict[Sdf.Path, set[str]] = {}
        self._ids: dict[Sdf.Path, str] = {}

    def acquire(self, material: Sdf.Path, user: str) -> None:
        if material not in self._users:
            self._users[material] = set()
            self._read(material)
        self._users[material].add(user)

    def release(self, material: Sdf.Path, user: str) -> None:
        users = self._users.get(material)
        if users is None:
            return
        users.discard(user)
        if not users:
            del self._users[material]
            material_id = self._ids.pop(material, "")
            if material_id:
                self.core.remove_prim(material_id)

    def material_id(self, material: Sdf.Path) -> str:
        return self._ids.get(material, "")

    def refresh(self, time: Usd.TimeCode) -> None:
        """Re-read every material (at ``time``): they may have been edited."""
        self.time = time
        for material in self._users:
            self._read(material)

    def paths(self) -> Iterable[Sdf.Path]:
        return self._users.keys()

    def _read(self, material: Sdf.Path) -> None:
        prim = self.stage.GetPrimAtPath(material)
        data = None
        if prim and prim.IsA(UsdShade.Material):
            data = read_material(prim, SampleReader(self.time), self.warn)
        material_id = f"{self.prefix}/materials{material}"
        if data is None:
            if self._ids.pop(material, ""):
                self.core.remove_prim(material_id)
            return
        if material not in self._ids:
            self.core.insert_sprim("material", material_id)
            self._ids[material] = material_id
        push_material(self.core, material_id, data, self.warn)


@dataclass
class _Instancer:
    """What one point instancer put in the delegate, and what it depends on."""

    meshes: InstancedMeshes
    materials: _InstancerMaterials
    roots: set[Sdf.Path] = field(default_factory=set)  # edits below these re-flatten it
    varying: bool = False
    dirty: bool = True


class PointInstancerDelegate:
    """Mirrors the point instancers of ``stage`` (outside native prototypes) into ``core``."""

    def __init__(self, stage: Usd.Stage, core, purposes: Iterable[str], warn: Callable[[str], None]):
        self.stage = stage
        self.core = core
        self.purposes = frozenset(purposes) | {UsdGeom.Tokens.default_}
        self.warn = warn
        self.shutter: Shutter | None = None
        self._instancers: dict[Sdf.Path, _Instancer] = {}
        self._structure_changed = True  # prims were added or removed: look for instancers
        self._stale: set[Sdf.Path] = set()  # edited prims (their meshes are read again)
        self._listener = Tf.Notice.Register(Usd.Notice.ObjectsChanged, self._on_changed, stage)

    def close(self) -> None:
        if self._listener is not None:
            self._listener.Revoke()
            self._listener = None

    def _on_changed(self, notice, _sender) -> None:
        changed = [*notice.GetResyncedPaths(), *notice.GetChangedInfoOnlyPaths()]
        if any(not path.IsPropertyPath() for path in notice.GetResyncedPaths()):
            self._structure_changed = True
        for path in changed:
            prim_path = path.GetPrimPath()
            self._stale.add(prim_path)
            binding = path.IsPropertyPath() and path.name.startswith("material:binding")
            for record in self._instancers.values():
                if binding or any(
                    prim_path.HasPrefix(root) or root.HasPrefix(prim_path) for root in record.roots
                ):
                    record.dirty = True

    def update(self, shutter: Shutter) -> None:
        """Re-flatten the point instancers whose inputs changed (or, at a new frame or shutter,
        might vary with time) and push what differs."""
        time_changed = shutter != self.shutter
        self.shutter = shutter
        if self._structure_changed:
            self._structure_changed = False
            found = set(self._find())
            for path in [p for p in self._instancers if p not in found]:
                self._instancers.pop(path).meshes.clear()
            for path in found:
                if path not in self._instancers:
                    self._instancers[path] = self._new_record(path)
                self._instancers[path].dirty = True
        stale, self._stale = self._stale, set()
        for path, record in self._instancers.items():
            if record.dirty or (time_changed and record.varying):
                self._sync(self.stage.GetPrimAtPath(path), record, stale, time_changed)

    def _find(self) -> Iterator[Sdf.Path]:
        """Point instancers outside native prototypes and outside other instancers' prototypes
        (those are flattened into their outer instancer)."""
        walk = iter(Usd.PrimRange(self.stage.GetPseudoRoot(), Usd.PrimDefaultPredicate))
        for prim in walk:
            if prim.IsA(UsdGeom.PointInstancer):
                walk.PruneChildren()
                yield prim.GetPath()

    def _new_record(self, path: Sdf.Path) -> _Instancer:
        materials = _InstancerMaterials(self.stage, self.core, self.warn, str(path))
        return _Instancer(InstancedMeshes(self.core, self.warn, materials, str(path)), materials)

    def _sync(self, prim: Usd.Prim, record: _Instancer, stale: set[Sdf.Path], time_changed: bool) -> None:
        flattener = Flattener(self.stage, self.shutter, self.warn)
        record.materials.refresh(self.shutter.frame)
        groups = self._groups(prim, flattener)
        record.meshes.update(groups, self.shutter, stale, time_changed)
        record.roots = {prim.GetPath(), *flattener.roots, *record.materials.paths()}
        record.varying = flattener.varying or record.meshes.varying
        record.dirty = False

    def _groups(self, prim: Usd.Prim, flattener: Flattener) -> dict[GroupKey, Group]:
        imageable = UsdGeom.Imageable(prim)
        purpose = imageable.ComputePurpose()
        if imageable.GetVisibilityAttr().ValueMightBeTimeVarying():
            flattener.varying = True
        if imageable.ComputeVisibility(self.shutter.frame) == UsdGeom.Tokens.invisible:
            return {}
        limit = self.shutter.max_segments
        segments = combine_segments(
            flattener.motion_segments(prim), flattener.point_instancer_segments(prim), limit
        )
        for prototype in _prototype_roots(prim):
            segments = combine_segments(segments, flattener.content_segments(prototype), limit)
        groups: dict[GroupKey, Group] = {}
        materials: dict[Sdf.Path, Sdf.Path | None] = {}
        leaves = flattener.point_instancer_leaves(prim, self.stage.GetPseudoRoot(), segments)
        for leaf in leaves:
            if (leaf.purpose or purpose) not in self.purposes:
                continue
            if leaf.proxy not in materials:
                material = bound_material(self.stage.GetPrimAtPath(leaf.proxy))
                materials[leaf.proxy] = material.GetPath() if material else None
            group_leaves(groups, leaf, materials[leaf.proxy], leaf.transforms, leaf.primvars)
        return groups
