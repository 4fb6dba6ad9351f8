"""usdrecord's lighting defaults (issue 11, item 2): hidden dome lights, the camera light of a
stage without lights, ``--enableDomeLightVisibility``, ``--disableCameraLight``, and the same
choices in the Python API. Emissive surfaces light the scene whatever the choice."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import UsdLux

import penumbra
from penumbra import _core
from penumbra.cli import main
from stages import add_camera, add_preview_material, add_quad, bind, new_stage

SIZE = dict(width=16, samples=8)
CLI_SIZE = ["-w", "16", "-spp", "8", "-cam", "/cam"]
ALBEDO = 0.5  # a mesh without material or displayColor: 0.5 grey, diffuse


def quad_stage(path=None, dome: float | None = None):
    """The camera sees a grey quad filling the central half of the image, background around
    it; with ``dome``, a uniform dome of that radiance is the only light."""
    stage = new_stage(path)
    add_camera(stage)
    add_quad(stage, "/World/quad")
    if dome is not None:
        UsdLux.DomeLight.Define(stage, "/World/sky").CreateIntensityAttr(dome)
    return stage


def centre(color: np.ndarray) -> np.ndarray:
    h, w = color.shape[:2]
    return color[h // 2, w // 2]


def centre_mean(color: np.ndarray) -> np.ndarray:
    """The mean of the central 4 × 4 pixels (less noise than one pixel)."""
    h, w = color.shape[:2]
    return color[h // 2 - 2 : h // 2 + 2, w // 2 - 2 : w // 2 + 2].mean(axis=(0, 1))


def corner(color: np.ndarray) -> np.ndarray:
    return color[0, 0]


def test_api_dome_visibility_is_a_render_choice():
    renderer = penumbra.Renderer(quad_stage(dome=1.0))
    seen = renderer.render(**SIZE)["color"]  # the Python API's default: domes are seen
    np.testing.assert_allclose(corner(seen), [1, 1, 1, 1], atol=1e-6)
    hidden = renderer.render(dome_light_visibility=False, **SIZE)["color"]
    np.testing.assert_array_equal(corner(hidden), [0, 0, 0, 0])
    # The hidden dome still lights the quad, exactly as the visible one did.
    np.testing.assert_allclose(centre(hidden), centre(seen), rtol=1e-6)
    assert centre(hidden)[3] == 1.0 and 0.3 < centre(hidden)[0] < 0.7
    again = renderer.render(dome_light_visibility=True, **SIZE)["color"]
    np.testing.assert_array_equal(again, seen)


def test_api_default_lights_of_a_stage_without_lights():
    renderer = penumbra.Renderer(quad_stage())
    dome = renderer.render(**SIZE)["color"]  # the Python API's default: a white dome, seen
    np.testing.assert_allclose(corner(dome), [1, 1, 1, 1], atol=1e-6)
    camera = renderer.render(default_light="camera", **SIZE)["color"]
    # The camera light is never seen; it gives a white Lambertian surface facing the camera
    # radiance 1, so the grey quad shows its albedo.
    np.testing.assert_array_equal(corner(camera), [0, 0, 0, 0])
    np.testing.assert_allclose(centre(camera)[:3], ALBEDO, rtol=0.02)
    dark = renderer.render(default_light="none", **SIZE)["color"]
    np.testing.assert_array_equal(centre(dark), [0, 0, 0, 1])
    with pytest.raises(ValueError, match="default_light must be one of"):
        renderer.render(default_light="sun", **SIZE)


def test_camera_light_follows_the_camera():
    """Seen from 60° off the quad's normal, the camera light's irradiance is cos 60°."""
    stage = quad_stage()
    add_camera(stage, "/side", translate=(0, -5 * np.sin(np.pi / 3), 5 * 0.5), rotate_x=60)
    renderer = penumbra.Renderer(stage)
    image = renderer.render(camera="/side", default_light="camera", **SIZE)["color"]
    np.testing.assert_allclose(centre(image)[:3], ALBEDO * 0.5, rtol=0.03)


def test_a_stage_light_replaces_the_default_light():
    stage = quad_stage()
    renderer = penumbra.Renderer(stage)
    assert centre(renderer.render(default_light="camera", **SIZE)["color"])[0] > 0.4
    sky = UsdLux.DomeLight.Define(stage, "/World/sky")
    sky.CreateIntensityAttr(0.5)
    lit = renderer.render(default_light="camera", width=16, samples=64)["color"]
    np.testing.assert_allclose(centre_mean(lit)[:3], ALBEDO * 0.5, rtol=0.03)  # the dome alone
    stage.RemovePrim("/World/sky")
    np.testing.assert_allclose(
        centre(renderer.render(default_light="camera", **SIZE)["color"])[:3], ALBEDO, rtol=0.02
    )


def emissive_stage(path):
    """A grey quad lit by a small quad 1 unit in front of it emitting radiance 1 towards it
    (black diffuse; its back faces the camera, which therefore does not see it); no lights."""
    stage = quad_stage(path)
    glow = add_preview_material(
        stage, "/Looks/glow", diffuseColor=(0.0, 0.0, 0.0), emissiveColor=(1.0, 1.0, 1.0)
    )
    lamp = add_quad(stage, "/World/lamp", center=(0, 0, 1), half_size=0.25)
    lamp.CreateOrientationAttr("leftHanded")  # faces −Z, towards the grey quad
    bind(lamp, glow)
    return stage


def test_cli_defaults_hide_domes_and_light_unlit_stages_from_the_camera(tmp_path, capsys):
    domed = tmp_path / "dome.usda"
    quad_stage(domed, dome=1.0).Save()
    assert main([str(domed), str(tmp_path / "hidden.exr"), *CLI_SIZE]) == 0
    hidden = _core.read_image(str(tmp_path / "hidden.exr"))[0]
    np.testing.assert_array_equal(corner(hidden), [0, 0, 0, 0])
    assert 0.3 < centre(hidden)[0] < 0.7
    assert main([str(domed), str(tmp_path / "seen.exr"), *CLI_SIZE, "--enableDomeLightVisibility"]) == 0
    seen = _core.read_image(str(tmp_path / "seen.exr"))[0]
    np.testing.assert_allclose(corner(seen), [1, 1, 1, 1], atol=1e-6)

    unlit = tmp_path / "unlit.usda"
    quad_stage(unlit).Save()
    capsys.readouterr()
    assert main([str(unlit), str(tmp_path / "camera.exr"), *CLI_SIZE]) == 0
    assert "the stage has no lights; rendering under a camera light" in capsys.readouterr().err
    camera = _core.read_image(str(tmp_path / "camera.exr"))[0]
    np.testing.assert_array_equal(corner(camera), [0, 0, 0, 0])
    np.testing.assert_allclose(centre(camera)[:3], ALBEDO, rtol=0.02)
    assert main([str(unlit), str(tmp_path / "dark.exr"), *CLI_SIZE, "--disableCameraLight"]) == 0
    dark = _core.read_image(str(tmp_path / "dark.exr"))[0]
    np.testing.assert_array_equal(centre(dark), [0, 0, 0, 1])
    np.testing.assert_array_equal(corner(dark), [0, 0, 0, 0])


@pytest.mark.parametrize("flags", [[], ["--disableCameraLight"]])
def test_emissive_surfaces_light_the_scene_whatever_the_choice(tmp_path, flags):
    path = tmp_path / "emissive.usda"
    emissive_stage(path).Save()
    out = tmp_path / "o.exr"
    assert main([str(path), str(out), "-w", "32", "-spp", "64", "-cam", "/cam", *flags]) == 0
    pixels = _core.read_image(str(out))[0]
    # Under the lamp (which shadows the camera light there), the quad shows the lamp's light:
    # irradiance ≈ 0.23 from a 0.5 × 0.5 square of radiance 1 at distance 1, radiance
    # ≈ 0.5 · 0.23 / π ≈ 0.037.
    under = pixels[15:17, 15:17, :3].mean(axis=(0, 1))
    np.testing.assert_allclose(under, 0.037, rtol=0.3)
    beside = pixels[16, 20, 0]  # 0.56 units off centre, out of the lamp's shadow
    if flags:
        assert beside < 0.05  # the lamp's light alone
    else:
        assert ALBEDO * 0.98 < beside < ALBEDO + 0.05  # the camera light's, and the lamp's
