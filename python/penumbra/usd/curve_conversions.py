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
  ``ranges`` restricts a curve to part of its knot domain: its spans are clipped to it (the
  Bézier points of a clipped span are fitted through points of the clipped span, which is what
  splitting it by de Casteljau's algorithm gives), so a restricted curve is converted by spans
  even where its order and knots would have let it pass as a B-spline or linear curve.

  Curves of the same order and vertex count whose knot vectors are the same relative to their
  domains (a groom's strands share one) share one map, computed once from the first of them
  and applied to all of them at once: a million strands cost no Python loop per strand. Curves
  whose knots (and ranges) are shifted or scaled copies of another's get its map (the same up
  to rounding).
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
        ``consequence`` when they cannot be carried over. One value of any interpolation is
        constant (see :func:`_one_value_is_constant`)."""
        if values is None:
            return values, interpolation
        interpolation = _one_value_is_constant(values, interpolation)
        if self.vertex_map is None and not self.vertex_as_varying:
            return values, interpolation
        if interpolation in (UsdGeom.Tokens.constant, UsdGeom.Tokens.uniform):
            return values, interpolation
        if self.vertex_as_varying:  # Hermite: one value per point is one per segment end
            return values, UsdGeom.Tokens.varying
        expected = self.vertex_map.columns
        if interpolation == UsdGeom.Tokens.vertex and len(values) == expected:
            mapped = self.vertex_map.apply(values.reshape(len(values), -1))
            return mapped.reshape((-1,) + values.shape[1:]), interpolation
        if interpolation == UsdGeom.Tokens.vertex:
            problem = f"has {len(values)} values, expected {expected} (one per point)"
        else:
            problem = (
                f"has {len(values)} values; {self.source} data is read as constant, uniform or "
                "vertex (one value per point) only"
            )
        warn(f"{path}: {attribute} ({interpolation}) {problem}; {consequence}")
        return None, interpolation


def _one_value_is_constant(values: np.ndarray, interpolation: str) -> str:
    """``interpolation`` of ``values``, constant when there is a single value: ``widths = [w]``
    without interpolation metadata is vertex by the schema's fallback, and Hydra's Storm (like
    the Points reader) reads a single value of any interpolation as the whole prim's, where the
    count it does not match would skip the prim."""
    return UsdGeom.Tokens.constant if len(values) == 1 else interpolation


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
    naming the attribute when ``order``, ``knots``, ``pointWeights`` or ``ranges`` do not fit
    the points."""
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
    domains = layout.domains(knots)
    ranges = _ranges(curves, reader, domains, warn, path)
    if ranges is None:
        return None
    whole = (ranges == domains).all()  # else clipped spans, whatever the order and knots
    rational = len(weights) > 0 and _per_curve(
        weights, layout.vertex_starts, lambda w_max, w_min: w_max - w_min > 1e-12 * w_max
    ).any()
    if not rational and whole and (orders == 2).all():
        return BasisCurves("linear", "bezier", "nonperiodic", counts, positions)
    if not rational and whole and (orders == 4).all() and _uniform(knots, layout).all():
        return BasisCurves("cubic", "bspline", "nonperiodic", counts, positions)
    if not rational and (orders <= 4).all():
        convert, curve_basis, wrap, weights = _BezierSpans, "bezier", "nonperiodic", None
    else:  # every curve weighted as soon as pointWeights are authored, as a single one may be
        convert, curve_basis, wrap = _RefinedSpans, "catmullRom", "pinned"
        weights = weights if len(weights) else None
    classes = [(members, kind_of, convert(rows, kind_ranges, order))
               for members, kind_of, rows, kind_ranges, order
               in _classes_of_curves(knots, ranges, layout)]
    if any((conversion.rows_per_curve == 0).any() for _, _, conversion in classes):
        warn(f"{path}: knots leave a curve without a span of positive length; skipped")
        return None
    vertex_map = _GroupedMap(layout.vertex_starts, int(counts.sum()), classes, weights)
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

    def domains(self, knots: np.ndarray) -> np.ndarray:
        """Each curve's knot domain, [knots[order − 1], knots[count]], float64 (C, 2)."""
        return np.stack(
            [knots[self.knot_starts + self.orders - 1], knots[self.knot_starts + self.counts]], 1
        )


def _ranges(
    curves: UsdGeom.NurbsCurves,
    reader: SampleReader,
    domains: np.ndarray,
    warn: Callable[[str], None],
    path: str,
) -> np.ndarray | None:
    """Each curve's parametric range, float64 (C, 2): its ``ranges`` clipped to its knot domain
    ``domains`` (beyond it the curve is not defined: its basis functions no longer sum to 1),
    its whole domain where ``ranges`` is not authored (or empty); ``None`` after a warning when
    there is not one range per curve, or one leaves its curve no part of its domain."""
    value = reader.get(curves.GetRangesAttr())
    ranges = np.asarray(value if value is not None else [], dtype=np.float64).reshape(-1, 2)
    if len(ranges) == 0:
        return domains
    if len(ranges) == len(domains):
        ranges = np.stack(
            [np.maximum(ranges[:, 0], domains[:, 0]), np.minimum(ranges[:, 1], domains[:, 1])], 1
        )
        if (ranges[:, 0] < ranges[:, 1]).all():  # NaN fails too
            return ranges
    warn(
        f"{path}: ranges must give each of the {len(domains)} curves a minimum below its "
        "maximum, overlapping its knot domain; skipped"
    )
    return None


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


def _classes_of_curves(
    knots: np.ndarray, ranges: np.ndarray, layout: _Layout
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]]:
    """The curves by order and vertex count, each class with its kinds of knot vector and
    range: those the same relative to their domain (a groom's strands share one) share one
    conversion. Each class: its curves, the kind of each, the knots and the range of the first
    curve of each kind (one row a kind), from which the kind's conversion is computed, and the
    order."""
    counts, orders = layout.counts, layout.orders
    shape_of = np.unique(orders * (counts.max() + 1) + counts, return_inverse=True)[1]
    classes = []
    for members in _indices_by_label(shape_of.reshape(-1)):
        order, count = int(orders[members[0]]), int(counts[members[0]])
        rows = knots[layout.knot_starts[members, None] + np.arange(count + order)]
        spans = ranges[members]
        if (rows == rows[0]).all() and (spans == spans[0]).all():  # a groom's strands
            kind_of = np.zeros(len(members), dtype=np.int64)
        else:
            low, high = rows[:, order - 1 : order], rows[:, count : count + 1]
            with np.errstate(divide="ignore", invalid="ignore"):
                relative = np.nan_to_num((np.hstack([rows, spans]) - low) / (high - low), nan=-1.0)
            # Knot multiplicities too: rounding must not merge a tiny span with a repeated knot.
            key = np.concatenate([relative, np.diff(rows, axis=1) > 0], 1)
            kind_of = np.unique(key, axis=0, return_inverse=True)[1].reshape(-1)
        firsts = np.array([kind[0] for kind in _indices_by_label(kind_of)])
        classes.append((members, kind_of, rows[firsts], spans[firsts], order))
    return classes


