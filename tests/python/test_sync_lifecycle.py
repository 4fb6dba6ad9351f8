"""The render delegate's lifecycle (docs/architecture.md): each kind of edit syncs only what it
must — no re-dicing or BVH rebuild for a primvar, sidedness, material, visibility or transform
edit; an edit of one material or light builds that sprim alone, opening no other material's
textures and loading no other light's — the image after edits is bit-identical to a fresh
render of the edited stage, and moving the view camera re-dices nothing unless a dicing camera
is asked for and moved."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

import penumbra
from stages import add_camera, add_preview_material, add_quad, bind, lit_quad_stage
from test_api import sync_counts
from test_textures import quadrants, write_texture

FAST = dict(camera="/cam", width=32, samples=4)
# The faces of a cube whose corner k is at (k & 4, k & 2, k & 1), counter-clockwise from outside.
CUBE_FACE_INDICES = [0, 1, 3, 2, 2, 3, 7, 6, 6, 7, 5, 4, 4, 5, 1, 0, 1, 5, 7, 3, 4, 0, 2, 6]


def subdivided_cube(stage, path: str, center=(0.0, 0.0, 0.0)) -> UsdGeom.Mesh:
    """A Catmull-Clark cube of side 1 (its limit surface is a rounded blob)."""
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(
        [Gf.Vec3f(x - 0.5, y - 0.5, z - 0.5) for x in (0, 1) for y in (0, 1) for z in (0, 1)]
    )
    mesh.CreateFaceVertexCountsAttr([4] * 6)
    mesh.CreateFaceVertexIndicesAttr(CUBE_FACE_INDICES)
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.catmullClark)
    mesh.AddTranslateOp().Set(Gf.Vec3d(*center))
    return mesh


def edit_stage():
    stage = lit_quad_stage()
    add_quad(stage, "/World/painted", center=(1.2, 1.2, 0.1), half_size=0.5, color=(0.2, 0.6, 0.2))
    # Wound clockwise: the camera sees its back, which a single-sided mesh does not show.
    flipped = add_quad(stage, "/World/flipped", center=(1.2, -1.2, 0.1), half_size=0.5)
    flipped.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
    material = add_preview_material(stage, "/World/Looks/paint", diffuseColor=(0.1, 0.7, 0.1))
    bind(UsdGeom.Mesh(stage.GetPrimAtPath("/World/quad")), material)
    subdivided_cube(stage, "/World/blob", center=(-1.0, -1.0, 0.5))
    return stage


def _set_display_color(stage):
    UsdGeom.Gprim(stage.GetPrimAtPath("/World/painted")).GetDisplayColorAttr().Set(
        [Gf.Vec3f(0.9, 0.1, 0.1)]
    )


def _set_double_sided(stage):
    UsdGeom.Gprim(stage.GetPrimAtPath("/World/flipped")).GetDoubleSidedAttr().Set(True)


def _set_material_input(stage):
    shader = stage.GetPrimAtPath("/World/Looks/paint/Surface")
    shader.GetAttribute("inputs:diffuseColor").Set(Gf.Vec3f(0.7, 0.1, 0.1))


def _move(stage):
    stage.GetPrimAtPath("/World/painted").GetAttribute("xformOp:translate").Set(
        Gf.Vec3d(0.9, 1.1, 0.1)
    )


def _move_subdivided(stage):
    stage.GetPrimAtPath("/World/blob").GetAttribute("xformOp:translate").Set(
        Gf.Vec3d(-0.8, -1.0, 0.5)
    )


def _hide(stage):
    UsdGeom.Imageable(stage.GetPrimAtPath("/World/painted")).MakeInvisible()


def _set_points(stage):
    UsdGeom.Mesh(stage.GetPrimAtPath("/World/painted")).GetPointsAttr().Set(
        [Gf.Vec3f(-0.4, -0.5, 0), Gf.Vec3f(0.5, -0.5, 0), Gf.Vec3f(0.5, 0.5, 0), Gf.Vec3f(-0.5, 0.5, 0)]
    )


# edit, the prims it syncs again, mesh geometry syncs, BVH builds, subdivision dicings
EDITS = {
    "displayColor": (_set_display_color, {"/World/painted"}, 1, 0, 0),
    "doubleSided": (_set_double_sided, {"/World/flipped"}, 1, 0, 0),
    "material input": (_set_material_input, {"/World/Looks/paint"}, 0, 0, 0),
    "transform": (_move, {"/World/painted"}, 0, 0, 0),
    "subdivision surface transform": (_move_subdivided, {"/World/blob"}, 0, 0, 0),
    "visibility": (_hide, {"/World/painted"}, 0, 0, 0),
    "points": (_set_points, {"/World/painted"}, 1, 1, 0),
}


@pytest.mark.parametrize("kind", EDITS)
def test_an_edit_syncs_only_what_it_must(kind):
    edit, synced, geometry_syncs, bvh_builds, dicings = EDITS[kind]
    stage = edit_stage()
    renderer = penumbra.Renderer(stage)
    before_image = renderer.render(**FAST)
    before, stats = sync_counts(renderer), renderer.delegate.sync_statistics()
    edit(stage)
    edited = renderer.render(**FAST)
    after, stats_after = sync_counts(renderer), renderer.delegate.sync_statistics()
    assert {p for p in after if after[p] != before[p]} == synced
    assert stats_after["meshGeometrySyncs"] - stats["meshGeometrySyncs"] == geometry_syncs
    assert stats_after["meshBvhBuilds"] - stats["meshBvhBuilds"] == bvh_builds
    assert stats_after["subdivisionDicings"] - stats["subdivisionDicings"] == dicings
    assert not np.array_equal(edited["color"], before_image["color"])  # the edit shows
    fresh = penumbra.Renderer(stage).render(**FAST)
    np.testing.assert_array_equal(edited["color"], fresh["color"])


def test_each_render_dices_for_its_own_camera_as_a_fresh_renderer_does():
    # A frame's facets depend on that frame alone, so that farm workers, a resumed sequence and
    # a fresh process dice it alike (the first render's camera and width had been kept: 416 of
    # 544 pixels of a dolly's last frame differed between a farm and a local range).
    stage = edit_stage()
    add_camera(stage, "/side", translate=(2.0, 0.0, 5.0))
    renderer = penumbra.Renderer(stage)
    renderer.render(**FAST)
    stage.GetPrimAtPath("/cam").GetAttribute("xformOp:translate").Set(Gf.Vec3d(0.5, 0.0, 2.0))
    for options in (FAST, {**FAST, "camera": "/side", "width": 48}):
        image = renderer.render(**options)
        fresh = penumbra.Renderer(stage).render(**options)
        np.testing.assert_array_equal(image["color"], fresh["color"])


def test_a_pinned_dicing_camera_re_dices_nothing_when_the_view_moves_or_switches():
    stage = edit_stage()
    add_camera(stage, "/side", translate=(2.0, 0.0, 5.0))
    renderer = penumbra.Renderer(stage)
    renderer.render(**FAST, dicing_camera="/side")
    stats = renderer.delegate.sync_statistics()
    blob = renderer.delegate.sync_count("/World/blob")
    stage.GetPrimAtPath("/cam").GetAttribute("xformOp:translate").Set(Gf.Vec3d(0.5, 0.0, 2.0))
    renderer.render(**FAST)
    renderer.render(**{**FAST, "camera": "/side"})
    assert renderer.delegate.sync_statistics() == stats
    assert renderer.delegate.sync_count("/World/blob") == blob


def test_a_dicing_camera_re_dices_as_it_moves():
    stage = edit_stage()
    renderer = penumbra.Renderer(stage)
    renderer.render(**FAST, dicing_camera="/cam")
    assert renderer.delegate.dicing_camera() == "/cam"
    dicings = renderer.delegate.sync_statistics()["subdivisionDicings"]
    stage.GetPrimAtPath("/cam").GetAttribute("xformOp:translate").Set(Gf.Vec3d(0.0, 0.0, 2.0))
    moved = renderer.render(**FAST)
    assert renderer.delegate.sync_statistics()["subdivisionDicings"] == dicings + 1
    # The blob is diced for the camera where it is now, as a fresh renderer dices it.
    np.testing.assert_array_equal(moved["color"], penumbra.Renderer(stage).render(**FAST)["color"])


def textured_material(stage, path: str, file) -> UsdShade.Material:
    """A UsdPreviewSurface whose diffuseColor reads a UsdUVTexture of ``file``."""
    material = add_preview_material(stage, path, roughness=0.5)
    texture = UsdShade.Shader.Define(stage, f"{path}/Texture")
    texture.CreateIdAttr("UsdUVTexture")
    texture.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(str(file)))
    surface = UsdShade.Shader(stage.GetPrimAtPath(f"{path}/Surface"))
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        texture.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    )
    return material


def sprim_stage(tmp_path):
    """edit_stage with a textured material on /World/painted, a material whose texture is
    missing on /World/flipped, and a textured dome and a rect light besides the sun."""
    stage = edit_stage()
    checker = write_texture(tmp_path / "checker.exr", quadrants(8))
    painted = UsdGeom.Mesh(stage.GetPrimAtPath("/World/painted"))
    bind(painted, textured_material(stage, "/World/Looks/textured", checker))
    flipped = UsdGeom.Mesh(stage.GetPrimAtPath("/World/flipped"))
    bind(flipped, textured_material(stage, "/World/Looks/missing", tmp_path / "nowhere.exr"))
    sky = np.zeros((4, 8, 3), dtype=np.float32)
    sky[:, :, 0] = np.linspace(0.1, 0.8, 8)
    sky[:, :, 1] = 0.3
    dome = UsdLux.DomeLight.Define(stage, "/World/sky")
    dome.CreateIntensityAttr(0.5)
    dome.CreateTextureFileAttr(Sdf.AssetPath(str(write_texture(tmp_path / "sky.exr", sky))))
    rect = UsdLux.RectLight.Define(stage, "/World/panel")
    rect.CreateIntensityAttr(4.0)
    rect.AddTranslateOp().Set(Gf.Vec3d(0.5, 0.5, 2.0))
    return stage


def render_quietly(renderer) -> tuple[dict, list[str]]:
    """A render of the FAST view, and the messages of the warnings it gave."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = renderer.render(**FAST)
    messages = [str(w.message) for w in caught if issubclass(w.category, penumbra.PenumbraWarning)]
    return image, messages


