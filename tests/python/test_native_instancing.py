"""Native instancing (instanceable prims sharing a USD prototype), nested instancing and spinning
point-instancer copies: every instanced mesh is one hidden mesh rprim whose copies share its BVH.

The camera of :func:`stages.add_camera` sees the square [-2, 2]² of the z = 0 plane."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt

import penumbra
from penumbra.usd.flattening import spin_matrices
from stages import (
    add_camera,
    add_distant_light,
    add_instance,
    add_preview_material,
    add_quad,
    add_sphere_mesh,
    assert_live_edit_renders_as_fresh,
    bind_through_a_collection,
    new_stage,
    render_with_warnings,
)

WIDTH = 40
SMALL = dict(camera="/cam", width=WIDTH, samples=1)


def at(image, x: float, y: float) -> np.ndarray:
    """RGBA of the pixel at plane point (x, y) of the view of [-2, 2]²."""
    height, width = image["color"].shape[:2]
    return image["color"][int((2 - y) / 4 * height), int((x + 2) / 4 * width)]


def hidden_meshes(renderer: penumbra.Renderer) -> list[str]:
    return sorted(p for p in renderer.delegate.prim_ids() if p.startswith("/prototypes/"))


def ball_grid_stage(instanceable: bool = True) -> Usd.Stage:
    """A 4 × 4 grid of references to one sphere prototype (radius 0.3)."""
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    add_sphere_mesh(stage, "/Proto/ball", radius=0.3)
    stage.GetPrimAtPath("/Proto").SetSpecifier(Sdf.SpecifierClass)
    for i in range(16):
        x, y = -1.5 + i % 4, -1.5 + i // 4
        add_instance(stage, f"/World/ball_{i}", "/Proto", (x, y, 0.0)).SetInstanceable(instanceable)
    return stage


def test_instances_render_as_the_flat_stage_with_one_hidden_mesh():
    flat = penumbra.Renderer(ball_grid_stage(instanceable=False))
    instanced = penumbra.Renderer(ball_grid_stage(instanceable=True))
    assert hidden_meshes(flat) == []
    assert hidden_meshes(instanced) == ["/prototypes/World/ball_0/ball"]
    assert not any(p.startswith("/World/ball_") for p in instanced.delegate.prim_ids())
    options = dict(camera="/cam", width=64, samples=4)
    expected = flat.render(**options)["color"]
    rendered = instanced.render(**options)["color"]
    # Same rays, same seeds: only float rounding of the placement (instance transform vs
    # transformed mesh) may move a hit, so an edge pixel may differ by one sample's weight.
    difference = np.abs(rendered - expected)
    assert rendered[..., 3].mean() > 0.2
    assert difference.mean() < 1e-3 and (difference > 1e-3).mean() < 0.01


def test_bindings_on_instance_roots_give_each_instance_its_material():
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    add_quad(stage, "/Proto/tile", half_size=0.4)
    stage.GetPrimAtPath("/Proto").SetSpecifier(Sdf.SpecifierClass)
    red = add_preview_material(stage, "/Looks/red", diffuseColor=(1.0, 0.0, 0.0))
    blue = add_preview_material(stage, "/Looks/blue", diffuseColor=(0.0, 0.0, 1.0))
    for name, x, material in (("a", -1.0, red), ("b", 1.0, blue), ("c", 0.0, red)):
        instance = add_instance(stage, f"/World/{name}", "/Proto", (x, 1.0, 0.0))
        UsdShade.MaterialBindingAPI.Apply(instance).Bind(material)
    renderer = penumbra.Renderer(stage)
    image = renderer.render(**SMALL)
    left, right, middle = at(image, -1, 1), at(image, 1, 1), at(image, 0, 1)
    assert left[0] > 5 * left[2] and middle[0] > 5 * middle[2] and right[2] > 5 * right[0]
    assert hidden_meshes(renderer) == [  # one mesh per (prototype mesh, material)
        "/prototypes/World/a/tile/materials/Looks/blue",
        "/prototypes/World/a/tile/materials/Looks/red",
    ]


def nested_stage() -> Usd.Stage:
    """/Pair holds two instances of /Tile (a quad) at x = ±0.5; two instances of /Pair at
    y = ±1 give four quads at (±0.5, ±1)."""
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    add_quad(stage, "/Tile/quad", half_size=0.2)
    UsdGeom.Xform.Define(stage, "/Pair")
    add_instance(stage, "/Pair/left", "/Tile", (-0.5, 0.0, 0.0))
    add_instance(stage, "/Pair/right", "/Tile", (0.5, 0.0, 0.0))
    for path in ("/Tile", "/Pair"):
        stage.GetPrimAtPath(path).SetSpecifier(Sdf.SpecifierClass)
    add_instance(stage, "/World/top", "/Pair", (0.0, 1.0, 0.0))
    add_instance(stage, "/World/bottom", "/Pair", (0.0, -1.0, 0.0))
    return stage


def covered(image) -> set[tuple[float, float]]:
    """Which of the points (x, y), x, y in {-1.5, -1, -0.5, 0, 0.5, 1, 1.5}, are covered."""
    grid = np.arange(-1.5, 1.6, 0.5)
    return {(x, y) for x in grid for y in grid if at(image, x, y)[3] > 0.5}


def test_nested_native_instances_flatten_into_one_instancer():
    renderer = penumbra.Renderer(nested_stage())
    image = renderer.render(**SMALL)
    assert covered(image) == {(x, y) for x in (-0.5, 0.5) for y in (-1.0, 1.0)}
    (mesh,) = hidden_meshes(renderer)
    assert mesh.endswith("/quad")


def nested_point_instancer_stage(inner: str) -> Usd.Stage:
    """An outer point instancer with copies at (±1, 1) of a prototype holding either an inner
    point instancer (``inner="instancer"``: copies at (0, ±0.5), turned a quarter by the
    prototype root's own rotation, so at (∓0.5, 0) from each outer copy) or an instanceable
    reference (``inner="instance"``: one copy offset by (0, -2))."""
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    outer = UsdGeom.PointInstancer.Define(stage, "/World/outer")
    root = UsdGeom.Xform.Define(stage, "/World/outer/Prototypes/cluster")
    if inner == "instancer":
        root.AddRotateZOp().Set(90.0)  # the prototype's own transform is part of each copy
        nested = UsdGeom.PointInstancer.Define(stage, "/World/outer/Prototypes/cluster/inner")
        add_quad(stage, "/World/outer/Prototypes/cluster/inner/Prototypes/tile", half_size=0.2)
        nested.CreatePrototypesRel().SetTargets(["/World/outer/Prototypes/cluster/inner/Prototypes/tile"])
        nested.CreatePositionsAttr(Vt.Vec3fArray([(0, 0.5, 0), (0, -0.5, 0)]))
        nested.CreateProtoIndicesAttr(Vt.IntArray([0, 0]))
    else:
        add_quad(stage, "/Tile/quad", half_size=0.2)
        stage.GetPrimAtPath("/Tile").SetSpecifier(Sdf.SpecifierClass)
        add_instance(stage, "/World/outer/Prototypes/cluster/ref", "/Tile", (0.0, -2.0, 0.0))
    outer.CreatePrototypesRel().SetTargets(["/World/outer/Prototypes/cluster"])
    outer.CreatePositionsAttr(Vt.Vec3fArray([(-1, 1, 0), (1, 1, 0)]))
    outer.CreateProtoIndicesAttr(Vt.IntArray([0, 0]))
    return stage


def test_point_instancer_prototypes_holding_instancers_and_instances():
    renderer = penumbra.Renderer(nested_point_instancer_stage("instancer"))
    image = renderer.render(**SMALL)
    assert covered(image) == {(-1.5, 1.0), (-0.5, 1.0), (0.5, 1.0), (1.5, 1.0)}
    assert len([p for p in renderer.delegate.prim_ids() if "/prototypes/" in p]) == 1
    image = penumbra.Renderer(nested_point_instancer_stage("instance")).render(**SMALL)
    assert covered(image) == {(-1.0, -1.0), (1.0, -1.0)}


def test_point_instancers_inside_native_prototypes():
    stage = nested_point_instancer_stage("instancer")
    stage.GetPrimAtPath("/World").SetSpecifier(Sdf.SpecifierClass)  # now a prototype source
    add_instance(stage, "/Shots/up", "/World", (0.0, 0.0, 0.0))
    add_instance(stage, "/Shots/down", "/World", (0.0, -2.0, 0.0))
    renderer = penumbra.Renderer(stage)
    image = renderer.render(**SMALL)
    assert covered(image) == {(x, y) for x in (-1.5, -0.5, 0.5, 1.5) for y in (1.0, -1.0)}
    assert len(hidden_meshes(renderer)) == 1  # copies of copies share the tile's BVH
    assert not any(p.startswith("/Shots") for p in renderer.delegate.prim_ids())


def test_spin_matches_usd_core_for_time_sampled_orientations():
    """usd-core applies angularVelocities to time-sampled orientations; Penumbra's spin of
    default-valued ones composes the same way (after the orientation, about the position)."""
    stage = Usd.Stage.CreateInMemory()
    instancer = UsdGeom.PointInstancer.Define(stage, "/pi")
    UsdGeom.Cube.Define(stage, "/pi/proto")
    instancer.CreatePrototypesRel().SetTargets(["/pi/proto"])
    instancer.CreateProtoIndicesAttr([0])
    instancer.CreatePositionsAttr().Set(Vt.Vec3fArray([(1, 2, 3)]), 0.0)
    orientation = Gf.Quath(Gf.Rotation(Gf.Vec3d(1, 0, 0), 90).GetQuat())
    instancer.CreateOrientationsAttr().Set(Vt.QuathArray([orientation]), 0.0)
    omega = np.array([[100.0, 200.0, 300.0]])  # degrees per second
    instancer.CreateAngularVelocitiesAttr().Set(Vt.Vec3fArray.FromNumpy(omega.astype(np.float32)), 0.0)
    seconds = 1.5 / stage.GetTimeCodesPerSecond()
    (usd,) = instancer.ComputeInstanceTransformsAtTime(1.5, 0.0)
    oriented = np.array(Gf.Matrix4d().SetRotate(Gf.Rotation(Gf.Vec3d(1, 0, 0), 90)))[:3, :3]
    ours = oriented @ spin_matrices(omega, np.array([seconds]))[0, 0]
    np.testing.assert_allclose(ours, np.array(usd)[:3, :3], atol=1e-3)


def spinning_bar_stage(degrees_per_second: float) -> Usd.Stage:
    """A point instancer copy of a thin bar (1.6 × 0.04) at the origin, positions and
    orientations default-valued, spinning about +Z; shutter [0, 1] at 24 time codes/s."""
    stage = new_stage()
    add_camera(stage).CreateShutterCloseAttr(1.0)
    add_distant_light(stage)
    instancer = UsdGeom.PointInstancer.Define(stage, "/World/spinner")
    bar = UsdGeom.Mesh.Define(stage, "/World/spinner/Prototypes/bar")
    bar.CreatePointsAttr([(-0.8, -0.02, 0), (0.8, -0.02, 0), (0.8, 0.02, 0), (-0.8, 0.02, 0)])
    bar.CreateFaceVertexCountsAttr([4])
    bar.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    bar.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    instancer.CreatePrototypesRel().SetTargets([bar.GetPath()])
    instancer.CreatePositionsAttr(Vt.Vec3fArray([(0, 0, 0)]))
    instancer.CreateProtoIndicesAttr(Vt.IntArray([0]))
    instancer.CreateAngularVelocitiesAttr(Vt.Vec3fArray([(0, 0, degrees_per_second)]))
    return stage


def test_angular_velocities_spin_copies_into_an_arc():
    degrees_per_second = 1440.0
    stage = spinning_bar_stage(degrees_per_second)
    swept = degrees_per_second * 1.0 / stage.GetTimeCodesPerSecond()  # shutter 1 code: 60°
    renderer = penumbra.Renderer(stage)
    image = renderer.render(camera="/cam", width=160, samples=64)
    radius = 0.6
    # The bar's other half sweeps 180° to 240°: its blurred start reaches just below 180°, so
    # look at the half from 0° to twice the swept angle.
    angles = np.arange(0.0, 2 * swept, 2.0)
    coverage = np.array(
        [at(image, radius * math.cos(math.radians(a)), radius * math.sin(math.radians(a)))[3] for a in angles]
    )
    inside = angles[coverage > 0.02]
    # Counter-clockwise (right-handed about +Z) from 0° to the swept angle, within a pixel.
    pixel_degrees = math.degrees(4 / 160 / radius)
    assert inside.min() <= pixel_degrees and abs(inside.max() - swept) <= 2 * pixel_degrees + 2
    # Inside the arc each point is covered for width / (r·θ) of the shutter.
    expected = 0.04 / (radius * math.radians(swept))
    middle = coverage[(angles > 10) & (angles < swept - 10)]
    assert middle.mean() == pytest.approx(expected, rel=0.35)
    sharp = renderer.render(camera="/cam", width=160, samples=4, disable_motion_blur=True)
    assert at(sharp, radius, 0.0)[3] > 0.5 and at(sharp, 0.0, radius)[3] == 0


def test_incremental_edits_of_native_instances():
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    add_quad(stage, "/Proto/tile", half_size=0.25)
    stage.GetPrimAtPath("/Proto").SetSpecifier(Sdf.SpecifierClass)
    left = add_instance(stage, "/World/left", "/Proto", (-1.0, 0.0, 0.0))
    add_instance(stage, "/World/right", "/Proto", (1.0, 0.0, 0.0))
    renderer = penumbra.Renderer(stage)
    image = renderer.render(**SMALL)
    assert at(image, -1, 0)[3] == 1 and at(image, 1, 0)[3] == 1
    (mesh,) = hidden_meshes(renderer)
    syncs = renderer.delegate.sync_count(mesh)

    # Moving an instance moves its copy; the prototype's mesh (and BVH) is not touched.
    left.GetAttribute("xformOp:translate").Set(Gf.Vec3d(-1.0, 1.0, 0.0))
    image = renderer.render(**SMALL)
    assert at(image, -1, 1)[3] == 1 and at(image, -1, 0)[3] == 0
    assert renderer.delegate.sync_count(mesh) == syncs

    # Editing the prototype's points reaches every instance.
    tile = stage.GetPrimAtPath("/Proto/tile")
    tile.GetAttribute("points").Set([(-0.6, -0.6, 0), (0.6, -0.6, 0), (0.6, 0.6, 0), (-0.6, 0.6, 0)])
    image = renderer.render(**SMALL)
    assert at(image, 1.5, 0.5)[3] == 1 and at(image, -1.5, 1.5)[3] == 1

    # Binding a material on an instance root recolours that instance only.
    green = add_preview_material(stage, "/Looks/green", diffuseColor=(0.0, 1.0, 0.0))
    UsdShade.MaterialBindingAPI.Apply(left).Bind(green)
    image = renderer.render(**SMALL)
    assert at(image, -1, 1)[1] > 5 * at(image, -1, 1)[0]
    assert at(image, 1, 0)[0] == pytest.approx(at(image, 1, 0)[1])

    # Not instanceable: rendered as ordinary meshes; instanceable again: copies again.
    left.SetInstanceable(False)
    image = renderer.render(**SMALL)
    assert renderer.delegate.has_prim("/World/left/tile")
    assert at(image, -1, 1)[1] > 5 * at(image, -1, 1)[0] and at(image, 1, 0)[3] == 1
    assert len(hidden_meshes(renderer)) == 1  # only the right instance is instanced now
    left.SetInstanceable(True)
    image = renderer.render(**SMALL)
    assert not renderer.delegate.has_prim("/World/left/tile")
    assert at(image, -1, 1)[1] > 5 * at(image, -1, 1)[0] and at(image, 1, 0)[3] == 1

    # Hiding an instance drops its copy.
    UsdGeom.Imageable(left).MakeInvisible()
    image = renderer.render(**SMALL)
    assert at(image, -1, 1)[3] == 0 and at(image, 1, 0)[3] == 1


def test_unreadable_prototype_mesh_warns_with_its_instance_path():
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    UsdGeom.Mesh.Define(stage, "/Proto/empty")
    stage.GetPrimAtPath("/Proto").SetSpecifier(Sdf.SpecifierClass)
    add_instance(stage, "/World/one", "/Proto")
    with pytest.warns(penumbra.PenumbraWarning, match=r"^/World/one/empty: mesh has no points"):
        penumbra.Renderer(stage).render(**SMALL)


def test_per_instance_primvars_colour_each_copy():
    """displayColor authored per instance colours the copies of one shared mesh: on a point
    instancer (vertex interpolation, one value per instance, invisibleIds masked alike) and on
    native instance roots (a constant primvar their prototype inherits), unless the mesh authors
    its own, which is nearer."""
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    add_quad(stage, "/World/scatter/protos/tile", half_size=0.3)
    instancer = UsdGeom.PointInstancer.Define(stage, "/World/scatter")
    instancer.CreatePrototypesRel().SetTargets(["/World/scatter/protos/tile"])
    instancer.CreateProtoIndicesAttr([0, 0, 0])
    instancer.CreatePositionsAttr([Gf.Vec3f(-1, 1, 0), Gf.Vec3f(0, 1, 0), Gf.Vec3f(1, 1, 0)])
    instancer.CreateInvisibleIdsAttr([1])
    colors = UsdGeom.PrimvarsAPI(instancer).CreatePrimvar(
        "displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.vertex
    )
    colors.Set([Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 1, 0), Gf.Vec3f(0, 0, 1)])
    add_quad(stage, "/Proto/tile", half_size=0.3)
    stage.GetPrimAtPath("/Proto").SetSpecifier(Sdf.SpecifierClass)
    for name, x, color in (("red", -1.0, (1, 0, 0)), ("blue", 1.0, (0, 0, 1))):
        instance = add_instance(stage, f"/World/{name}", "/Proto", (x, -1.0, 0.0))
        UsdGeom.PrimvarsAPI(instance).CreatePrimvar(
            "displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.constant
        ).Set([Gf.Vec3f(*color)])
    renderer = penumbra.Renderer(stage)
    image = renderer.render(**SMALL)
    for x, y, channel in ((-1, 1, 0), (1, 1, 2), (-1, -1, 0), (1, -1, 2)):
        rgb = at(image, x, y)[:3]
        assert rgb[channel] > 0.05 and rgb.sum() - rgb[channel] < 0.01 * rgb[channel], (x, y, rgb)
    assert at(image, 0, 1)[3] == 0.0  # the invisible copy
    assert len(hidden_meshes(renderer)) == 1  # the native instances still share one mesh

    # A displayColor on the prototype's mesh is nearer than the instances' and wins.
    UsdGeom.Mesh(stage.GetPrimAtPath("/Proto/tile")).CreateDisplayColorPrimvar(
        UsdGeom.Tokens.constant
    ).Set([Gf.Vec3f(0, 1, 0)])
    image = renderer.render(**SMALL)
    for x in (-1, 1):
        rgb = at(image, x, -1)[:3]
        assert rgb[1] > 0.05 and rgb[0] + rgb[2] < 0.01 * rgb[1], (x, rgb)


def red_or_blue(rgb) -> str:
    """Which of red, blue or neither (grey) a lit pixel shows."""
    if rgb[0] > 10 * rgb[2]:
        return "red"
    if rgb[2] > 10 * rgb[0]:
        return "blue"
    return "grey"


def test_per_instance_primvars_follow_usd_inheritance_and_time():
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    add_quad(stage, "/Proto/tile", half_size=0.3)
    UsdGeom.Xform.Define(stage, "/Pair")
    inner = add_instance(stage, "/Pair/inner", "/Proto", (0.0, 0.0, 0.0))
    for path in ("/Proto", "/Pair"):
        stage.GetPrimAtPath(path).SetSpecifier(Sdf.SpecifierClass)
    red = [Gf.Vec3f(1, 0, 0)]

    def color(prim, value, time=None, interpolation=UsdGeom.Tokens.constant):
        primvar = UsdGeom.PrimvarsAPI(prim).CreatePrimvar(
            "displayColor", Sdf.ValueTypeNames.Color3fArray, interpolation
        )
        primvar.Set(value) if time is None else primvar.Set(value, time)

    # Only one of two instances authors a colour: the other keeps the mesh's grey.
    a = add_instance(stage, "/World/a", "/Proto", (-1.0, 1.0, 0.0))
    add_instance(stage, "/World/b", "/Proto", (1.0, 1.0, 0.0))
    color(a, red)
    # A colour on an instance nested in a prototype reaches its copies.
    color(inner, red)
    add_instance(stage, "/World/pair", "/Pair", (-1.0, -1.0, 0.0))
    # A point instancer's per-instance colour may be animated; its constant primvar does not
    # override the prototype mesh's own colour (which is nearer).
    add_quad(stage, "/World/scatter/protos/tile", half_size=0.3)
    color(stage.GetPrimAtPath("/World/scatter/protos/tile"), [Gf.Vec3f(0, 0, 1)])
    instancer = UsdGeom.PointInstancer.Define(stage, "/World/scatter")
    instancer.CreatePrototypesRel().SetTargets(["/World/scatter/protos/tile"])
    instancer.CreateProtoIndicesAttr([0])
    instancer.CreatePositionsAttr([Gf.Vec3f(1.0, -1.0, 0.0)])
    UsdGeom.PrimvarsAPI(instancer).CreatePrimvar(
        "displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.constant
    ).Set(red)

    renderer = penumbra.Renderer(stage)
    image = renderer.render(**SMALL)
    assert red_or_blue(at(image, -1, 1)[:3]) == "red"
    assert red_or_blue(at(image, 1, 1)[:3]) == "grey"
    assert red_or_blue(at(image, -1, -1)[:3]) == "red"
    assert red_or_blue(at(image, 1, -1)[:3]) == "blue"

    # Animated per-instance colour: the same renderer follows the time code.
    color(instancer.GetPrim(), [Gf.Vec3f(1, 0, 0)], 1.0, UsdGeom.Tokens.vertex)
    color(instancer.GetPrim(), [Gf.Vec3f(0, 0, 1)], 2.0, UsdGeom.Tokens.vertex)
    UsdGeom.Mesh(stage.GetPrimAtPath("/World/scatter/protos/tile")).GetDisplayColorAttr().Clear()
    assert red_or_blue(at(renderer.render(time=1.0, **SMALL), 1, -1)[:3]) == "red"
    assert red_or_blue(at(renderer.render(time=2.0, **SMALL), 1, -1)[:3]) == "blue"


def test_prim_ids_do_not_depend_on_how_usd_numbered_its_prototypes():
    # USD names prototypes (/__Prototype_N) in an order that varies from one opening of a stage
    # to the next: hidden meshes are named and inserted by their instances' paths instead.
    path = Path(__file__).parents[1] / "assets" / "usd-wg" / "full_assets" / "SubdivisionSurfaces"
    stage = path / "Creases_SpinningPyramids.usda"
    renders = [
        penumbra.render(str(stage), width=48, samples=1, aovs=("primId",)) for _ in range(4)
    ]
    manifest = json.loads(renders[0].metadata["primIds"])
    assert len(manifest) == 3 and not any("__Prototype" in name for name in manifest.values())
    for image in renders[1:]:
        np.testing.assert_array_equal(image["primId"], renders[0]["primId"])
        assert json.loads(image.metadata["primIds"]) == manifest


def test_editing_a_collection_that_binds_materials_recolours_the_instances():
    # A collection-based binding's collection gaining an instance left its copy in its old
    # material until a new Renderer (a plain mesh was recoloured).
    stage = ball_grid_stage()
    green = add_preview_material(stage, "/Looks/green", diffuseColor=(0, 1, 0))
    collection = bind_through_a_collection(stage, "/World", green)
    assert_live_edit_renders_as_fresh(
        stage, lambda: collection.CreateIncludesRel().AddTarget("/World/ball_5"), **SMALL
    )
