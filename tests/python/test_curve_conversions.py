"""NurbsCurves converted to BasisCurves in batches (curves of one order and vertex count at once,
those sharing a knot vector sharing one conversion) give what converting them one curve at a
time gives: the reference below is that per-curve conversion (dense rows per curve, de Boor's
recurrence point by point), checked on randomised prims covering every branch; a groom of
100,000 strands converts with one conversion; ``ranges`` restricts curves to the part of their
domain it names; a single value of any interpolation is constant; vertex data that does not fit
is warned of as authored."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom

from penumbra.usd.curve_conversions import REFINED_SAMPLES_PER_SPAN, nurbs_to_basis
from penumbra.usd.sampling import SampleReader

PATH = "/World/nurbs"
MOTION_SAMPLES = 3
PRIMVAR_WIDTH = 2  # components of the vertex primvar mapped alongside the points


# ----------------------------------------------------------------------------------------------
# The reference: each curve on its own, its conversion as a dense matrix over its vertices.

_FIT = np.linalg.inv(
    np.array([[(1 - u) ** 3, 3 * u * (1 - u) ** 2, 3 * u * u * (1 - u), u**3]
              for u in np.linspace(0, 1, 4)])
)


def _reference_basis(knots, order, span, u):
    """The non-zero basis functions at ``u`` in ``span`` (The NURBS Book, A2.2)."""
    values, left, right = np.zeros(order), np.zeros(order), np.zeros(order)
    values[0] = 1.0
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


def _reference_row(knots, order, count, span, u, weights):
    row = np.zeros(count)
    values = _reference_basis(knots, order, span, u)
    if weights is not None:
        values = values * weights[span - order + 1 : span + 1]
        values /= values.sum()
    row[span - order + 1 : span + 1] = values
    return row


def _reference_block(knots, order, weights, bezier, extent=None):
    """The rows of one curve; ``extent``: its range (its whole domain when ``None``), to which
    its spans are clipped."""
    count = len(knots) - order
    low, high = extent if extent is not None else (knots[order - 1], knots[count])
    spans = [i for i in range(order - 1, count)
             if min(knots[i + 1], high) > max(knots[i], low)]
    rows = []
    for n, span in enumerate(spans):
        a, b = max(knots[span], low), min(knots[span + 1], high)
        if bezier:
            on_curve = np.array([_reference_row(knots, order, count, span, a + (b - a) * f, None)
                                 for f in np.linspace(0, 1, 4)])
            rows.extend(_FIT @ on_curve if n == 0 else (_FIT @ on_curve)[1:])
        else:
            rows.extend(_reference_row(knots, order, count, span, a + (b - a) * f, weights)
                        for f in np.arange(REFINED_SAMPLES_PER_SPAN) / REFINED_SAMPLES_PER_SPAN)
    if spans and not bezier:
        end = min(knots[spans[-1] + 1], high)
        rows.append(_reference_row(knots, order, count, spans[-1], end, weights))
    return np.array(rows).reshape(-1, count)


def _reference(counts, orders, knots, weights, values, ranges=None):
    """(type, basis, counts, mapped values) converting curve by curve; ``values`` (..., N, W);
    ``ranges`` (C, 2) or ``None``: every curve over its whole domain."""
    starts = np.concatenate([[0], np.cumsum(counts + orders)[:-1]])
    pieces = [knots[s : s + n + p] for s, n, p in zip(starts, counts, orders)]
    domains = np.array([(k[p - 1], k[n]) for k, n, p in zip(pieces, counts, orders)])
    extents = domains if ranges is None else np.stack(
        [np.maximum(ranges[:, 0], domains[:, 0]), np.minimum(ranges[:, 1], domains[:, 1])], 1)
    whole = (extents == domains).all()
    firsts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    weight_pieces = [weights[v : v + n] if weights is not None else None
                     for v, n in zip(firsts, counts)]
    rational = any(w is not None and np.ptp(w) > 1e-12 * w.max() for w in weight_pieces)
    if not rational and whole and (orders == 2).all():
        return "linear", "bezier", counts, values
    uniform = [np.diff(k).min() > 0 and np.ptp(np.diff(k)) <= 1e-9 * np.diff(k).max()
               for k in pieces]
    if not rational and whole and (orders == 4).all() and all(uniform):
        return "cubic", "bspline", counts, values
    bezier = not rational and (orders <= 4).all()
    blocks = [_reference_block(k, int(p), w, bezier, e)
              for k, p, w, e in zip(pieces, orders, weight_pieces, extents)]
    mapped = np.concatenate(
        [np.einsum("ij,...jk->...ik", block, values[..., f : f + n, :].astype(np.float64))
         for block, f, n in zip(blocks, firsts, counts)], axis=-2,
    ).astype(np.float32)
    counts_out = np.array([len(b) for b in blocks], dtype=np.int32)
    return "cubic", "bezier" if bezier else "catmullRom", counts_out, mapped


# ----------------------------------------------------------------------------------------------
# Randomised prims, one per branch.


def _clamped(rng, count, order, repeat=False, scale=1.0, offset=0.0):
    """A clamped knot vector; ``repeat``: an interior knot repeated up to ``order`` times (the
    curve may break there)."""
    interior = np.sort(rng.uniform(0, 1, count - order))
    if repeat and len(interior) >= 2:
        times = min(order, len(interior))
        interior[1 : 1 + times - 1] = interior[0]
    return offset + scale * np.concatenate([np.zeros(order), interior, np.ones(order)])


def _uniform(rng, count, order):
    return rng.uniform(-5, 5) + rng.uniform(0.1, 3) * np.arange(count + order)


def _case(name, rng):
    """(counts, orders, knots, weights or None) of a prim exercising branch ``name``."""
    curves = []  # (count, order, knots, weights)
    if name == "uniform order 4":
        for _ in range(40):
            count = int(rng.integers(4, 9))
            curves.append((count, 4, _uniform(rng, count, 4), None))
    elif name == "order 2":
        for _ in range(40):
            count = int(rng.integers(2, 7))
            curves.append((count, 2, np.sort(rng.uniform(0, 4, count + 2)), None))
    elif name in ("clamped order 3", "clamped order 4"):
        order = int(name[-1])
        groom = _clamped(rng, 6, order)
        for i in range(60):
            count = int(rng.integers(order, order + 5))
            shared = i % 3 == 0 and count == 6
            knots = groom if shared else _clamped(rng, count, order, repeat=i % 5 == 1)
            curves.append((count, order, knots, None))
    elif name == "mixed orders":
        for i in range(60):
            order = int(rng.integers(2, 5))
            count = int(rng.integers(order, order + 4))
            knots = _uniform(rng, count, order) if i % 2 else _clamped(rng, count, order)
            curves.append((count, order, knots, None))
    elif name == "rational":
        shared = _clamped(rng, 5, 3)
        for i in range(50):
            order = int(rng.integers(2, 6))
            count = 5 if i % 4 == 0 else int(rng.integers(order, order + 4))
            knots = shared if (i % 4 == 0 and order == 3) else _clamped(rng, count, order)
            curves.append((count, order, knots, rng.uniform(0.2, 3.0, count)))
    elif name == "weights authored but constant, higher order":
        for _ in range(30):
            order = int(rng.integers(3, 11))
            count = int(rng.integers(order, order + 4))
            curves.append((count, order, _clamped(rng, count, order), np.full(count, 2.5)))
    elif name == "periodic-looking":
        for i in range(40):
            order = 3 + i % 2
            count = int(rng.integers(order + 1, order + 6))
            # Uniform knots over more points than the domain needs, or clamped at one end only.
            knots = np.arange(count + order, dtype=np.float64) * 0.5
            if i % 3 == 0:
                knots[:order] = knots[order - 1]
            curves.append((count, order, knots, None))
        curves.append((4, 4, np.array([0, 0, 0, 0, 1, 1, 1, 1.0]), None))
    elif name in ("ranges", "rational with ranges"):
        # Parts of their domains (whole ones among them), some sharing knots and ranges, some
        # scaled and shifted copies of another, some reaching past the domain (clipped to it).
        shared = _clamped(rng, 6, 4)
        for i in range(60):
            order = int(rng.integers(2, 5))
            count = int(rng.integers(order, order + 4))
            knots = _uniform(rng, count, order) if i % 2 else _clamped(rng, count, order)
            if i % 4 == 0:
                count, order, knots = 6, 4, shared * 2.0 ** (i % 3) + i % 5
            low, high = knots[order - 1], knots[count]
            cuts = np.array([rng.uniform(-0.2, 0.5), rng.uniform(0.55, 1.2)])
            if i % 4 == 0:
                cuts = np.array([0.25, 0.75])
            elif i % 7 == 3:
                cuts = np.array([0.0, 1.0])
            extent = low + (high - low) * cuts
            rational = name.startswith("rational") and i % 9 == 5
            weights = rng.uniform(0.2, 3.0, count) if rational else None
            curves.append((count, order, knots, weights, extent))
    elif name == "shifted and scaled knots":
        # Exactly the same relative to their domains (binary fractions, scales and offsets).
        base = np.concatenate([np.zeros(4), np.sort(rng.integers(1, 64, 3)) / 64, np.ones(4)])
        for _ in range(40):
            scale, offset = 2.0 ** rng.integers(-3, 4), float(rng.integers(-9, 9))
            curves.append((7, 4, offset + scale * base, None))
    else:
        raise ValueError(name)
    curves = [curve if len(curve) == 5 else curve + (None,) for curve in curves]
    counts = np.array([c for c, _, _, _, _ in curves], dtype=np.int32)
    orders = np.array([o for _, o, _, _, _ in curves], dtype=np.int64)
    knots = np.concatenate([k for _, _, k, _, _ in curves]).astype(np.float64)
    weighted = [w for _, _, _, w, _ in curves if w is not None]
    weights = (np.concatenate([w if w is not None else np.ones(c) for c, _, _, w, _ in curves])
               if weighted else None)
    ranged = [e for _, _, _, _, e in curves if e is not None]
    ranges = np.array([e for _, _, _, _, e in curves]) if ranged else None
    return counts, orders, knots, weights, ranges


def _convert(counts, orders, knots, weights, positions, ranges=None):
    stage = Usd.Stage.CreateInMemory()
    curves = UsdGeom.NurbsCurves.Define(stage, PATH)
    curves.CreateCurveVertexCountsAttr(counts.tolist())
    curves.CreateOrderAttr(orders.tolist())
    curves.CreateKnotsAttr(knots.tolist())
    if weights is not None:
        curves.CreatePointWeightsAttr(weights.tolist())
    if ranges is not None:
        curves.CreateRangesAttr([Gf.Vec2d(*extent) for extent in ranges])
    messages = []
    converted = nurbs_to_basis(curves, counts, positions, SampleReader(Usd.TimeCode.Default()),
                               messages.append, PATH)
    assert messages == []
    return converted


CASES = [
    "uniform order 4", "order 2", "clamped order 3", "clamped order 4", "mixed orders",
    "rational", "weights authored but constant, higher order", "periodic-looking",
    "shifted and scaled knots", "ranges", "rational with ranges",
]
EXPECTED_BASES = {
    "uniform order 4": "bspline", "order 2": "bezier", "rational": "catmullRom",
    "weights authored but constant, higher order": "catmullRom",
    "rational with ranges": "catmullRom",
}


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("name", CASES)
def test_grouped_conversion_gives_what_curve_by_curve_conversion_gives(name, seed):
    rng = np.random.default_rng([seed, CASES.index(name)])
    counts, orders, knots, weights, ranges = _case(name, rng)
    points = int(counts.sum())
    positions = rng.normal(size=(MOTION_SAMPLES, points, 3)).astype(np.float32)
    primvar = rng.normal(size=(points, PRIMVAR_WIDTH)).astype(np.float32)

    converted = _convert(counts, orders, knots, weights, positions, ranges)
    exact = np.repeat(_alone_in_their_group(counts, orders, knots, ranges), converted.counts)
    mapped, interpolation = converted.remap(primvar, UsdGeom.Tokens.vertex, "primvars:p",
                                            pytest.fail, PATH)

    curve_type, basis, expected_counts, expected_positions = _reference(
        counts, orders, knots, weights, positions, ranges)
    _, _, _, expected_primvar = _reference(counts, orders, knots, weights, primvar, ranges)
    assert (converted.type, converted.basis) == (curve_type, basis)
    assert basis == EXPECTED_BASES.get(name, "bezier")
    assert interpolation == UsdGeom.Tokens.vertex
    np.testing.assert_array_equal(converted.counts, expected_counts)
    assert converted.positions.dtype == expected_positions.dtype
    if converted.vertex_map is None:  # passed through
        assert converted.positions is positions
    else:
        # Bit for bit where the conversion was computed from the curve's own knots, else (knots
        # that differ by an affine map) up to rounding.
        np.testing.assert_array_equal(converted.positions[:, exact], expected_positions[:, exact])
        np.testing.assert_array_equal(mapped[exact], expected_primvar[exact])
        np.testing.assert_allclose(converted.positions, expected_positions, rtol=0, atol=1e-6)
        np.testing.assert_allclose(mapped, expected_primvar, rtol=0, atol=1e-6)
    if name == "shifted and scaled knots":
        assert converted.vertex_map.kinds == 1


def _alone_in_their_group(counts, orders, knots, ranges=None):
    """Per curve: whether every curve of the same order and vertex count whose knots (and
    range) are the same relative to their domain has the very same knots (and range)."""
    starts = np.concatenate([[0], np.cumsum(counts + orders)[:-1]])
    keys, raw = [], {}
    for curve, (start, count, order) in enumerate(zip(starts, counts, orders)):
        k = knots[start : start + count + order]
        low, high = k[order - 1], k[count]
        if ranges is not None:  # clipped to the domain, as the conversion takes it
            k = np.append(k, np.clip(ranges[curve], low, high))
        key = (int(count), int(order), ((k - low) / (high - low)).tobytes())
        raw.setdefault(key, set()).add(k.tobytes())
        keys.append(key)
    return np.array([len(raw[key]) == 1 for key in keys])


def test_a_groom_of_clamped_cubic_strands_converts_as_one_group_to_its_bezier_curves():
    # A clamped cubic of 4 vertices is one span: the Bézier curve of its vertices.
    strands = 100_000
    rng = np.random.default_rng(7)
    positions = rng.normal(size=(strands * 4, 3)).astype(np.float32)
    counts = np.full(strands, 4, dtype=np.int32)
    orders = np.full(strands, 4, dtype=np.int64)
    knots = np.tile([0.0, 0, 0, 0, 1, 1, 1, 1], strands)
    converted = _convert(counts, orders, knots, None, positions)
    assert (converted.type, converted.basis, converted.wrap) == ("cubic", "bezier", "nonperiodic")
    assert converted.vertex_map.kinds == 1
    np.testing.assert_array_equal(converted.counts, counts)
    np.testing.assert_allclose(converted.positions, positions, rtol=0, atol=1e-5)


@pytest.mark.parametrize(
    "interpolation, values, consequence, message",
    [
        ("vertex", [0.1] * 5, "skipped",
         "primvars:widths (vertex) has 5 values, expected 4 (one per point); skipped"),
        ("varying", [0.1] * 2, "ignored",
         "primvars:widths (varying) has 2 values; NurbsCurves data is read as constant, "
         "uniform or vertex (one value per point) only; ignored"),
    ],
)
def test_vertex_data_that_does_not_fit_is_warned_of_as_authored(
    interpolation, values, consequence, message
):
    counts = np.array([4], dtype=np.int32)
    positions = np.zeros((4, 3), dtype=np.float32)
    converted = _convert(counts, np.array([4]), np.array([0.0, 0, 0, 0, 1, 1, 1, 1]), None,
                         positions)
    messages = []
    mapped, _ = converted.remap(np.array(values, dtype=np.float32), interpolation,
                                "primvars:widths", messages.append, PATH, consequence)
    assert mapped is None
    assert messages == [f"{PATH}: {message}"]


def test_one_value_of_any_interpolation_is_constant():
    # `widths = [w]` without metadata is vertex (the schema's fallback): Storm draws it as the
    # whole prim's width, where it had skipped the prim for not having one per point.
    counts = np.array([4], dtype=np.int32)
    positions = np.zeros((4, 3), dtype=np.float32)
    converted = _convert(counts, np.array([3]), np.array([0.0, 0, 0, 1, 2, 2, 2]), None,
                         positions)
    for interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying, UsdGeom.Tokens.uniform):
        width = np.array([0.1], dtype=np.float32)
        mapped, taken = converted.remap(width, interpolation, "widths", pytest.fail, PATH)
        assert taken == UsdGeom.Tokens.constant and mapped is width


# ----------------------------------------------------------------------------------------------
# ranges, against the curves' own algebra: the Bézier form of a uniform B-spline segment split by
# de Casteljau's algorithm, and a rational curve in Bernstein form.


def _de_casteljau(points, t):
    """The Bézier points of ``points`` (4, 3) before and after ``t``."""
    rows = [np.asarray(points, dtype=np.float64)]
    while len(rows[-1]) > 1:
        rows.append((1 - t) * rows[-1][:-1] + t * rows[-1][1:])
    return np.array([row[0] for row in rows]), np.array([row[-1] for row in reversed(rows)])


def _b_spline_segment_as_bezier(p):
    """The Bézier points of the uniform cubic B-spline segment of ``p`` (4, 3)."""
    return np.array([(p[0] + 4 * p[1] + p[2]) / 6, (2 * p[1] + p[2]) / 3, (p[1] + 2 * p[2]) / 3,
                     (p[1] + 4 * p[2] + p[3]) / 6])


@pytest.mark.parametrize(
    "extent, segments",
    [
        # A whole knot span: the second of the domain's three, from (P1 + 4 P2 + P3) / 6.
        ((4.0, 5.0), lambda q: [q[1]]),
        # Across a knot: the second half of the first span and the first quarter of the second.
        ((3.5, 4.25), lambda q: [_de_casteljau(q[0], 0.5)[1], _de_casteljau(q[1], 0.25)[0]]),
        # Within one span: its middle third.
        ((4 + 1 / 3, 4 + 2 / 3),
         lambda q: [_de_casteljau(_de_casteljau(q[1], 1 / 3)[1], 0.5)[0]]),
    ],
)
def test_ranges_restrict_a_uniform_cubic_to_that_part_of_its_b_spline(extent, segments):
    rng = np.random.default_rng(3)
    points = rng.normal(size=(6, 3)).astype(np.float32)
    converted = _convert(np.array([6], dtype=np.int32), np.array([4]), np.arange(10.0), None,
                         points, ranges=[extent])
    spans = [_b_spline_segment_as_bezier(points[s : s + 4].astype(np.float64)) for s in range(3)]
    pieces = segments(spans)
    expected = np.concatenate([pieces[0]] + [piece[1:] for piece in pieces[1:]])
    assert (converted.type, converted.basis) == ("cubic", "bezier")
    np.testing.assert_array_equal(converted.counts, [len(expected)])
    np.testing.assert_allclose(converted.positions, expected, rtol=0, atol=1e-5)


def test_ranges_restrict_a_rational_curve_to_its_points_there():
    # A rational quadratic quarter circle, from u = 0.25 to 0.75: refined through points of the
    # circle from C(0.25) to C(0.75) (C in Bernstein form).
    points = np.array([(1, 0, 0), (1, 1, 0), (0, 1, 0)], dtype=np.float32)
    weights = np.array([1, np.sqrt(0.5), 1])
    converted = _convert(np.array([3], dtype=np.int32), np.array([3]),
                         np.array([0.0, 0, 0, 1, 1, 1]), weights, points, ranges=[(0.25, 0.75)])

    def circle_at(u):
        bernstein = np.array([(1 - u) ** 2, 2 * u * (1 - u), u * u]) * weights
        return bernstein @ points / bernstein.sum()

    assert converted.basis == "catmullRom"
    np.testing.assert_array_equal(converted.counts, [REFINED_SAMPLES_PER_SPAN + 1])
    np.testing.assert_allclose(converted.positions[[0, -1]], [circle_at(0.25), circle_at(0.75)],
                               rtol=0, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(converted.positions, axis=1), 1, rtol=0, atol=1e-6)
    fractions = np.arange(REFINED_SAMPLES_PER_SPAN + 1) / REFINED_SAMPLES_PER_SPAN
    expected = [circle_at(u) for u in 0.25 + 0.5 * fractions]
    np.testing.assert_allclose(converted.positions, expected, rtol=0, atol=1e-6)


def test_ranges_over_the_whole_domain_or_past_it_change_nothing():
    # Past the domain the curve is not defined: such a range is clipped to the domain.
    points = np.random.default_rng(4).normal(size=(6, 3)).astype(np.float32)
    for extent in ((3.0, 6.0), (-100.0, 100.0)):
        converted = _convert(np.array([6], dtype=np.int32), np.array([4]), np.arange(10.0), None,
                             points, ranges=[extent])
        assert (converted.basis, converted.vertex_map) == ("bspline", None)
        assert converted.positions is points