def fresh_render(stage) -> np.ndarray:
    return render_quietly(penumbra.Renderer(stage))[0]["color"]


def test_a_material_edit_builds_that_material_alone(tmp_path):
    stage = sprim_stage(tmp_path)
    renderer = penumbra.Renderer(stage)
    before, messages = render_quietly(renderer)
    assert any("nowhere.exr" in m for m in messages)  # reported when it first syncs
    counts, stats = sync_counts(renderer), renderer.delegate.sync_statistics()

    _set_material_input(stage)  # /World/Looks/paint, untextured
    edited, messages = render_quietly(renderer)
    after = renderer.delegate.sync_statistics()
    assert {p for p, n in sync_counts(renderer).items() if n != counts[p]} == {"/World/Looks/paint"}
    assert after["materialBuilds"] - stats["materialBuilds"] == 1
    assert after["materialTextureOpens"] == stats["materialTextureOpens"]  # none reopened
    assert messages == []  # the missing texture is not reported again
    assert not np.array_equal(edited["color"], before["color"])
    np.testing.assert_array_equal(edited["color"], fresh_render(stage))

    # A textured material opens its own texture, and no other.
    shader = stage.GetPrimAtPath("/World/Looks/textured/Surface")
    shader.GetAttribute("inputs:roughness").Set(0.2)
    edited, _ = render_quietly(renderer)
    final = renderer.delegate.sync_statistics()
    assert final["materialBuilds"] - after["materialBuilds"] == 1
    assert final["materialTextureOpens"] - after["materialTextureOpens"] == 1
    np.testing.assert_array_equal(edited["color"], fresh_render(stage))


