"""Per-face material bindings: GeomSubsets of family "materialBind" bind materials of their own
to the faces they list (UsdShade), on polygon meshes and subdivision surfaces, in fresh renders
and through live edits."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt

import penumbra
from stages import (
    add_camera,
    add_instance,
    add_instancer,
    add_preview_material,
    assert_live_edit_renders_as_fresh,
    bind,
    emitter_stage,
    pixel,
    render_with_warnings,
)

BLUE, RED, GREEN, WHITE = (0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1.0, 1.0, 1.0)
# Where the camera sees each face of the 2 x 2 grid: faces 0 and 1 below, 2 and 3 above.
FACE_CENTRES = ((0.25, 0.75), (0.75, 0.75), (0.25, 0.25), (0.75, 0.25))
RENDER = dict(camera="/cam", width=64, samples=4, seed=1, max_path_depth=0)


def emitter(stage, name: str, colour) -> UsdShade.Material:
    """A black material emitting radiance ``colour``: with max_path_depth 0 the image is it."""
    return add_preview_material(
        stage, f"/Looks/{name}", diffuseColor=(0.0, 0.0, 0.0), emissiveColor=colour
    )


def add_grid(stage, path: str, half_size: float = 2.0, scheme: str = "none") -> UsdGeom.Mesh:
    """A 2 x 2 grid of quads over [-half_size, half_size]² of the z = 0 plane."""
    mesh = UsdGeom.Mesh.Define(stage, path)
    coordinates = (-half_size, 0, half_size)
    mesh.CreatePointsAttr([Gf.Vec3f(x, y, 0) for y in coordinates for x in coordinates])
    mesh.CreateFaceVertexCountsAttr([4] * 4)
    mesh.CreateFaceVertexIndicesAttr([0, 1, 4, 3, 1, 2, 5, 4, 3, 4, 7, 6, 4, 5, 8, 7])
    mesh.CreateSubdivisionSchemeAttr(scheme)
    return mesh


def grid_stage(scheme: str = "none"):
    """A 2 x 2 grid of quads filling the view, bound to blue, on black."""
    stage = emitter_stage()
    add_camera(stage)
    mesh = add_grid(stage, "/World/grid", scheme=scheme)
    bind(mesh, emitter(stage, "blue", BLUE))
    return stage, mesh


def bind_subset(mesh: UsdGeom.Imageable, name: str, faces, material) -> UsdGeom.Subset:
    subset = UsdShade.MaterialBindingAPI(mesh.GetPrim()).CreateMaterialBindSubset(
        name, Vt.IntArray(faces)
    )
    UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(material)
    return subset


def face_colours(image) -> list[tuple[float, ...]]:
    return [tuple(float(c) for c in pixel(image, u, v)) for u, v in FACE_CENTRES]


@pytest.mark.parametrize("scheme", ["none", "catmullClark"])
def test_subsets_bind_their_faces_and_the_rest_keep_the_mesh_material(scheme: str):
    stage, mesh = grid_stage(scheme)
    bind_subset(mesh, "a", [1], emitter(stage, "red", RED))
    bind_subset(mesh, "b", [2, 3], emitter(stage, "green", GREEN))
    image, warnings = render_with_warnings(stage, 64)
    assert warnings == []
    image = penumbra.Renderer(stage).render(**RENDER)
    assert face_colours(image) == [BLUE, RED, GREEN, GREEN]


def test_overlapping_subsets_give_a_face_to_the_first():
    stage, mesh = grid_stage()
    bind_subset(mesh, "a", [0, 3], emitter(stage, "red", RED))
    bind_subset(mesh, "b", [3, 2], emitter(stage, "green", GREEN))
    assert face_colours(penumbra.Renderer(stage).render(**RENDER)) == [RED, BLUE, GREEN, RED]


def test_a_subset_without_a_binding_keeps_the_mesh_material():
    stage, mesh = grid_stage()
    UsdShade.MaterialBindingAPI(mesh.GetPrim()).CreateMaterialBindSubset("bare", Vt.IntArray([0]))
    bind_subset(mesh, "a", [1], emitter(stage, "red", RED))
    assert face_colours(penumbra.Renderer(stage).render(**RENDER)) == [BLUE, RED, BLUE, BLUE]


def test_subsets_bind_faces_of_an_unbound_mesh():
    stage, mesh = grid_stage()
    UsdShade.MaterialBindingAPI(mesh.GetPrim()).UnbindAllBindings()
    mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(0.5)])
    bind_subset(mesh, "a", [1], emitter(stage, "red", RED))
    colours = face_colours(penumbra.Renderer(stage).render(**RENDER))
    assert colours[1] == RED
    assert colours[0] == colours[2] == colours[3] == (0.0, 0.0, 0.0)  # grey, not emitting


def test_a_subset_material_that_cuts_out_its_faces_leaves_the_others():
    stage, mesh = grid_stage()
    hole = add_preview_material(stage, "/Looks/hole", opacity=0.0, opacityThreshold=0.5)
    bind_subset(mesh, "a", [1, 2], hole)
    alpha = penumbra.Renderer(stage).render(**RENDER)["color"][..., 3]
    seen = [float(alpha[int(v * 64), int(u * 64)]) for u, v in FACE_CENTRES]
    assert seen == [1.0, 0.0, 0.0, 1.0]


def test_faces_of_a_subset_show_where_the_mesh_material_cuts_the_rest_out():
    stage, mesh = grid_stage()
    bind(mesh, add_preview_material(stage, "/Looks/hole", opacity=0.0, opacityThreshold=0.5))
    bind_subset(mesh, "a", [3], emitter(stage, "red", RED))
    image = penumbra.Renderer(stage).render(**RENDER)
    alpha = image["color"][..., 3]
    assert [float(alpha[int(v * 64), int(u * 64)]) for u, v in FACE_CENTRES] == [0, 0, 0, 1]
    assert face_colours(image)[3] == RED


def test_indices_outside_the_faces_and_other_element_types_are_named_and_left_out():
    stage, mesh = grid_stage()
    bind_subset(mesh, "a", [1, 7, -1], emitter(stage, "red", RED))
    points = bind_subset(mesh, "b", [2], emitter(stage, "green", GREEN))
    points.GetElementTypeAttr().Set(UsdGeom.Tokens.point)
    image, warnings = render_with_warnings(stage, 64)
    assert len(warnings) == 3, warnings
    assert any("/World/grid/a.indices: 1 of 3 indices are negative" in w for w in warnings)
    assert any(
        "/World/grid/a.indices: 1 of 3 indices are not faces of the mesh (it has 4" in w
        for w in warnings
    )
    assert any("/World/grid/b" in w and "elementType 'point'" in w for w in warnings)
    colours = face_colours(penumbra.Renderer(stage).render(**RENDER))
    assert colours == [BLUE, RED, BLUE, BLUE]


def test_a_subset_binding_through_a_collection_binds_its_faces():
    stage, mesh = grid_stage()
    subset = UsdShade.MaterialBindingAPI(mesh.GetPrim()).CreateMaterialBindSubset(
        "a", Vt.IntArray([2])
    )
    collection = Sdf.Path("/World.collection:painted")
    api = UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath("/World"))
    painted = Usd.CollectionAPI.Apply(stage.GetPrimAtPath("/World"), "painted")
    painted.CreateIncludesRel().AddTarget(subset.GetPath())
    # Stronger than descendants: else the mesh's own binding, nearer the subset, would win.
    api.Bind(
        painted, emitter(stage, "green", GREEN), "painted", UsdShade.Tokens.strongerThanDescendants
    )
    assert collection == painted.GetCollectionPath()
    colours = face_colours(penumbra.Renderer(stage).render(**RENDER))
    assert colours == [BLUE, BLUE, GREEN, BLUE]


def remove_top_faces(mesh: UsdGeom.Mesh) -> None:
    mesh.GetFaceVertexCountsAttr().Set([4, 4])
    mesh.GetFaceVertexIndicesAttr().Set([0, 1, 4, 3, 1, 2, 5, 4])


def edited_grid():
    stage, mesh = grid_stage()
    subset = bind_subset(mesh, "a", [1], emitter(stage, "red", RED))
    emitter(stage, "green", GREEN)
    return stage, mesh, subset


@pytest.mark.parametrize(
    "edit",
    [
        lambda stage, mesh, subset: subset.GetIndicesAttr().Set(Vt.IntArray([0, 3])),
        lambda stage, mesh, subset: UsdShade.MaterialBindingAPI(subset.GetPrim()).Bind(
            UsdShade.Material(stage.GetPrimAtPath("/Looks/green"))
        ),
        lambda stage, mesh, subset: stage.RemovePrim(subset.GetPath()),
        lambda stage, mesh, subset: bind_subset(
            mesh, "b", [2], UsdShade.Material(stage.GetPrimAtPath("/Looks/green"))
        ),
        lambda stage, mesh, subset: subset.GetElementTypeAttr().Set(UsdGeom.Tokens.point),
        lambda stage, mesh, subset: stage.GetPrimAtPath("/Looks/red/Surface")
        .GetAttribute("inputs:emissiveColor")
        .Set(Gf.Vec3f(*WHITE)),
        lambda stage, mesh, subset: remove_top_faces(mesh),
    ],
    ids=[
        "indices",
        "binding",
        "subset removed",
        "subset added",
        "element type",
        "material edited",
        "faces removed",
    ],
)
def test_live_edits_of_subsets_render_as_a_fresh_renderer(edit):
    stage, mesh, subset = edited_grid()
    assert_live_edit_renders_as_fresh(stage, lambda: edit(stage, mesh, subset), **RENDER)


def test_animated_subset_indices_follow_the_frame():
    stage, mesh, subset = edited_grid()
    subset.GetIndicesAttr().Set(Vt.IntArray([1]), 1)
    subset.GetIndicesAttr().Set(Vt.IntArray([2]), 2)
    renderer = penumbra.Renderer(stage)
    first = renderer.render(time=1.0, **RENDER)
    second = renderer.render(time=2.0, **RENDER)
    assert face_colours(first) == [BLUE, RED, BLUE, BLUE]
    assert face_colours(second) == [BLUE, BLUE, RED, BLUE]
    np.testing.assert_array_equal(
        second["color"], penumbra.Renderer(stage).render(time=2.0, **RENDER)["color"]
    )


def instanced_grid_stage():
    """A prototype grid (faces 0.5 wide, blue, its face 1 red and faces 2 and 3 green through
    subsets), and two copies of it, centred at x = -1 and x = +1."""
    stage = emitter_stage()
    add_camera(stage)
    mesh = add_grid(stage, "/Proto/grid", half_size=0.5)
    bind(mesh, emitter(stage, "blue", BLUE))
    bind_subset(mesh, "a", [1], emitter(stage, "red", RED))
    bind_subset(mesh, "b", [2, 3], emitter(stage, "green", GREEN))
    emitter(stage, "white", WHITE)
    return stage, mesh


def add_instances(stage, names_and_x=(("left", -1.0), ("right", 1.0))) -> None:
    """Makes ``/Proto`` a class and places native instances of it at ``/World/<name>``."""
    stage.GetPrimAtPath("/Proto").SetSpecifier(Sdf.SpecifierClass)
    for name, x in names_and_x:
        add_instance(stage, f"/World/{name}", "/Proto", (x, 0.0, 0.0))


def copy_face_colours(image, centre_x: float) -> list[tuple[float, ...]]:
    """The colours of the faces of a grid copy centred at (centre_x, 0) (camera sees [-2, 2]²)."""
    colour = image["color"]
    size = colour.shape[0]
    result = []
    for dx, dy in ((-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)):
        x, y = centre_x + dx, dy
        row, column = int((2 - y) / 4 * size), int((x + 2) / 4 * size)
        result.append(tuple(float(c) for c in colour[row, column, :3]))
    return result


def test_native_instances_render_their_prototype_subsets_and_their_own_bindings():
    stage, _ = instanced_grid_stage()
    add_instances(stage)
    # The right copy's subset "a" is white: a collection-based binding on the instance root,
    # stronger than the prototype's own, names its instance proxy.
    right = stage.GetPrimAtPath("/World/right")
    painted = Usd.CollectionAPI.Apply(right, "painted")
    painted.CreateIncludesRel().AddTarget("/World/right/grid/a")
    UsdShade.MaterialBindingAPI.Apply(right).Bind(
        painted,
        UsdShade.Material(stage.GetPrimAtPath("/Looks/white")),
        "painted",
        UsdShade.Tokens.strongerThanDescendants,
    )
    image, warnings = render_with_warnings(stage, 64)
    assert warnings == []
    image = penumbra.Renderer(stage).render(**RENDER)
    assert copy_face_colours(image, -1.0) == [BLUE, RED, GREEN, GREEN]
    assert copy_face_colours(image, 1.0) == [BLUE, WHITE, GREEN, GREEN]


def scattered_grid_stage():
    """:func:`instanced_grid_stage`'s grid as the prototype of a point instancer's two copies."""
    stage, _ = instanced_grid_stage()
    add_instancer(stage, "/World/scatter", "/World/scatter/protos/tile", [(-1, 0, 0), (1, 0, 0)])
    stage.DefinePrim("/World/scatter/protos")
    Sdf.CopySpec(stage.GetRootLayer(), "/Proto", stage.GetRootLayer(), "/World/scatter/protos/tile")
    stage.RemovePrim("/Proto")
    return stage


def test_point_instancer_copies_render_their_prototype_subsets():
    stage = scattered_grid_stage()
    image, warnings = render_with_warnings(stage, 64)
    assert warnings == []
    image = penumbra.Renderer(stage).render(**RENDER)
    assert copy_face_colours(image, -1.0) == [BLUE, RED, GREEN, GREEN]
    assert copy_face_colours(image, 1.0) == [BLUE, RED, GREEN, GREEN]


def test_editing_a_prototype_subset_renders_instances_as_a_fresh_renderer():
    stage, mesh = instanced_grid_stage()
    add_instances(stage)
    subset = UsdGeom.Subset(stage.GetPrimAtPath("/Proto/grid/a"))
    assert_live_edit_renders_as_fresh(
        stage, lambda: subset.GetIndicesAttr().Set(Vt.IntArray([0])), **RENDER
    )


def test_subsets_of_a_gprim_other_than_a_mesh_are_named_and_left_out():
    stage = emitter_stage()
    add_camera(stage)
    cube = UsdGeom.Cube.Define(stage, "/World/cube")
    bind(cube, emitter(stage, "blue", BLUE))
    bind_subset(cube, "a", [0], emitter(stage, "red", RED))
    image, warnings = render_with_warnings(stage, 64)
    assert warnings == [
        "/World/cube: per-face material bindings (GeomSubsets) are read on Mesh prims only; "
        "this Cube's own binding is used"
    ]
    image = penumbra.Renderer(stage).render(**RENDER)
    assert tuple(float(c) for c in pixel(image, 0.5, 0.5)) == BLUE


def test_editing_a_point_instancer_prototype_subset_renders_as_a_fresh_renderer():
    stage = scattered_grid_stage()
    subset = UsdGeom.Subset(stage.GetPrimAtPath("/World/scatter/protos/tile/grid/a"))
    assert_live_edit_renders_as_fresh(
        stage, lambda: subset.GetIndicesAttr().Set(Vt.IntArray([0])), **RENDER
    )


def test_indices_past_the_faces_bind_the_faces_the_mesh_gains_at_other_times():
    # Indices past the faces at the first time read were dropped for good: a mesh that gained
    # those faces later kept its own material there (live and CLI renders alike).
    stage, mesh = grid_stage()
    mesh.GetFaceVertexCountsAttr().Set([4, 4], 1)
    mesh.GetFaceVertexIndicesAttr().Set([0, 1, 4, 3, 1, 2, 5, 4], 1)
    mesh.GetFaceVertexCountsAttr().Set([4] * 4, 2)
    mesh.GetFaceVertexIndicesAttr().Set([0, 1, 4, 3, 1, 2, 5, 4, 3, 4, 7, 6, 4, 5, 8, 7], 2)
    bind_subset(mesh, "a", [1, 3], emitter(stage, "red", RED))
    renderer = penumbra.Renderer(stage)
    renderer.render(time=1.0, **RENDER)
    live = renderer.render(time=2.0, **RENDER)
    assert face_colours(live) == [BLUE, RED, BLUE, RED]
    fresh = penumbra.Renderer(stage).render(time=2.0, **RENDER)
    np.testing.assert_array_equal(live["color"], fresh["color"])


def test_a_subset_material_an_instance_does_not_render_is_not_read():
    stage, mesh = instanced_grid_stage()
    UsdGeom.Subset(stage.GetPrimAtPath("/Proto/grid/a")).GetElementTypeAttr().Set(
        UsdGeom.Tokens.point
    )
    add_instances(stage, [("copy", 0.0)])
    renderer = penumbra.Renderer(stage)
    renderer.render(**RENDER)
    assert renderer.delegate.has_prim("/Looks/green")
    assert not renderer.delegate.has_prim("/Looks/red")  # subset "a" binds no face


def test_subsets_of_an_instanced_gprim_other_than_a_mesh_are_named():
    stage = emitter_stage()
    add_camera(stage)
    cube = UsdGeom.Cube.Define(stage, "/Proto/cube")
    bind_subset(cube, "a", [0], emitter(stage, "red", RED))
    add_instances(stage, [("copy", 0.0)])
    _, warnings = render_with_warnings(stage, 32)
    assert warnings == [
        "/World/copy/cube: per-face material bindings (GeomSubsets) are read on Mesh prims "
        "only; this Cube's own binding is used"
    ]