def _indices_by_label(labels: np.ndarray) -> list[np.ndarray]:
    """The indices of each label's entries (labels 0 … L − 1), in order."""
    return np.split(np.argsort(labels, kind="stable"), np.cumsum(np.bincount(labels))[:-1])


class _Conversion:
    """Linear maps from the control points of curves of one order and vertex count, one curve
    of each knot vector in ``knots`` (a row each) restricted to its range in ``ranges`` (a row
    each), to the vertices they convert to: vertex r is Σ_k ``values[r, k]`` · (control point
    ``first[r] + k`` of curve ``curve[r]``): the ``order`` points whose basis functions are not
    zero where it is taken. Rows are curve by curve."""

    def __init__(self, knots: np.ndarray, ranges: np.ndarray, order: int):
        kinds, length = knots.shape
        count = length - order
        # The spans clipped to their curve's range (a whole domain leaves them as they are).
        starts = np.maximum(knots[:, order - 1 : count], ranges[:, :1])
        ends = np.minimum(knots[:, order : count + 1], ranges[:, 1:])
        curve, span = np.nonzero(ends > starts)  # those of positive length, curve by curve
        self._starts, self._ends = starts[curve, span], ends[curve, span]
        # All the knot vectors in a row: each span's recurrence reads its own curve's knots only.
        self._flat = Direction(kinds * length - order, order - 1, knots.reshape(-1), 0.0, 0.0)
        self._spans = span + order - 1 + curve * length
        self._span_curve, self._order, self._length = curve, order, length
        self.curve, self.first, self.values = self._rows()
        self.rows_per_curve = np.bincount(self.curve, minlength=kinds)
        self.row_starts = np.concatenate([[0], np.cumsum(self.rows_per_curve)[:-1]])

    def _rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``curve``, ``first`` and ``values`` of every row (by subclass)."""
        raise NotImplementedError

    def _basis(self, params: np.ndarray, spans: np.ndarray, curve: np.ndarray):
        """The non-zero basis functions at ``params`` in (flat) ``spans`` of curves ``curve``,
        and the first control point (of its curve) they weigh."""
        on_curve = basis(self._flat, params, spans)
        return on_curve.values, on_curve.first - curve * self._length


class _BezierSpans(_Conversion):
    """Bézier points of each span of non-rational curves of order at most 4, consecutive spans
    sharing their end point: each span's polynomial through its points at 0, 1/3, 2/3 and 1."""

    def _rows(self):
        spans, curve = self._spans, self._span_curve
        a, b = self._starts[:, None], self._ends[:, None]
        values, first = self._basis(
            (a + (b - a) * np.linspace(0, 1, 4)).reshape(-1), np.repeat(spans, 4),
            np.repeat(curve, 4),
        )
        bezier = _BEZIER_FIT @ values.reshape(len(spans), 4, self._order)
        keep = np.ones((len(spans), 4), dtype=bool)
        keep[1:, 0] = curve[1:] != curve[:-1]  # a later span starts where the one before ends
        return np.repeat(curve, 4)[keep.reshape(-1)], first.reshape(-1, 4)[keep], bezier[keep]