def test_a_light_edit_builds_that_light_alone(tmp_path):
    stage = sprim_stage(tmp_path)
    renderer = penumbra.Renderer(stage)
    before, _ = render_quietly(renderer)
    counts, stats = sync_counts(renderer), renderer.delegate.sync_statistics()
    assert stats["lightTextureLoads"] == 1  # the dome's

    UsdLux.RectLight(stage.GetPrimAtPath("/World/panel")).GetIntensityAttr().Set(12.0)
    edited, _ = render_quietly(renderer)
    after = renderer.delegate.sync_statistics()
    assert {p for p, n in sync_counts(renderer).items() if n != counts[p]} == {"/World/panel"}
    assert after["lightBuilds"] - stats["lightBuilds"] == 1
    assert after["lightTextureLoads"] == stats["lightTextureLoads"]
    assert after["materialBuilds"] == stats["materialBuilds"]
    assert not np.array_equal(edited["color"], before["color"])
    np.testing.assert_array_equal(edited["color"], fresh_render(stage))


def test_lights_added_hidden_and_removed_match_a_fresh_render(tmp_path):
    stage = sprim_stage(tmp_path)
    renderer = penumbra.Renderer(stage)
    render_quietly(renderer)
    stats = renderer.delegate.sync_statistics()
    # /World/bulb sorts before /World/panel and /World/sky: they move along the light list.
    bulb = UsdLux.SphereLight.Define(stage, "/World/bulb")
    bulb.CreateIntensityAttr(6.0)
    bulb.CreateRadiusAttr(0.2)
    bulb.AddTranslateOp().Set(Gf.Vec3d(-0.5, 0.5, 1.0))
    edits = [
        lambda: None,
        lambda: UsdGeom.Imageable(stage.GetPrimAtPath("/World/panel")).MakeInvisible(),
        lambda: stage.RemovePrim("/World/bulb"),
        lambda: UsdGeom.Imageable(stage.GetPrimAtPath("/World/panel")).MakeVisible(),
    ]
    images = []
    for edit in edits:
        edit()
        image, _ = render_quietly(renderer)
        np.testing.assert_array_equal(image["color"], fresh_render(stage))
        images.append(image["color"])
    assert not np.array_equal(images[0], images[1]) and not np.array_equal(images[1], images[2])
    # The dome's texture was loaded once, whatever came and went around it.
    assert renderer.delegate.sync_statistics()["lightTextureLoads"] == stats["lightTextureLoads"]


