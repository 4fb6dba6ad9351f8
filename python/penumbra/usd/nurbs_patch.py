"""UsdGeomNurbsPatch evaluated into a quad mesh with normals from the surface's derivatives.

The patch is read as the schema defines it: ``uVertexCount`` × ``vVertexCount`` control points
with u varying fastest (``points[v * uVertexCount + u]``), orders (degree + 1) and knot vectors
of ``count + order`` values per direction, optional ``pointWeights`` (a rational patch: the
points are not pre-weighted), and ``uRange``/``vRange`` (by default the whole valid range,
``knots[order - 1]`` to ``knots[count]``). ``uForm``/``vForm`` only record the modeller's intent:
a closed or periodic patch repeats its first control points in the data itself, so the authored
data alone is evaluated. Trim curves are not applied (a warning names the prim).

Density follows the control net, per knot span and direction:

* degree 1: one segment per span. The patch is then piecewise (bi)linear and the quads are
  exactly its control polygons: a bilinear patch is the quad of its four points.
* degree p ≥ 2: ``max(p, ceil(turn / MAX_TURN_PER_SEGMENT))`` segments, at most
  ``MAX_SEGMENTS_PER_SPAN``, where ``turn`` is the largest total turning angle, over the rows of
  control points in that direction, of the p + 1 points that shape the span. The curve turns no
  more than its control polygon (knot insertion only cuts corners), and segments are uniform in
  the parameter, so each turns about ``MAX_TURN_PER_SEGMENT`` (more where the curve turns
  faster than its mean over the span: a rational quadratic quarter circle's 16 segments turn
  0.92 to 1.05 times π/32, and the arc is within 1.4e-3 of its radius from its chords).

Vertices lie on the surface (evaluated in double precision from the non-zero basis functions
at each parameter, by de Boor's triangular scheme over all parameters at once); their normals
are ∂S/∂u × ∂S/∂v (negated for ``leftHanded``), taken from the neighbouring vertices where the
derivatives degenerate (a pole). Bilinear patches (degree 1 both ways) are shaded flat, as
polygons are.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from pxr import Usd, UsdGeom

from .sampling import SampleReader

MAX_TURN_PER_SEGMENT = math.pi / 32
MAX_SEGMENTS_PER_SPAN = 64
MAX_VERTICES = 1_000_000
"""At most this many vertices a patch: a denser grid is thinned evenly, with a warning (a noisy
100 × 100 net would otherwise reach 33 million vertices and gigabytes of evaluation)."""

_TRIM_ATTRIBUTES = (
    "trimCurve:counts",
    "trimCurve:orders",
    "trimCurve:vertexCounts",
    "trimCurve:knots",
    "trimCurve:ranges",
    "trimCurve:points",
)


class Direction(NamedTuple):
    """One parametric direction of a patch."""

    count: int  # control points
    degree: int  # order − 1
    knots: np.ndarray  # float64 [count + degree + 1]
    low: float  # the parametric range evaluated
    high: float


class Patch(NamedTuple):
    """A validated NURBS patch (control points not included: they may be sampled over time)."""

    u: Direction
    v: Direction
    weights: np.ndarray | None  # float64 [v.count * u.count], or None: polynomial
    left_handed: bool


class Tessellation(NamedTuple):
    counts: np.ndarray  # int32 [F]: 4 per quad
    indices: np.ndarray  # int32 [4F]
    points: np.ndarray  # float32 [N, 3]
    normals: np.ndarray  # float32 [N, 3] per vertex, or [0, 3] when the patch is bilinear


def read_patch(
    prim: Usd.Prim, reader: SampleReader, warn: Callable[[str], None], path: str
) -> tuple[Patch, np.ndarray] | None:
    """The patch of ``prim`` and its control points (float64 [N, 3]) at the reader's time;
    ``None`` after one warning naming the prim and the attribute when the data cannot describe
    a patch."""
    patch = UsdGeom.NurbsPatch(prim)
    directions = []
    for name, count_attr, order_attr, knots_attr, range_attr in (
        ("u", patch.GetUVertexCountAttr(), patch.GetUOrderAttr(), patch.GetUKnotsAttr(),
         patch.GetURangeAttr()),
        ("v", patch.GetVVertexCountAttr(), patch.GetVOrderAttr(), patch.GetVKnotsAttr(),
         patch.GetVRangeAttr()),
    ):
        direction = _read_direction(
            name, reader.get(count_attr), reader.get(order_attr), reader.get(knots_attr),
            reader.get(range_attr), warn, path,
        )
        if direction is None:
            return None
        directions.append(direction)
    u, v = directions
    expected = u.count * v.count
    points = _finite_array(reader.get(patch.GetPointsAttr()), (3,))
    if points is None or len(points) != expected:
        found = "non-finite or non-3-vector values" if points is None else f"{len(points)} values"
        warn(
            f"{path}: points has {found}, expected {expected} finite points "
            f"(uVertexCount {u.count} × vVertexCount {v.count}); skipped"
        )
        return None
    weights = None
    authored_weights = reader.get(patch.GetPointWeightsAttr())
    if authored_weights is not None and len(authored_weights) > 0:
        weights = _finite_array(authored_weights, ())
        if weights is None or len(weights) != expected or not (weights > 0).all():
            warn(
                f"{path}: pointWeights must be {expected} finite positive values "
                "(one per point); skipped"
            )
            return None
    _warn_if_trimmed(patch, reader.time, warn, path)
    left_handed = reader.get(patch.GetOrientationAttr()) == UsdGeom.Tokens.leftHanded
    return Patch(u, v, weights, left_handed), points


def _read_direction(
    name: str, count, order, knots, parametric_range, warn: Callable[[str], None], path: str
) -> Direction | None:
    """One direction's counts, knots and range, validated (``name``: "u" or "v")."""
    count_name, order_name, knots_name = f"{name}VertexCount", f"{name}Order", f"{name}Knots"
    if count is None or count < 2:
        warn(f"{path}: {count_name} must be at least 2 (it is {count}); skipped")
        return None
    if order is None or not 2 <= order <= count:
        warn(f"{path}: {order_name} must be from 2 to {count_name} ({count}), not {order}; skipped")
        return None
    values = _finite_array(knots, ())
    if values is None or len(values) != count + order:
        found = "non-finite values" if values is None else f"{len(values)} values"
        warn(
            f"{path}: {knots_name} has {found}, expected {count + order} "
            f"({count_name} + {order_name}); skipped"
        )
        return None
    degree = order - 1
    if (np.diff(values) < 0).any() or not values[degree] < values[count]:
        warn(
            f"{path}: {knots_name} must be non-decreasing with "
            f"{knots_name}[{degree}] < {knots_name}[{count}]; skipped"
        )
        return None
    low, high = float(values[degree]), float(values[count])
    if parametric_range is not None:
        low, high = (float(x) for x in parametric_range)
        if not (values[degree] <= low < high <= values[count]):  # NaN fails too
            warn(
                f"{path}: {name}Range ({low}, {high}) must be increasing within "
                f"[{values[degree]}, {values[count]}]; skipped"
            )
            return None
    return Direction(int(count), degree, values, low, high)


