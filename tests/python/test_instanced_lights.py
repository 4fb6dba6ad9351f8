"""Lights in a point instancer's prototypes: every copy of a prototype holding a light is a
light of its own, placed with the copy, as the same lamps placed by hand would be."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux, Vt

import penumbra
from stages import (
    add_camera,
    add_instance,
    add_instancer,
    add_quad,
    assert_live_edit_renders_as_fresh,
    new_stage,
    render_with_warnings,
)

RENDER = dict(camera="/cam", width=40, samples=16, seed=1)
PLACES = ((-1.0, 0.5, 0.0), (1.0, -0.5, 0.0))


def add_lamp(stage, path: str) -> UsdLux.SphereLight:
    """A lamp: a small card with a bulb half a unit in front of it, facing the camera."""
    UsdGeom.Xform.Define(stage, path)
    add_quad(stage, f"{path}/shade", half_size=0.2)
    bulb = UsdLux.SphereLight.Define(stage, f"{path}/bulb")
    bulb.CreateRadiusAttr(0.1)
    bulb.CreateIntensityAttr(30.0)
    bulb.AddTranslateOp().Set(Gf.Vec3d(0, 0, 0.5))
    return bulb


def wall_stage():
    """A camera facing a wall half a unit behind the z = 0 plane, nothing lighting it."""
    stage = new_stage()
    add_camera(stage)
    add_quad(stage, "/World/wall", center=(0.0, 0.0, -0.5), half_size=3.0)
    return stage


def lamps_stage(instanced: bool):
    """Two lamps in front of a wall: copies of a point instancer, or placed by hand."""
    stage = wall_stage()
    if instanced:
        add_lamp(stage, "/World/lamps/Protos/lamp")
        add_instancer(stage, "/World/lamps", "/World/lamps/Protos/lamp", PLACES)
    else:
        for n, place in enumerate(PLACES):
            add_lamp(stage, f"/World/lamp{n}")
            UsdGeom.Xform(stage.GetPrimAtPath(f"/World/lamp{n}")).AddTranslateOp().Set(
                Gf.Vec3d(*place)
            )
    return stage


def test_each_copy_of_a_prototype_light_lights_as_a_lamp_placed_by_hand():
    image, messages = render_with_warnings(lamps_stage(instanced=True), 40)
    assert messages == []
    instanced = penumbra.Renderer(lamps_stage(instanced=True)).render(**RENDER)["color"]
    by_hand = penumbra.Renderer(lamps_stage(instanced=False)).render(**RENDER)["color"]
    assert instanced[..., :3].mean() > 0.05  # lit, and by its own lamps: no default light
    np.testing.assert_allclose(instanced, by_hand, rtol=1e-5, atol=1e-5)


def test_lights_of_a_stage_lit_only_by_copies_keep_the_default_light_off():
    stage = lamps_stage(instanced=True)
    stage.GetPrimAtPath("/World/lamps/Protos/lamp/bulb").GetAttribute("inputs:intensity").Set(0.0)
    image = penumbra.Renderer(stage).render(**RENDER)["color"]
    assert image[..., :3].max() == 0  # unlit: no default light in the copies' place


def edit_intensity(stage):
    stage.GetPrimAtPath("/World/lamps/Protos/lamp/bulb").GetAttribute("inputs:intensity").Set(90.0)


def edit_positions(stage):
    UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/lamps")).GetPositionsAttr().Set(
        Vt.Vec3fArray([(0.0, 0.0, 0.0), (1.0, 1.0, 0.0)])
    )


def edit_copies(stage):
    instancer = UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/lamps"))
    instancer.GetPositionsAttr().Set(Vt.Vec3fArray(PLACES[:1]))
    instancer.GetProtoIndicesAttr().Set(Vt.IntArray([0]))


def edit_bulb_place(stage):
    UsdGeom.Xformable(stage.GetPrimAtPath("/World/lamps/Protos/lamp/bulb")).GetOrderedXformOps()[
        0
    ].Set(Gf.Vec3d(0.3, 0, 0.5))


def edit_type(stage):
    stage.GetPrimAtPath("/World/lamps/Protos/lamp/bulb").SetTypeName("DiskLight")


@pytest.mark.parametrize(
    "edit", [edit_intensity, edit_positions, edit_copies, edit_bulb_place, edit_type]
)
def test_live_edits_of_instanced_lights_render_as_a_fresh_renderer(edit):
    stage = lamps_stage(instanced=True)
    assert_live_edit_renders_as_fresh(stage, lambda: edit(stage), **RENDER)


def test_copies_of_a_linked_light_are_named_and_light_everything():
    stage = lamps_stage(instanced=True)
    bulb = UsdLux.LightAPI(stage.GetPrimAtPath("/World/lamps/Protos/lamp/bulb"))
    bulb.GetLightLinkCollectionAPI().CreateExcludesRel().AddTarget("/World/wall")
    image, messages = render_with_warnings(stage, 40)
    assert messages == [
        "/World/lamps/Protos/lamp/bulb: the light and shadow links of lights in point-instancer "
        "prototypes are not supported yet; its copies light and shadow everything"
    ]
    assert image[..., :3].mean() > 0.05


def test_lights_of_an_instancer_inside_another_prototype_are_named_and_skipped():
    stage = wall_stage()
    add_lamp(stage, "/World/outer/Protos/group/inner/Protos/lamp")
    inner = "/World/outer/Protos/group/inner"
    add_instancer(stage, inner, f"{inner}/Protos/lamp", [(0.0, 0.0, 0.0)])
    add_instancer(stage, "/World/outer", "/World/outer/Protos/group", PLACES)
    image, messages = render_with_warnings(stage, 40)
    assert messages == [
        "/World/outer/Protos/group/inner: lights in the prototypes of a point instancer inside "
        "a native instance or another instancer's prototypes are not rendered yet; 1 skipped "
        "(first: "
        "/World/outer/Protos/group/inner/Protos/lamp/bulb)"
    ]
    assert image[..., :3].max() == 0  # the lamps' cards are there, unlit: no default light


def test_lights_of_native_instances_in_a_prototype_light_each_copy():
    # A prototype holding two native instances of one lamp: each copy had one bulb, silently.
    def stage_of(instanced: bool):
        stage = wall_stage()
        add_lamp(stage, "/Assets/lamp")
        stage.GetPrimAtPath("/Assets").SetSpecifier(Sdf.SpecifierClass)
        root = "/World/lamps/Protos/pair" if instanced else "/World/pair"
        UsdGeom.Xform.Define(stage, root)
        for name, x in (("a", -0.5), ("b", 0.5)):
            add_instance(stage, f"{root}/{name}", "/Assets/lamp", (x, 0.0, 0.0))
        if instanced:
            add_instancer(stage, "/World/lamps", root, [(0.0, 0.5, 0.0)])
        else:
            UsdGeom.Xform(stage.GetPrimAtPath(root)).AddTranslateOp().Set(Gf.Vec3d(0, 0.5, 0))
        return stage

    instanced = penumbra.Renderer(stage_of(True)).render(**RENDER)["color"]
    by_hand = penumbra.Renderer(stage_of(False)).render(**RENDER)["color"]
    np.testing.assert_allclose(instanced, by_hand, rtol=1e-5, atol=1e-5)


def test_copies_light_from_where_they_are_at_the_frame_as_lights_do():
    # Copies moving over the shutter had their lights at shutter open; lights do not blur.
    def stage_of(moving: bool):
        stage = lamps_stage(instanced=True)
        stage.RemovePrim("/World/lamps/Protos/lamp/shade")
        camera = UsdGeom.Camera(stage.GetPrimAtPath("/cam"))
        camera.CreateShutterOpenAttr(0.25)
        camera.CreateShutterCloseAttr(0.75)
        if moving:
            instancer = UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/lamps"))
            instancer.CreateVelocitiesAttr(Vt.Vec3fArray([(24, 0, 0), (0, 24, 0)]))
        return stage

    moving = penumbra.Renderer(stage_of(True)).render(time=1.0, **RENDER)["color"]
    still = penumbra.Renderer(stage_of(False)).render(time=1.0, **RENDER)["color"]
    np.testing.assert_array_equal(moving, still)


def test_dome_lights_in_prototypes_are_named_and_skipped():
    stage = lamps_stage(instanced=True)
    UsdLux.DomeLight.Define(stage, "/World/lamps/Protos/lamp/sky")
    _, messages = render_with_warnings(stage, 40)
    assert messages == [
        "/World/lamps/Protos/lamp/sky: dome lights in point-instancer prototypes are not copied; "
        "skipped"
    ]


def test_hiding_every_copy_keeps_the_default_light_off_as_hiding_the_lamps_does():
    # With every copy hidden the default light came on; hidden lamps placed by hand keep it off.
    stage = lamps_stage(instanced=True)
    UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/lamps")).CreateInvisibleIdsAttr(
        Vt.Int64Array([0, 1])
    )
    UsdGeom.Imageable(stage.GetPrimAtPath("/World/lamps")).MakeInvisible()
    image = penumbra.Renderer(stage).render(**RENDER)["color"]
    assert image[..., :3].max() == 0


def test_lights_of_a_point_instancer_in_a_native_instance_are_named_and_keep_the_default_off():
    # They were skipped as if nested in another instancer, and the default light came on.
    stage = wall_stage()
    add_lamp(stage, "/Set/lamps/Protos/lamp")
    add_instancer(stage, "/Set/lamps", "/Set/lamps/Protos/lamp", PLACES)
    stage.GetPrimAtPath("/Set").SetSpecifier(Sdf.SpecifierClass)
    add_instance(stage, "/World/set", "/Set")
    image, messages = render_with_warnings(stage, 40)
    assert len(messages) == 1 and messages[0].startswith(
        "/World/set/lamps: lights in the prototypes of a point instancer inside a native instance"
    ), messages
    assert image[..., :3].max() == 0


def test_copies_of_a_sphere_light_scaled_unevenly_are_named_once():
    # A lamp placed by hand with an uneven scale is named in a warning; its copies were not.
    stage = lamps_stage(instanced=True)
    UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/lamps")).CreateScalesAttr(
        Vt.Vec3fArray([(1, 2, 1), (1, 2, 1)])
    )
    _, messages = render_with_warnings(stage, 40)
    assert messages == [
        "/World/lamps/Protos/lamp/bulb: scaled unevenly (1, 2, 1); rendered as a sphere of the "
        "scales' geometric mean radius, not an ellipsoid (in its copies by /World/lamps)"
    ]
