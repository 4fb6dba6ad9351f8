"""The Python API of docs/design.md §2.3 and the incremental scene delegate, through the real core."""

from __future__ import annotations

import os

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdVol

import penumbra
from penumbra import _core
from stages import (
    CORNELL,
    add_camera,
    add_distant_light,
    add_instance,
    add_preview_material,
    add_quad,
    bind,
    lit_quad_stage,
    new_stage,
    pixel,
)

SMALL = dict(width=32, samples=4)
FAST = dict(camera="/cam", **SMALL)


def sync_counts(renderer: penumbra.Renderer) -> dict[str, int]:
    delegate = renderer.delegate
    return {prim_id: delegate.sync_count(prim_id) for prim_id in delegate.prim_ids()}


def test_design_snippet_and_incremental_edit(tmp_path):
    stage = Usd.Stage.Open(str(CORNELL))
    renderer = penumbra.Renderer(stage)
    image = renderer.render(
        camera="/cam", time=1.0, width=64, samples=4, seed=0, aovs=("color", "depth")
    )
    assert image["color"].shape == (36, 64, 4) and image["color"].dtype == np.float32
    assert image["depth"].shape == (36, 64, 1)
    # The centre pixel sees the back wall (z = -1) from the camera at z = 4.4568.
    assert image["depth"][18, 32, 0] == pytest.approx(5.4568, rel=1e-3)
    image.write(tmp_path / "out.exr")
    pixels, names, metadata = _core.read_image(str(tmp_path / "out.exr"))
    assert names == ["R", "G", "B", "A", "depth"]
    np.testing.assert_array_equal(pixels[..., 4], image["depth"][..., 0])
    assert metadata["penumbra:camera"] == "/cam"
    assert metadata["penumbra:version"] == penumbra.__version__

    before = sync_counts(renderer)
    stage.GetPrimAtPath("/World/short_box").GetAttribute("xformOp:translate").Set((1, 0, 0), 1.0)
    image2 = renderer.render(camera="/cam", time=1.0, width=64, samples=4, seed=0)
    after = sync_counts(renderer)
    changed = {prim_id for prim_id in after if after[prim_id] != before.get(prim_id)}
    assert changed == {"/World/short_box"}
    assert after["/World/short_box"] == before["/World/short_box"] + 1
    assert not np.array_equal(image["color"], image2["color"])


def test_unchanged_scene_resyncs_nothing_and_is_deterministic():
    renderer = penumbra.Renderer(Usd.Stage.Open(str(CORNELL)))
    first = renderer.render(**SMALL)
    counts = sync_counts(renderer)
    second = renderer.render(**SMALL)
    assert sync_counts(renderer) == counts
    np.testing.assert_array_equal(first["color"], second["color"])
    assert first.metadata["samples"] == 4 and first.metadata["seed"] == 0
    assert first.metadata["camera"] == "/cam"  # from the render settings


def test_new_time_resyncs_only_time_varying_prims():
    stage = lit_quad_stage()
    add_quad(stage, "/World/static", center=(-1.5, 1.5, 0), half_size=0.3)
    mover = add_quad(stage, "/World/mover", center=(0, 0, 0.5), half_size=0.3, color=(1, 0, 0))
    translate = mover.GetOrderedXformOps()[0].GetAttr()
    translate.Set(Gf.Vec3d(-1.2, 0, 0.5), 1.0)
    translate.Set(Gf.Vec3d(1.2, 0, 0.5), 2.0)
    renderer = penumbra.Renderer(stage)
    at_1 = renderer.render(time=1.0, **FAST)
    before = sync_counts(renderer)
    at_2 = renderer.render(time=2.0, **FAST)
    after = sync_counts(renderer)
    assert {p for p in after if after[p] != before[p]} == {"/World/mover"}
    assert pixel(at_1, 0.17, 0.5)[0] > 2 * pixel(at_1, 0.17, 0.5)[1]  # red mover on the left
    assert pixel(at_2, 0.83, 0.5)[0] > 2 * pixel(at_2, 0.83, 0.5)[1]  # then on the right


def test_ancestor_transform_edit_moves_subtree():
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    group = UsdGeom.Xform.Define(stage, "/World/group")
    shift = group.AddTranslateOp()
    shift.Set(Gf.Vec3d(0, 0, 0))
    add_quad(stage, "/World/group/quad", half_size=0.5)
    renderer = penumbra.Renderer(stage)
    centred = renderer.render(**FAST)
    shift.Set(Gf.Vec3d(1.2, 0, 0))
    moved = renderer.render(**FAST)
    assert pixel(centred, 0.5, 0.5).mean() > 0.05
    assert pixel(moved, 0.5, 0.5).mean() == 0.0
    assert pixel(moved, 0.8, 0.5).mean() > 0.05