def _finite_array(value, shape: tuple[int, ...]) -> np.ndarray | None:
    """``value`` as float64 of element shape ``shape`` when every number is finite, else
    ``None``."""
    if value is None:
        return None
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        return None
    if array.shape[1:] != shape or not np.isfinite(array).all():
        return None
    return array


def _warn_if_trimmed(
    patch: UsdGeom.NurbsPatch, time: Usd.TimeCode, warn: Callable[[str], None], path: str
) -> None:
    """Warn (once per prim: ``warn`` drops repeated messages) when trim curves are authored."""
    prim = patch.GetPrim()
    for name in _TRIM_ATTRIBUTES:
        value = prim.GetAttribute(name).Get(time)
        if value is not None and len(value) > 0:
            warn(f"{path}: trim curves ({name}) are ignored; the untrimmed patch is rendered")
            return


# ----------------------------------------------------------------------------------------------
# Evaluation (pure functions)


def parameters(direction: Direction, net: np.ndarray) -> np.ndarray:
    """The increasing parameters a direction is sampled at (see the module's documentation);
    ``net``: the control points as rows along this direction, float64 [rows, count, 3]."""
    knots, degree = direction.knots, direction.degree
    turns = _span_turns(net, degree)
    pieces = []
    for span in range(degree, direction.count):
        start, end = max(knots[span], direction.low), min(knots[span + 1], direction.high)
        if start >= end:
            continue
        segments = 1
        if degree > 1:
            needed = math.ceil(turns[span - degree] / MAX_TURN_PER_SEGMENT - 1e-9)
            segments = min(max(degree, needed), MAX_SEGMENTS_PER_SPAN)
        pieces.append(np.linspace(start, end, segments + 1)[:-1])
    pieces.append(np.array([direction.high]))
    return np.concatenate(pieces)


