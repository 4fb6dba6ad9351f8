"""Mesh lights (UsdLuxMeshLightAPI) read from USD: shaped and shadowed by UsdLux's applied
schemas (ShapingAPI, ShadowAPI) as the other lights are, about the mesh's own frame; emitting
from the front their geometry shows, mirrored or not."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux

import penumbra
from stages import add_camera, add_preview_material, add_quad, bind, new_stage

LAMP_HALF_SIZE = 0.1
LAMP_HEIGHT = 1.0
# Tilted 45° about Y, the lamp's -Z axis meets the floor at x = -1; a 15° cone lights the floor
# from x = -tan 60° to -tan 30° (about -1.73 to -0.58) along y = 0.
TILT_DEGREES = 45.0
CONE_DEGREES = 15.0
RENDER = dict(camera="/cam", width=32, samples=64, seed=3)


def floor_stage() -> Usd.Stage:
    """A grey floor in the z = 0 plane, [-2, 2]² of it seen straight down from z = 5."""
    stage = new_stage()
    add_camera(stage)
    add_quad(stage, "/World/floor", half_size=2.0, color=(0.5, 0.5, 0.5))
    return stage


def place_lamp(prim: Usd.Prim, tilt_degrees: float) -> None:
    """The lamp's frame: LAMP_HEIGHT above the origin, its -Z axis tilted about Y."""
    lamp = UsdGeom.Xformable(prim)
    lamp.AddTranslateOp().Set(Gf.Vec3d(0, 0, LAMP_HEIGHT))
    lamp.AddRotateYOp().Set(tilt_degrees)