def grid_stage(count: int):
    """``count`` distinct small cubes in a grid on z = 0, in the view of lit_quad_stage's camera."""
    stage = lit_quad_stage()
    stage.RemovePrim("/World/quad")
    UsdGeom.Xform.Define(stage, "/World/Grid")
    layer = stage.GetRootLayer()
    side = int(count**0.5) + 1
    points = [Gf.Vec3f(x, y, z) for x in (0, 0.06) for y in (0, 0.06) for z in (0, 0.06)]
    with Sdf.ChangeBlock():
        for i in range(count):
            spec = Sdf.CreatePrimInLayer(layer, f"/World/Grid/c{i}")
            spec.specifier, spec.typeName = Sdf.SpecifierDef, "Mesh"
            values = {
                "points": (Sdf.ValueTypeNames.Point3fArray, points),
                "faceVertexCounts": (Sdf.ValueTypeNames.IntArray, [4] * 6),
                "faceVertexIndices": (Sdf.ValueTypeNames.IntArray, CUBE_FACE_INDICES),
                "subdivisionScheme": (Sdf.ValueTypeNames.Token, "none"),
                "xformOp:translate": (
                    Sdf.ValueTypeNames.Double3,
                    Gf.Vec3d(0.1 * (i % side) - 1.8, 0.1 * (i // side) - 1.8, 0),
                ),
                "xformOpOrder": (Sdf.ValueTypeNames.TokenArray, ["xformOp:translate"]),
            }
            for name, (type_name, value) in values.items():
                Sdf.AttributeSpec(spec, name, type_name).default = value
    return stage


def test_moving_a_mesh_among_thousands_rebuilds_no_top_level_bvh():
    """Moving meshes of a large stage between small renders builds a BVH of the moved meshes
    alone (the scene's overlay; docs/architecture.md); a render of many samples folds them into
    the top level. Every image equals a fresh render of the edited stage."""
    stage = grid_stage(1200)
    renderer = penumbra.Renderer(stage)
    small = dict(camera="/cam", width=24, samples=2)  # 1,152 samples: the overlay stays
    before_image = renderer.render(**small)
    built = renderer.delegate.sync_statistics()["topLevelBvhPrimitives"]
    for path, offset in (("/World/Grid/c40", (0.03, 0.02, 0.1)), ("/World/Grid/c700", (0, 0, 0.3))):
        translate = stage.GetPrimAtPath(path).GetAttribute("xformOp:translate")
        translate.Set(translate.Get() + Gf.Vec3d(*offset))
    edited = renderer.render(**small)
    assert renderer.delegate.sync_statistics()["topLevelBvhPrimitives"] - built == 2
    assert not np.array_equal(edited["color"], before_image["color"])  # the edit shows
    fresh = penumbra.Renderer(stage).render(**small)
    np.testing.assert_array_equal(edited["color"], fresh["color"])

    large = dict(camera="/cam", width=96, samples=4)  # 36,864 samples: folded
    folded = renderer.render(**large)
    assert renderer.delegate.sync_statistics()["topLevelBvhPrimitives"] - built > 1200
    fresh = penumbra.Renderer(stage).render(**large)
    np.testing.assert_array_equal(folded["color"], fresh["color"])


def collection_bound_stage(owner: str):
    """edit_stage with /World binding blue to the members of collection ``coll`` of
    ``owner``: those of its collection ``inner``, which includes /World/painted."""
    stage = edit_stage()
    blue = add_preview_material(stage, "/World/Looks/blue", diffuseColor=(0.1, 0.1, 0.8))
    prim = stage.GetPrimAtPath(owner) or stage.DefinePrim(owner, "Scope")
    inner = Usd.CollectionAPI.Apply(prim, "inner")
    inner.CreateIncludesRel().AddTarget("/World/painted")
    collection = Usd.CollectionAPI.Apply(prim, "coll")
    collection.CreateIncludesRel().AddTarget(inner.GetCollectionPath())
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath("/World")).Bind(collection, blue, "b")
    return stage


def _explicit_blob(collection):  # explicitOnly: /World/blob, not its descendants
    collection.GetIncludesRel().SetTargets(["/World/blob"])
    collection.CreateExpansionRuleAttr(Usd.Tokens.explicitOnly)


COLLECTION_EDITS = {
    "include added": lambda coll, inner: coll.GetIncludesRel().AddTarget("/World/blob"),
    "includes cleared": lambda coll, inner: coll.GetIncludesRel().ClearTargets(True),
    "expansion rule": lambda coll, inner: _explicit_blob(coll),
    "included collection": lambda coll, inner: inner.GetIncludesRel().AddTarget("/World/blob"),
    # The owner prim resyncs (and with /Collections, nothing the binding reaches).
    "API removed": lambda coll, inner: coll.GetPrim().RemoveAPI(Usd.CollectionAPI, "coll"),
}


@pytest.mark.parametrize("owner", ["/World", "/Collections"])
@pytest.mark.parametrize("kind", COLLECTION_EDITS)
def test_editing_the_collection_of_a_collection_binding_rebinds_its_members(kind, owner):
    # The binding itself is not edited: its members are.
    stage = collection_bound_stage(owner)
    renderer = penumbra.Renderer(stage)
    before = renderer.render(**FAST)
    prim = stage.GetPrimAtPath(owner)
    COLLECTION_EDITS[kind](Usd.CollectionAPI(prim, "coll"), Usd.CollectionAPI(prim, "inner"))
    edited = renderer.render(**FAST)
    np.testing.assert_array_equal(edited["color"], penumbra.Renderer(stage).render(**FAST)["color"])
    assert not np.array_equal(edited["color"], before["color"])  # the edit shows