def _span_turns(net: np.ndarray, degree: int) -> np.ndarray:
    """For each span (degree … count − 1), the largest total turning angle over the rows of
    ``net`` of the control polygon through the span's points (span − degree … span)."""
    edges = np.diff(net, axis=1)  # [rows, count - 1, 3]
    lengths = np.linalg.norm(edges, axis=2)
    usable = lengths > 0
    # A zero-length edge has no direction: it takes the last one before it.
    last = np.maximum.accumulate(np.where(usable, np.arange(edges.shape[1]), 0), axis=1)
    rows = np.arange(edges.shape[0])[:, None]
    known = usable[rows, last]
    directions = edges[rows, last] / np.where(known, lengths[rows, last], 1.0)[..., None]
    cosines = np.clip((directions[:, 1:] * directions[:, :-1]).sum(axis=2), -1.0, 1.0)
    angles = np.where(known[:, 1:] & known[:, :-1], np.arccos(cosines), 0.0)
    count = net.shape[1]
    turns = np.zeros(count - degree)
    for span in range(degree, count):  # angles between edges span-degree … span-1
        window = angles[:, span - degree : span - 1]
        turns[span - degree] = window.sum(axis=1).max() if window.size else 0.0
    return turns


class Basis(NamedTuple):
    """The B-spline basis functions of one direction that are non-zero at each parameter: those
    of control points ``first`` … ``first + degree``."""

    first: np.ndarray  # int [m]
    values: np.ndarray  # float64 [m, degree + 1]
    derivatives: np.ndarray  # float64 [m, degree + 1]: their first derivatives


def basis(direction: Direction, params: np.ndarray, spans: np.ndarray | None = None) -> Basis:
    """The basis functions of ``direction`` at ``params`` (de Boor's triangular scheme over all
    parameters at once: memory in proportion to the parameters, not to the control points).
    ``spans``: the non-empty knot span whose polynomial each parameter is evaluated in (by
    default the one it lies in; a curve that is not continuous at a knot has two values there)."""
    knots, degree, count = direction.knots, direction.degree, direction.count
    if spans is None:
        # The span of each parameter: the last non-empty one starting at or before it, except
        # that the end of the range belongs to the span it closes.
        span = np.searchsorted(knots, params, side="right") - 1
        closing = np.searchsorted(knots, params, side="left") - 1
        span = np.where(params >= knots[count], closing, span).clip(degree, count - 1)
    else:
        span = spans
    # left[j] = t − t_{span+1−j}, right[j] = t_{span+j} − t (j = 1 … degree)
    steps = np.arange(1, degree + 1)
    left = params[:, None] - knots[span[:, None] + 1 - steps]
    right = knots[span[:, None] + steps] - params[:, None]
    values = np.ones((len(params), 1))
    lower = values
    for j in range(1, degree + 1):  # values[:, r]: N_{span−j+r, j}
        lower = values
        values = np.zeros((len(params), j + 1))
        for r in range(j):
            # t_{span+r+1} − t_{span+r+1−j}: positive, as the span is not empty
            share = lower[:, r] / (right[:, r] + left[:, j - r - 1])
            values[:, r] += right[:, r] * share
            values[:, r + 1] = left[:, j - r - 1] * share
    # N'_{i,p} = p · (N_{i,p−1} / (t_{i+p} − t_i) − N_{i+1,p−1} / (t_{i+p+1} − t_{i+1})),
    # i = span − p + r; lower[:, r] is N_{span−p+1+r, p−1}.
    first = span - degree
    derivatives = np.zeros_like(values)
    for r in range(degree):
        i = first + r + 1
        term = degree * lower[:, r] / (knots[i + degree] - knots[i])
        derivatives[:, r + 1] += term
        derivatives[:, r] -= term
    return Basis(first, values, derivatives)


