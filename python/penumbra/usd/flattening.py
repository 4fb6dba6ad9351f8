"""Instancing flattened: every instanced mesh with the transforms of all its copies.

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
``angularVelocities`` only from time-sampled orientations (``orientationsf`` when it has values,
as usd-core reads it); for default-valued ones Penumbra moves and spins each copy itself (units
per second, degrees per second: docs/design.md §3).
Copies with a NaN or infinity in their transform are skipped with one warning per instancer
(or per prim whose xformOps hold it); a scale of 0 hides its copies as it hides a mesh
(transforms are composed downwards, never inverted).

Per-instance primvars travel with the copies (:attr:`Leaf.primvars`, one row per copy): a point
instancer's vertex/varying primvars and the constant primvars of instances and instancers, which
the copied mesh inherits unless it authors the name itself. Nested levels compose outer-major,
the inner (nearer) level winning; a copy lacking a primvar others in its group have gets NaN,
which the delegate reads as "use the mesh's own".

(:mod:`.instanced_meshes` pushes the flattened copies; :mod:`.point_instancers` mirrors point
instancers.)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdVol, Vt

from .lights import light_type
from .mesh import as_vec3_array, numeric_primvar, reads_as_mesh
from .motion import ACCELERATION_SEGMENTS, XformCaches, transform_samples
from .sampling import SampleReader, Shutter, changes_within, transform_might_vary

_MAX_STEP_SPIN = 90.0  # degrees a spinning copy may turn between two motion samples
# UsdImaging's traversal of point-instancer prototypes: the default one with abstract prims.
_PROTOTYPE_PREDICATE = Usd.PrimIsActive & Usd.PrimIsDefined & Usd.PrimIsLoaded


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


PrototypeCopies = tuple[Usd.Prim, np.ndarray, dict[str, np.ndarray], dict[str, np.ndarray]]
"""A prototype root and its copies (see :meth:`Flattener.point_instancer_copies`)."""


@dataclass
class LightCopies:
    """Copies of one light in one prototype of a point instancer."""

    light: Usd.Prim  # the light's prim (in a native instance there, its prototype's)
    path: Sdf.Path  # where it is in the prototype's namespace (through native instances)
    prototype: int  # which of the instancer's prototypes with copies holds it
    transforms: np.ndarray  # float64 (N, 1, 4, 4): light-to-world at the frame, per copy


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
        self.lights: set[Sdf.Path] = set()  # lights of nested instancers' prototypes: skipped
        self._segments: dict[Sdf.Path, int] = {}
        self._lights_below: dict[Sdf.Path, set[Sdf.Path]] = {}  # noted by content_segments
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

    def relative(self, prim: Usd.Prim, root: Usd.Prim, segments: int) -> np.ndarray | None:
        """(K, 4, 4) transforms of ``prim`` relative to ``root`` (whose own transform is
        excluded; relative to the pseudo-root or a USD prototype: world); K = 1 unless
        something between them moves. ``None``, with a warning, when not finite."""
        moving = segments and any(
            UsdGeom.Xformable(p).TransformMightBeTimeVarying() for p in _up_to(prim, root)
        )
        # Composed from the transforms below root, not as world(prim) · world(root)⁻¹: a scale
        # of 0 (a common way to hide things) has no inverse.
        matrices = np.stack(
            [
                np.asarray(self.caches.at(t).ComputeRelativeTransform(prim, root)[0])
                for t in self.times(segments if moving else 0)
            ]
        )
        if np.isfinite(matrices).all():
            return matrices
        self.warn_not_finite(prim)
        return None

    def warn_not_finite(self, prim: Usd.Prim) -> None:
        """Warn that the transform of ``prim`` is not finite, so that what it places is skipped
        (the delegate would drop it without a word)."""
        self.warn(
            f"{user_facing_path(prim)}: the world transform is not finite (a NaN or infinity in "
            "an xformOp); the prim is not rendered"
        )

    # Motion needs

    def content_segments(self, root: Usd.Prim) -> int:
        """Uniform steps the moving transforms below ``root`` need (0: all static); notes on
        the way the lights below it, in native instances too (see :meth:`lights_below`)."""
        path = root.GetPath()
        if path not in self._segments:
            self._segments[path] = 0  # guards against cycles of prototypes
            self._lights_below[path] = lights = set()
            limit = self.shutter.max_segments
            total = 0
            for prim, kind in self._walk(root):
                if prim != root and UsdGeom.Xformable(prim):
                    total = combine_segments(total, self.motion_segments(prim), limit)
                if kind == "light":
                    lights.add(user_facing_path(prim))
                elif kind == "instance":
                    nested = self.content_segments(prim.GetPrototype())
                    total = combine_segments(total, nested, limit)
                    lights |= self._lights_below[prim.GetPrototype().GetPath()]
                elif kind == "point instancer":
                    total = combine_segments(total, self.point_instancer_segments(prim), limit)
                    for prototype in prototype_roots(prim):
                        nested = self.content_segments(prototype)
                        total = combine_segments(total, nested, limit)
            self._segments[path] = total
        return self._segments[path]

    def lights_below(self, root: Usd.Prim) -> set[Sdf.Path]:
        """The visible UsdLux lights below ``root`` (included), in native instances there too,
        by :func:`user_facing_path`; not those of point instancers there (theirs)."""
        self.content_segments(root)
        return self._lights_below[root.GetPath()]

    def point_instancer_segments(self, prim: Usd.Prim) -> int:
        """Uniform steps the copies of point instancer ``prim`` need (0: static): the authored
        samples of positions, orientations (or orientationsf) and scales inside the shutter;
        velocities move copies linearly, accelerations and angular velocities bend their paths;
        and the motion of the prototype roots, whose own transforms are part of each copy."""
        limit = self.shutter.max_segments
        roots = 0  # their world motion: a finer grid than their own transforms need, never coarser
        for prototype in prototype_roots(prim):
            roots = combine_segments(roots, self.motion_segments(prototype), limit)
        instancer = UsdGeom.PointInstancer(prim)
        keyed = [
            instancer.GetPositionsAttr(),
            _orientations_attr(instancer),
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
            return roots
        segments = self.shutter.segments(
            t for attr in keyed for t in attr.GetTimeSamplesInInterval(interval)
        )
        if accelerations or spins:
            segments = max(segments, min(ACCELERATION_SEGMENTS, limit))
        if spins:  # keep each step's turn unambiguous for slerp
            rate = _fastest_spin(spins)
            swept = rate * interval.size / self.stage.GetTimeCodesPerSecond()
            segments = max(segments, min(math.ceil(swept / _MAX_STEP_SPIN), limit))
        return combine_segments(segments, roots, limit)

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
                transforms = self.relative(prim, root, segments)
                if transforms is not None:
                    yield Leaf(prim, prim.GetPath(), _authored_purpose(prim, stop), transforms[None])
            elif kind == "instance":
                yield from self._instance_leaves(prim, root, segments)
            elif kind == "point instancer":
                yield from self.point_instancer_leaves(prim, root, segments)

    def _instance_leaves(self, instance: Usd.Prim, root: Usd.Prim, segments: int) -> Iterator[Leaf]:
        prototype = instance.GetPrototype()
        placement = self.relative(instance, root, segments)
        if placement is None:
            return
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

    def point_instancer_leaves(
        self,
        prim: Usd.Prim,
        root: Usd.Prim,
        segments: int,
        light_copies: list[LightCopies] | None = None,
    ) -> Iterator[Leaf]:
        """The meshes of the prototypes of point instancer ``prim`` (below ``root``), one leaf
        per prototype mesh holding all its copies, relative to ``root``; the lights of its
        prototypes are appended to ``light_copies`` (relative to ``root`` too), or, without it
        (an instancer inside a native instance or another instancer's prototype), left out with
        a warning."""
        copies = self.point_instancer_copies(prim, segments)
        if not copies:
            return
        placement = self.relative(prim, root, segments)
        if placement is None:
            return
        if light_copies is not None:
            light_copies += self._light_copies(prim, root, copies, segments)
        else:
            # Copies of copies carry no lights (a light per copy of a copy); say so rather
            # than drop them silently.
            lights = (self.lights_below(prototype) for prototype, *_ in copies)
            dropped = sorted(set().union(*lights))
            if dropped:
                self.lights.update(dropped)
                self.warn(
                    f"{user_facing_path(prim)}: lights in the prototypes of a point instancer "
                    "inside a native instance or another instancer's prototypes are not "
                    f"rendered yet; {len(dropped)} skipped (first: {dropped[0]})"
                )
        # Visibility counts from each prototype root down (the walk) and the instancer's own,
        # as in UsdImaging: prims above a prototype root are often made invisible just to keep
        # the prototypes from rendering where they are defined.
        for prototype, transforms, primvars, inherited in copies:
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

    def _light_copies(
        self, prim: Usd.Prim, root: Usd.Prim, copies: list[PrototypeCopies], segments: int
    ) -> list[LightCopies]:
        """The copies of the lights in the prototypes of point instancer ``prim`` (below
        ``root``; ``copies`` as :meth:`point_instancer_copies` gives them on the grid of
        ``segments``), each placed where its copy is at the frame, as lights are."""
        if not any(self.lights_below(prototype) for prototype, *_ in copies):
            return []
        if segments:
            copies = self.point_instancer_copies(prim, 0)
        placement = self.relative(prim, root, 0)
        if placement is None:
            return []
        result = []
        for index, (prototype, transforms, _, _) in enumerate(copies):
            for light, path, relative in self._lights_in(prototype):
                result.append(LightCopies(light, path, index, relative @ transforms @ placement))
        return result

    def _lights_in(
        self, root: Usd.Prim
    ) -> Iterator[tuple[Usd.Prim, Sdf.Path, np.ndarray]]:
        """(light, its path in the namespace of ``root``, (1, 4, 4) light-to-root transform at
        the frame) of each visible light below ``root`` (included), in native instances there
        too, one for each instance (a native instance's lights are prims of its prototype). A
        walk of its own: :meth:`_walk` warns of volumes, which the walk for meshes has said."""
        predicate = Usd.PrimDefaultPredicate if root.IsPrototype() else _PROTOTYPE_PREDICATE
        walk = iter(Usd.PrimRange(root, predicate))
        for prim in walk:
            if _invisible(prim, self) or prim.IsA(UsdGeom.PointInstancer):
                walk.PruneChildren()  # a nested instancer's lights are warned of elsewhere
                continue
            if light_type(prim) is not None:
                relative = self.relative(prim, root, 0)
                if relative is not None:
                    yield prim, prim.GetPath(), relative
            if prim.IsInstance():
                placement = self.relative(prim, root, 0)
                if placement is None:
                    continue
                prototype = prim.GetPrototype()
                for light, path, relative in self._lights_in(prototype):
                    inside = path.ReplacePrefix(prototype.GetPath(), prim.GetPath())
                    yield light, inside, relative @ placement

    def point_instancer_copies(self, prim: Usd.Prim, segments: int) -> list[PrototypeCopies]:
        """(prototype root, (N, K, 4, 4) copy transforms relative to the instancer, per-copy
        primvars, inherited primvars) for each prototype with visible copies; K = 1 unless the
        copies move."""
        instancer = UsdGeom.PointInstancer(prim)
        path = prim.GetPath()
        frame = self.shutter.frame
        prototypes = instancer.GetPrototypesRel().GetForwardedTargets()
        authored = instancer.GetProtoIndicesAttr().Get(frame)
        if authored is not None and not isinstance(authored, Vt.IntArray):
            self.warn(f"{path}: protoIndices has a value of type {type(authored).__name__}, not "
                      "int[]; the instancer is skipped")
            return []
        indices = np.asarray(authored or [], dtype=np.int64)
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
        if not samples:
            # usd-core computes nothing when positions are missing (UsdGeomPointInstancer
            # requires them).
            self.warn(f"{path}: no positions for {len(indices)} protoIndices; the instancer is skipped")
            return []
        # (N, K, 4, 4): each copy's transform at every sample time.
        local = np.stack([np.asarray(s, dtype=np.float64).reshape(-1, 4, 4) for s in samples], axis=1)
        if len(local) != len(indices):
            self.warn(f"{path}: instance attributes do not match protoIndices; instances skipped")
            return []
        if len(times) > 1:
            local = self._default_valued_motion(instancer, local, times)
        mask = instancer.ComputeMaskAtTime(frame)
        keep = np.asarray(mask, dtype=bool) if mask else np.ones(len(indices), dtype=bool)
        # The delegate would drop copies with a NaN or infinity without a word.
        bad = keep & ~np.isfinite(local).all(axis=(1, 2, 3))
        if bad.any():
            self._warn_not_finite(instancer, bad, times)
            keep &= ~bad
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

    def _warn_not_finite(
        self, instancer: UsdGeom.PointInstancer, bad: np.ndarray, times: list[Usd.TimeCode]
    ) -> None:
        """One warning for the ``bad`` (N,) copies of ``instancer``, naming the instance
        attributes with a NaN or infinity for any of them at the frame or the grid's times."""
        names = []
        for attr in (
            instancer.GetPositionsAttr(),
            instancer.GetOrientationsAttr(),
            instancer.GetOrientationsfAttr(),
            instancer.GetScalesAttr(),
            instancer.GetVelocitiesAttr(),
            instancer.GetAccelerationsAttr(),
            instancer.GetAngularVelocitiesAttr(),
        ):
            for time in (self.shutter.frame, *times):
                values = np.asarray(attr.Get(time) or [])
                if values.dtype.kind != "f" or values.shape[:1] != bad.shape:
                    continue  # unauthored, or of a type usd-core does not read either
                if (bad & ~np.isfinite(values.reshape(len(bad), -1)).all(axis=1)).any():
                    names.append(attr.GetName())
                    break
        # Otherwise the prototype root's own transform, which usd-core includes in each copy.
        where = ", ".join(names) or "the prototypes' xformOps"
        self.warn(
            f"{user_facing_path(instancer.GetPrim())}: a NaN or infinity in {where} for "
            f"{int(bad.sum())} of {len(bad)} instances; those instances are skipped"
        )

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
        """Copies moved by what usd-core leaves out: for default-valued orientations (of
        :func:`_orientations_attr`), a spin of ``angularVelocities`` (degrees/s, about the copy's
        position, after its orientation, as usd-core composes it); for default-valued positions,
        p + v·Δ + ½·a·Δ², with Δ = (t − frame) / timeCodesPerSecond."""
        frame = self.shutter.frame.GetValue()
        seconds = np.array([t.GetValue() - frame for t in times]) / self.stage.GetTimeCodesPerSecond()
        count = len(local)
        local = local.copy()
        if not _orientations_attr(instancer).GetNumTimeSamples():
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
        another type than 3-vectors or the wrong count) unless there is one per copy."""
        value = attr.Get(self.shutter.frame)
        if value is None or np.size(value) == 0:
            return None
        vectors = as_vec3_array(value)
        if vectors is None:
            self.warn(
                f"{user_facing_path(instancer.GetPrim())}: {attr.GetName()} has type "
                f"{type(value).__name__}, not 3-vectors; ignored"
            )
            return None
        if len(vectors) != count:
            self.warn(
                f"{user_facing_path(instancer.GetPrim())}: {attr.GetName()} has "
                f"{len(vectors)} values for {count} instances; ignored"
            )
            return None
        return vectors.astype(np.float64)

    # Walking a subtree

    def _walk(self, root: Usd.Prim) -> Iterator[tuple[Usd.Prim, str]]:
        """``(prim, kind)`` below ``root`` (included) that instancing renders: "mesh",
        "instance" (an instanceable prim), "point instancer"; and "light" (UsdLux lights, which
        native instances render as instance proxies, point instancers not yet); invisible
        subtrees skipped, volumes skipped with a warning. The walk of a point-instancer
        prototype admits abstract prims, as UsdImaging's does (prototypes are often kept under
        a ``class`` so that they do not render in place); native prototypes' walk, and the
        stage's own traversal, do not."""
        predicate = Usd.PrimDefaultPredicate if root.IsPrototype() else _PROTOTYPE_PREDICATE
        walk = iter(Usd.PrimRange(root, predicate))
        for prim in walk:
            if _invisible(prim, self):
                walk.PruneChildren()
                continue
            if prim.IsA(UsdGeom.PointInstancer):
                walk.PruneChildren()
                yield prim, "point instancer"
                continue
            if prim.IsA(UsdVol.Volume):
                self.warn(
                    f"{user_facing_path(prim)}: volumes in native instances and point-instancer "
                    "prototypes are not rendered; skipped"
                )
                walk.PruneChildren()
                continue
            if reads_as_mesh(prim) or prim.IsA(UsdGeom.Points) or prim.IsA(UsdGeom.Curves):
                yield prim, "mesh"  # a leaf: meshes, points and curves are copied alike
            elif light_type(prim) is not None:
                yield prim, "light"
            if prim.IsInstance():
                yield prim, "instance"


