"""UsdGeomCamera's exposure: the image's radiance times the camera's linear exposure scale
(``ComputeLinearExposureScale``: 2^exposure · exposure:time · exposure:iso / 100 ·
exposure:responsivity / exposure:fStop²), alpha and the other AOVs as they were. The camera's
exposure inputs were not read: a lighter's +1 stop on the camera changed nothing."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Usd, UsdGeom

import penumbra
from stages import add_camera, add_distant_light, add_quad, assert_live_edit_renders_as_fresh, new_stage

RENDER = dict(camera="/cam", width=32, samples=4, seed=1)


def lit_stage() -> tuple[Usd.Stage, UsdGeom.Camera]:
    stage = new_stage()
    add_quad(stage, "/quad", half_size=1.0, color=(0.5, 0.4, 0.3))
    add_distant_light(stage)
    return stage, add_camera(stage)


def image(stage: Usd.Stage, **aovs) -> dict[str, np.ndarray]:
    return penumbra.Renderer(stage).render(**RENDER, **aovs)


def test_one_stop_doubles_the_colour_and_leaves_alpha_and_aovs():
    stage, camera = lit_stage()
    aovs = dict(aovs=["color", "normal", "variance", "depth"])
    before = image(stage, **aovs)
    camera.CreateExposureAttr(1.0)
    after = image(stage, **aovs)
    assert before["color"][..., :3].max() > 0.05
    np.testing.assert_array_equal(after["color"][..., :3], 2 * before["color"][..., :3])
    np.testing.assert_array_equal(after["color"][..., 3], before["color"][..., 3])
    np.testing.assert_array_equal(after["variance"], 4 * before["variance"])
    for name in ("normal", "depth"):
        np.testing.assert_array_equal(after[name], before[name])


def test_the_scale_is_usd_own_linear_exposure_scale():
    stage, camera = lit_stage()
    before = image(stage)["color"][..., :3]
    camera.CreateExposureAttr(-1.5)
    camera.CreateExposureTimeAttr(0.5)
    camera.CreateExposureIsoAttr(400.0)
    camera.CreateExposureResponsivityAttr(1.5)
    camera.CreateExposureFStopAttr(2.8)
    expected = camera.ComputeLinearExposureScale(Usd.TimeCode(1))
    assert expected == pytest.approx(2**-1.5 * 0.5 * 4 * 1.5 / 2.8**2)
    after = image(stage)["color"][..., :3]
    lit = before > 0.01
    np.testing.assert_allclose(after[lit] / before[lit], expected, rtol=1e-6)


def test_a_live_exposure_edit_renders_as_a_fresh_renderer():
    stage, camera = lit_stage()
    assert_live_edit_renders_as_fresh(stage, lambda: camera.CreateExposureAttr(2.0), **RENDER)


def test_an_animated_exposure_follows_the_frame():
    stage, camera = lit_stage()
    stage.SetEndTimeCode(2)
    attr = camera.CreateExposureAttr()
    attr.Set(0.0, 1)
    attr.Set(1.0, 2)
    renderer = penumbra.Renderer(stage)
    first = renderer.render(time=1, **RENDER)["color"][..., :3]
    second = renderer.render(time=2, **RENDER)["color"][..., :3]
    np.testing.assert_array_equal(second, 2 * first)