def _combine(weights: np.ndarray, first: np.ndarray, grid: np.ndarray, axis: int) -> np.ndarray:
    """Σ_k weights[:, k] · grid[first + k] along ``axis`` (0 or 1) of ``grid`` [a, b, 4]: the
    grid with that axis replaced by one entry per row of ``weights``."""
    total = 0.0
    for k in range(weights.shape[1]):
        if axis == 0:
            total = total + weights[:, k, None, None] * grid[first + k]
        else:
            total = total + weights[None, :, k, None] * grid[:, first + k]
    return total


def tessellate(
    patch: Patch,
    points: np.ndarray,
    u_params: np.ndarray,
    v_params: np.ndarray,
    with_normals: bool = True,
) -> Tessellation:
    """The quad mesh of ``patch`` with control points ``points`` (float64 [N, 3]) sampled at
    ``u_params`` × ``v_params`` (vertex ``j * len(u_params) + i`` at (u_i, v_j))."""
    u, v = patch.u, patch.v
    weights = patch.weights if patch.weights is not None else np.ones(len(points))
    homogeneous = np.concatenate([points * weights[:, None], weights[:, None]], axis=1)
    net = homogeneous.reshape(v.count, u.count, 4)
    bu, bv = basis(u, u_params), basis(v, v_params)
    rows = _combine(bv.values, bv.first, net, 0)  # [mv, u.count, 4]
    surface = _combine(bu.values, bu.first, rows, 1)  # [mv, mu, 4]
    positions = surface[..., :3] / surface[..., 3:]
    mu, mv = len(u_params), len(v_params)
    grid = np.arange(mu * mv, dtype=np.int32).reshape(mv, mu)
    quads = np.stack([grid[:-1, :-1], grid[:-1, 1:], grid[1:, 1:], grid[1:, :-1]], axis=-1)
    normals = np.empty((0, 3), dtype=np.float32)
    if with_normals:
        along_u = _combine(bu.derivatives, bu.first, rows, 1)
        along_v = _combine(bu.values, bu.first, _combine(bv.derivatives, bv.first, net, 0), 1)
        # The quotient rule: ∂(A/w) = (∂A − ∂w · S) / w.
        du = (along_u[..., :3] - along_u[..., 3:] * positions) / surface[..., 3:]
        dv = (along_v[..., :3] - along_v[..., 3:] * positions) / surface[..., 3:]
        normals = _unit_normals(np.cross(du, dv), positions)
        if patch.left_handed:
            normals = -normals
        normals = np.ascontiguousarray(normals.reshape(-1, 3), dtype=np.float32)
    face_count = (mu - 1) * (mv - 1)
    return Tessellation(
        np.full(face_count, 4, dtype=np.int32),
        np.ascontiguousarray(quads.reshape(-1), dtype=np.int32),
        np.ascontiguousarray(positions.reshape(-1, 3), dtype=np.float32),
        normals,
    )


