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
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pxr import UsdGeom

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
    vertex_map: _BlockDiagonal | None = None
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
        if interpolation == UsdGeom.Tokens.vertex and len(values) == self.vertex_map.columns:
            mapped = self.vertex_map.apply(values.reshape(len(values), -1))
            return mapped.reshape((-1,) + values.shape[1:]), interpolation
        warn(
            f"{path}: {attribute} ({interpolation}, {len(values)} values) cannot be carried over "
            f"to the curves {self.source} converts to; {consequence}"
        )
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
    knot_starts = np.concatenate([[0], np.cumsum(counts + orders)[:-1]])
    vertex_starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    pieces = [
        (knots[k0 : k0 + n + p], int(p), weights[v0 : v0 + n] if len(weights) else None)
        for k0, v0, n, p in zip(knot_starts, vertex_starts, counts, orders)
    ]
    if any((np.diff(k) < 0).any() for k, _, _ in pieces):
        warn(f"{path}: knots must not decrease within a curve; skipped")
        return None
    rational = [w is not None and np.ptp(w) > 1e-12 * w.max() for _, _, w in pieces]
    if not any(rational) and (orders == 2).all():
        return BasisCurves("linear", "bezier", "nonperiodic", counts, positions)
    if not any(rational) and (orders == 4).all() and all(_uniform(k) for k, _, _ in pieces):
        return BasisCurves("cubic", "bspline", "nonperiodic", counts, positions)
    if not any(rational) and (orders <= 4).all():
        blocks = [_bezier_rows(k, p, len(k) - p) for k, p, _ in pieces]
        basis, wrap = "bezier", "nonperiodic"
    else:
        blocks = [_refined_rows(k, p, len(k) - p, w) for k, p, w in pieces]
        basis, wrap = "catmullRom", "pinned"
    if any(len(block) == 0 for block in blocks):
        warn(f"{path}: knots leave a curve without a span of positive length; skipped")
        return None
    vertex_map = _BlockDiagonal(blocks)
    return BasisCurves(
        "cubic", basis, wrap, np.array([len(b) for b in blocks], dtype=np.int32),
        vertex_map.apply(positions), vertex_map=vertex_map, source="NurbsCurves",
    )


def _uniform(knots: np.ndarray) -> bool:
    steps = np.diff(knots)
    return bool(steps.min() > 0 and np.ptp(steps) <= 1e-9 * steps.max())


def _spans(knots: np.ndarray, order: int, count: int) -> list[int]:
    """The indices i of the knot spans [t_i, t_i+1) of positive length in the curve's domain."""
    return [i for i in range(order - 1, count) if knots[i + 1] > knots[i]]


def _basis(knots: np.ndarray, order: int, span: int, u: float) -> np.ndarray:
    """The ``order`` B-spline basis functions that are not zero on ``span`` at ``u``
    (functions span − order + 1 … span), by de Boor's recurrence (The NURBS Book, A2.2)."""
    values = np.zeros(order)
    values[0] = 1.0
    left, right = np.zeros(order), np.zeros(order)
    for j in range(1, order):
        left[j] = u - knots[span + 1 - j]
        right[j] = knots[span + j] - u
        saved = 0.0
        for r in range(j):
            term = values[r] / (right[r + 1] + left[j - r])
            values[r] = saved + right[r + 1] * term
            saved = left[j - r] * term
        values[j] = saved
    return values


def _row(knots: np.ndarray, order: int, count: int, span: int, u: float, weights) -> np.ndarray:
    """The curve's point at ``u`` (in ``span``) as weights of its ``count`` control points."""
    row = np.zeros(count)
    values = _basis(knots, order, span, u)
    if weights is not None:
        values = values * weights[span - order + 1 : span + 1]
        values /= values.sum()
    row[span - order + 1 : span + 1] = values
    return row


def _bezier_rows(knots: np.ndarray, order: int, count: int) -> np.ndarray:
    """Bézier points (as weights of the control points) of each span of a non-rational curve
    of order at most 4, consecutive spans sharing their end point."""
    rows = []
    for n, span in enumerate(_spans(knots, order, count)):
        a, b = knots[span], knots[span + 1]
        on_curve = np.array(
            [_row(knots, order, count, span, a + (b - a) * f, None) for f in np.linspace(0, 1, 4)]
        )
        bezier = _BEZIER_FIT @ on_curve
        rows.extend(bezier if n == 0 else bezier[1:])
    return np.array(rows).reshape(-1, count)


def _refined_rows(knots: np.ndarray, order: int, count: int, weights) -> np.ndarray:
    """Points through which a rational (or higher-order) curve is refined, as weights of its
    control points: ``REFINED_SAMPLES_PER_SPAN`` per span and the curve's end."""
    spans = _spans(knots, order, count)
    rows = [
        _row(knots, order, count, span, knots[span] + (knots[span + 1] - knots[span]) * f, weights)
        for span in spans
        for f in np.arange(REFINED_SAMPLES_PER_SPAN) / REFINED_SAMPLES_PER_SPAN
    ]
    if spans:
        rows.append(_row(knots, order, count, spans[-1], knots[spans[-1] + 1], weights))
    return np.array(rows).reshape(-1, count)


class _BlockDiagonal:
    """A linear map of vertex rows, curve by curve: each curve's block maps its own vertices
    (kept as blocks: a dense matrix over all curves would grow with their count squared)."""

    def __init__(self, blocks: list[np.ndarray]):
        self.blocks = blocks
        self.columns = sum(block.shape[1] for block in blocks)

    def apply(self, values: np.ndarray) -> np.ndarray:
        """``values`` (..., N_source, W) mapped to float32 (..., N, W)."""
        parts, start = [], 0
        for block in self.blocks:
            source = values[..., start : start + block.shape[1], :].astype(np.float64)
            parts.append(np.einsum("ij,...jk->...ik", block, source))
            start += block.shape[1]
        return np.concatenate(parts, axis=-2).astype(np.float32)