def _orientations_attr(instancer: UsdGeom.PointInstancer) -> Usd.Attribute:
    """The orientations usd-core places copies by (UsdGeomPointInstancer::UsesOrientationsf):
    ``orientationsf`` when it holds quaternions at the earliest time, else ``orientations``."""
    precise = instancer.GetOrientationsfAttr()
    value = precise.Get(Usd.TimeCode.EarliestTime())
    if isinstance(value, Vt.QuatfArray) and len(value):
        return precise
    return instancer.GetOrientationsAttr()


def _fastest_spin(spins) -> float:
    """The fastest rate (degrees per second) among angularVelocities ``spins``: 0 when they are
    not 3-vectors (the copies are placed without them, after a warning); rates that are not
    finite are left out (their copies are skipped, after a warning)."""
    vectors = as_vec3_array(spins)
    if vectors is None:
        return 0.0
    rates = np.linalg.norm(vectors.astype(np.float64), axis=1)
    rates = rates[np.isfinite(rates)]
    return float(rates.max()) if len(rates) else 0.0


def spin_matrices(angular_velocities: np.ndarray, seconds: np.ndarray) -> np.ndarray:
    """(N, K, 3, 3) rotations (row-vector convention, as Gf) by ``angular_velocities`` (N, 3),
    degrees per second about their own direction, over each of ``seconds`` (K,); NaN for a
    spin that is not finite."""
    # An infinite rate gives NaN quietly: the caller skips such copies with its own warning.
    with np.errstate(invalid="ignore"):
        rate = np.linalg.norm(angular_velocities, axis=1)
        axis = np.divide(
            angular_velocities,
            rate[:, None],
            out=np.zeros_like(angular_velocities),
            where=rate[:, None] > 0,
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
    first instance in path order (prototype paths mean nothing to users, and USD names and
    lists prototypes and their instances in no fixed order)."""
    path = prim.GetPath()
    if not prim.IsInPrototype():
        return path
    root = prim.GetStage().GetPrimAtPath(path.GetPrefixes()[0])
    instances = root.GetInstances() if root else []
    if not instances:
        return path
    first = min(instances, key=lambda instance: instance.GetPath())
    return user_facing_path(first).AppendPath(path.MakeRelativePath(root.GetPath()))


def prototype_roots(prim: Usd.Prim) -> Iterator[Usd.Prim]:
    """The prototype root prims of point instancer ``prim``."""
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
