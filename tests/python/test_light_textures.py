"""Light textures (`texture:file` of DomeLight and RectLight) decode as UsdUVTexture's
`sourceColorSpace = auto` does: an 8-bit PNG without colour metadata holds sRGB-encoded values
(as Storm reads it), an OpenEXR linear ones."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux

import penumbra
from stages import new_stage
from test_textures import write_texture

ENCODED = 128 / 255


def srgb_decoded(encoded: float) -> float:
    return encoded / 12.92 if encoded <= 0.04045 else ((encoded + 0.055) / 1.055) ** 2.4


def narrow_camera(stage, eye_z: float) -> None:
    """A camera at (0, 0, eye_z) looking at the origin (down -Z at eye_z = 0)."""
    camera = UsdGeom.Camera.Define(stage, "/cam")
    camera.CreateFocalLengthAttr(50.0)
    camera.CreateHorizontalApertureAttr(1.0)
    camera.CreateVerticalApertureAttr(1.0)
    placed = UsdGeom.Xformable(camera)
    placed.AddTranslateOp().Set(Gf.Vec3d(0, 0, eye_z))
    if eye_z < 0:
        placed.AddRotateYOp().Set(180.0)


def seen(stage) -> float:
    """The mean of the central pixels, seen straight on."""
    image = penumbra.Renderer(stage).render(camera="/cam", width=8, samples=4)["color"]
    return float(np.asarray(image)[3:5, 3:5, :3].mean())


@pytest.mark.parametrize("extension", ["png", "exr"])
@pytest.mark.parametrize("kind", ["dome", "rect"])
def test_light_textures_decode_as_auto_does(tmp_path, extension, kind):
    file = write_texture(tmp_path / f"grey.{extension}", np.full((4, 8, 3), ENCODED, np.float32))
    stage = new_stage()
    if kind == "dome":
        light = UsdLux.DomeLight.Define(stage, "/light")
        narrow_camera(stage, 0.0)
    else:  # emitting towards -Z: seen from z = -5, filling the view
        light = UsdLux.RectLight.Define(stage, "/light")
        light.CreateWidthAttr(100.0)
        light.CreateHeightAttr(100.0)
        narrow_camera(stage, -5.0)
    light.CreateTextureFileAttr(Sdf.AssetPath(str(file)))
    expected = srgb_decoded(ENCODED) if extension == "png" else ENCODED
    assert seen(stage) == pytest.approx(expected, rel=1e-3)


@pytest.mark.parametrize("first", ["other", "broken", "missing"])
def test_a_sky_repainted_between_renders_is_read_again(tmp_path, first):
    # A DomeLight kept the image it had loaded first, whatever happened to its file since.
    sky = tmp_path / "sky.exr"
    if first != "missing":
        write_texture(sky, np.full((4, 8, 3), 0.25, np.float32))
    if first == "broken":
        sky.write_bytes(sky.read_bytes()[:100])
    stage = new_stage()
    UsdLux.DomeLight.Define(stage, "/light").CreateTextureFileAttr(Sdf.AssetPath(str(sky)))
    narrow_camera(stage, 0.0)
    renderer = penumbra.Renderer(stage)
    render = dict(camera="/cam", width=8, samples=4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", penumbra.PenumbraWarning)
        before = renderer.render(**render)["color"]
    write_texture(sky, np.full((8, 16, 3), 0.75, np.float32))  # another size: another stamp
    after = renderer.render(**render)["color"]
    assert float(np.asarray(after)[3:5, 3:5, :3].mean()) == pytest.approx(0.75, rel=1e-3)
    np.testing.assert_array_equal(after, penumbra.Renderer(stage).render(**render)["color"])
    assert not np.array_equal(before, after)
