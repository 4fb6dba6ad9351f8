"""Motion over a frame's shutter: transform samples, deformation samples and velocity samples.

Every array returned holds one sample (static) or K samples at the uniformly spaced times
:meth:`Shutter.times` gives (the render delegate's layout, see docs/core-api.md "Motion"):

* transforms: world matrices at the times that include every authored xformOp time sample of
  the prim and its ancestors inside the shutter; the render delegate interpolates translation
  linearly and rotation by slerp, so steps are halved (up to the maximum) while a step's
  midpoint strays from that interpolation: an object turning about its own origin needs no
  extra samples, an object orbiting a pivot does (its origin would otherwise cut the chord),
  and a turn of 180° or more between two keys is sampled finely enough to keep its direction;
* points: ``velocities`` (units/s) and ``accelerations`` (units/s²) extrapolated from the
  points' sample at or before the frame, Δ = (t − t0) / timeCodesPerSecond; they replace the
  interpolation of ``points`` samples inside the shutter (UsdGeomPointBased: the only blur for a
  changing point count) where usd-core's ComputePointsAtTimes uses them, sampled in step with the
  points, one per point. Else time-sampled ``points`` (constant topology) at the times that
  include their authored samples.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from pxr import Gf, Usd, UsdGeom

from .sampling import SampleReader, Shutter, changes_within, transform_might_vary

ACCELERATION_SEGMENTS = 4
"""Steps over the shutter for accelerated points (a parabola: 5 samples keep it within 1/64 of
its sagitta); velocities alone move linearly and need one."""
ARC_TOLERANCE = 0.035  # midpoint deviation / step length: about 1 % of an orbit's radius
_TURN_TOLERANCE = 0.01  # radians by which a step's midpoint may leave the shorter arc
_MAX_STEP_TURN = math.radians(120)  # steps turning more are ambiguous for slerp: halved


class XformCaches:
    """One ``UsdGeom.XformCache`` per time code, shared by the prims of one sync."""

    def __init__(self) -> None:
        self._caches: dict[float | None, UsdGeom.XformCache] = {}
        self._last: tuple[Usd.TimeCode | None, UsdGeom.XformCache | None] = (None, None)

    def at(self, time: Usd.TimeCode) -> UsdGeom.XformCache:
        """The cache of transforms at ``time``."""
        last_time, cache = self._last
        if time is not last_time:  # prims of a sync mostly ask at the same frame's object
            key = None if time.IsDefault() else time.GetValue()
            cache = self._caches.get(key)
            if cache is None:
                cache = self._caches[key] = UsdGeom.XformCache(time)
            self._last = time, cache
        return cache

    def world(self, prim: Usd.Prim, time: Usd.TimeCode) -> Gf.Matrix4d:
        """The local-to-world transform of ``prim`` at ``time``."""
        return self.at(time).GetLocalToWorldTransform(prim)


def transform_samples(prim: Usd.Prim, shutter: Shutter, caches: XformCaches) -> np.ndarray:
    """The local-to-world transform of ``prim``: float64 (4, 4), or (K, 4, 4) when it moves
    during the shutter."""

    def world(segments: int) -> list[Gf.Matrix4d]:
        return [caches.world(prim, time) for time in shutter.times(segments)]

    if not (shutter.blurred and transform_might_vary(prim)):
        return np.asarray(caches.world(prim, shutter.frame))  # float64: no conversion
    segments = shutter.segments(xform_sample_times(prim, shutter.interval))
    matrices = world(segments)
    while 2 * segments <= shutter.max_segments:
        finer = world(2 * segments)
        if all(_interpolates(*finer[2 * k : 2 * k + 3]) for k in range(segments)):
            break
        segments, matrices = 2 * segments, finer
    if all(matrix == matrices[0] for matrix in matrices):
        return np.array(matrices[0], dtype=np.float64)
    return np.array([np.array(matrix) for matrix in matrices], dtype=np.float64)


def transforms_samples(
    prims: list[Usd.Prim], shutter: Shutter, caches: XformCaches
) -> list[np.ndarray]:
    """:func:`transform_samples` of each of ``prims`` (without motion, in one pass through the
    frame's cache)."""
    if shutter.blurred:
        return [transform_samples(prim, shutter, caches) for prim in prims]
    world = caches.at(shutter.frame).GetLocalToWorldTransform
    return [np.asarray(world(prim)) for prim in prims]


def xform_sample_times(prim: Usd.Prim, interval: Gf.Interval) -> set[float]:
    """The authored time samples inside ``interval`` of the xformOps that place ``prim``."""
    times: set[float] = set()
    while prim and not prim.IsPseudoRoot():
        xformable = UsdGeom.Xformable(prim)
        if xformable:
            times.update(xformable.GetTimeSamplesInInterval(interval))
            if xformable.GetResetXformStack():
                break
        prim = prim.GetParent()
    return times


def _interpolates(start: Gf.Matrix4d, middle: Gf.Matrix4d, end: Gf.Matrix4d) -> bool:
    """Whether ``middle`` is where the render delegate's interpolation of a step from
    ``start`` to ``end`` puts it (translation on the chord, rotation on the shorter arc)."""
    a, b, c = (m.ExtractTranslation() for m in (start, middle, end))
    chord = (c - a).GetLength()
    scale = 1.0 + a.GetLength() + c.GetLength()
    if (b - (a + c) * 0.5).GetLength() > ARC_TOLERANCE * chord + 1e-9 * scale:
        return False
    qa, qb, qc = (m.ExtractRotationQuat() for m in (start, middle, end))
    turn = _angle(qa, qc)
    return turn <= _MAX_STEP_TURN and _angle(qa, qb) + _angle(qb, qc) - turn <= _TURN_TOLERANCE


def _angle(p: Gf.Quatd, q: Gf.Quatd) -> float:
    """The rotation angle between unit quaternions ``p`` and ``q`` (radians, 0..π)."""
    dot = abs(p.GetReal() * q.GetReal() + Gf.Dot(p.GetImaginary(), q.GetImaginary()))
    return 2.0 * math.acos(min(1.0, dot))


def point_samples(
    mesh: UsdGeom.PointBased,
    points: np.ndarray,
    reader: SampleReader,
    warn: Callable[[str], None],
    path: str,
    velocities_might_be_authored: bool = True,
) -> np.ndarray:
    """The object-space points of ``mesh`` (or any point-based gprim, as UsdGeomPoints) over
    the reader's shutter: float32 (N, 3), or (K, N, 3) when they deform or move with
    velocities. ``points``: float32 (N, 3) at the reader's time (also the fallback when the
    topology changes within the shutter).
    ``velocities_might_be_authored`` False: the caller knows the mesh has no velocities."""
    shutter = reader.shutter
    moves = velocities_might_be_authored and mesh.GetVelocitiesAttr().HasAuthoredValue()
    if moves:
        reader.depends_on_shutter()  # extrapolated over the shutter from the frame's sample
    samples = None
    if shutter.blurred:
        samples = _point_motion(mesh, shutter, moves, len(points), warn, path)
    if samples is None or all(np.array_equal(s, samples[0]) for s in samples):
        return points
    return samples


def _point_motion(
    mesh: UsdGeom.PointBased,
    shutter: Shutter,
    moves: bool,
    count: int,
    warn: Callable[[str], None],
    path: str,
) -> np.ndarray | None:
    """Velocity motion (``moves``: velocities are authored) or the points' samples; velocities
    replace the interpolation of points keyed within the shutter where usd-core's
    ComputePointsAtTimes uses them (UsdGeomPointBased); ``None`` when nothing moves."""
    attr = mesh.GetPointsAttr()
    if not changes_within(attr, shutter.interval):
        return _velocity_motion(mesh, shutter, warn, path) if moves else None
    if moves:
        # usd-core pairs velocities with the points' samples only when sampled at their times.
        if _in_step(attr, mesh.GetVelocitiesAttr(), shutter.frame):
            samples = _velocity_motion(mesh, shutter, warn, path, keyed=True)
            if samples is not None:
                return samples
        else:
            warn(f"{path}: velocities are not sampled at the times of the points' samples; "
                 "the points are interpolated instead")
    return _deformation(mesh, shutter, count, warn, path)


def _in_step(lead: Usd.Attribute, follower: Usd.Attribute, frame: Usd.TimeCode) -> bool:
    """Whether ``follower`` is time-sampled where ``lead`` is about ``frame``, the condition on
    which usd-core extrapolates ``lead`` by ``follower`` (UsdGeom's sampling utilities)."""
    samples = _bracket(lead, frame)
    return bool(samples) and samples == _bracket(follower, frame)


def _bracket(attr: Usd.Attribute, frame: Usd.TimeCode) -> tuple[float, ...]:
    """The sample of ``attr`` at or before ``frame`` (its first one if none is) and the samples
    bracketing the moment after ``frame``, as usd-core compares them; () without samples."""
    time = frame.GetValue()
    at = attr.GetBracketingTimeSamples(time)
    if not at:
        return ()
    after = attr.GetBracketingTimeSamples(time + Usd.TimeCode.SafeStep()) if at[0] == at[1] else at
    return (at[0], *after)


def _deformation(
    mesh: UsdGeom.PointBased, shutter: Shutter, count: int, warn: Callable[[str], None], path: str
) -> np.ndarray | None:
    """Time-sampled points at the shutter's times; ``None`` (after a warning) when the point
    count or the topology changes within the shutter."""
    attr = mesh.GetPointsAttr()
    times = shutter.times(shutter.segments(attr.GetTimeSamplesInInterval(shutter.interval)))
    samples = [np.asarray(attr.Get(time), dtype=np.float32).reshape(-1, 3) for time in times]
    topology = [
        attr
        for attr in _topology(mesh)
        if attr.ValueMightBeTimeVarying()
    ]
    if any(len(s) != count for s in samples) or any(
        attr.Get(time) != attr.Get(shutter.frame) for attr in topology for time in times
    ):
        warn(
            f"{path}: the point count or topology changes within the shutter; "
            "deformation motion blur ignored (points at the frame used)"
        )
        return None
    return np.stack(samples)


def _topology(gprim: UsdGeom.PointBased) -> tuple[Usd.Attribute, ...]:
    """The attributes of a mesh's topology (other point-based gprims have none)."""
    if not isinstance(gprim, UsdGeom.Mesh):
        return ()
    return (gprim.GetFaceVertexCountsAttr(), gprim.GetFaceVertexIndicesAttr())


def _velocity_motion(
    mesh: UsdGeom.PointBased,
    shutter: Shutter,
    warn: Callable[[str], None],
    path: str,
    keyed: bool = False,
) -> np.ndarray | None:
    """p(t) = p0 + v·Δ + ½·a·Δ² at the shutter's times, p0, v and a at the points' sample at
    or before the frame; ``None`` when the velocities do not match the points. ``keyed`` (the
    points change within the shutter): accelerations count only sampled in step with the
    velocities, as usd-core has it."""
    attr = mesh.GetPointsAttr()
    bracket = attr.GetBracketingTimeSamples(shutter.frame.GetValue())
    t0 = Usd.TimeCode(bracket[0]) if bracket else shutter.frame
    origin = np.asarray(attr.Get(t0), dtype=np.float64).reshape(-1, 3)
    velocities = _per_point(mesh.GetVelocitiesAttr(), t0, len(origin), warn, path)
    if velocities is None:
        return None
    accelerations = None
    if not keyed or _in_step(mesh.GetVelocitiesAttr(), mesh.GetAccelerationsAttr(), shutter.frame):
        accelerations = _per_point(mesh.GetAccelerationsAttr(), t0, len(origin), warn, path)
    segments = min(ACCELERATION_SEGMENTS if accelerations is not None else 1, shutter.max_segments)
    seconds_per_code = 1.0 / mesh.GetPrim().GetStage().GetTimeCodesPerSecond()
    samples = []
    for time in shutter.times(segments):
        delta = (time.GetValue() - t0.GetValue()) * seconds_per_code
        moved = origin + velocities * delta
        if accelerations is not None:
            moved += 0.5 * accelerations * delta * delta
        samples.append(moved)
    return np.asarray(samples, dtype=np.float32)


def _per_point(
    attr: Usd.Attribute, time: Usd.TimeCode, count: int, warn: Callable[[str], None], path: str
) -> np.ndarray | None:
    """The vectors of ``attr`` at ``time`` when authored; ``None`` (after a warning if they
    are authored but do not match the ``count`` points) otherwise."""
    if not attr.HasAuthoredValue():
        return None
    values = np.asarray(attr.Get(time) or [], dtype=np.float64).reshape(-1, 3)
    if len(values) != count:
        warn(f"{path}: {len(values)} {attr.GetName()} for {count} points; ignored")
        return None
    return values
