"""Motion blur in images: small emissive spheres on black seen by a camera at the origin looking
down −Z (f = 0.1, film 0.036 wide, 960 px); a point (x, y, z) projects to column
480 + f·x/(−z) · 960/0.036. Every kind of motion moves the sphere from x = −0.1 to x = +0.1 at
z = −1 over the shutter [0, 1] of frame 1: a streak from column 213.3 to 746.7.
"""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdShade

import penumbra
from measure import centroid, intensity, streak_ends
from penumbra import _core
from penumbra.cli import main
from stages import add_camera, add_emissive_sphere, bind, emitter_stage

WIDTH = 960
FOCAL, FILM = 0.1, 0.036
RADIUS = 0.005  # the sphere: 13.3 px on the film at z = −1
START, END = -0.1, 0.1
DEPTH = -1.0
RENDER = dict(camera="/cam", time=1.0, width=WIDTH, samples=64, max_path_depth=0)


def column(x: float, z: float = DEPTH, width: int = WIDTH) -> float:
    """The image x (px) of a point at x, z (scene units) in an image ``width`` px wide."""
    return width / 2 + FOCAL * x / -z / FILM * width


SHARP = column(RADIUS) - column(0)  # the sphere's image radius, px


def streak_stage(shutter=(0.0, 1.0), film_height: float = 0.0036001, path=None):
    """A camera with the given shutter, a strip of film (96 px high by default: usdrecord's
    int(960 / aspect) of the float apertures 0.36 and 0.036 would be 95), no sphere."""
    stage = emitter_stage(path=path)
    stage.SetEndTimeCode(2)
    camera = add_camera(
        stage, translate=(0, 0, 0), focal_length=10 * FOCAL, aperture=(10 * FILM, 10 * film_height)
    )
    camera.CreateShutterOpenAttr(shutter[0])
    camera.CreateShutterCloseAttr(shutter[1])
    return stage


def translated_stage(**kwargs):
    """The sphere moved by its translate op (keys at frames 1 and 2)."""
    stage = streak_stage(**kwargs)
    ball = add_emissive_sphere(stage, "/ball", (0, 0, DEPTH), RADIUS)
    translate = ball.GetOrderedXformOps()[0].GetAttr()
    translate.Set(Gf.Vec3d(START, 0, DEPTH), 1.0)
    translate.Set(Gf.Vec3d(END, 0, DEPTH), 2.0)
    return stage


def deformed_stage():
    """The same motion as time-sampled points."""
    stage = streak_stage()
    ball = add_emissive_sphere(stage, "/ball", (0, 0, DEPTH), RADIUS)
    rest = np.array(ball.GetPointsAttr().Get())
    for time, x in ((1.0, START), (2.0, END)):
        ball.GetPointsAttr().Set((rest + (x, 0, 0)).tolist(), time)
    return stage


def velocity_stage():
    """The same motion from velocities (units per second) at 48 time codes per second."""
    stage = streak_stage()
    stage.SetTimeCodesPerSecond(48)
    ball = add_emissive_sphere(stage, "/ball", (0, 0, DEPTH), RADIUS)
    rest = np.array(ball.GetPointsAttr().Get())
    ball.GetPointsAttr().Set((rest + (START, 0, 0)).tolist())
    speed = (END - START) * 48  # one time code is 1/48 s
    ball.CreateVelocitiesAttr([Gf.Vec3f(speed, 0, 0)] * len(rest))
    return stage


def assert_streak(image, start: float, end: float, sharp: float = SHARP) -> None:
    """A uniform streak from column ``start`` to ``end`` of a sphere ``sharp`` px in radius."""
    weights = intensity(image)
    first, last = streak_ends(weights, sharp)
    assert first == pytest.approx(start, abs=2) and last == pytest.approx(end, abs=2)
    columns = weights.sum(axis=0)
    inner = columns[round(start + 0.1 * (end - start)) : round(end - 0.1 * (end - start))]
    assert inner.std() / inner.mean() < 0.1  # uniform intensity along the streak


def test_translation_streak_ends_at_projected_positions():
    image = penumbra.Renderer(translated_stage()).render(**RENDER)
    assert_streak(image, column(START), column(END))


def test_shutter_centred_on_frame_equals_shutter_after_frame():
    after = penumbra.Renderer(translated_stage()).render(**RENDER)
    centred = penumbra.Renderer(translated_stage(shutter=(-0.5, 0.5))).render(
        **{**RENDER, "time": 1.5}
    )
    np.testing.assert_array_equal(after["color"], centred["color"])


@pytest.mark.parametrize("make_stage", [deformed_stage, velocity_stage])
def test_point_motion_matches_transform_motion(make_stage):
    reference = intensity(penumbra.Renderer(translated_stage()).render(**RENDER))
    moved = intensity(penumbra.Renderer(make_stage()).render(**RENDER))
    streak = reference[reference > 0].mean()
    assert np.abs(moved - reference).mean() < 0.01 * streak
    assert streak_ends(moved, SHARP) == pytest.approx(streak_ends(reference, SHARP), abs=0.5)


