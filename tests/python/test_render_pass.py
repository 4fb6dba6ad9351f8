"""UsdRenderPass collections (``penumbra-record -rp``, ``Renderer(render_pass=...)``): prune,
renderVisibility, cameraVisibility and matte, on meshes, native instances and point instancers.

The stage: a grey back wall at z = -1 and bright quads at z = 0 in front of it, lit by a
distant light along -Z, so that each quad shadows the wall right behind it. Expected, per quad:
pruned or outside renderVisibility: the lit wall (no shadow); outside cameraVisibility: the wall
in the quad's shadow; matte: colour and alpha 0.
"""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdRender, Vt

import penumbra
from penumbra.cli import main
from penumbra.errors import SceneError

from stages import add_camera, add_distant_light, add_instance, add_quad, new_stage, pixel

QUADS = {  # name: centre
    "pruned": (-1.0, 1.0),
    "invisible": (1.0, 1.0),
    "cameraHidden": (-1.0, -1.0),
    "matte": (1.0, -1.0),
}
INSTANCE_CENTRE = (0.0, 0.0)  # a native instance of a small quad, in the matte collection
POINTS_CENTRE = (0.0, 1.5)  # a point instancer's copy, pruned
BRIGHT, WALL = 0.9, 0.5
LIT = 3.0 / np.pi  # radiance per unit albedo under the normalized distant light


def pass_stage(path=None) -> Usd.Stage:
    stage = new_stage(path)
    add_camera(stage)
    add_quad(stage, "/World/back", center=(0, 0, -1), half_size=3, color=(WALL,) * 3)
    for name, (x, y) in QUADS.items():
        add_quad(stage, f"/World/{name}", center=(x, y, 0), half_size=0.3, color=(BRIGHT,) * 3)
    stage.CreateClassPrim("/Prototypes")
    UsdGeom.Xform.Define(stage, "/Prototypes/small")
    add_quad(stage, "/Prototypes/small/quad", half_size=0.2, color=(BRIGHT,) * 3)
    add_instance(stage, "/World/instance", "/Prototypes/small", translate=(*INSTANCE_CENTRE, 0))
    points = UsdGeom.PointInstancer.Define(stage, "/World/points")
    add_quad(stage, "/World/points/prototypes/small", half_size=0.2, color=(BRIGHT,) * 3)
    points.CreatePrototypesRel().SetTargets(["/World/points/prototypes/small"])
    points.CreateProtoIndicesAttr([0])
    points.CreatePositionsAttr(Vt.Vec3fArray([Gf.Vec3f(*POINTS_CENTRE, 0)]))
    add_distant_light(stage)

    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets(["/cam"])
    settings.CreateResolutionAttr(Gf.Vec2i(80, 80))
    render_pass = UsdRender.Pass.Define(stage, "/Render/Pass")
    render_pass.GetRenderSourceRel().SetTargets(["/Render/Settings"])
    pass_prim = render_pass.GetPrim()
    Usd.CollectionAPI(pass_prim, "prune").GetIncludesRel().SetTargets(
        ["/World/pruned", "/World/points"]
    )
    Usd.CollectionAPI(pass_prim, "renderVisibility").GetExcludesRel().SetTargets(
        ["/World/invisible"]
    )
    Usd.CollectionAPI(pass_prim, "cameraVisibility").GetExcludesRel().SetTargets(
        ["/World/cameraHidden"]
    )
    Usd.CollectionAPI(pass_prim, "matte").GetIncludesRel().SetTargets(
        ["/World/matte", "/World/instance"]
    )
    return stage


def at(image, centre) -> tuple[np.ndarray, float]:
    """RGB and alpha of the pixel at a point (x, y) of the z = 0 plane."""
    u, v = (centre[0] + 2) / 4, (2 - centre[1]) / 4
    rgba = image["color"]
    h, w = rgba.shape[:2]
    return pixel(image, u, v), float(rgba[int(v * h), int(u * w), 3])


def behind(centre) -> tuple[float, float]:
    """Where the wall point right behind a point of the z = 0 plane appears on that plane, as
    the camera at z = 5 sees it (the wall is at z = -1)."""
    return centre[0] * 5 / 6, centre[1] * 5 / 6


def render(stage, **kwargs):
    return penumbra.Renderer(stage, **kwargs).render(camera="/cam", width=80, samples=16)


def test_without_the_pass_every_quad_renders():
    image = render(pass_stage())
    for centre in [*QUADS.values(), INSTANCE_CENTRE, POINTS_CENTRE]:
        rgb, alpha = at(image, centre)
        assert rgb == pytest.approx([BRIGHT * LIT] * 3, rel=0.03)
        assert alpha == 1


def test_each_collection_does_what_the_schema_says():
    image = render(pass_stage(), render_pass="/Render/Pass")
    lit_wall = WALL * LIT  # direct light only: light the quads reflect back adds up to 3 %
    for name in ("pruned", "invisible"):  # gone: the wall behind is lit (no shadow)
        rgb, alpha = at(image, QUADS[name])
        assert rgb == pytest.approx([lit_wall] * 3, rel=0.05), name
        assert alpha == 1
    rgb, alpha = at(image, POINTS_CENTRE)  # the pruned point instancer's copy
    assert rgb == pytest.approx([lit_wall] * 3, rel=0.05)
    # Hidden from the camera, the quad still shadows the wall behind it: with direct light only
    # (light the quad's back reflects from the lit wall brightens the shadow by about 4 %), the
    # wall right behind its centre is black.
    direct = penumbra.Renderer(pass_stage(), render_pass="/Render/Pass").render(
        camera="/cam", width=80, samples=16, max_path_depth=1
    )
    rgb, alpha = at(direct, behind(QUADS["cameraHidden"]))
    assert list(rgb) == [0, 0, 0] and alpha == 1
    for centre in (QUADS["matte"], INSTANCE_CENTRE):  # holdouts
        rgb, alpha = at(image, centre)
        assert list(rgb) == [0, 0, 0] and alpha == 0
    # The lit wall elsewhere is unchanged.
    assert at(image, (0, -1.6))[0] == pytest.approx([lit_wall] * 3, rel=0.05)


def test_the_command_line_applies_the_pass(tmp_path):
    stage_path = tmp_path / "pass.usda"
    pass_stage(stage_path).Save()
    out = tmp_path / "out.exr"
    assert main([str(stage_path), str(out), "-rp", "/Render/Pass", "-spp", "4", "-w", "80"]) == 0
    pixels, _, _ = penumbra._core.read_image(str(out))
    assert pixels.shape[:2] == (80, 80)
    u, v = (QUADS["matte"][0] + 2) / 4, (2 - QUADS["matte"][1]) / 4
    assert list(pixels[int(v * 80), int(u * 80)]) == [0, 0, 0, 0]


def test_a_path_that_is_no_render_pass_is_a_scene_error():
    with pytest.raises(SceneError, match="/World/back is not a RenderPass prim"):
        penumbra.Renderer(pass_stage(), render_pass=Sdf.Path("/World/back"))