def _unit_normals(normals: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """``normals`` [mv, mu, 3] normalised. Where they vanish (the derivatives are parallel or
    zero, as along a pole's row of coincident vertices), the mean unit normal of the usable
    grid neighbours of every vertex at that position, each neighbouring position counted once
    (so that a closed seam's duplicate does not count twice): ±Z at a sphere's poles."""
    extent = np.ptp(positions.reshape(-1, 3), axis=0).max() or 1.0
    length = np.linalg.norm(normals, axis=2, keepdims=True)
    usable = (length > 1e-12 * extent * extent)[..., 0]
    unit = np.where(usable[..., None], normals / np.where(usable[..., None], length, 1.0), 0.0)
    if usable.all():
        return unit
    rows, columns = usable.shape
    index = np.arange(rows * columns).reshape(rows, columns)
    j, i = np.nonzero(~usable)
    points, neighbours = [], []
    for dj, di in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        nj, ni = j + dj, i + di
        inside = (nj >= 0) & (nj < rows) & (ni >= 0) & (ni < columns)
        points.append(index[j[inside], i[inside]])
        neighbours.append(index[nj[inside], ni[inside]])
    point, neighbour = np.concatenate(points), np.concatenate(neighbours)
    kept = usable.reshape(-1)[neighbour]
    point, neighbour = point[kept], neighbour[kept]
    flat_positions = positions.reshape(-1, 3).astype(np.float32)  # coincident within rounding
    flat_unit = unit.reshape(-1, 3)
    degenerate = index[j, i]
    groups, group_of = np.unique(flat_positions[degenerate], axis=0, return_inverse=True)
    group_of_point = np.full(rows * columns, -1)
    group_of_point[degenerate] = group_of.reshape(-1)
    group = group_of_point[point]
    keys = np.column_stack([group, flat_positions[neighbour]])
    _, first = np.unique(keys, axis=0, return_index=True)
    sums = np.zeros((len(groups), 3))
    np.add.at(sums, group[first], flat_unit[neighbour[first]])
    size = np.linalg.norm(sums, axis=1, keepdims=True)
    means = np.where(size > 0, sums / np.where(size > 0, size, 1.0), 0.0)
    flat_unit = flat_unit.copy()
    flat_unit[degenerate] = means[group_of.reshape(-1)]
    return flat_unit.reshape(unit.shape)


def _within_budget(
    u_params: np.ndarray, v_params: np.ndarray, warn: Callable[[str], None], path: str
) -> tuple[np.ndarray, np.ndarray]:
    """The parameters, both directions thinned evenly (their ends kept) when their grid would
    exceed MAX_VERTICES, after a warning naming the prim."""
    total = len(u_params) * len(v_params)
    if total <= MAX_VERTICES:
        return u_params, v_params
    scale = math.sqrt(MAX_VERTICES / total)

    def thinned(params: np.ndarray) -> np.ndarray:
        keep = max(2, int(len(params) * scale))
        return params[np.round(np.linspace(0, len(params) - 1, keep)).astype(np.int64)]

    u_params, v_params = thinned(u_params), thinned(v_params)
    warn(f"{path}: its tessellation would have {total:,} vertices; thinned to "
         f"{len(u_params) * len(v_params):,} (at most {MAX_VERTICES:,} a patch)")
    return u_params, v_params


class Generated(NamedTuple):
    """A patch read and tessellated at one time."""

    patch: Patch
    control: np.ndarray  # float64 [N, 3]: the control points at that time
    tessellation: Tessellation
    points_for: Callable[[np.ndarray], np.ndarray]  # other control points → the mesh's points


def mesh(
    prim: Usd.Prim, reader: SampleReader, warn: Callable[[str], None], path: str
) -> Generated | None:
    """Read and tessellate NurbsPatch ``prim`` at the reader's time; ``None`` after a warning
    when the patch cannot be read. ``points_for`` evaluates other control points (motion
    samples) on the same parameters, so that every sample has the same topology."""
    read = read_patch(prim, reader, warn, path)
    if read is None:
        return None
    patch, control = read
    net = control.reshape(patch.v.count, patch.u.count, 3)
    u_params, v_params = _within_budget(
        parameters(patch.u, net), parameters(patch.v, net.transpose(1, 0, 2)), warn, path
    )
    bilinear = patch.u.degree == 1 and patch.v.degree == 1  # shaded flat, as its quads
    tessellation = tessellate(patch, control, u_params, v_params, with_normals=not bilinear)

    def points_for(points: np.ndarray) -> np.ndarray:
        return tessellate(patch, points.astype(np.float64), u_params, v_params, False).points

    return Generated(patch, control, tessellation, points_for)
