"""UsdGeomBasisCurves (and NurbsCurves and HermiteCurves) from USD to pixels: round tubes as wide
as their widths predict, centre lines where each basis puts them, pinned curves reaching their
end points, ribbons facing their normals, motion blur over the shutter, a white furnace, a
curves-only stage framed by default, per-curve displayColor, a single value of any
interpolation as the whole prim's, NURBS (restricted to their ranges) and Hermite curves where
their curves lie, bad data warned of and skipped, and edits rendering as fresh renders."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade

import penumbra
from penumbra import _core
from penumbra.memory import FILM_BYTES_PER_PIXEL, resident_memory
from stages import (
    add_camera,
    add_preview_material,
    add_primvar_emission_material,
    bind,
    new_stage,
)

WIDTH = 64
FOCAL = 50.0
APERTURE = 20.0
DISTANCE = 10.0
PIXELS_PER_UNIT = FOCAL / DISTANCE / (APERTURE / WIDTH)  # 16 at z = 0
# The default light, a dome, lights the curves; hidden from camera rays, it leaves the
# background's alpha 0, so that alpha shows what the curves cover.
FAST = dict(camera="/cam", width=WIDTH, samples=8, dome_light_visibility=False)
PATH = "/World/hair"
CACHE = 64 * 2**20  # the texture cache the memory budget test leaves room for


def curves_stage(
    positions, counts=None, widths=None, type="linear", basis="bezier", wrap="nonperiodic",
    normals=None, colors=None, color_interpolation=UsdGeom.Tokens.uniform,
):
    """A camera at z = DISTANCE looking down −Z at BasisCurves ``/World/hair``; no lights (the
    default light)."""
    stage = new_stage()
    add_camera(
        stage, translate=(0.0, 0.0, DISTANCE), focal_length=FOCAL, aperture=(APERTURE, APERTURE)
    )
    hair = UsdGeom.BasisCurves.Define(stage, PATH)
    hair.CreatePointsAttr([Gf.Vec3f(*p) for p in positions])
    hair.CreateCurveVertexCountsAttr(counts if counts is not None else [len(positions)])
    hair.CreateTypeAttr(type)
    hair.CreateBasisAttr(basis)
    hair.CreateWrapAttr(wrap)
    if widths is not None:
        hair.CreateWidthsAttr(widths)
        if len(widths) == 1:
            hair.SetWidthsInterpolation(UsdGeom.Tokens.constant)
    if normals is not None:
        hair.CreateNormalsAttr([Gf.Vec3f(*n) for n in normals])
        if len(normals) == 1:
            hair.SetNormalsInterpolation(UsdGeom.Tokens.constant)
    if colors is not None:
        hair.CreateDisplayColorPrimvar(color_interpolation).Set([Gf.Vec3f(*c) for c in colors])
    return stage


def alpha(image) -> np.ndarray:
    return image["color"][:, :, 3]


def coverage(image) -> np.ndarray:
    """Which pixels the geometry covers (alpha above one half)."""
    return alpha(image) > 0.5


def column_x(column: int) -> float:
    """The x (at z = 0) of a pixel column's centre."""
    return (column + 0.5 - WIDTH / 2) / PIXELS_PER_UNIT


def column_x_of(x: float) -> int:
    return int(np.floor(x * PIXELS_PER_UNIT + WIDTH / 2))


def centre_y(image, column: int) -> float:
    """The y (at z = 0) of the centre of what covers ``column`` (its alpha-weighted mean)."""
    weights = alpha(image)[:, column]
    rows = np.arange(WIDTH) + 0.5
    return float((WIDTH / 2 - (weights * rows).sum() / weights.sum()) / PIXELS_PER_UNIT)


# The cubic bases of the UsdGeomBasisCurves schema, as matrices of their segments' polynomials
# (rows: the vertices' weights for 1, t, t², t³).
BASES = {
    "bezier": np.array([[1, 0, 0, 0], [-3, 3, 0, 0], [3, -6, 3, 0], [-1, 3, -3, 1]]),
    "bspline": np.array([[1, 4, 1, 0], [-3, 0, 3, 0], [3, -6, 3, 0], [-1, 3, -3, 1]]) / 6,
    "catmullRom": np.array([[0, 2, 0, 0], [-1, 0, 1, 0], [2, -5, 4, -1], [-1, 3, -3, 1]]) / 2,
}


def cubic_curve(vertices, basis: str, wrap: str = "nonperiodic", steps: int = 400) -> np.ndarray:
    """Points along a cubic curve of ``vertices`` (the schema's segments of ``basis``; pinned
    B-splines and Catmull-Rom curves get the schema's phantom end vertices)."""
    v = np.asarray(vertices, dtype=np.float64)
    if wrap == "pinned":
        v = np.concatenate([[2 * v[0] - v[1]], v, [2 * v[-1] - v[-2]]])
    stride = 3 if basis == "bezier" else 1
    t = np.linspace(0, 1, steps)
    powers = np.stack([np.ones_like(t), t, t * t, t**3], axis=1)
    return np.concatenate(
        [powers @ BASES[basis] @ v[s : s + 4] for s in range(0, len(v) - 3, stride)]
    )


