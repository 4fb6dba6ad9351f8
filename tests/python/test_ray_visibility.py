"""Per-object ray visibility (``primvars:penumbra:visibility:*``) and holdout
(``primvars:penumbra:holdout``), docs/ray-visibility.md.

Each scene is built so that what a ray kind sees shows in a pixel of its own: shadows on a far
wall beside their casters, a mirror beside the object it reflects, glass in front of half of an
emitter, a diffuse wall lit only by what a reflector bounces onto it.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt

import penumbra
from penumbra.errors import PenumbraWarning

from stages import (
    add_camera,
    add_distant_light,
    add_instance,
    add_preview_material,
    add_quad,
    bind,
    emitter_stage,
    new_stage,
)

WIDTH = 80  # pixels across the camera's view of [-2, 2]² on the z = 0 plane
WALL_Z = -3.0  # the shadow scene's far wall
LIT = 3.0 / np.pi  # radiance per unit albedo under the normalized distant light
BRIGHT, WALL = 0.9, 0.5


def set_primvar(prim: Usd.Prim, name: str, value, type_name=Sdf.ValueTypeNames.Bool,
                interpolation=UsdGeom.Tokens.constant) -> None:
    primvar = UsdGeom.PrimvarsAPI(prim).CreatePrimvar(name, type_name, interpolation)
    primvar.Set(value)


def plane_pixel(image, x: float, y: float, alpha: bool = False):
    """RGB (and alpha) of the pixel showing point (x, y) of the z = 0 plane."""
    rgba = image["color"]
    h, w = rgba.shape[:2]
    row, col = min(h - 1, int((2 - y) / 4 * h)), min(w - 1, int((x + 2) / 4 * w))
    return rgba[row, col, :4] if alpha else rgba[row, col, :3]


def on_wall(x: float, y: float) -> tuple[float, float]:
    """Where the point (x, y) of the far wall appears on the z = 0 plane (camera at z = 5)."""
    scale = 5 / (5 - WALL_Z)
    return x * scale, y * scale


def render(stage, **kwargs):
    options = dict(camera="/cam", width=WIDTH, samples=16)
    options.update(kwargs)
    return penumbra.Renderer(stage).render(**options)


# ------------------------------------------------------------------------------------------
# Camera and shadow rays: quads at z = 0 in front of a far wall, lit by a distant light along
# -Z. A quad's shadow is the square right behind it on the wall; seen from the camera, the part
# of it nearer the image's centre is beside the quad, not behind it.

QUAD_HALF = 0.3


def shadow_stage() -> Usd.Stage:
    stage = new_stage()
    add_camera(stage)
    add_quad(stage, "/World/wall", center=(0, 0, WALL_Z), half_size=8, color=(WALL,) * 3)
    add_distant_light(stage)
    return stage


def add_caster(stage, path: str, x: float, y: float) -> UsdGeom.Mesh:
    return add_quad(stage, path, center=(x, y, 0), half_size=QUAD_HALF, color=(BRIGHT,) * 3)


def shadow_pixel(image, x: float, y: float):
    """The wall inside the shadow of the quad at (x, y), where the camera sees it beside the
    quad: halfway between where the shadow's inner edge and the quad's appear."""
    scale = on_wall(1, 1)[0]

    def halfway(centre: float) -> float:
        edge = centre - np.sign(centre) * QUAD_HALF
        return edge * (1 + scale) / 2

    return plane_pixel(image, halfway(x), halfway(y))


def direct(stage, **kwargs):
    """Direct light only: a shadow is then black."""
    return render(stage, max_path_depth=1, **kwargs)


def test_the_shadow_scene_shows_quads_and_their_shadows():
    stage = shadow_stage()
    add_caster(stage, "/World/quad", 1, 1)
    image = direct(stage)
    assert plane_pixel(image, 1, 1) == pytest.approx([BRIGHT * LIT] * 3, rel=0.03)
    assert list(shadow_pixel(image, 1, 1)) == [0, 0, 0]
    assert plane_pixel(image, -1, -1) == pytest.approx([WALL * LIT] * 3, rel=0.03)


def test_a_camera_invisible_object_still_casts_its_shadow():
    stage = shadow_stage()
    quad = add_caster(stage, "/World/quad", 1, 1)
    set_primvar(quad.GetPrim(), "penumbra:visibility:camera", False)
    image = direct(stage)
    # Where the quad would be, the camera sees the lit wall far behind it (outside its shadow).
    assert plane_pixel(image, 1, 1) == pytest.approx([WALL * LIT] * 3, rel=0.03)
    assert list(shadow_pixel(image, 1, 1)) == [0, 0, 0]


def test_a_shadow_invisible_object_is_seen_but_casts_no_shadow():
    stage = shadow_stage()
    quad = add_caster(stage, "/World/quad", 1, 1)
    set_primvar(quad.GetPrim(), "penumbra:visibility:shadow", False)
    add_caster(stage, "/World/other", -1, -1)
    image = direct(stage)
    assert plane_pixel(image, 1, 1) == pytest.approx([BRIGHT * LIT] * 3, rel=0.03)
    assert shadow_pixel(image, 1, 1) == pytest.approx([WALL * LIT] * 3, rel=0.03)
    assert list(shadow_pixel(image, -1, -1)) == [0, 0, 0]  # the other quad's shadow stays


def test_an_ancestor_hides_its_descendants_and_a_nearer_value_wins():
    stage = shadow_stage()
    group = UsdGeom.Xform.Define(stage, "/World/group").GetPrim()
    set_primvar(group, "penumbra:visibility:shadow", False)
    add_caster(stage, "/World/group/inherits", 1, 1)
    overrides = add_caster(stage, "/World/group/overrides", -1, -1)
    set_primvar(overrides.GetPrim(), "penumbra:visibility:shadow", True)
    image = direct(stage)
    assert shadow_pixel(image, 1, 1) == pytest.approx([WALL * LIT] * 3, rel=0.03)
    assert list(shadow_pixel(image, -1, -1)) == [0, 0, 0]
    # Both are seen: only shadows were turned off.
    for x in (1, -1):
        assert plane_pixel(image, x, x) == pytest.approx([BRIGHT * LIT] * 3, rel=0.03)


def test_a_holdout_has_no_colour_and_no_alpha_and_still_shadows():
    stage = shadow_stage()
    set_primvar(add_caster(stage, "/World/quad", 1, 1).GetPrim(), "penumbra:holdout", True)
    image = direct(stage)
    assert list(plane_pixel(image, 1, 1, alpha=True)) == [0, 0, 0, 0]
    assert list(shadow_pixel(image, 1, 1)) == [0, 0, 0]
    assert plane_pixel(image, -1, -1, alpha=True)[3] == 1


def test_native_instances_and_point_instancer_copies_take_their_placers_visibility():
    stage = shadow_stage()
    stage.CreateClassPrim("/Prototypes")
    UsdGeom.Xform.Define(stage, "/Prototypes/small")
    add_quad(stage, "/Prototypes/small/quad", half_size=QUAD_HALF, color=(BRIGHT,) * 3)
    instance = add_instance(stage, "/World/instance", "/Prototypes/small", translate=(1, 1, 0))
    set_primvar(instance, "penumbra:visibility:camera", False)
    points = UsdGeom.PointInstancer.Define(stage, "/World/points")
    add_quad(stage, "/World/points/prototypes/small", half_size=QUAD_HALF, color=(BRIGHT,) * 3)
    points.CreatePrototypesRel().SetTargets(["/World/points/prototypes/small"])
    points.CreateProtoIndicesAttr([0])
    points.CreatePositionsAttr(Vt.Vec3fArray([Gf.Vec3f(-1, -1, 0)]))
    set_primvar(points.GetPrim(), "penumbra:visibility:shadow", False)
    image = direct(stage)
    assert plane_pixel(image, 1, 1) == pytest.approx([WALL * LIT] * 3, rel=0.03)  # unseen
    assert list(shadow_pixel(image, 1, 1)) == [0, 0, 0]
    assert plane_pixel(image, -1, -1) == pytest.approx([BRIGHT * LIT] * 3, rel=0.03)
    assert shadow_pixel(image, -1, -1) == pytest.approx([WALL * LIT] * 3, rel=0.03)


@pytest.mark.parametrize("hidden", [False, True])
def test_points_and_curves_take_their_visibility(hidden):
    stage = shadow_stage()
    dots = UsdGeom.Points.Define(stage, "/World/dots")  # a sphere at (1, 1, 0)
    dots.CreatePointsAttr([Gf.Vec3f(1, 1, 0)])
    dots.CreateWidthsAttr([2 * QUAD_HALF])
    dots.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(BRIGHT)])
    hair = UsdGeom.BasisCurves.Define(stage, "/World/hair")  # a tube along y at x = -1
    hair.CreateTypeAttr(UsdGeom.Tokens.linear)
    hair.CreateCurveVertexCountsAttr([2])
    hair.CreatePointsAttr([Gf.Vec3f(-1, -1.5, 0), Gf.Vec3f(-1, 1.5, 0)])
    hair.CreateWidthsAttr([2 * QUAD_HALF])
    hair.SetWidthsInterpolation(UsdGeom.Tokens.constant)
    hair.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(BRIGHT)])
    if hidden:
        set_primvar(dots.GetPrim(), "penumbra:visibility:camera", False)
        set_primvar(hair.GetPrim(), "penumbra:visibility:shadow", False)
    image = direct(stage)
    # The camera sees them where their normal points back along its ray: cos θ towards the
    # light is 5 / |(1, 1, 5)| on the sphere, 5 / |(1, 0, 5)| on the tube.
    sphere = [BRIGHT * LIT * 5 / np.sqrt(27)] * 3
    tube = [BRIGHT * LIT * 5 / np.sqrt(26)] * 3
    expected = [WALL * LIT] * 3 if hidden else sphere
    assert plane_pixel(image, 1, 1) == pytest.approx(expected, rel=0.03)
    assert list(plane_pixel(image, *on_wall(0.9, 0.9))) == [0, 0, 0]  # the sphere's shadow
    assert plane_pixel(image, -1, 0) == pytest.approx(tube, rel=0.03)
    hair_shadow = plane_pixel(image, *on_wall(-0.9, 0))
    if hidden:
        assert hair_shadow == pytest.approx([WALL * LIT] * 3, rel=0.03)
    else:
        assert list(hair_shadow) == [0, 0, 0]


def test_an_edit_of_the_primvar_reaches_the_render():
    stage = shadow_stage()
    quad = add_caster(stage, "/World/quad", 1, 1)
    renderer = penumbra.Renderer(stage)
    options = dict(camera="/cam", width=WIDTH, samples=4, max_path_depth=1)
    quad_seen = [BRIGHT * LIT] * 3
    assert plane_pixel(renderer.render(**options), 1, 1) == pytest.approx(quad_seen, rel=0.03)
    set_primvar(quad.GetPrim(), "penumbra:visibility:camera", False)
    wall_seen = [WALL * LIT] * 3
    assert plane_pixel(renderer.render(**options), 1, 1) == pytest.approx(wall_seen, rel=0.03)
    quad.GetPrim().RemoveProperty("primvars:penumbra:visibility:camera")
    assert plane_pixel(renderer.render(**options), 1, 1) == pytest.approx(quad_seen, rel=0.03)


@pytest.mark.parametrize(
    "type_name, interpolation, value, complaint",
    [
        (Sdf.ValueTypeNames.Int, UsdGeom.Tokens.constant, 0, "has type int, not bool"),
        (Sdf.ValueTypeNames.Bool, UsdGeom.Tokens.uniform, False, "has uniform interpolation"),
    ],
)
def test_a_value_that_is_not_a_constant_bool_is_ignored_with_one_warning(
    type_name, interpolation, value, complaint
):
    stage = shadow_stage()
    quad = add_caster(stage, "/World/quad", 1, 1)
    set_primvar(quad.GetPrim(), "penumbra:visibility:camera", value, type_name, interpolation)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = direct(stage)
    messages = [str(w.message) for w in caught if issubclass(w.category, PenumbraWarning)]
    named = [m for m in messages if "primvars:penumbra:visibility:camera" in m]
    assert len(named) == 1 and "/World/quad" in named[0] and complaint in named[0]
    assert plane_pixel(image, 1, 1) == pytest.approx([BRIGHT * LIT] * 3, rel=0.03)


# ------------------------------------------------------------------------------------------
# Glossy rays: a mirror at z = -1 behind a small double-sided emitter at (EMITTER_X, 0, 0).
# The camera sees the emitter at x = EMITTER_X and its reflection (a virtual emitter at z = -2)
# at x = EMITTER_X · 5/7 on the z = 0 plane.

EMITTER_X = 1.5


def mirror_stage() -> tuple[Usd.Stage, Usd.Prim]:
    stage = emitter_stage()
    add_camera(stage)
    mirror = add_quad(stage, "/World/mirror", center=(0, 0, -1), half_size=6)
    bind(mirror, add_preview_material(stage, "/Looks/mirror", diffuseColor=(1.0, 1.0, 1.0),
                                      metallic=1.0, roughness=0.0))
    emitter = add_quad(stage, "/World/emitter", center=(EMITTER_X, 0, 0), half_size=0.2)
    emitter.CreateDoubleSidedAttr(True)
    bind(emitter, UsdShade.Material(stage.GetPrimAtPath("/Looks/glow")))
    return stage, emitter.GetPrim()


def seen_and_reflected(stage) -> tuple[float, float]:
    image = render(stage, width=160)
    return (float(plane_pixel(image, EMITTER_X, 0).mean()),
            float(plane_pixel(image, EMITTER_X * 5 / 7, 0).mean()))


def test_the_mirror_shows_the_emitter():
    seen, reflected = seen_and_reflected(mirror_stage()[0])
    assert seen == pytest.approx(1, rel=1e-3) and reflected > 0.8


def test_a_camera_invisible_object_shows_in_a_mirror():
    stage, emitter = mirror_stage()
    set_primvar(emitter, "penumbra:visibility:camera", False)
    seen, reflected = seen_and_reflected(stage)
    assert seen < 0.05 and reflected > 0.8


def test_a_glossy_invisible_object_is_seen_but_not_in_a_mirror():
    stage, emitter = mirror_stage()
    set_primvar(emitter, "penumbra:visibility:glossy", False)
    seen, reflected = seen_and_reflected(stage)
    assert seen == pytest.approx(1, rel=1e-3) and reflected == 0


# ------------------------------------------------------------------------------------------
# Transmission rays: an emitting wall at z = -1, seen through a thin glass pane on the left
# half of the view and directly on the right.


def glass_stage() -> tuple[Usd.Stage, Usd.Prim]:
    stage = emitter_stage()
    add_camera(stage)
    wall = add_quad(stage, "/World/glowingWall", center=(0, 0, -1), half_size=6)
    bind(wall, UsdShade.Material(stage.GetPrimAtPath("/Looks/glow")))
    pane = add_quad(stage, "/World/pane", center=(-1.5, 0, 0), half_size=1.4)
    bind(pane, add_preview_material(stage, "/Looks/glass", opacity=0.0, ior=1.5, roughness=0.0))
    return stage, wall.GetPrim()


def test_a_transmission_invisible_object_is_not_seen_through_glass():
    stage, wall = glass_stage()
    clear = render(stage)
    through, beside = plane_pixel(clear, -1.5, 0).mean(), plane_pixel(clear, 1.5, 0).mean()
    assert through > 0.8 and beside == pytest.approx(1, rel=1e-3)
    set_primvar(wall, "penumbra:visibility:transmission", False)
    image = render(stage)
    assert plane_pixel(image, -1.5, 0).mean() < 0.1  # only what the pane reflects of nothing
    assert plane_pixel(image, 1.5, 0).mean() == pytest.approx(1, rel=1e-3)


# ------------------------------------------------------------------------------------------
# Diffuse rays: a white wall at z = -1 facing the camera, lit only by a reflector: a quad in the
# plane x = -1 facing +X, lit by a distant light along -X that meets the wall edge-on.


def bounce_stage() -> tuple[Usd.Stage, Usd.Prim]:
    stage = new_stage()
    add_camera(stage)
    add_quad(stage, "/World/wall", center=(0, 0, -1), half_size=6, color=(1.0, 1.0, 1.0))
    reflector = add_quad(stage, "/World/reflector", half_size=1, color=(1.0, 1.0, 1.0), facing="z")
    reflector.AddRotateYOp().Set(90.0)  # +Z turns to +X
    reflector.GetPrim().GetAttribute("xformOp:translate").Set(Gf.Vec3d(-1, 0, 0))
    light = add_distant_light(stage)
    light.CreateAngleAttr(0.0)  # parallel: no light at all reaches the wall directly
    UsdGeom.Xformable(light.GetPrim()).AddRotateYOp().Set(90.0)  # shining along -X
    return stage, reflector.GetPrim()


def test_a_diffuse_invisible_object_bounces_no_light_onto_its_neighbour():
    stage, reflector = bounce_stage()
    near_reflector = (-0.5 * 5 / 6, 0)  # the wall at x = -0.5
    lit = plane_pixel(render(stage, samples=64), *near_reflector).mean()
    assert lit > 0.05
    set_primvar(reflector, "penumbra:visibility:diffuse", False)
    assert plane_pixel(render(stage, samples=64), *near_reflector).mean() < 1e-3