class _RefinedSpans(_Conversion):
    """Points of (rational or higher-order) curves through which they are refined, before any
    weights: ``REFINED_SAMPLES_PER_SPAN`` per span and each curve's end."""

    def _rows(self):
        spans, curve = self._spans, self._span_curve
        fractions = np.arange(REFINED_SAMPLES_PER_SPAN) / REFINED_SAMPLES_PER_SPAN
        starts, ends = self._starts[:, None], self._ends[:, None]
        params = starts + (ends - starts) * fractions
        last = np.flatnonzero(np.append(curve[1:] != curve[:-1], True))  # each curve's last span
        order = np.argsort(  # each curve's end after its last span's samples
            np.append(np.arange(params.size), last * REFINED_SAMPLES_PER_SPAN + 7.5), kind="stable"
        )
        all_curves = np.append(np.repeat(curve, REFINED_SAMPLES_PER_SPAN), curve[last])[order]
        values, first = self._basis(
            np.append(params.reshape(-1), self._ends[last])[order],
            np.append(np.repeat(spans, REFINED_SAMPLES_PER_SPAN), spans[last])[order],
            all_curves,
        )
        return all_curves, first, values


class _GroupedMap:
    """The linear map of vertex rows of all the curves of a prim, applied class by class of
    curves (one order and vertex count) to all its curves at once, each curve taking the rows
    of its kind of knot vector; weighted per curve by ``weights`` when given (a rational
    curve's point is Σ wᵢNᵢPᵢ / Σ wᵢNᵢ)."""

    CHUNK = 1 << 16  # curves mapped at once, bounding the temporary arrays

    def __init__(
        self,
        vertex_starts: np.ndarray,
        columns: int,
        classes: list[tuple[np.ndarray, np.ndarray, _Conversion]],
        weights: np.ndarray | None,
    ):
        self.vertex_starts, self.classes, self.weights = vertex_starts, classes, weights
        rows = np.zeros(len(vertex_starts), dtype=np.int64)
        for curves, kind_of, conversion in classes:
            rows[curves] = conversion.rows_per_curve[kind_of]
        self.counts = rows.astype(np.int32)
        self.starts = np.concatenate([[0], np.cumsum(rows)[:-1]])
        self.rows = int(rows.sum())
        self.columns = columns
        # How many knot vectors conversions were computed for (fewer than curves: shared).
        self.kinds = sum(len(conversion.rows_per_curve) for _, _, conversion in classes)

    def apply(self, values: np.ndarray) -> np.ndarray:
        """``values`` (..., N_source, W) mapped to float32 (..., N, W)."""
        out = np.empty(values.shape[:-2] + (self.rows, values.shape[-1]), dtype=np.float32)
        for curves, kind_of, conversion in self.classes:
            for chunk in range(0, len(curves), self.CHUNK):
                part = curves[chunk : chunk + self.CHUNK]
                kinds = kind_of[chunk : chunk + self.CHUNK]
                per_curve = conversion.rows_per_curve[kinds]
                row_curve = np.repeat(np.arange(len(part)), per_curve)
                within = np.arange(len(row_curve)) - np.repeat(np.cumsum(per_curve) - per_curve,
                                                               per_curve)
                row = conversion.row_starts[kinds][row_curve] + within
                sources = self.vertex_starts[part][row_curve] + conversion.first[row]
                coefficients = self._coefficients(conversion.values[row], sources)
                # Summed in the order of the control points, as the product of the curve's
                # dense matrix with its points sums them (the same result to the last bit).
                out[..., self.starts[part][row_curve] + within, :] = sum(
                    coefficients[:, k, None] * values[..., sources + k, :]
                    for k in range(coefficients.shape[1])
                )
        return out

    def _coefficients(self, values: np.ndarray, sources: np.ndarray) -> np.ndarray:
        """``values`` (R, order), weighted for the curves whose rows start at ``sources``."""
        if self.weights is None:
            return values
        weighted = values * self.weights[sources[:, None] + np.arange(values.shape[1])]
        return weighted / weighted.sum(axis=-1, keepdims=True)