def predicted_y(points: np.ndarray, x: float) -> float:
    order = np.argsort(points[:, 0])
    return float(np.interp(x, points[order, 0], points[order, 1]))


def test_a_round_linear_curve_is_as_wide_as_its_width_predicts():
    stage = curves_stage([(-3, 0, 0), (3, 0, 0)], widths=[0.5])
    covered = coverage(penumbra.render(stage, **FAST))
    expected = 0.5 * PIXELS_PER_UNIT  # width · focal / distance, in pixels: 8
    for column in (8, 32, 56):
        assert abs(covered[:, column].sum() - expected) <= 1


def test_a_strand_tapering_to_a_zero_width_tip_renders():
    # Grooms taper to 0 (it skipped the prim): 8 px wide at x = -1.5, half that at the middle of
    # the tapering half, nothing past the tip.
    stage = curves_stage([(-3, 0, 0), (0, 0, 0), (3, 0, 0)], widths=[0.5, 0.5, 0.0])
    UsdGeom.BasisCurves(stage.GetPrimAtPath(PATH)).SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        covered = coverage(penumbra.render(stage, **FAST))
    assert abs(covered[:, column_x_of(-1.5)].sum() - 0.5 * PIXELS_PER_UNIT) <= 1
    assert abs(covered[:, column_x_of(1.5)].sum() - 0.25 * PIXELS_PER_UNIT) <= 1
    assert not covered[:, column_x_of(3.2):].any()


def test_wrongly_sized_colours_and_primvars_are_dropped_and_the_curves_render():
    # As a mesh's (they had skipped the prim): one warning each, naming what is used instead.
    stage = curves_stage([(-3, 0, 0), (3, 0, 0), (-3, 1, 0), (3, 1, 0)], counts=[2, 2],
                         widths=[0.5], colors=[(1, 0, 0)] * 3)
    hair = UsdGeom.BasisCurves(stage.GetPrimAtPath(PATH))
    UsdGeom.PrimvarsAPI(hair).CreatePrimvar(
        "tint", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex
    ).Set([1.0, 0.5, 0.25])
    with pytest.warns(penumbra.PenumbraWarning) as record:
        renderer = penumbra.Renderer(stage)
        image = renderer.render(**FAST)
    messages = [str(w.message) for w in record if str(w.message).startswith(f"{PATH}: ")]
    assert messages == [
        f"{PATH}: displayColor (uniform) has 3 values, expected 2; the fallback colour is used",
        f"{PATH}: primvar tint of width 1 (vertex) has 3 values, expected 4; materials reading "
        "it use their fallback",
    ]
    assert coverage(image)[:, 32].sum() > 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        renderer.render(**FAST)  # nothing changed: no warning again


def test_unauthored_widths_are_one_unit():
    covered = coverage(penumbra.render(curves_stage([(-3, 0, 0), (3, 0, 0)]), **FAST))
    assert abs(covered[:, 32].sum() - PIXELS_PER_UNIT) <= 1


def _hermite_with_one_width(stage):
    hermite = UsdGeom.HermiteCurves.Define(stage, PATH)
    hermite.CreatePointsAttr([Gf.Vec3f(-3, 0, 0), Gf.Vec3f(0, 0, 0), Gf.Vec3f(3, 0, 0)])
    hermite.CreateTangentsAttr([Gf.Vec3f(3, 0, 0)] * 3)
    hermite.CreateCurveVertexCountsAttr([3])
    return hermite


@pytest.mark.parametrize("hermite", [False, True], ids=["basis", "hermite"])
@pytest.mark.parametrize("interpolation", [None, "vertex", "varying", "uniform"])
def test_a_single_width_of_any_interpolation_is_the_whole_prims(interpolation, hermite):
    # `widths = [0.5]` without metadata is vertex by the schema's fallback; Storm draws it as
    # the width of every curve, where the prim was skipped for not having one per vertex.
    stage = curves_stage([(-3, 0, 0), (0, 0, 0), (3, 0, 0)])
    if hermite:
        stage.RemovePrim(PATH)
        curves = _hermite_with_one_width(stage)
    else:
        curves = UsdGeom.BasisCurves(stage.GetPrimAtPath(PATH))
    curves.CreateWidthsAttr([0.5])
    if interpolation:
        curves.SetWidthsInterpolation(interpolation)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        covered = coverage(penumbra.render(stage, **FAST))
    for column in (8, 32, 56):
        assert abs(covered[:, column].sum() - 0.5 * PIXELS_PER_UNIT) <= 1


