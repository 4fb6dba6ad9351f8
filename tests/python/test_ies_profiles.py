"""UsdLuxShapingAPI's IES profiles (``shaping:ies:file``, ``angleScale``, ``normalize``): the
profile's candelas multiply what a local light emits in each direction, its nadir along the
light's -Z and its horizontal angle 0 towards -X (hdEmbree's convention). They were named in a
warning and ignored: a lamp's beam pattern rendered as a bare bulb."""

from __future__ import annotations

import math
import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux

import penumbra
from stages import add_camera, add_quad, new_stage

RENDER = dict(camera="/cam", width=40, samples=16, seed=1)
HEIGHT = 1.0  # of the lamp above the floor


def write_profile(path: Path, vertical, horizontal, candelas, multiplier: float = 1.0) -> str:
    """An LM-63-2002 type C profile: ``candelas[h][v]``."""
    rows = "\n".join(" ".join(f"{c:g}" for c in row) for row in candelas)
    path.write_text(
        "IESNA:LM-63-2002\n[TEST] penumbra\nTILT=NONE\n"
        f"1 -1 {multiplier:g} {len(vertical)} {len(horizontal)} 1 2 0 0 0\n1 1 0\n"
        f"{' '.join(f'{a:g}' for a in vertical)}\n{' '.join(f'{a:g}' for a in horizontal)}\n"
        f"{rows}\n"
    )
    return str(path)


def lamp_stage(profile: str | None, **shaping) -> tuple[Usd.Stage, UsdLux.SphereLight]:
    """A point lamp HEIGHT above a white floor (y = 0), its -Z turned down; a camera above
    seeing [-2, 2]² of the floor."""
    stage = new_stage()
    add_quad(stage, "/floor", half_size=4.0, color=(1.0, 1.0, 1.0), facing="y")
    add_camera(stage, translate=(0.0, 5.0, 0.0), rotate_x=-90.0)
    lamp = UsdLux.SphereLight.Define(stage, "/lamp")
    lamp.CreateRadiusAttr(0.0)
    lamp.CreateIntensityAttr(1.0)
    lamp.AddTranslateOp().Set(Gf.Vec3d(0, HEIGHT, 0))
    lamp.AddRotateXOp().Set(-90.0)  # -Z (the nadir) down to -Y; -X stays -X
    shaping_api = UsdLux.ShapingAPI.Apply(lamp.GetPrim())
    if profile is not None:
        shaping_api.CreateShapingIesFileAttr(Sdf.AssetPath(profile))
    for name, value in shaping.items():
        getattr(shaping_api, f"CreateShapingIes{name}Attr")(value)
    return stage, lamp


def floor_radiance(stage: Usd.Stage, x: float, z: float) -> float:
    """The floor's radiance (red) at (x, z), in an image whose pixels span 0.1 units."""
    color = penumbra.Renderer(stage).render(**RENDER)["color"]
    height, width = color.shape[:2]
    return float(color[int((z + 2) / 4 * height), int((x + 2) / 4 * width), 0])


def test_a_constant_profile_scales_the_lamp_by_its_candelas_or_not_when_normalized(tmp_path):
    """I/4 from a radius-0 sphere, times 250 cd (a multiplier of 2.5 on 100): the floor under
    it has radiance (1/π) · 250 · I/4 / h²."""
    profile = write_profile(tmp_path / "flat.ies", [0, 90, 180], [0], [[100, 100, 100]], 2.5)
    bare = floor_radiance(lamp_stage(None)[0], 0, 0)
    assert bare == pytest.approx(1 / math.pi * 0.25 / HEIGHT**2, rel=0.02)
    assert floor_radiance(lamp_stage(profile)[0], 0, 0) == pytest.approx(250 * bare, rel=1e-4)
    normalized = floor_radiance(lamp_stage(profile, Normalize=True)[0], 0, 0)
    assert normalized == pytest.approx(bare, rel=1e-3)


def test_a_spot_profile_lights_the_floor_within_its_beam(tmp_path):
    """Full up to 20° off the nadir, none past 30°: lit at 11° (0.2 out at height 1), dark at
    45° (1 out)."""
    profile = write_profile(tmp_path / "spot.ies", [0, 20, 30, 90], [0], [[100, 100, 0, 0]])
    stage = lamp_stage(profile)[0]
    assert floor_radiance(stage, 0.2, 0) > 0.5 * floor_radiance(stage, 0, 0) > 0
    assert floor_radiance(stage, 1.0, 0) == 0


def test_horizontal_angle_0_points_along_the_lamps_minus_x(tmp_path):
    """A profile lit towards horizontal angle 0 alone (0°: 100 cd, 90°–270°: none): the floor
    on the lamp's -X side is lit, the +X side dark; 90° is -Z's turn towards -Y."""
    profile = write_profile(
        tmp_path / "side.ies", [0, 90], [0, 90, 180, 270, 360],
        [[100, 100], [0, 0], [0, 0], [0, 0], [100, 100]],
    )
    stage = lamp_stage(profile)[0]
    assert floor_radiance(stage, -0.8, 0) > 0
    assert floor_radiance(stage, 0.8, 0) == 0
    # Past 90° either way round (towards ±Z off the +X side): between 90° and 270°, dark.
    assert floor_radiance(stage, 0.3, 0.8) == 0 and floor_radiance(stage, 0.3, -0.8) == 0