def test_purpose_and_visibility_filtering():
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    for name, x, purpose in (
        ("default", -1.5, None),
        ("render", -0.5, "render"),
        ("proxy", 0.5, "proxy"),
        ("guide", 1.5, "guide"),
    ):
        quad = add_quad(stage, f"/World/{name}", center=(x, 0, 0), half_size=0.3)
        if purpose:
            quad.CreatePurposeAttr(purpose)
    hidden = add_quad(stage, "/World/hidden", center=(0, 1.5, 0), half_size=0.3)
    hidden.MakeInvisible()
    columns = {"default": 0.125, "render": 0.375, "proxy": 0.625, "guide": 0.875}

    def lit(image):
        return {name: pixel(image, u, 0.5).mean() > 0.05 for name, u in columns.items()}

    default = penumbra.Renderer(stage)  # usdrecord's default: default + proxy
    image = default.render(**FAST)
    assert lit(image) == {"default": True, "render": False, "proxy": True, "guide": False}
    assert pixel(image, 0.5, 0.125).mean() == 0.0  # invisible
    render_purpose = penumbra.Renderer(stage, purposes=("render",))
    assert lit(render_purpose.render(**FAST)) == {
        "default": True,
        "render": True,
        "proxy": False,
        "guide": False,
    }

    before = sync_counts(default)
    hidden.MakeVisible()
    shown = default.render(**FAST)
    assert pixel(shown, 0.5, 0.125).mean() > 0.05
    after = sync_counts(default)
    assert {p for p in after if after[p] != before[p]} == {"/World/hidden"}


def test_display_color_and_fallback_albedo():
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    add_quad(stage, "/World/red", center=(-1, 0, 0), half_size=0.5, color=(0.8, 0.1, 0.1))
    add_quad(stage, "/World/grey", center=(1, 0, 0), half_size=0.5)
    image = penumbra.Renderer(stage).render(**FAST)
    red, grey = pixel(image, 0.25, 0.5), pixel(image, 0.75, 0.5)
    assert red[0] > 5 * red[1] and red[0] > 5 * red[2]
    assert grey.min() > 0.05 and np.ptp(grey) < 1e-3 * grey.max()
    assert red[0] / grey[0] == pytest.approx(0.8 / 0.5, rel=0.02)


def test_indexed_uniform_display_color_is_deindexed():
    stage = lit_quad_stage()
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/quad"))
    mesh.GetFaceVertexCountsAttr().Set([3, 3])
    mesh.GetFaceVertexIndicesAttr().Set([0, 1, 2, 0, 2, 3])
    primvar = mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform)
    primvar.Set([Gf.Vec3f(0, 0, 1), Gf.Vec3f(0, 1, 0)])
    primvar.SetIndices([1, 0])  # first triangle green, second blue
    image = penumbra.Renderer(stage).render(**FAST)
    lower_right, upper_left = pixel(image, 0.7, 0.6), pixel(image, 0.3, 0.4)
    assert lower_right[1] > 5 * lower_right[2]
    assert upper_left[2] > 5 * upper_left[1]


@pytest.mark.parametrize(
    "orientation, double_sided, visible",
    [("rightHanded", False, True), ("leftHanded", False, False), ("leftHanded", True, True)],
)
def test_orientation_and_culling(orientation, double_sided, visible):
    stage = lit_quad_stage()
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/quad"))
    mesh.CreateOrientationAttr(orientation)
    mesh.GetDoubleSidedAttr().Set(double_sided)
    value = pixel(penumbra.Renderer(stage).render(**FAST), 0.5, 0.5).mean()
    assert (value > 0.05) == visible