def test_a_single_normal_without_metadata_faces_the_whole_ribbon():
    stage = curves_stage([(-3, 0, 0), (0, 0, 0), (3, 0, 0)], widths=[0.5])
    UsdGeom.BasisCurves(stage.GetPrimAtPath(PATH)).CreateNormalsAttr([Gf.Vec3f(0, 0, 1)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        covered = coverage(penumbra.render(stage, **FAST))
    assert abs(covered[:, 16:48].sum(axis=0).mean() - 0.5 * PIXELS_PER_UNIT) <= 1


ZIGZAG = [(-1.8, -0.9, 0), (-1.0, 0.6, 0), (-0.2, -0.5, 0), (0.6, 1.0, 0), (1.4, -0.2, 0),
          (2.2, 0.8, 0), (3.0, 0.0, 0)]


@pytest.mark.parametrize(
    "basis, vertices",
    [("bezier", ZIGZAG), ("bspline", ZIGZAG), ("catmullRom", ZIGZAG)],
)
def test_a_cubic_curve_centre_line_is_where_its_basis_puts_it(basis, vertices):
    stage = curves_stage(vertices, widths=[0.12], type="cubic", basis=basis)
    image = penumbra.render(stage, **{**FAST, "samples": 16})
    curve = cubic_curve(vertices, basis)
    low, high = curve[:, 0].min() + 0.1, curve[:, 0].max() - 0.1
    # Where Bézier segments meet, the centre line has a corner: a column's coverage there is not
    # centred on it.
    corners = [x for x, _, _ in vertices[3:-1:3]] if basis == "bezier" else []
    inside = [
        c for c in range(WIDTH)
        if low < column_x(c) < high and all(abs(column_x(c) - x) > 0.1 for x in corners)
    ]
    errors = [abs(centre_y(image, c) - predicted_y(curve, column_x(c))) for c in inside]
    assert len(inside) > 40 and max(errors) < 0.04, max(errors)  # under 2/3 of a pixel


def test_bezier_ends_and_midpoint_catmull_rom_interpolates_and_b_spline_does_not():
    bezier = [(-1.5, -1, 0), (-0.5, 1.5, 0), (0.5, 1.5, 0), (1.5, -1, 0)]
    fine = {**FAST, "samples": 16}
    image = penumbra.render(curves_stage(bezier, widths=[0.12], type="cubic"), **fine)
    assert abs(centre_y(image, 32) - 7 / 8) < 0.05  # B(½) = (P0 + 3 P1 + 3 P2 + P3) / 8
    covered = alpha(image).sum(axis=0) > 0.5
    first, last = np.flatnonzero(covered)[[0, -1]]  # it ends at P0 and P3
    assert abs(column_x(first) - -1.5) < 0.12 and abs(column_x(last) - 1.5) < 0.12
    for basis, through in (("catmullRom", True), ("bspline", False)):
        stage = curves_stage(ZIGZAG, widths=[0.12], type="cubic", basis=basis)
        image = penumbra.render(stage, **fine)
        for x, y, _ in ZIGZAG[2:5]:  # interior vertices (B-splines pass 0.35 or more from them)
            offset = abs(centre_y(image, column_x_of(x)) - y)
            assert (offset < 0.06) == through, (basis, x, offset)


def test_a_pinned_curve_reaches_its_end_points():
    vertices = [(-1.5, 0, 0), (-0.5, 0.8, 0), (0.5, -0.8, 0), (1.5, 0, 0)]

    def extent(wrap):
        image = penumbra.render(
            curves_stage(vertices, widths=[0.12], type="cubic", basis="bspline", wrap=wrap), **FAST
        )
        covered = np.flatnonzero(alpha(image).sum(axis=0) > 0.5)
        return column_x(covered[0]), column_x(covered[-1])

    left, right = extent("pinned")
    assert abs(left - -1.5) < 0.12 and abs(right - 1.5) < 0.12
    left, right = extent("nonperiodic")  # from (P0 + 4 P1 + P2) / 6 to (P1 + 4 P2 + P3) / 6
    assert abs(left - -0.5) < 0.12 and abs(right - 0.5) < 0.12


def test_a_ribbon_has_its_full_width_face_on_and_nearly_vanishes_edge_on():
    def rows_covered(normal) -> float:
        stage = curves_stage([(-3, 0, 0), (3, 0, 0)], widths=[0.5], normals=[normal])
        return float(coverage(penumbra.render(stage, **FAST))[:, 16:48].sum(axis=0).mean())

    assert abs(rows_covered((0, 0, 1)) - 0.5 * PIXELS_PER_UNIT) <= 1
    assert rows_covered((0, 1, 0)) < 0.5


def test_a_moving_curve_blurs_over_the_shutter():
    stage = curves_stage([(0, -3, 0), (0, 3, 0)], widths=[0.5])
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/cam"))
    camera.CreateShutterOpenAttr(0.0)
    camera.CreateShutterCloseAttr(1.0)
    hair = UsdGeom.BasisCurves(stage.GetPrimAtPath(PATH))
    hair.GetPointsAttr().Set([Gf.Vec3f(-1, -3, 0), Gf.Vec3f(-1, 3, 0)], 1.0)
    hair.GetPointsAttr().Set([Gf.Vec3f(1, -3, 0), Gf.Vec3f(1, 3, 0)], 2.0)
    options = {**FAST, "samples": 64}
    still = coverage(penumbra.render(stage, **options, disable_motion_blur=True))
    assert abs(still[32].sum() - 0.5 * PIXELS_PER_UNIT) <= 1
    row = alpha(penumbra.render(stage, **options))[16:48].mean(axis=0)
    # A band 0.5 wide sweeping 2 units: every pixel of the sweep's middle is covered a quarter
    # of the shutter, and what it touches spans the travel plus its width.
    travel, width = 2.0 * PIXELS_PER_UNIT, 0.5 * PIXELS_PER_UNIT
    assert abs(row[24:40].mean() - 0.25) < 0.04
    assert abs((row > 0.02).sum() - (travel + width)) <= 2


def test_white_diffuse_tubes_under_a_white_dome_stay_white():
    stage = new_stage()
    add_camera(stage, translate=(0, 0, DISTANCE), focal_length=FOCAL, aperture=(APERTURE, APERTURE))
    hair = UsdGeom.BasisCurves.Define(stage, PATH)
    rows = np.linspace(-1.8, 1.8, 7)
    hair.CreatePointsAttr([Gf.Vec3f(x, y, 0) for y in rows for x in (-3.0, 3.0)])
    hair.CreateCurveVertexCountsAttr([2] * len(rows))
    hair.CreateTypeAttr(UsdGeom.Tokens.linear)
    hair.CreateWidthsAttr([0.4])
    hair.SetWidthsInterpolation(UsdGeom.Tokens.constant)
    white = add_preview_material(
        stage, "/World/Looks/white", diffuseColor=(1.0, 1.0, 1.0), useSpecularWorkflow=1,
        specularColor=(0.0, 0.0, 0.0),
    )
    bind(hair, white)
    UsdLux.DomeLight.Define(stage, "/Dome").CreateIntensityAttr(1.0)
    image = penumbra.render(stage, camera="/cam", width=WIDTH, samples=64, seed=5,
                            max_path_depth=64, max_diffuse_depth=64,
                            dome_light_visibility=False)["color"]
    covered = image[..., 3] > 0.99  # the tubes, not the hidden dome
    assert covered.sum() > 300
    np.testing.assert_allclose(image[covered][:, :3].mean(axis=0), 1.0, rtol=0.03)


def test_a_curves_only_stage_is_framed_and_lit_by_default():
    stage = curves_stage([(-2, -1, 0), (0, 3, 1), (3, 0, -1)], widths=[0.3], type="linear")
    stage.RemovePrim("/cam")
    image = penumbra.render(stage, width=32, samples=4, dome_light_visibility=False)
    covered = coverage(image)
    assert covered.any()
    assert image["color"][covered][:, :3].max() > 0.05  # lit
    border = np.concatenate([covered[0], covered[-1], covered[:, 0], covered[:, -1]])
    assert not border.any()


def test_display_color_per_curve_shows():
    stage = curves_stage(
        [(-3, -1, 0), (3, -1, 0), (-3, 1, 0), (3, 1, 0)], counts=[2, 2], widths=[0.5],
        colors=[(1, 0, 0), (0, 1, 0)],
    )
    color = penumbra.render(stage, **FAST)["color"]
    below, above = color[32 + 16, 32, :3], color[32 - 16, 32, :3]
    assert below[0] > 0.05 and below[0] > 5 * below[1]
    assert above[1] > 0.05 and above[1] > 5 * above[0]


@pytest.mark.parametrize("interpolation", ["uniform", "vertex", "varying"])
def test_one_display_color_or_primvar_value_of_any_interpolation_colours_every_curve(
    interpolation,
):
    def two_curves():
        stage = curves_stage([(-3, -1, 0), (3, -1, 0), (-3, 1, 0), (3, 1, 0)], counts=[2, 2],
                             widths=[0.5], colors=[(1, 0, 0)], color_interpolation=interpolation)
        return stage, UsdGeom.BasisCurves(stage.GetPrimAtPath(PATH))

    stage, _ = two_curves()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        color = penumbra.render(stage, **FAST)["color"]
    for row in (32 + 16, 32 - 16):
        assert color[row, 32, 0] > 0.05 and color[row, 32, 0] > 5 * color[row, 32, 1]

    stage, hair = two_curves()
    UsdGeom.PrimvarsAPI(hair).CreatePrimvar(
        "tint", Sdf.ValueTypeNames.Color3fArray, interpolation
    ).Set([Gf.Vec3f(1, 0.5, 0)])
    bind(hair, add_primvar_emission_material(stage, "/World/Looks/tinted", "tint"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        color = penumbra.render(stage, **{**FAST, "samples": 16})["color"]
    for row in (32 + 16, 32 - 16):
        np.testing.assert_allclose(color[row, 32, :3], (1, 0.5, 0), atol=0.01)


def _nurbs(stage, points, order, knots, weights=None, widths=(0.12,)):
    nurbs = UsdGeom.NurbsCurves.Define(stage, "/World/nurbs")
    nurbs.CreatePointsAttr([Gf.Vec3f(*p) for p in points])
    nurbs.CreateCurveVertexCountsAttr([len(points)])
    nurbs.CreateOrderAttr([order])
    nurbs.CreateKnotsAttr(knots)
    if weights is not None:
        nurbs.CreatePointWeightsAttr(weights)
    nurbs.CreateWidthsAttr(list(widths))
    nurbs.SetWidthsInterpolation(UsdGeom.Tokens.constant)
    return nurbs


def _camera_only_stage():
    stage = new_stage()
    add_camera(stage, translate=(0, 0, DISTANCE), focal_length=FOCAL, aperture=(APERTURE, APERTURE))
    return stage


def test_uniform_cubic_nurbs_render_as_the_b_spline_of_their_points():
    stage = _camera_only_stage()
    _nurbs(stage, ZIGZAG, 4, list(range(len(ZIGZAG) + 4)))
    image = penumbra.render(stage, **FAST)
    b_spline = curves_stage(ZIGZAG, widths=[0.12], type="cubic", basis="bspline")
    reference = penumbra.render(b_spline, **FAST)
    assert coverage(reference).sum() > 50
    np.testing.assert_array_equal(alpha(image), alpha(reference))


def test_nurbs_ranges_restrict_them_to_that_part_of_their_curve():
    points = [(-1.8 + 0.72 * i, 0.6 * (-1) ** i, 0) for i in range(6)]
    stage = _camera_only_stage()
    _nurbs(stage, points, 4, list(range(10))).CreateRangesAttr([Gf.Vec2d(4, 5)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        image = penumbra.render(stage, **{**FAST, "samples": 16})
    # Knots 4 to 5 are the uniform B-spline's middle segment, from (P1 + 4 P2 + P3) / 6 to
    # (P2 + 4 P3 + P4) / 6: x from −0.36 to 0.36 (the whole curve reaches ±1.08).
    x = np.array(points)[:, 0]
    start, end = (x[1] + 4 * x[2] + x[3]) / 6, (x[2] + 4 * x[3] + x[4]) / 6
    covered = np.flatnonzero(alpha(image).sum(axis=0) > 0.3)
    assert abs(column_x(covered[0]) - start) < 0.1 and abs(column_x(covered[-1]) - end) < 0.1


def test_clamped_nurbs_reach_their_end_points_on_their_curve():
    vertices = [(-1.5, -1, 0), (-0.5, 1.5, 0), (0.5, 1.5, 0), (1.5, -1, 0)]
    stage = _camera_only_stage()
    _nurbs(stage, vertices, 4, [0, 0, 0, 0, 1, 1, 1, 1])  # one span: the Bézier curve
    image = penumbra.render(stage, **{**FAST, "samples": 16})
    curve = cubic_curve(vertices, "bezier")
    for column in range(column_x_of(-1.3), column_x_of(1.3)):
        assert abs(centre_y(image, column) - predicted_y(curve, column_x(column))) < 0.05


def test_a_rational_nurbs_quarter_circle_lies_on_its_circle():
    radius = 1.8
    stage = _camera_only_stage()
    points = [(radius, 0, 0), (radius, radius, 0), (0, radius, 0)]
    _nurbs(stage, [(x - 0.9, y - 0.9, z) for x, y, z in points], 3, [0, 0, 0, 1, 1, 1],
           weights=[1, np.sqrt(0.5), 1], widths=(0.08,))
    weights = alpha(penumbra.render(stage, **{**FAST, "samples": 16}))
    rows, columns = np.nonzero(weights > 0.3)
    x = column_x(columns) + 0.9
    y = (WIDTH / 2 - (rows + 0.5)) / PIXELS_PER_UNIT + 0.9
    distance = np.hypot(x, y)
    assert len(rows) > 30
    assert np.abs(distance - radius).max() < 0.04 + 0.75 / PIXELS_PER_UNIT  # band + a pixel


def test_hermite_curves_render_as_their_bezier_curves():
    points, tangents = [(-1.5, -1, 0), (1.5, -1, 0)], [(3, 7.5, 0), (3, -7.5, 0)]
    stage = _camera_only_stage()
    hermite = UsdGeom.HermiteCurves.Define(stage, "/World/hermite")
    hermite.CreatePointsAttr([Gf.Vec3f(*p) for p in points])
    hermite.CreateTangentsAttr([Gf.Vec3f(*t) for t in tangents])
    hermite.CreateCurveVertexCountsAttr([2])
    hermite.CreateWidthsAttr([0.12])
    hermite.SetWidthsInterpolation(UsdGeom.Tokens.constant)
    image = penumbra.render(stage, **{**FAST, "samples": 16})
    # P0, P0 + T0/3, P1 − T1/3, P1: the Bézier curve of the earlier test.
    curve = cubic_curve([(-1.5, -1, 0), (-0.5, 1.5, 0), (0.5, 1.5, 0), (1.5, -1, 0)], "bezier")
    for column in range(column_x_of(-1.3), column_x_of(1.3)):
        assert abs(centre_y(image, column) - predicted_y(curve, column_x(column))) < 0.05


def _bad_count(hair):
    hair.GetCurveVertexCountsAttr().Set([3])


def _negative_width(hair):
    hair.GetWidthsAttr().Set([0.5, -0.5, 0.5, 0.5])


def _nan_width(hair):
    hair.GetWidthsAttr().Set([0.5, float("nan"), 0.5, 0.5])


def _too_few_for_cubic(hair):
    hair.GetTypeAttr().Set(UsdGeom.Tokens.cubic)
    hair.GetBasisAttr().Set(UsdGeom.Tokens.bspline)
    hair.GetPointsAttr().Set([Gf.Vec3f(-1, 0, 0), Gf.Vec3f(0, 1, 0), Gf.Vec3f(1, 0, 0)])
    hair.GetCurveVertexCountsAttr().Set([3])
    hair.GetWidthsAttr().Set([0.5] * 3)


def _short_normals(hair):
    hair.CreateNormalsAttr([Gf.Vec3f(0, 0, 1)] * 3)


def _normals_along_the_curve(hair):
    """Ribbons facing along their own curve (the points run along x): no width direction."""
    hair.CreateNormalsAttr([Gf.Vec3f(1, 0, 0)])
    hair.SetNormalsInterpolation(UsdGeom.Tokens.constant)


def _unknown_basis(hair):
    hair.GetTypeAttr().Set(UsdGeom.Tokens.cubic)  # linear curves have no basis
    hair.GetBasisAttr().Set("hermite")


@pytest.mark.parametrize(
    "spoil, attribute",
    [
        (_bad_count, "curveVertexCounts"),
        (_negative_width, "widths"),
        (_nan_width, "widths"),
        (_too_few_for_cubic, "vert"),
        (_short_normals, "normals"),
        (_normals_along_the_curve, "normals"),
        (_unknown_basis, "basis"),
    ],
    ids=lambda v: getattr(v, "__name__", v),
)
def test_bad_data_is_warned_of_once_naming_prim_and_attribute_and_skipped(spoil, attribute):
    stage = curves_stage([(-1.5, 0, 0), (-0.5, 0, 0), (0.5, 0, 0), (1.5, 0, 0)], widths=[0.5] * 4)
    spoil(UsdGeom.BasisCurves(stage.GetPrimAtPath(PATH)))
    with pytest.warns(penumbra.PenumbraWarning) as record:
        renderer = penumbra.Renderer(stage)
        image = renderer.render(**FAST)
    messages = [str(w.message) for w in record if str(w.message).startswith(f"{PATH}: ")]
    assert len(messages) == 1 and attribute in messages[0], messages
    assert messages[0].endswith("skipped")
    assert not coverage(image).any()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        renderer.render(**FAST)  # nothing changed: no warning again


def _move_a_curve(hair):
    moved = list(hair.GetPointsAttr().Get())
    moved[1] = Gf.Vec3f(2.5, 0.6, 0)
    hair.GetPointsAttr().Set(moved)


def _widen(hair):
    hair.GetWidthsAttr().Set([0.3, 0.6, 0.3, 0.6])


def _recolor(hair):
    hair.GetDisplayColorPrimvar().Set([Gf.Vec3f(0.1, 0.2, 0.9)] * 2)


def _translate(hair):
    hair.AddTranslateOp().Set(Gf.Vec3d(0.3, -0.2, 0.0))


def _bind(hair):
    stage = hair.GetPrim().GetStage()
    bind(hair, add_preview_material(stage, "/World/Looks/red", diffuseColor=(0.8, 0.0, 0.0)))


def _hide(hair):
    hair.MakeInvisible()


@pytest.mark.parametrize(
    "edit", [_move_a_curve, _widen, _recolor, _translate, _bind, _hide], ids=lambda e: e.__name__
)
def test_an_edit_renders_as_a_fresh_render(edit):
    stage = curves_stage(
        [(-2, -1, 0), (2, -1, 0), (-2, 1, 0), (2, 1, 0)], counts=[2, 2], widths=[0.4] * 4,
        colors=[(1, 0.5, 0.2)] * 2,
    )
    renderer = penumbra.Renderer(stage)
    before = renderer.render(**FAST)
    edit(UsdGeom.BasisCurves(stage.GetPrimAtPath(PATH)))
    edited = renderer.render(**FAST)
    assert not np.array_equal(edited["color"], before["color"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fresh = penumbra.render(stage, **FAST)
    np.testing.assert_array_equal(edited["color"], fresh["color"])


def test_curves_prims_take_set_curves_and_the_per_prim_setters():
    delegate = _core.RenderDelegate()
    delegate.insert_rprim("basisCurves", "/hair")
    positions = np.zeros((4, 3), np.float32)
    delegate.set_curves(
        "/hair", "cubic", "bspline", "pinned", np.int32([4]), np.stack([positions, positions + 1]),
        np.float32([0.1]), "constant", normals=np.float32([[0, 0, 1]]),
        normals_interpolation="constant", display_color=np.float32([[1, 0, 0]]),
        display_color_interpolation="uniform",
        primvars={"size": (np.float32([1, 2, 3, 4]), "vertex")},
    )
    delegate.set_transform("/hair", np.eye(4))
    delegate.set_visible("/hair", False)
    delegate.set_pass_visibility("/hair", camera_visible=False)
    delegate.set_mesh_material("/hair", "")
    assert delegate.prim_ids() == ["/hair"]
    for token in ("type", "basis", "wrap"):
        tokens = {"type": "cubic", "basis": "bezier", "wrap": "nonperiodic", token: "spiral"}
        with pytest.raises(ValueError, match=f"unknown curve {token} 'spiral'"):
            delegate.set_curves("/hair", **tokens, curve_vertex_counts=np.int32([4]),
                                positions=positions, widths=np.float32([1]))
    with pytest.raises(ValueError, match="points must have shape"):
        delegate.set_curves("/hair", "linear", "bezier", "nonperiodic", np.int32([4]),
                            np.zeros((4, 2), np.float32), np.float32([1]))
    with pytest.raises(KeyError):
        delegate.set_curves("/nothing", "linear", "bezier", "nonperiodic", np.int32([4]),
                            positions, np.float32([1]))


def test_curves_count_in_the_memory_estimate():
    def estimate(strands: int) -> int:
        delegate = _core.RenderDelegate()
        delegate.insert_rprim("basisCurves", "/hair")
        delegate.set_curves(
            "/hair", "cubic", "bspline", "nonperiodic", np.full(strands, 4, np.int32),
            np.zeros((4 * strands, 3), np.float32), np.float32([0.1]), "constant",
        )
        return delegate.estimated_sync_bytes()

    # Each strand's 4 vertices and its one segment cost about 350 bytes to build.
    assert 200 * 1000 < estimate(1000) < 600 * 1000
    assert estimate(2000) == 2 * estimate(1000)


def test_a_groom_is_checked_against_the_memory_budget_before_it_is_built():
    strands = 20_000
    roots = np.stack([np.linspace(-1.5, 1.5, strands), np.zeros(strands), np.zeros(strands)], 1)
    offsets = np.array([(0, 0, 0), (0, 0.3, 0), (0.05, 0.6, 0), (0.1, 0.9, 0)])
    stage = curves_stage((roots[:, None] + offsets).reshape(-1, 3), counts=[4] * strands,
                         widths=[0.01], type="cubic", basis="bspline")
    renderer = penumbra.Renderer(stage)
    estimate = renderer.delegate.estimated_sync_bytes()
    assert estimate > 300 * strands
    budget = resident_memory() + CACHE + 16 * 16 * FILM_BYTES_PER_PIXEL + estimate // 2
    with pytest.raises(penumbra.SceneError, match="acceleration structures"):
        renderer.render("/cam", width=16, samples=1, max_memory=budget, texture_cache=CACHE)
    assert renderer.delegate.estimated_sync_bytes() == estimate  # nothing was built


@pytest.mark.parametrize(
    "attribute, value, problem",
    [
        ("order", [5], "order must give"),
        ("knots", [0, 1, 2, 3, 4, 5, 6], "knots has 7 values"),
        ("knots", [0, 1, 2, 3, 2, 5, 6, 7], "knots must not decrease"),
        ("knots", [0, 1, 2, 3, 4, 5, 6, float("nan")], "knots must be finite"),
        ("pointWeights", [1.0, 0.0, 1.0, 1.0], "pointWeights must be positive"),
        ("ranges", [Gf.Vec2d(3.6, 3.4)], "ranges must give"),
        ("ranges", [Gf.Vec2d(4.5, 5.0)], "ranges must give"),  # past the domain [3, 4]
        ("ranges", [Gf.Vec2d(3.0, 4.0)] * 2, "ranges must give"),
    ],
)
def test_bad_nurbs_are_warned_of_naming_the_attribute_and_skipped(attribute, value, problem):
    stage = _camera_only_stage()
    nurbs = _nurbs(stage, [(-1.5, 0, 0), (-0.5, 1, 0), (0.5, 1, 0), (1.5, 0, 0)], 4,
                   list(range(8)), widths=(0.5,))
    nurbs.GetPrim().GetAttribute(attribute).Set(value)
    with pytest.warns(penumbra.PenumbraWarning) as record:
        renderer = penumbra.Renderer(stage)
    messages = [str(w.message) for w in record if str(w.message).startswith("/World/nurbs: ")]
    assert len(messages) == 1 and problem in messages[0] and messages[0].endswith("skipped")
    assert not renderer.delegate.has_prim("/World/nurbs")


def test_hermite_curves_without_a_tangent_per_point_are_skipped():
    stage = _camera_only_stage()
    hermite = UsdGeom.HermiteCurves.Define(stage, "/World/hermite")
    hermite.CreatePointsAttr([Gf.Vec3f(-1, 0, 0), Gf.Vec3f(1, 0, 0)])
    hermite.CreateTangentsAttr([Gf.Vec3f(1, 0, 0)])
    hermite.CreateCurveVertexCountsAttr([2])
    with pytest.warns(penumbra.PenumbraWarning, match="/World/hermite: tangents has 1 values"):
        renderer = penumbra.Renderer(stage)
    assert not renderer.delegate.has_prim("/World/hermite")


@pytest.mark.parametrize("counts", [[0, 0, 0, 0, 0, 2], [2, 0], [1, 1]])
def test_hermite_curves_with_a_curve_of_fewer_than_two_points_are_skipped(counts):
    stage = _camera_only_stage()
    hermite = UsdGeom.HermiteCurves.Define(stage, "/World/hermite")
    hermite.CreatePointsAttr([Gf.Vec3f(-1, 0, 0), Gf.Vec3f(1, 0, 0)])
    hermite.CreateTangentsAttr([Gf.Vec3f(1, 0, 0), Gf.Vec3f(1, 0, 0)])
    hermite.CreateCurveVertexCountsAttr(counts)
    first = next(i for i, count in enumerate(counts) if count < 2)
    with pytest.warns(penumbra.PenumbraWarning) as record:
        renderer = penumbra.Renderer(stage)
    messages = [str(w.message) for w in record if str(w.message).startswith("/World/hermite: ")]
    assert messages == [f"/World/hermite: curveVertexCounts[{first}] = {counts[first]}; a Hermite "
                        "curve needs at least 2 points; skipped"]
    assert not renderer.delegate.has_prim("/World/hermite")


def test_widths_primvar_whose_indices_do_not_fit_is_warned_of_and_skipped():
    stage = curves_stage([(-1, 0, 0), (1, 0, 0)])
    widths = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(PATH)).CreatePrimvar(
        "widths", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex
    )
    widths.Set([0.1, 0.1])
    widths.SetIndices([0, 5])  # index 5 names no value
    with pytest.warns(penumbra.PenumbraWarning) as record:
        renderer = penumbra.Renderer(stage)
    messages = [str(w.message) for w in record if str(w.message).startswith(f"{PATH}: ")]
    assert messages == [f"{PATH}: primvars:widths is authored but has no usable values; skipped"]
    assert not renderer.delegate.has_prim(PATH)


def _moving_stage():
    stage = curves_stage([(-1, -3, 0), (-1, 3, 0)], widths=[0.5])
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/cam"))
    camera.CreateShutterOpenAttr(0.0)
    camera.CreateShutterCloseAttr(1.0)
    return stage, UsdGeom.BasisCurves(stage.GetPrimAtPath(PATH))


def test_velocities_blur_curves_as_the_same_motion_time_sampled_does():
    stage, hair = _moving_stage()
    hair.GetPointsAttr().Set([Gf.Vec3f(-1, -3, 0), Gf.Vec3f(-1, 3, 0)], 1.0)
    hair.GetPointsAttr().Set([Gf.Vec3f(1, -3, 0), Gf.Vec3f(1, 3, 0)], 2.0)
    options = {**FAST, "samples": 32}
    sampled = penumbra.render(stage, **options)
    stage, hair = _moving_stage()
    per_second = 2.0 * stage.GetTimeCodesPerSecond()  # 2 units a frame
    hair.CreateVelocitiesAttr([Gf.Vec3f(per_second, 0, 0)] * 2)
    by_velocity = penumbra.render(stage, **options)
    assert alpha(sampled)[32].max() < 0.75  # blurred
    np.testing.assert_allclose(alpha(by_velocity), alpha(sampled), atol=1e-6)


def test_a_material_reads_per_curve_primvars():
    stage = curves_stage(
        [(-3, -1, 0), (3, -1, 0), (-3, 1, 0), (3, 1, 0)], counts=[2, 2], widths=[0.5]
    )
    hair = UsdGeom.BasisCurves(stage.GetPrimAtPath(PATH))
    tint = UsdGeom.PrimvarsAPI(hair).CreatePrimvar(
        "tint", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.uniform
    )
    tint.Set([Gf.Vec3f(1, 0.5, 0), Gf.Vec3f(0, 0.5, 1)])
    material = add_primvar_emission_material(stage, "/World/Looks/tinted", "tint")
    bind(hair, material)
    color = penumbra.render(stage, **{**FAST, "samples": 16})["color"]
    # Emission alone: each tube shows its curve's tint where it covers a pixel whole.
    np.testing.assert_allclose(color[32 + 16, 32, :3], (1, 0.5, 0), atol=0.01)
    np.testing.assert_allclose(color[32 - 16, 32, :3], (0, 0.5, 1), atol=0.01)