def test_angle_scale_remaps_the_vertical_angle_about_the_zenith(tmp_path):
    """(θ − π) / (1 + s) + π: with s = 1 the nadir reads the profile at 90°."""
    profile = write_profile(tmp_path / "ramp.ies", [0, 10, 90, 180], [0], [[10, 10, 100, 100]])
    plain = floor_radiance(lamp_stage(profile)[0], 0, 0)
    widened = floor_radiance(lamp_stage(profile, AngleScale=1.0)[0], 0, 0)
    assert widened == pytest.approx(10 * plain, rel=1e-3)


def test_an_unreadable_profile_is_named_and_the_lamp_renders_unshaped(tmp_path):
    missing = str(tmp_path / "missing.ies")
    stage = lamp_stage(missing)[0]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        radiance = floor_radiance(stage, 0, 0)
    messages = [str(w.message) for w in caught]
    assert any(missing in m and "renders without its IES profile" in m for m in messages), messages
    assert radiance == pytest.approx(floor_radiance(lamp_stage(None)[0], 0, 0), rel=1e-6)


def test_a_profile_rewritten_on_disk_is_read_again(tmp_path):
    path = tmp_path / "lamp.ies"
    write_profile(path, [0, 180], [0], [[100, 100]])
    stage = lamp_stage(str(path))[0]
    renderer = penumbra.Renderer(stage)
    before = renderer.render(**RENDER)["color"]
    write_profile(path, [0, 180], [0], [[300, 300]])
    os.utime(path, (1, 1e9))  # a stamp unlike the first file's, however fast the write
    after = renderer.render(**RENDER)["color"]
    lit = before[..., 0] > 0
    np.testing.assert_allclose(after[..., 0][lit] / before[..., 0][lit], 3, rtol=1e-5)


def test_a_profile_on_a_distant_light_is_named_as_unsupported(tmp_path):
    profile = write_profile(tmp_path / "flat.ies", [0, 180], [0], [[100, 100]])
    stage = new_stage()
    add_quad(stage, "/floor", half_size=4.0, facing="y")
    add_camera(stage, translate=(0.0, 5.0, 0.0), rotate_x=-90.0)
    sun = UsdLux.DistantLight.Define(stage, "/sun")
    UsdLux.ShapingAPI.Apply(sun.GetPrim()).CreateShapingIesFileAttr(Sdf.AssetPath(profile))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        penumbra.Renderer(stage).render(**RENDER)
    assert any(
        "/sun: inputs:shaping:ies:file is not supported yet; ignored" in str(w.message)
        for w in caught
    )


def test_a_mesh_lights_profile_rewritten_on_disk_is_read_again(tmp_path):
    """The light of a UsdLuxMeshLightAPI mesh is its mesh's: its profile was never looked at
    again."""
    path = tmp_path / "panel.ies"
    write_profile(path, [0, 180], [0], [[100, 100]])
    stage = new_stage()
    add_quad(stage, "/floor", half_size=4.0, color=(1.0, 1.0, 1.0), facing="y")
    add_camera(stage, translate=(0.0, 5.0, 0.0), rotate_x=-90.0)
    panel = add_quad(stage, "/panel", center=(3.0, 1.0, 0.0), half_size=0.2, facing="y")
    UsdGeom.Xformable(panel).AddRotateXOp().Set(180.0)  # facing down
    UsdLux.MeshLightAPI.Apply(panel.GetPrim())
    UsdLux.ShapingAPI.Apply(panel.GetPrim()).CreateShapingIesFileAttr(Sdf.AssetPath(str(path)))
    renderer = penumbra.Renderer(stage)
    before = renderer.render(**RENDER)["color"]
    write_profile(path, [0, 180], [0], [[300, 300]])
    os.utime(path, (1, 1e9))
    after = renderer.render(**RENDER)["color"]
    np.testing.assert_allclose(after, penumbra.Renderer(stage).render(**RENDER)["color"])
    assert before[..., 0].sum() > 1
    assert after[..., 0].sum() == pytest.approx(3 * before[..., 0].sum(), rel=0.02)


def test_a_relative_profile_is_found_beside_its_layer_once_it_is_there(tmp_path, monkeypatch):
    """Not in the working directory (a file of the same name there was used silently), and a
    live Renderer reads it once it appears beside the layer."""
    layer = tmp_path / "scene" / "lamp.usda"
    layer.parent.mkdir()
    monkeypatch.chdir(tmp_path)
    (tmp_path / "profiles").mkdir()
    write_profile(tmp_path / "profiles" / "lamp.ies", [0, 180], [0], [[1000, 1000]])  # a decoy
    stage = lamp_stage("./profiles/lamp.ies")[0]
    stage.GetRootLayer().Export(str(layer))
    stage = Usd.Stage.Open(str(layer))
    renderer = penumbra.Renderer(stage)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        unshaped = renderer.render(**RENDER)["color"]
    expected = str(layer.parent / "profiles" / "lamp.ies")
    assert any(expected in str(w.message) for w in caught), [str(w.message) for w in caught]
    (layer.parent / "profiles").mkdir()
    write_profile(layer.parent / "profiles" / "lamp.ies", [0, 180], [0], [[100, 100]])
    shaped = renderer.render(**RENDER)["color"]
    lit = unshaped[..., 0] > 0
    np.testing.assert_allclose(shaped[..., 0][lit] / unshaped[..., 0][lit], 100, rtol=1e-4)
