"""NurbsCurves and HermiteCurves as the BasisCurves the renderer traces.

* HermiteCurves (points and tangents) → cubic Bézier curves, exactly: a segment from P0 to P1
  with tangents T0 and T1 is the Bézier curve P0, P0 + T0/3, P1 − T1/3, P1. Per-point data
  (vertex or varying) becomes varying on the Bézier curves: one value per segment end.
* NurbsCurves, by their ``order``, ``knots`` and ``pointWeights``: non-rational curves of order 4
  with a uniform knot vector are cubic B-splines with the same vertices; all of order 2 are
  linear curves through their control points; other non-rational curves of order up to 4 are
  converted exactly to cubic Bézier curves, one per knot span (each span is a polynomial of
  degree 3 or less: its Bézier points are fitted through four points on it), which covers clamped
  ("pinned") knot vectors; rational or higher-order curves are refined into pinned Catmull-Rom
  curves through ``REFINED_SAMPLES_PER_SPAN`` points per span, evaluated by de Boor's
  recurrence with the weights. Vertex data goes through the same linear map as the points.
  ``ranges`` is not read: curves span their whole knot domain.

  Curves of the same order and vertex count whose knot vectors are the same relative to their
  domains (a groom's strands share one) share one map, computed once from the first of them
  and applied to all of them at once: a million strands cost no Python loop per strand. Curves
  whose knots are shifted or scaled copies of another's get its map (the same up to rounding).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pxr import UsdGeom

from .nurbs_patch import Direction, basis
from .sampling import SampleReader

REFINED_SAMPLES_PER_SPAN = 8
"""Points per knot span through which rational (or higher-order) NURBS curves are refined."""

# Bézier points from the points at u = 0, 1/3, 2/3, 1 of a cubic polynomial.
_BEZIER_FIT = np.linalg.inv(
    np.array(
        [[(1 - u) ** 3, 3 * u * (1 - u) ** 2, 3 * u * u * (1 - u), u**3] for u in np.linspace(0, 1, 4)]
    )
)


@dataclass
class BasisCurves:
    """Curves as ``set_curves`` takes them. ``vertex_map`` (rows of source vertices → rows of
    these vertices) and ``vertex_as_varying`` say how per-vertex data of the prim they were
    converted from is carried over; neither: they are the prim's own."""

    type: str
    basis: str
    wrap: str
    counts: np.ndarray  # int32 (C,)
    positions: np.ndarray  # float32 (N, 3), or (K, N, 3) over the shutter
    vertex_map: _GroupedMap | None = None
    vertex_as_varying: bool = False
    source: str = ""  # the converted prim's type, for messages

    def remap(
        self,
        values: np.ndarray | None,
        interpolation: str,
        attribute: str,
        warn: Callable[[str], None],
        path: str,
        consequence: str = "ignored",
    ) -> tuple[np.ndarray | None, str]:
        """Primvar ``values`` of the source prim with ``interpolation``, as these curves take
        them; ``(None, interpolation)`` after a warning naming the prim, the attribute and the
        ``consequence`` when they cannot be carried over."""
        if values is None or (self.vertex_map is None and not self.vertex_as_varying):
            return values, interpolation
        if interpolation in (UsdGeom.Tokens.constant, UsdGeom.Tokens.uniform):
            return values, interpolation
        if self.vertex_as_varying:  # Hermite: one value per point is one per segment end
            return values, UsdGeom.Tokens.varying
        expected = self.vertex_map.columns
        if interpolation == UsdGeom.Tokens.vertex and len(values) == expected:
            mapped = self.vertex_map.apply(values.reshape(len(values), -1))
            return mapped.reshape((-1,) + values.shape[1:]), interpolation
        found = f"{len(values)} value{'' if len(values) == 1 else 's'}"
        if interpolation == UsdGeom.Tokens.vertex:
            problem = f"has {found}, expected {expected} (one per point)"
        else:
            problem = (
                f"has {found}; {self.source} data is read as constant, uniform or vertex "
                "(one value per point) only"
            )
        warn(f"{path}: {attribute} ({interpolation}) {problem}; {consequence}")
        return None, interpolation