def test_material_binding_and_shader_edit():
    stage = lit_quad_stage()
    material = add_preview_material(
        stage, "/World/Looks/paint", diffuseColor=(0.1, 0.7, 0.1), roughness=1.0
    )
    bind(UsdGeom.Mesh(stage.GetPrimAtPath("/World/quad")), material)
    renderer = penumbra.Renderer(stage)
    green = pixel(renderer.render(**FAST), 0.5, 0.5)
    assert green[1] > 3 * green[0]
    assert renderer.delegate.has_prim("/World/Looks/paint")

    before = sync_counts(renderer)
    shader = stage.GetPrimAtPath("/World/Looks/paint/Surface")
    shader.GetAttribute("inputs:diffuseColor").Set(Gf.Vec3f(0.7, 0.1, 0.1))
    red = pixel(renderer.render(**FAST), 0.5, 0.5)
    after = sync_counts(renderer)
    assert red[0] > 3 * red[1]
    assert {p for p in after if after[p] != before[p]} == {"/World/Looks/paint"}


def test_non_preview_surface_material_falls_back_with_warning():
    stage = lit_quad_stage()
    material = add_preview_material(stage, "/World/Looks/odd", diffuseColor=(0.1, 0.7, 0.1))
    shader = stage.GetPrimAtPath("/World/Looks/odd/Surface")
    # A surface Penumbra does not render (MaterialX surfaces are test_materialx's).
    shader.GetAttribute("info:id").Set("PxrSurface")
    bind(UsdGeom.Mesh(stage.GetPrimAtPath("/World/quad")), material)
    with pytest.warns(penumbra.PenumbraWarning, match="/World/Looks/odd.*not UsdPreviewSurface"):
        value = pixel(penumbra.Renderer(stage).render(**FAST), 0.5, 0.5)
    assert value.min() > 0.05 and np.ptp(value) < 1e-3 * value.max()  # grey fallback


def test_native_instances_render_copies_of_one_prototype_mesh():
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    add_quad(stage, "/Prototypes/tile/quad", half_size=0.4)
    stage.GetPrimAtPath("/Prototypes").SetSpecifier(Sdf.SpecifierClass)
    for name, x in (("left", -1.0), ("right", 1.0)):
        add_instance(stage, f"/World/{name}", "/Prototypes/tile", (x, 0.0, 0.0))
    renderer = penumbra.Renderer(stage)
    image = renderer.render(**FAST)
    ids = set(renderer.delegate.prim_ids())
    assert "/prototypes/World/left/quad" in ids
    assert not {"/World/left/quad", "/World/right/quad"} & ids
    assert pixel(image, 0.25, 0.5).mean() > 0.05 and pixel(image, 0.75, 0.5).mean() > 0.05
    assert pixel(image, 0.5, 0.5).mean() == 0.0


def test_added_and_removed_prims():
    stage = lit_quad_stage()
    renderer = penumbra.Renderer(stage)
    renderer.render(**FAST)
    add_quad(stage, "/World/extra", center=(1.5, 1.5, 0.1), half_size=0.3, color=(1, 0, 0))
    image = renderer.render(**FAST)
    assert pixel(image, 0.875, 0.125)[0] > 0.05
    stage.RemovePrim("/World/extra")
    image = renderer.render(**FAST)
    assert not renderer.delegate.has_prim("/World/extra")
    assert pixel(image, 0.875, 0.125).max() == 0.0


def test_unsupported_prims_warn_once_per_type():
    stage = lit_quad_stage()
    UsdVol.ParticleField3DGaussianSplat.Define(stage, "/World/splats1")
    UsdVol.ParticleField3DGaussianSplat.Define(stage, "/World/splats2")
    UsdGeom.Sphere.Define(stage, "/World/ball")  # implicit surfaces are supported (tessellated)
    UsdVol.Volume.Define(stage, "/World/smoke")  # volumes are supported (test_volumes.py)
    with pytest.warns(penumbra.PenumbraWarning) as record:
        penumbra.Renderer(stage)
    messages = [str(w.message) for w in record]
    first = "(first: /World/splats1)"
    assert f"2 ParticleField3DGaussianSplat prims not supported yet, skipped {first}" in messages
    assert not any("Sphere" in message for message in messages)
    assert not any("Volume prim" in message for message in messages)


def test_mesh_without_points_is_skipped_with_warning():
    stage = lit_quad_stage()
    broken = UsdGeom.Mesh.Define(stage, "/World/empty")
    broken.CreateFaceVertexCountsAttr([3])
    broken.CreateFaceVertexIndicesAttr([0, 1, 2])
    with pytest.warns(penumbra.PenumbraWarning, match="/World/empty: mesh has no points"):
        renderer = penumbra.Renderer(stage)
    assert not renderer.delegate.has_prim("/World/empty")
    assert pixel(renderer.render(**FAST), 0.5, 0.5).mean() > 0.05


