"""UsdGeomPoints from USD to pixels: spheres of their widths (discs facing their normals),
framed by the default camera and lit by the default light, per-point displayColor, uniform data
as one value for the whole prim, bad widths warned of and skipped, and a point's edit rendering
as a fresh render of the edited stage."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom

import penumbra
from penumbra import _core
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
# The default light, a dome, lights the points; hidden from camera rays, it leaves the
# background's alpha 0, so that alpha shows what the points cover.
FAST = dict(camera="/cam", width=WIDTH, samples=8, dome_light_visibility=False)


def points_stage(
    positions, widths=None, normals=None, colors=None, widths_interpolation=None,
    color_interpolation=UsdGeom.Tokens.vertex,
):
    """A camera at z = DISTANCE looking down −Z at points ``/World/dots``; no lights (the
    default light)."""
    stage = new_stage()
    add_camera(
        stage, translate=(0.0, 0.0, DISTANCE), focal_length=FOCAL, aperture=(APERTURE, APERTURE)
    )
    dots = UsdGeom.Points.Define(stage, "/World/dots")
    dots.CreatePointsAttr([Gf.Vec3f(*p) for p in positions])
    if widths is not None:
        dots.CreateWidthsAttr(widths)
        if widths_interpolation:
            dots.SetWidthsInterpolation(widths_interpolation)
    if normals is not None:
        dots.CreateNormalsAttr([Gf.Vec3f(*n) for n in normals])
    if colors is not None:
        color = dots.CreateDisplayColorPrimvar(color_interpolation)
        color.Set([Gf.Vec3f(*c) for c in colors])
    return stage


def coverage(image) -> np.ndarray:
    """Which pixels the geometry covers (alpha above one half)."""
    return image["color"][:, :, 3] > 0.5


def to_pixels(length: float) -> float:
    """A length at DISTANCE, face on, in pixels: width · focal / distance over a pixel's
    share of the aperture."""
    return length * FOCAL / DISTANCE / (APERTURE / WIDTH)


def predicted_diameter(width: float) -> float:
    """The diameter in pixels of a point of diameter ``width`` at DISTANCE."""
    return to_pixels(width)


def test_a_points_only_stage_is_framed_and_lit_by_default():
    stage = points_stage([(0, 0, 0), (2, 1, 0), (-1, -2, 1)], widths=[0.5, 0.5, 0.5])
    stage.RemovePrim("/cam")
    image = penumbra.render(stage, width=32, samples=4, dome_light_visibility=False)
    covered = coverage(image)
    assert covered.any()
    assert image["color"][covered][:, :3].max() > 0.05  # lit
    # Framed: nothing touches the image's border.
    border = np.concatenate([covered[0], covered[-1], covered[:, 0], covered[:, -1]])
    assert not border.any()


def test_a_sphere_point_covers_its_predicted_diameter():
    image = penumbra.render(points_stage([(0, 0, 0)], widths=[1.0]), **FAST)
    covered = coverage(image)
    across = covered.any(axis=0).sum()
    down = covered.any(axis=1).sum()
    expected = predicted_diameter(1.0)  # 16 pixels
    assert abs(across - expected) <= 1 and abs(down - expected) <= 1


def test_unauthored_widths_are_one_unit():
    image = penumbra.render(points_stage([(0, 0, 0)]), **FAST)
    assert abs(coverage(image).any(axis=0).sum() - predicted_diameter(1.0)) <= 1


def test_primvars_widths_set_the_diameters_over_the_widths_attribute():
    # As UsdImaging reads them (exporters write pscale there): they were ignored, and the
    # points drawn one unit wide.
    stage = points_stage([(0, 0, 0)], widths=[2.0])
    UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/World/dots")).CreatePrimvar(
        "widths", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex
    ).Set([0.5])
    image = penumbra.render(stage, **FAST)
    assert abs(coverage(image).any(axis=0).sum() - predicted_diameter(0.5)) <= 1


def test_discs_face_their_normals():
    def covered(normal) -> int:
        stage = points_stage([(0, 0, 0)], widths=[1.0], normals=[normal])
        return int(coverage(penumbra.render(stage, **FAST)).sum())

    face_on = covered((0, 0, 1))
    disc_area = np.pi / 4 * predicted_diameter(1.0) ** 2
    assert abs(face_on - disc_area) < 0.15 * disc_area
    assert covered((1, 0, 0)) <= 0.05 * disc_area  # edge on: nearly invisible
    assert abs(covered((0, 0, -1)) - face_on) <= 0.05 * disc_area  # facing away: the same disc


def test_display_color_per_point_shows():
    stage = points_stage(
        [(-1.5, 0, 0), (1.5, 0, 0)], widths=[1.0, 1.0], colors=[(1, 0, 0), (0, 1, 0)]
    )
    color = penumbra.render(stage, **FAST)["color"]
    middle = WIDTH // 2
    left = color[middle, middle - int(to_pixels(1.5)), :3]
    right = color[middle, middle + int(to_pixels(1.5)), :3]
    assert left[0] > 0.05 and left[0] > 5 * left[1]
    assert right[1] > 0.05 and right[1] > 5 * right[0]


THREE = [(-1.5, 0, 0), (0, 0, 0), (1.5, 0, 0)]


def test_uniform_display_color_and_primvars_are_one_value_for_all_the_points():
    # A Points prim is one element: uniform data has one value for it (hdPrman's count), which
    # had been read as one per point and the prim skipped for lacking the others.
    stage = points_stage(THREE, widths=[1.0], colors=[(1, 0, 0)],
                         color_interpolation=UsdGeom.Tokens.uniform)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        color = penumbra.render(stage, **FAST)["color"]
    for x, _, _ in THREE:
        seen = color[WIDTH // 2, WIDTH // 2 + int(to_pixels(x)), :3]
        assert seen[0] > 0.05 and seen[0] > 5 * seen[1]

    stage = points_stage(THREE, widths=[1.0])
    dots = UsdGeom.Points(stage.GetPrimAtPath("/World/dots"))
    UsdGeom.PrimvarsAPI(dots).CreatePrimvar(
        "tint", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.uniform
    ).Set([Gf.Vec3f(1, 0.5, 0)])
    bind(dots, add_primvar_emission_material(stage, "/World/Looks/tinted", "tint"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        color = penumbra.render(stage, **{**FAST, "samples": 16})["color"]
    for x, _, _ in THREE:
        np.testing.assert_allclose(color[WIDTH // 2, WIDTH // 2 + int(to_pixels(x)), :3],
                                   (1, 0.5, 0), atol=0.01)


def test_per_point_data_authored_uniform_is_read_per_point():
    # Exporters write per-point data as uniform too; one value per point can only mean that.
    stage = points_stage(THREE, widths=[0.5, 1.0, 0.5], widths_interpolation="uniform",
                         colors=[(1, 0, 0)] * 3, color_interpolation=UsdGeom.Tokens.uniform)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        image = penumbra.render(stage, **FAST)
    row = coverage(image)[WIDTH // 2]
    expected = predicted_diameter(0.5) * 2 + predicted_diameter(1.0)
    assert abs(row.sum() - expected) <= 3
    seen = image["color"][WIDTH // 2, WIDTH // 2, :3]
    assert seen[0] > 0.05 and seen[0] > 5 * seen[1]


def test_colours_and_primvars_that_fit_neither_are_dropped_and_the_points_render():
    # As a mesh's: the warning names the authored interpolation (varying had been named vertex),
    # and the points render with the fallbacks (they had been skipped).
    stage = points_stage(THREE, widths=[1.0], colors=[(1, 0, 0)] * 2,
                         color_interpolation=UsdGeom.Tokens.varying)
    dots = UsdGeom.Points(stage.GetPrimAtPath("/World/dots"))
    UsdGeom.PrimvarsAPI(dots).CreatePrimvar(
        "tint", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.vertex
    ).Set([Gf.Vec3f(1, 0.5, 0)] * 2)
    with pytest.warns(penumbra.PenumbraWarning) as record:
        renderer = penumbra.Renderer(stage)
        image = renderer.render(**FAST)
    messages = [str(w.message) for w in record if str(w.message).startswith("/World/dots: ")]
    assert messages == [
        "/World/dots: primvars:displayColor (varying) has 2 values, expected 1 or 3 (one per "
        "point); the fallback colour is used",
        "/World/dots: primvars:tint (vertex) has 2 values, expected 1 or 3 (one per point); "
        "materials reading it use their fallback",
    ]
    assert renderer.delegate.has_prim("/World/dots")
    seen = image["color"][WIDTH // 2, WIDTH // 2, :3]
    assert coverage(image).any() and seen[1] == pytest.approx(seen[0], rel=1e-3)  # grey


@pytest.mark.parametrize(
    "widths, problem",
    [([1.0, 1.0], "widths (vertex) has 2 values, expected 1 or 3 (one per point)"),
     ([1.0, -1.0, 1.0], "widths must be")],
)
def test_bad_widths_warn_naming_the_prim_and_skip_it(widths, problem):
    stage = points_stage([(0, 0, 0), (1, 0, 0), (2, 0, 0)], widths=widths)
    with pytest.warns(penumbra.PenumbraWarning) as record:
        renderer = penumbra.Renderer(stage)
        image = renderer.render(**FAST)
    messages = [str(w.message) for w in record]
    assert any(m.startswith("/World/dots: ") and problem in m for m in messages), messages
    assert not renderer.delegate.has_prim("/World/dots")
    assert not coverage(image).any()


def test_points_of_zero_width_are_invisible_and_the_others_render():
    # It skipped the whole prim.
    stage = points_stage([(-1.5, 0, 0), (0, 0, 0), (1.5, 0, 0)], widths=[1.0, 0.0, 1.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        covered = coverage(penumbra.render(stage, **FAST))
    assert abs(covered[WIDTH // 2].sum() - 2 * predicted_diameter(1.0)) <= 2
    assert not covered[WIDTH // 2, WIDTH // 2]


def test_nan_width_warns_and_skips():
    stage = points_stage([(0, 0, 0)], widths=[float("nan")])
    with pytest.warns(penumbra.PenumbraWarning, match="/World/dots: widths must be"):
        image = penumbra.render(stage, **FAST)
    assert not coverage(image).any()


def _move_one_point(dots: UsdGeom.Points) -> None:
    moved = list(dots.GetPointsAttr().Get())
    moved[1] = Gf.Vec3f(0.5, 1.5, 0.2)
    dots.GetPointsAttr().Set(moved)


def _widen(dots: UsdGeom.Points) -> None:
    dots.GetWidthsAttr().Set([0.6, 1.2, 0.6])


def _recolor(dots: UsdGeom.Points) -> None:
    dots.GetDisplayColorPrimvar().Set([Gf.Vec3f(0.1, 0.2, 0.9)] * 3)


def _translate(dots: UsdGeom.Points) -> None:
    dots.AddTranslateOp().Set(Gf.Vec3d(0.3, -0.2, 0.0))


def _bind(dots: UsdGeom.Points) -> None:
    stage = dots.GetPrim().GetStage()
    bind(dots, add_preview_material(stage, "/World/Looks/red", diffuseColor=(0.8, 0.0, 0.0)))


def _hide(dots: UsdGeom.Points) -> None:
    dots.MakeInvisible()


@pytest.mark.parametrize(
    "edit", [_move_one_point, _widen, _recolor, _translate, _bind, _hide], ids=lambda e: e.__name__
)
def test_an_edit_renders_as_a_fresh_render(edit):
    positions = [(-1.0, 0, 0), (0.0, 1.0, 0), (1.0, -0.5, 0)]
    stage = points_stage(positions, widths=[0.6, 0.6, 0.6], colors=[(1, 0.5, 0.2)] * 3)
    renderer = penumbra.Renderer(stage)
    before = renderer.render(**FAST)
    edit(UsdGeom.Points(stage.GetPrimAtPath("/World/dots")))
    edited = renderer.render(**FAST)
    assert not np.array_equal(edited["color"], before["color"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fresh = penumbra.render(stage, **FAST)
    np.testing.assert_array_equal(edited["color"], fresh["color"])


def test_moving_points_blur_over_the_shutter():
    stage = points_stage([(0, 0, 0)], widths=[1.0])
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/cam"))
    camera.CreateShutterOpenAttr(0.0)
    camera.CreateShutterCloseAttr(1.0)
    dots = UsdGeom.Points(stage.GetPrimAtPath("/World/dots"))
    dots.GetPointsAttr().Set([Gf.Vec3f(-1, 0, 0)], 1.0)
    dots.GetPointsAttr().Set([Gf.Vec3f(1, 0, 0)], 2.0)
    options = {**FAST, "samples": 64}
    still = coverage(penumbra.render(stage, **options, disable_motion_blur=True))
    assert abs(still.any(axis=0).sum() - predicted_diameter(1.0)) <= 1
    alpha = penumbra.render(stage, **options)["color"][WIDTH // 2, :, 3]
    # The point's centre travels 2 units over the shutter: no pixel is covered all the time,
    # and what it touches at all spans the travel plus its diameter.
    travel, diameter = to_pixels(2.0), predicted_diameter(1.0)
    assert alpha.max() < 0.75
    assert abs((alpha > 0).sum() - (travel + diameter)) <= 2


def test_points_take_transform_visibility_and_material():
    stage = points_stage([(0, 0, 0)], widths=[1.0])
    dots = UsdGeom.Points(stage.GetPrimAtPath("/World/dots"))
    dots.AddTranslateOp().Set(Gf.Vec3d(1.0, 0, 0))
    bind(dots, add_preview_material(stage, "/World/Looks/red", diffuseColor=(0.8, 0.0, 0.0)))
    color = penumbra.render(stage, **FAST)["color"]
    shifted = WIDTH // 2 + int(to_pixels(1.0))
    assert color[WIDTH // 2, shifted, 3] > 0.5 and color[WIDTH // 2, WIDTH // 2, 3] < 0.5
    assert color[WIDTH // 2, shifted, 0] > 5 * color[WIDTH // 2, shifted, 1]
    dots.MakeInvisible()
    assert not coverage(penumbra.render(stage, **FAST)).any()


def test_colours_that_fit_neither_are_warned_of_once():
    # Three colours for two points: dropped with one warning, not again at the next render.
    stage = points_stage([(0, 0, 0), (1, 0, 0)], widths=[1.0, 1.0], colors=[(1, 0, 0)] * 3)
    with pytest.warns(penumbra.PenumbraWarning) as record:
        renderer = penumbra.Renderer(stage)
        image = renderer.render(**FAST)
    messages = [str(w.message) for w in record if str(w.message).startswith("/World/dots: ")]
    assert len(messages) == 1 and messages[0].endswith("; the fallback colour is used"), messages
    assert coverage(image).any()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        renderer.render(**FAST)  # nothing changed: no warning again


def test_points_prims_take_the_per_prim_setters():
    delegate = _core.RenderDelegate()
    delegate.insert_rprim("points", "/dots")
    positions = np.zeros((2, 3), np.float32)
    delegate.set_points("/dots", positions, np.ones(2, np.float32))
    moving = np.stack([positions, positions + 1])  # (K, N, 3): two steps over the shutter
    delegate.set_points(
        "/dots",
        moving,
        np.ones(2, np.float32),
        normals=np.tile(np.float32([0, 0, 1]), (2, 1)),
        display_color=np.float32([[1, 0, 0]]),
        display_color_interpolation="constant",
        primvars={"size": (np.float32([1, 2]), "vertex")},
    )
    delegate.set_transform("/dots", np.eye(4))
    delegate.set_visible("/dots", False)
    delegate.set_pass_visibility("/dots", camera_visible=False)
    delegate.set_mesh_material("/dots", "")
    with pytest.raises(ValueError, match="points must have shape"):
        delegate.set_points("/dots", np.zeros((2, 2), np.float32), np.ones(2, np.float32))
    with pytest.raises(KeyError):
        delegate.set_points("/nothing", positions, np.ones(2, np.float32))


def test_per_point_normals_authored_uniform_face_their_discs():
    stage = points_stage(THREE, widths=[1.0], normals=[(1, 0, 0)] * 3)  # discs edge on
    UsdGeom.Points(stage.GetPrimAtPath("/World/dots")).SetNormalsInterpolation("uniform")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        image = penumbra.render(stage, **FAST)
    # Edge on: a sliver each, where spheres would cover their diameter.
    assert coverage(image)[WIDTH // 2].sum() < predicted_diameter(1.0)