def hermite_to_bezier(
    curves: UsdGeom.HermiteCurves,
    counts: np.ndarray,
    positions: np.ndarray,
    reader: SampleReader,
    warn: Callable[[str], None],
    path: str,
) -> BasisCurves | None:
    """HermiteCurves as cubic Bézier curves (tangents at the frame, over every position
    sample); ``None`` after a warning when a curve has fewer than 2 points or there is not one
    tangent per point."""
    if (counts < 2).any():
        first = int(np.flatnonzero(counts < 2)[0])
        warn(f"{path}: curveVertexCounts[{first}] = {int(counts[first])}; a Hermite curve needs "
             "at least 2 points; skipped")
        return None
    tangents = np.asarray(reader.get(curves.GetTangentsAttr()) or [], np.float32).reshape(-1, 3)
    count = positions.shape[-2]
    if len(tangents) != count:
        warn(f"{path}: tangents has {len(tangents)} values for {count} points; skipped")
        return None
    curve = np.repeat(np.arange(len(counts)), counts)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    first_out = 3 * np.arange(count) - 2 * curve  # where each point lands
    inner = np.ones(count, dtype=bool)
    inner[starts + counts - 1] = False  # the others start a segment
    out = np.empty(positions.shape[:-2] + (3 * count - 2 * len(counts), 3), dtype=np.float32)
    out[..., first_out, :] = positions
    j = np.flatnonzero(inner)
    out[..., first_out[j] + 1, :] = positions[..., j, :] + tangents[j] / 3
    out[..., first_out[j] + 2, :] = positions[..., j + 1, :] - tangents[j + 1] / 3
    bezier_counts = (3 * counts - 2).astype(np.int32)
    return BasisCurves(
        "cubic", "bezier", "nonperiodic", bezier_counts, out, vertex_as_varying=True,
        source="HermiteCurves",
    )


def nurbs_to_basis(
    curves: UsdGeom.NurbsCurves,
    counts: np.ndarray,
    positions: np.ndarray,
    reader: SampleReader,
    warn: Callable[[str], None],
    path: str,
) -> BasisCurves | None:
    """NurbsCurves as BasisCurves (see the module's description); ``None`` after a warning
    naming the attribute when ``order``, ``knots`` or ``pointWeights`` do not fit the points."""
    orders = np.asarray(reader.get(curves.GetOrderAttr()) or [], dtype=np.int64).reshape(-1)
    knots = np.asarray(reader.get(curves.GetKnotsAttr()) or [], dtype=np.float64).reshape(-1)
    weights_value = reader.get(curves.GetPointWeightsAttr())
    weights = np.asarray(weights_value if weights_value is not None else [], np.float64).reshape(-1)
    if len(orders) != len(counts) or (orders < 2).any() or (counts < orders).any():
        warn(
            f"{path}: order must give each of the {len(counts)} curves an order of 2 or more, "
            "at most its vertex count; skipped"
        )
        return None
    if not np.isfinite(knots).all():
        warn(f"{path}: knots must be finite; skipped")
        return None
    if len(knots) != int((counts + orders).sum()):
        warn(
            f"{path}: knots has {len(knots)} values, not one per vertex plus the order per "
            "curve; skipped"
        )
        return None
    if len(weights) and (len(weights) != counts.sum() or not (weights > 0).all()):
        warn(f"{path}: pointWeights must be positive, one per point; skipped")
        return None
    layout = _Layout(counts.astype(np.int64), orders)
    decreasing = np.diff(knots) < 0
    decreasing[layout.knot_starts[1:] - 1] = False  # from one curve to the next
    if decreasing.any():
        warn(f"{path}: knots must not decrease within a curve; skipped")
        return None
    rational = len(weights) > 0 and _per_curve(
        weights, layout.vertex_starts, lambda w_max, w_min: w_max - w_min > 1e-12 * w_max
    ).any()
    if not rational and (orders == 2).all():
        return BasisCurves("linear", "bezier", "nonperiodic", counts, positions)
    if not rational and (orders == 4).all() and _uniform(knots, layout).all():
        return BasisCurves("cubic", "bspline", "nonperiodic", counts, positions)
    if not rational and (orders <= 4).all():
        convert, curve_basis, wrap, weights = _BezierSpans, "bezier", "nonperiodic", None
    else:  # every curve weighted as soon as pointWeights are authored, as a single one may be
        convert, curve_basis, wrap = _RefinedSpans, "catmullRom", "pinned"
        weights = weights if len(weights) else None
    groups = _groups(knots, layout)
    if any(len(spans) == 0 for _, spans, _ in groups):
        warn(f"{path}: knots leave a curve without a span of positive length; skipped")
        return None
    vertex_map = _GroupedMap(
        layout.vertex_starts, int(counts.sum()),
        [(members, convert(*first, spans)) for members, spans, first in groups],
        weights,
    )
    return BasisCurves(
        "cubic", curve_basis, wrap, vertex_map.counts, vertex_map.apply(positions),
        vertex_map=vertex_map, source="NurbsCurves",
    )