def test_out_of_range_indices_warn_naming_prim_and_rest_renders():
    stage = lit_quad_stage()
    bad = add_quad(stage, "/World/bad", center=(1.5, 1.5, 0))
    bad.GetFaceVertexIndicesAttr().Set([0, 1, 2, 99])
    with pytest.warns(penumbra.PenumbraWarning, match="/World/bad"):
        image = penumbra.Renderer(stage).render(**FAST)
    assert pixel(image, 0.5, 0.5).mean() > 0.05


def test_height_from_camera_aspect_and_render_settings():
    stage = lit_quad_stage()
    UsdGeom.Camera(stage.GetPrimAtPath("/cam")).GetVerticalApertureAttr().Set(2.0)
    renderer = penumbra.Renderer(stage)
    size = dict(camera="/cam", samples=1)
    assert renderer.render(width=40, **size)["color"].shape[:2] == (20, 40)
    assert renderer.render(width=40, height=10, **size)["color"].shape[:2] == (10, 40)
    settings = stage.DefinePrim("/Render/Settings", "RenderSettings")
    settings.CreateAttribute("resolution", Sdf.ValueTypeNames.Int2).Set(Gf.Vec2i(30, 10))
    settings.CreateRelationship("camera").SetTargets(["/cam"])
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    assert renderer.render(samples=1)["color"].shape[:2] == (10, 30)
    assert renderer.render(width=60, samples=1)["color"].shape[:2] == (20, 60)


def test_camera_errors():
    stage = lit_quad_stage()
    renderer = penumbra.Renderer(stage)
    with pytest.raises(penumbra.SceneError, match="/World is not a camera"):
        renderer.render(camera="/World", **SMALL)
    with pytest.raises(penumbra.SceneError, match="no camera named 'nope'"):
        renderer.render(camera="nope", **SMALL)
    # Without a camera named anywhere, the stage's only camera is used (as husk does) ...
    assert renderer.render(**SMALL).metadata["camera"] == "/cam"
    # ... and with several, a camera framing the stage is made (session layer).
    add_camera(stage, "/cam2")
    assert renderer.render(**SMALL).metadata["camera"] == "/PenumbraFramingCamera"
    assert renderer.render(camera="cam", **SMALL).metadata["camera"] == "/cam"
    with pytest.raises(penumbra.SceneError, match="no camera: .* no geometry to frame"):
        penumbra.Renderer(Usd.Stage.CreateInMemory()).render(**SMALL)


def test_render_convenience_on_a_path():
    image = penumbra.render(CORNELL, width=32, samples=2, seed=3)
    assert image["color"].shape == (18, 32, 4)
    assert image.metadata["seed"] == 3 and image.metadata["timeCode"] == 1.0
    with pytest.raises(penumbra.SceneError, match="missing.usda: no such file"):
        penumbra.render("missing.usda")


def test_a_stage_path_that_is_no_regular_file_is_refused(tmp_path):
    """Reading a FIFO would block until something writes to it: refused before opening."""
    fifo, folder = tmp_path / "pipe.usda", tmp_path / "folder.usda"
    os.mkfifo(fifo)
    folder.mkdir()
    with pytest.raises(penumbra.SceneError, match="pipe.usda: cannot read the file: it is a FIFO"):
        penumbra.Renderer(fifo)
    with pytest.raises(penumbra.SceneError, match="folder.usda: cannot read the file: it is a dir"):
        penumbra.render(str(folder))


def test_memory_budget_counts_the_aovs_asked_for():
    """A budget that holds a colour film fails with a clear error once six more AOVs would
    outgrow it (each AOV adds memory.AOV_BYTES_PER_PIXEL a pixel)."""
    from penumbra import memory

    renderer = penumbra.Renderer(lit_quad_stage())
    width, height = 2000, 1000
    colour_film = width * height * memory.FILM_BYTES_PER_PIXEL
    six_aovs = 6 * width * height * memory.AOV_BYTES_PER_PIXEL
    budget = memory.resident_memory() + colour_film + six_aovs // 2
    aovs = ("color", "depth", "Z", "normal", "position", "albedo", "primId")
    with pytest.raises(penumbra.SceneError, match="memory budget"):
        renderer.render(camera="/cam", width=width, height=height, samples=1, aovs=aovs,
                        max_memory=budget)
    image = renderer.render(camera="/cam", width=width, height=height, samples=1, max_memory=budget)
    assert image.width == width