def add_mesh_lamp(stage: Usd.Stage, tilt_degrees: float = 0.0) -> Usd.Prim:
    """A square UsdLuxMeshLightAPI card in its XY plane whose front faces its -Z, as a rect light
    of the same size emits."""
    s = LAMP_HALF_SIZE
    mesh = UsdGeom.Mesh.Define(stage, "/World/lamp")
    mesh.CreatePointsAttr([Gf.Vec3f(-s, -s, 0), Gf.Vec3f(-s, s, 0), Gf.Vec3f(s, s, 0),
                           Gf.Vec3f(s, -s, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.CreateDoubleSidedAttr(False)
    place_lamp(mesh.GetPrim(), tilt_degrees)
    UsdLux.MeshLightAPI.Apply(mesh.GetPrim())
    UsdLux.LightAPI(mesh.GetPrim()).CreateIntensityAttr(200.0)
    return mesh.GetPrim()


def add_rect_lamp(stage: Usd.Stage, tilt_degrees: float) -> Usd.Prim:
    """The rect light the mesh lamp's card is: same size, frame and radiance."""
    light = UsdLux.RectLight.Define(stage, "/World/lamp")
    light.CreateWidthAttr(2 * LAMP_HALF_SIZE)
    light.CreateHeightAttr(2 * LAMP_HALF_SIZE)
    light.CreateIntensityAttr(200.0)
    place_lamp(light.GetPrim(), tilt_degrees)
    return light.GetPrim()


def shape(prim: Usd.Prim) -> None:
    shaping = UsdLux.ShapingAPI.Apply(prim)
    shaping.CreateShapingConeAngleAttr(CONE_DEGREES)
    shaping.CreateShapingConeSoftnessAttr(0.0)


def floor_at(image, x: float, y: float = 0.0) -> float:
    """The mean radiance of the 2 × 2 pixels around floor point (x, y)."""
    rgb = image["color"][..., :3]
    height, width = rgb.shape[:2]
    column = int((x + 2) / 4 * width)
    row = int((2 - y) / 4 * height)
    return float(rgb[row - 1:row + 1, column - 1:column + 1].mean())


def test_a_mesh_lights_cone_is_shaped_about_its_meshs_own_minus_z():
    mesh_stage, rect_stage = floor_stage(), floor_stage()
    shape(add_mesh_lamp(mesh_stage, TILT_DEGREES))
    shape(add_rect_lamp(rect_stage, TILT_DEGREES))
    mesh_lit = penumbra.Renderer(mesh_stage).render(**RENDER)
    rect_lit = penumbra.Renderer(rect_stage).render(**RENDER)
    spot = floor_at(rect_lit, -1.0)
    assert spot > 0.05
    # Below the lamp (45° off its axis) and on the far side the cone lights nothing; an
    # unshaped lamp, or one shaped about the world's -Z, would light both.
    for x in (0.0, 1.0):
        assert floor_at(mesh_lit, x) < 0.02 * spot, x
        assert floor_at(rect_lit, x) < 0.02 * spot, x
    # Where the cone falls, the card lights the floor as the rect light it matches does.
    for x in (-1.5, -1.0, -0.75):
        assert abs(floor_at(mesh_lit, x) / floor_at(rect_lit, x) - 1) < 0.1, x


def test_an_unshaped_mesh_light_lights_the_whole_floor():
    stage = floor_stage()
    add_mesh_lamp(stage, TILT_DEGREES)
    image = penumbra.Renderer(stage).render(**RENDER)
    assert floor_at(image, 0.0) > 0.3 * floor_at(image, -1.0) > 0


def test_shadow_api_turns_a_mesh_lights_shadows_off():
    stage = floor_stage()
    lamp = add_mesh_lamp(stage)
    open_sky = penumbra.Renderer(stage).render(**RENDER)
    # A card between the lamp and the floor, facing the floor: camera rays from above do not
    # see its back (single-sided), shadow rays do.
    blocker = add_quad(stage, "/World/blocker", center=(0, 0, 0.5), half_size=0.5)
    blocker.GetOrientationAttr().Set(UsdGeom.Tokens.leftHanded)
    shadowed = penumbra.Renderer(stage).render(**RENDER)
    UsdLux.ShadowAPI.Apply(lamp).CreateShadowEnableAttr(False)
    unshadowed = penumbra.Renderer(stage).render(**RENDER)
    below = floor_at(open_sky, 0.0)
    assert below > 0.05
    assert floor_at(shadowed, 0.0) < 0.02 * below
    assert abs(floor_at(unshadowed, 0.0) / below - 1) < 0.1
    np.testing.assert_allclose(floor_at(unshadowed, 1.8), floor_at(open_sky, 1.8), rtol=0.1)


def test_turning_a_shaped_mesh_light_turns_its_cone_in_a_live_render():
    stage = floor_stage()
    lamp = add_mesh_lamp(stage, TILT_DEGREES)
    shape(lamp)
    renderer = penumbra.Renderer(stage)
    before = renderer.render(**RENDER)
    assert floor_at(before, -1.0) > 50 * floor_at(before, 1.0)
    lamp.GetAttribute("xformOp:rotateY").Set(-TILT_DEGREES)
    after = renderer.render(**RENDER)
    assert floor_at(after, 1.0) > 50 * floor_at(after, -1.0)
    np.testing.assert_array_equal(after["color"], penumbra.Renderer(stage).render(**RENDER)["color"])


@pytest.mark.parametrize("direct_lighting", ["mis", "light", "bsdf"])
def test_a_mirrored_mesh_light_emits_from_the_front_its_geometry_shows(direct_lighting: str):
    """A card modelled facing +Z and mirrored through its XY plane (scale z = -1) faces the
    floor, as the same card modelled facing -Z does, to every strategy: the light's samples
    must not leave from its back (its corners' winding reverses under the mirror)."""
    images = []
    for mirrored in (False, True):
        stage = floor_stage()
        lamp = add_mesh_lamp(stage)
        if mirrored:
            points = UsdGeom.Mesh(lamp).GetPointsAttr()
            points.Set([points.Get()[i] for i in (0, 3, 2, 1)])  # facing +Z
            UsdGeom.Xformable(lamp).AddScaleOp().Set(Gf.Vec3f(1, 1, -1))
        images.append(penumbra.Renderer(stage).render(direct_lighting=direct_lighting,
                                                      **RENDER))
    plain, mirror = images
    for x in (0.0, 1.0):
        assert floor_at(plain, x) > 0.01
        assert abs(floor_at(mirror, x) / floor_at(plain, x) - 1) < 0.1, x


def test_a_mesh_lights_back_glows_by_its_material_alone():
    """A mesh light emits from its front; its back glows by its material's emissiveColor, which
    is no light's: the light's diffuse multiplier does not dim it (nor does the light tracer
    take it over)."""
    images = {}
    for multiplier in (1.0, 0.0):
        stage = floor_stage()
        lamp = add_mesh_lamp(stage, tilt_degrees=180.0)  # its front faces up, its back the floor
        UsdLux.LightAPI(lamp).CreateDiffuseAttr(multiplier)
        bind(UsdGeom.Mesh(lamp), add_preview_material(stage, "/World/glow",
                                                      emissiveColor=(40.0, 40.0, 40.0),
                                                      diffuseColor=(0.0, 0.0, 0.0)))
        images[multiplier] = penumbra.Renderer(stage).render(**RENDER)
    for x in (0.0, 1.0):
        glow = floor_at(images[1.0], x)
        assert glow > 0.01
        assert abs(floor_at(images[0.0], x) / glow - 1) < 0.1, x


def sweeping_lamp_stage(how: str, position: float | None = None) -> Usd.Stage:
    """The floor under a mesh lamp facing down 0.4 above it, swept from x = -1 to 1 over the
    shutter by its transform (``how="transform"``) or its points (``"points"``); or standing
    still at x = ``position``."""
    stage = floor_stage()
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/cam"))
    camera.CreateShutterOpenAttr(0.0)
    camera.CreateShutterCloseAttr(1.0)
    lamp = add_mesh_lamp(stage)
    mesh = UsdGeom.Mesh(lamp)
    mesh.GetPrim().GetAttribute("xformOp:translate").Set(Gf.Vec3d(0, 0, 0.4))
    if position is not None:
        UsdGeom.Xformable(lamp).AddTranslateOp(opSuffix="sweep").Set(Gf.Vec3d(position, 0, 0))
        return stage
    if how == "transform":
        sweep = UsdGeom.Xformable(lamp).AddTranslateOp(opSuffix="sweep")
        sweep.Set(Gf.Vec3d(-1, 0, 0), 1.0)
        sweep.Set(Gf.Vec3d(1, 0, 0), 2.0)
    else:
        points = mesh.GetPointsAttr()
        still = points.Get()
        for time, offset in ((1.0, -1.0), (2.0, 1.0)):
            points.Set([Gf.Vec3f(p[0] + offset, p[1], p[2]) for p in still], time)
    return stage


@pytest.mark.parametrize("how", ["transform", "points"])
def test_a_moving_mesh_light_lights_the_floor_from_where_it_is_at_each_time(how: str):
    """Over the shutter the lamp's light sweeps the floor: the motion-blurred image is the mean
    of the lamp standing at the moments of its sweep, next-event estimation included (it drew
    the lamp where it stood at shutter open: a pool of light at x = -1 alone)."""
    render = dict(camera="/cam", width=32, samples=64, seed=3, time=1.0)
    swept = penumbra.Renderer(sweeping_lamp_stage(how)).render(**render)["color"][..., 0]
    moments = 16
    standing = np.mean([
        penumbra.Renderer(sweeping_lamp_stage(how, -1 + 2 * (k + 0.5) / moments))
        .render(**render)["color"][..., 0]
        for k in range(moments)
    ], axis=0)
    band = slice(12, 20)  # the rows about y = 0, under the lamp's path
    for columns in (slice(0, 8), slice(8, 16), slice(16, 24), slice(24, 32)):
        expected = standing[band, columns].mean()
        assert expected > 0.1
        assert abs(swept[band, columns].mean() / expected - 1) < 0.05, columns


@pytest.mark.parametrize("lamp", ["mesh light", "rect light under a ceiling"])
def test_a_lamp_far_from_the_origin_lights_the_floor_to_every_strategy(lamp: str):
    """Twenty units from the origin, a shadow ray's start, moved off the floor by its rounding
    margin there, brought the lamp's point nearer than the ray's length: it ran on past the
    lamp into the lamp's own mesh, or into the ceiling 1e-4 above a rect light, and next-event
    estimation found the floor in shadow (1.8e-5 against 0.036 found by BSDF rays)."""
    stage = new_stage()
    world = UsdGeom.Xform.Define(stage, "/World")
    world.AddTranslateOp().Set(Gf.Vec3d(20, 0, 0))
    add_camera(stage, translate=(20, 0, 5))
    add_quad(stage, "/World/floor", half_size=2.0, color=(0.5, 0.5, 0.5))
    if lamp == "mesh light":
        panel = add_mesh_lamp(stage)
        UsdGeom.Mesh(panel).GetPointsAttr().Set(
            [Gf.Vec3f(x, y, 0) for x, y in ((-0.5, -0.5), (-0.5, 0.5), (0.5, 0.5), (0.5, -0.5))])
    else:
        light = UsdLux.RectLight.Define(stage, "/World/lamp")
        light.CreateIntensityAttr(5.0)
        light.AddTranslateOp().Set(Gf.Vec3d(0, 0, 1))
        ceiling = add_quad(stage, "/World/ceiling", center=(0, 0, 1.0001), half_size=2.0)
        ceiling.GetOrientationAttr().Set(UsdGeom.Tokens.leftHanded)  # facing the floor
    below = {
        strategy: floor_at(penumbra.Renderer(stage).render(direct_lighting=strategy, **RENDER),
                           0.0)
        for strategy in ("bsdf", "light", "mis")
    }
    assert below["bsdf"] > 0.01
    for strategy in ("light", "mis"):
        assert abs(below[strategy] / below["bsdf"] - 1) < 0.1, (strategy, below)


def test_a_subdivided_mesh_light_is_drawn_on_the_surface_rays_meet():
    """USD's default subdivision scheme is catmullClark: a cube made a light is traced as its
    limit surface, and next-event estimation must draw points there, not on the larger cage
    (it lit the floor 2.6 x as brightly as the glowing surface rays see did)."""
    stage = floor_stage()
    cube = UsdGeom.Mesh.Define(stage, "/World/lamp")
    s = 0.25
    cube.CreatePointsAttr([Gf.Vec3f(x, y, z) for z in (-s, s) for y in (-s, s) for x in (-s, s)])
    cube.CreateFaceVertexCountsAttr([4] * 6)
    cube.CreateFaceVertexIndicesAttr([0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4,
                                      2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5])
    cube.AddTranslateOp().Set(Gf.Vec3d(0, 0, 1))
    UsdLux.MeshLightAPI.Apply(cube.GetPrim())
    UsdLux.LightAPI(cube.GetPrim()).CreateIntensityAttr(20.0)
    assert cube.GetSubdivisionSchemeAttr().Get() == UsdGeom.Tokens.catmullClark
    around = {
        strategy: np.mean([floor_at(image, x) for x in (-1.2, 1.2)])
        for strategy in ("bsdf", "light", "mis")
        for image in [penumbra.Renderer(stage).render(direct_lighting=strategy, **RENDER)]
    }
    assert around["bsdf"] > 0.01
    for strategy in ("light", "mis"):
        assert abs(around[strategy] / around["bsdf"] - 1) < 0.1, (strategy, around)


@pytest.mark.parametrize("diffuse, specular", [(0.0, 1.0), (1.0, 0.0), (0.3, 2.0)])
def test_a_lights_diffuse_and_specular_multipliers_scale_its_lobes_to_every_strategy(
    diffuse: float, specular: float
):
    """UsdLux's inputs:diffuse and inputs:specular scale the light a surface's diffuse and
    specular lobes reflect. A BSDF ray carries the whole BSDF's value, whichever lobe it was
    drawn from: it must scale each lobe's share of it, as next-event estimation does (it
    scaled all of it by the drawn lobe's multiplier: 26 % dark with diffuse 0 under a dome,
    36 % under a rect light)."""
    stage = floor_stage()
    floor = UsdGeom.Mesh(stage.GetPrimAtPath("/World/floor"))
    bind(floor, add_preview_material(stage, "/World/rough", diffuseColor=(0.5, 0.5, 0.5),
                                     roughness=0.6, specularColor=(0.3, 0.3, 0.3),
                                     useSpecularWorkflow=1))
    light = UsdLux.RectLight.Define(stage, "/World/lamp")
    light.CreateWidthAttr(2.0)
    light.CreateHeightAttr(2.0)
    light.CreateIntensityAttr(5.0)
    light.CreateDiffuseAttr(diffuse)
    light.CreateSpecularAttr(specular)
    light.AddTranslateOp().Set(Gf.Vec3d(0, 0, 2))
    render = dict(RENDER, samples=256, max_path_depth=1)
    means = {
        strategy: float(penumbra.Renderer(stage).render(direct_lighting=strategy, **render)
                        ["color"][..., :3].mean())
        for strategy in ("bsdf", "light", "mis")
    }
    assert means["light"] > 0.005
    for strategy in ("bsdf", "mis"):
        assert abs(means[strategy] / means["light"] - 1) < 0.03, (strategy, means)