class _Layout:
    """Where each curve's vertices and knots start in the prim's flat arrays."""

    def __init__(self, counts: np.ndarray, orders: np.ndarray):
        self.counts, self.orders = counts, orders
        self.vertex_starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        self.knot_starts = np.concatenate([[0], np.cumsum(counts + orders)[:-1]])


def _per_curve(
    values: np.ndarray, starts: np.ndarray, test: Callable[[np.ndarray, np.ndarray], np.ndarray]
) -> np.ndarray:
    """``test(max, min)`` of each curve's ``values`` (curves start at ``starts``; none empty)."""
    return test(np.maximum.reduceat(values, starts), np.minimum.reduceat(values, starts))


def _uniform(knots: np.ndarray, layout: _Layout) -> np.ndarray:
    """Whether each curve's knot vector is uniform."""
    steps = np.delete(np.diff(knots), layout.knot_starts[1:] - 1)  # within curves only
    starts = layout.knot_starts - np.arange(len(layout.counts))
    return _per_curve(
        steps, starts, lambda most, least: (least > 0) & (most - least <= 1e-9 * most)
    )


def _groups(
    knots: np.ndarray, layout: _Layout
) -> list[tuple[np.ndarray, np.ndarray, tuple[np.ndarray, int]]]:
    """The curves that share one conversion: the same order, vertex count and knot vector
    relative to its domain (a groom's strands share one). Each group: its curves, the indices
    of their knot spans of positive length within the domain, and the knots and order of its
    first curve, from which its conversion is computed."""
    counts, orders = layout.counts, layout.orders
    shape_of = np.unique(orders * (counts.max() + 1) + counts, return_inverse=True)[1]
    groups = []
    for members in _classes(shape_of.reshape(-1)):
        order, count = int(orders[members[0]]), int(counts[members[0]])
        rows = knots[layout.knot_starts[members, None] + np.arange(count + order)]
        if (rows == rows[0]).all():  # a groom's strands
            kinds = [np.arange(len(members))]
        else:
            low, high = rows[:, order - 1 : order], rows[:, count : count + 1]
            with np.errstate(divide="ignore", invalid="ignore"):
                relative = np.nan_to_num((rows - low) / (high - low), nan=-1.0)
            # Knot multiplicities too: rounding must not merge a tiny span with a repeated knot.
            key = np.concatenate([relative, np.diff(rows, axis=1) > 0], 1)
            kinds = _classes(np.unique(key, axis=0, return_inverse=True)[1].reshape(-1))
        for kind in kinds:
            own = rows[kind[0]]
            spans = np.flatnonzero(own[order : count + 1] > own[order - 1 : count]) + order - 1
            groups.append((members[kind], spans, (own, order)))
    return groups


def _classes(labels: np.ndarray) -> list[np.ndarray]:
    """The indices of each label's entries (labels 0 … L − 1), in order."""
    return np.split(np.argsort(labels, kind="stable"), np.cumsum(np.bincount(labels))[:-1])


class _Rows:
    """A linear map from a curve's control points to the vertices it converts to: vertex r is
    Σ_k ``values[r, k]`` · (control point ``first[r] + k``), the ``order`` points whose basis
    functions are not zero where it is taken."""

    first: np.ndarray  # int (R,)
    values: np.ndarray  # float64 (R, order)