@pytest.mark.parametrize("born", [True, False])
def test_velocities_win_over_interpolating_point_samples(born):
    """UsdGeomPointBased: velocities sampled with the points, not the line between the points'
    samples, move them over the shutter. A particle keyed at frames 1 and 2 whose velocities
    carry it from START to END; ``born``: a second particle appears at frame 2 (above the film),
    so the keys cannot be interpolated; else the frame-2 key is at 0, half way."""
    stage = streak_stage()
    particles = UsdGeom.Points.Define(stage, "/particles")
    bind(particles, UsdShade.Material(stage.GetPrimAtPath("/Looks/glow")))
    particles.CreateWidthsAttr([2 * RADIUS])
    particles.SetWidthsInterpolation(UsdGeom.Tokens.constant)
    speed = Gf.Vec3f((END - START) * stage.GetTimeCodesPerSecond(), 0, 0)
    later = [Gf.Vec3f(END, 0, DEPTH), Gf.Vec3f(0, 1, DEPTH)] if born else [Gf.Vec3f(0, 0, DEPTH)]
    for time, points in ((1.0, [Gf.Vec3f(START, 0, DEPTH)]), (2.0, later)):
        particles.GetPointsAttr().Set(points, time)
        particles.GetVelocitiesAttr().Set([speed] * len(points), time)
    width = WIDTH // 2  # as many samples per column of the streak, a quarter of the rays
    image = penumbra.Renderer(stage).render(**{**RENDER, "width": width})
    assert_streak(image, column(START, width=width), column(END, width=width), SHARP / 2)


def test_camera_motion_blurs_a_static_scene():
    stage = streak_stage()
    add_emissive_sphere(stage, "/ball", (END, 0, DEPTH), RADIUS)
    translate = UsdGeom.Xformable(stage.GetPrimAtPath("/cam")).GetOrderedXformOps()[0].GetAttr()
    translate.Set(Gf.Vec3d(0, 0, 0), 1.0)
    translate.Set(Gf.Vec3d(END - START, 0, 0), 2.0)  # the camera moves right: the image left
    image = penumbra.Renderer(stage).render(**RENDER)
    assert_streak(image, column(START), column(END))


def test_quarter_turn_leaves_an_arc_of_the_arm_length():
    """A sphere at the end of an arm turning 90° about Z within the frame (keys at the frame
    and the next only): the render delegate interpolates translations linearly, so the scene
    delegate must sample the orbit finely for the sphere to stay on its arc."""
    stage = streak_stage(film_height=FILM)
    arm = UsdGeom.Xform.Define(stage, "/arm")
    arm.AddTranslateOp().Set(Gf.Vec3d(0, 0, DEPTH))
    turn = arm.AddRotateZOp().GetAttr()
    turn.Set(0.0, 1.0)
    turn.Set(90.0, 2.0)
    length = 0.06
    add_emissive_sphere(stage, "/arm/ball", (length, 0, 0), 0.003)
    width = 480
    image = intensity(penumbra.Renderer(stage).render(**{**RENDER, "width": width, "samples": 32}))
    y, x = np.indices(image.shape) + 0.5
    dx, dy = x - width / 2, width / 2 - y  # about the pivot's image; image y points down
    radius = (image * np.hypot(dx, dy)).sum() / image.sum()
    assert radius == pytest.approx(column(length, width=width) - width / 2, rel=0.02)
    angles = np.degrees(np.arctan2(dy, dx))[image > 0]
    assert angles.min() > -10 and angles.max() < 100  # a quarter, counter-clockwise from +X
    mean_angle = (image[image > 0] * angles).sum() / image.sum()
    assert mean_angle == pytest.approx(45, abs=2)


def test_disable_motion_blur_gives_a_sharp_dot_at_the_frame(tmp_path):
    translated_stage(path=tmp_path / "moving.usda").Save()
    common = ["-cam", "/cam", "-w", "960", "-spp", "16", "--maxPathDepth", "0", "-f", "1"]
    args = [str(tmp_path / "moving.usda"), str(tmp_path / "sharp.#.exr"), *common]
    assert main([*args, "--disableMotionBlur"]) == 0
    pixels, _, metadata = _core.read_image(str(tmp_path / "sharp.1.exr"))
    weights = intensity(pixels)
    x, _ = centroid(weights)
    assert x == pytest.approx(column(START), abs=0.5)
    lit = np.nonzero(weights.sum(axis=0))[0]
    assert lit[-1] - lit[0] < 2 * SHARP + 6  # the sphere and the filter's reach
    assert float(metadata["penumbra:shutterClose"]) == 0.0


def test_shutter_close_before_open_is_a_scene_error(tmp_path, capsys):
    translated_stage(shutter=(0.5, 0.25), path=tmp_path / "bad.usda").Save()
    assert main([str(tmp_path / "bad.usda"), str(tmp_path / "out.exr"), "-cam", "/cam"]) == 1
    assert "/cam: shutter:close < shutter:open (0.25 < 0.5)" in capsys.readouterr().err
    assert not (tmp_path / "out.exr").exists()


def test_render_settings_disable_motion_blur():
    stage = translated_stage()
    settings = stage.DefinePrim("/Render/Settings", "RenderSettings")
    settings.CreateAttribute("disableMotionBlur", Sdf.ValueTypeNames.Bool).Set(True)
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    image = intensity(penumbra.Renderer(stage).render(**RENDER))
    lit = np.nonzero(image.sum(axis=0))[0]
    assert lit[-1] - lit[0] < 2 * SHARP + 6


def test_depth_of_field_and_motion_blur_are_deterministic_across_threads():
    stage = translated_stage(film_height=0.009)
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/cam"))
    camera.CreateFStopAttr(2.0)
    camera.CreateFocusDistanceAttr(2.0)
    renderer = penumbra.Renderer(stage)
    options = {**RENDER, "width": 240, "samples": 16}
    one = renderer.render(threads=1, **options)
    two = renderer.render(threads=2, **options)
    assert intensity(one).sum() > 0
    np.testing.assert_array_equal(one["color"], two["color"])