class _BezierSpans(_Rows):
    """Bézier points of each span of a non-rational curve of order at most 4, consecutive spans
    sharing their end point: each span's polynomial through its points at 0, 1/3, 2/3 and 1."""

    def __init__(self, knots: np.ndarray, order: int, spans: np.ndarray):
        a, b = knots[spans, None], knots[spans + 1, None]
        on_curve = basis(
            Direction(len(knots) - order, order - 1, knots, a[0, 0], b[-1, 0]),
            (a + (b - a) * np.linspace(0, 1, 4)).reshape(-1),
            np.repeat(spans, 4),
        )
        bezier = _BEZIER_FIT @ on_curve.values.reshape(len(spans), 4, order)
        keep = np.ones((len(spans), 4), dtype=bool)
        keep[1:, 0] = False  # the end point of the span before
        self.values = bezier[keep]
        self.first = on_curve.first.reshape(len(spans), 4)[keep]


class _RefinedSpans(_Rows):
    """Points of a (rational or higher-order) curve through which it is refined, before any
    weights: ``REFINED_SAMPLES_PER_SPAN`` per span and the curve's end."""

    def __init__(self, knots: np.ndarray, order: int, spans: np.ndarray):
        fractions = np.arange(REFINED_SAMPLES_PER_SPAN) / REFINED_SAMPLES_PER_SPAN
        params = knots[spans, None] + (knots[spans + 1, None] - knots[spans, None]) * fractions
        on_curve = basis(
            Direction(len(knots) - order, order - 1, knots, knots[spans[0]], knots[spans[-1] + 1]),
            np.append(params.reshape(-1), knots[spans[-1] + 1]),
            np.append(np.repeat(spans, REFINED_SAMPLES_PER_SPAN), spans[-1]),
        )
        self.values, self.first = on_curve.values, on_curve.first


class _GroupedMap:
    """The linear map of vertex rows of all the curves of a prim: one :class:`_Rows` per group
    of curves converted alike, applied to all its curves at once (weighted per curve by
    ``weights`` when given: a rational curve's point is Σ wᵢNᵢPᵢ / Σ wᵢNᵢ)."""

    CHUNK = 1 << 16  # curves mapped at once, bounding the temporary arrays

    def __init__(
        self,
        vertex_starts: np.ndarray,
        columns: int,
        groups: list[tuple[np.ndarray, _Rows]],
        weights: np.ndarray | None,
    ):
        self.vertex_starts, self.groups, self.weights = vertex_starts, groups, weights
        rows = np.zeros(len(vertex_starts), dtype=np.int64)
        for curves, conversion in groups:
            rows[curves] = len(conversion.first)
        self.counts = rows.astype(np.int32)
        self.starts = np.concatenate([[0], np.cumsum(rows)[:-1]])
        self.rows = int(rows.sum())
        self.columns = columns

    def apply(self, values: np.ndarray) -> np.ndarray:
        """``values`` (..., N_source, W) mapped to float32 (..., N, W)."""
        out = np.empty(values.shape[:-2] + (self.rows, values.shape[-1]), dtype=np.float32)
        for curves, conversion in self.groups:
            order = conversion.values.shape[1]
            for chunk in range(0, len(curves), self.CHUNK):
                part = curves[chunk : chunk + self.CHUNK]
                sources = self.vertex_starts[part, None] + conversion.first  # (C, R)
                coefficients = self._coefficients(conversion.values, sources)
                # Summed in the order of the control points, as the product of the curve's
                # dense matrix with its points sums them (the same result to the last bit).
                total = sum(
                    coefficients[..., k, None] * values[..., sources + k, :] for k in range(order)
                )
                out[..., self.starts[part, None] + np.arange(len(conversion.first)), :] = total
        return out

    def _coefficients(self, values: np.ndarray, sources: np.ndarray) -> np.ndarray:
        """``values`` (R, order), weighted for each curve whose rows start at ``sources``."""
        if self.weights is None:
            return values
        weighted = values * self.weights[sources[..., None] + np.arange(values.shape[1])]
        return weighted / weighted.sum(axis=-1, keepdims=True)
