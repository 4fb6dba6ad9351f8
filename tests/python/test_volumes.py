"""UsdVolVolumes from USD to pixels: OpenVDB fields written into tmp_path by penumbra.write_vdb,
read through the render delegate's cache of fields, placed by the Volume's transform (over the
shutter too), keyed material inputs followed frame by frame, bad data warned of (naming the
volume, the field and the file) and skipped, and the volumes' bytes counted in the memory
budget's estimate."""

from __future__ import annotations

import math
import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, UsdVol

import penumbra
from penumbra.memory import FILM_BYTES_PER_PIXEL, resident_memory
from stages import add_camera, add_distant_light, add_instance, add_quad, new_stage

WIDTH = 16
# The camera (stages.add_camera) sees [-2, 2]² of the z = 0 plane from z = 5; the default dome
# light, seen by camera rays, is a white background of radiance 1.
RENDER = dict(camera="/cam", width=WIDTH, samples=16)
VOXEL = 0.25
SIDE = 8  # voxels per side of the cube: [-1, 1]³ around its centre
DENSE = 40.0  # per unit: light crossing the cube is gone
CACHE = 16 * 2**20  # the smallest texture cache: the budgets below are tight


def cube_transform(centre=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Index to object of SIDE³ voxels of size VOXEL centred on ``centre`` (row vectors)."""
    matrix = np.eye(4) * VOXEL
    matrix[3] = [c - (SIDE - 1) / 2 * VOXEL for c in centre] + [1.0]
    return matrix


def write_cube(path: Path, centre=(0.0, 0.0, 0.0), value: float = DENSE, name="density") -> Path:
    """A .vdb file holding one grid ``name``: a dense cube of ``value`` around ``centre``."""
    grid = np.full((SIDE, SIDE, SIDE), value, dtype=np.float32)
    penumbra.write_vdb(str(path), {name: grid}, cube_transform(centre))
    return path


def add_volume(stage: Usd.Stage, path: str, fields: dict[str, object]) -> UsdVol.Volume:
    """A Volume at ``path`` with a field relationship per entry of ``fields``: a .vdb path
    (an OpenVDBAsset child of that name whose grid is named after the field), or an
    ``Sdf.Path`` the relationship targets as it is."""
    volume = UsdVol.Volume.Define(stage, path)
    for name, target in fields.items():
        if not isinstance(target, Sdf.Path):
            asset = UsdVol.OpenVDBAsset.Define(stage, f"{path}/{name}")
            asset.CreateFilePathAttr(Sdf.AssetPath(str(target)))
            asset.CreateFieldNameAttr(name)
            target = asset.GetPath()
        volume.CreateFieldRelationship(name, target)
    return volume


def cube_stage(tmp_path: Path) -> Usd.Stage:
    """The camera looking at a dense cube /World/smoke at the origin."""
    stage = new_stage()
    add_camera(stage)
    add_volume(stage, "/World/smoke", {"density": write_cube(tmp_path / "cube.vdb")})
    return stage


def render(renderer: penumbra.Renderer, **options) -> tuple[np.ndarray, list[str]]:
    """The colour (rows from the top) and the warnings of a render."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = renderer.render(**{**RENDER, **options})
    return image["color"][:, :, :3], [str(w.message) for w in caught]


def brightness(color: np.ndarray, u: float, v: float) -> float:
    """Mean RGB of the pixel at fractional (u, v) from the top left."""
    return float(color[int(v * WIDTH), int(u * WIDTH)].mean())


def touch(stage: Usd.Stage, path: str) -> None:
    """An edit of prim ``path`` that changes nothing it renders with."""
    prim = stage.GetPrimAtPath(path)
    prim.SetCustomDataByKey("edits", (prim.GetCustomDataByKey("edits") or 0) + 1)


def new_renderer(stage: Usd.Stage) -> tuple[penumbra.Renderer, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        renderer = penumbra.Renderer(stage)
    return renderer, [str(w.message) for w in caught]


def test_volume_reaches_the_renderer_and_absorbs_the_background(tmp_path):
    renderer, messages = new_renderer(cube_stage(tmp_path))
    assert not any("not supported" in m for m in messages)
    assert renderer.delegate.has_prim("/World/smoke")
    color, messages = render(renderer)
    assert messages == []
    statistics = renderer.delegate.sync_statistics()
    assert statistics["volumeFieldReads"] == 1
    assert statistics["volumeBytes"] > 0
    # The cube ([-1, 1]², the central half) hides the white dome behind it; around it the dome
    # is seen whole.
    assert brightness(color, 0.5, 0.5) < 0.5
    assert brightness(color, 0.05, 0.05) == pytest.approx(1.0, abs=1e-3)


def test_fields_are_read_once_for_several_volumes_and_renders(tmp_path):
    stage = cube_stage(tmp_path)
    add_volume(stage, "/World/twin", {"density": tmp_path / "cube.vdb"})
    renderer, _ = new_renderer(stage)
    render(renderer)
    assert renderer.delegate.sync_statistics()["volumeFieldReads"] == 1
    UsdGeom.Xformable(stage.GetPrimAtPath("/World/twin")).AddTranslateOp().Set(Gf.Vec3d(1, 0, 0))
    touch(stage, "/World/twin/density")  # the volume's data is read again
    render(renderer)
    assert renderer.delegate.sync_statistics()["volumeFieldReads"] == 1
    # A file written again (another size) is read again.
    penumbra.write_vdb(
        str(tmp_path / "cube.vdb"), {"density": np.full((4, 4, 4), DENSE, np.float32)}
    )
    touch(stage, "/World/twin/density")
    touch(stage, "/World/smoke/density")
    render(renderer)
    assert renderer.delegate.sync_statistics()["volumeFieldReads"] == 2


def test_memory_estimate_counts_grids_not_read_yet(tmp_path):
    stage = cube_stage(tmp_path)
    renderer, _ = new_renderer(stage)
    file_size = os.path.getsize(tmp_path / "cube.vdb")
    before = renderer.delegate.estimated_sync_bytes()
    assert before >= 2 * file_size
    render(renderer)
    assert renderer.delegate.estimated_sync_bytes() == 0
    # A second volume of the same file adds nothing: its grid is held.
    add_volume(stage, "/World/twin", {"density": tmp_path / "cube.vdb"})
    renderer.sync()
    assert renderer.delegate.estimated_sync_bytes() == 0
    # One of a new file adds twice its grid's size in memory: the same as the first cube's, of
    # the same voxels.
    add_volume(stage, "/World/other", {"density": write_cube(tmp_path / "other.vdb", value=2.0)})
    renderer.sync()
    assert renderer.delegate.estimated_sync_bytes() == before


def test_bad_volumes_warn_naming_prim_field_and_file_and_the_rest_renders(tmp_path):
    stage = new_stage()
    add_camera(stage)
    add_quad(stage, "/World/quad", center=(1.5, 1.5, 0), half_size=0.4)
    good = write_cube(tmp_path / "good.vdb")
    vector = tmp_path / "vector.vdb"
    penumbra.write_vdb(str(vector), {"vel": np.ones((2, 2, 2, 3), np.float32)})
    UsdVol.Volume.Define(stage, "/World/empty")
    add_volume(stage, "/World/not_asset", {"density": Sdf.Path("/World/quad")})
    add_volume(stage, "/World/missing", {"density": tmp_path / "nothing.vdb"})
    add_volume(stage, "/World/no_grid", {"density": good})
    stage.GetPrimAtPath("/World/no_grid/density").GetAttribute("fieldName").Set("smoke")
    add_volume(stage, "/World/vector", {"density": vector})
    stage.GetPrimAtPath("/World/vector/density").GetAttribute("fieldName").Set("vel")
    add_volume(stage, "/World/declared_vector", {"density": good})
    declared = UsdVol.OpenVDBAsset(stage.GetPrimAtPath("/World/declared_vector/density"))
    declared.CreateFieldDataTypeAttr("float3")
    add_volume(stage, "/World/no_color", {"density": good, "color": tmp_path / "gone.vdb"})
    renderer, messages = new_renderer(stage)
    color, rendered = render(renderer)
    messages += rendered
    expected = {
        "/World/empty": ("without fields",),
        "/World/not_asset": ("field density (/World/quad)", "Mesh", "not an OpenVDBAsset"),
        "/World/missing": ("field density", str(tmp_path / "nothing.vdb"), "not found"),
        "/World/no_grid": ("field slot 'density'", str(good), "'smoke'", "skipped"),
        "/World/vector": ("field slot 'density'", str(vector), "'vel'", "scalar"),
        "/World/declared_vector": ("field density", "float3", str(good), "scalar"),
        "/World/no_color": ("field color", str(tmp_path / "gone.vdb"), "color slot is dropped"),
    }
    for prim, parts in expected.items():
        found = [m for m in messages if m.startswith(prim + ":")]
        assert len(found) == 1, (prim, messages)
        assert all(part in found[0] for part in parts), (found[0], parts)
    assert len(messages) == len(expected), messages
    # The rest renders: the quad, and the volume that lost its colour slot only.
    assert renderer.delegate.has_prim("/World/no_color")
    assert renderer.delegate.sync_statistics()["volumeBytes"] > 0
    assert brightness(color, 0.5, 0.5) < 0.5  # the no_color cube (no_grid, vector: nothing)
    assert np.isfinite(color).all()
    # Bad volumes stay out of the renderer without failing later renders.
    render(renderer)


def test_repaired_voxels_warn_once_with_their_counts(tmp_path):
    grid = np.full((SIDE, SIDE, SIDE), 1.0, dtype=np.float32)
    grid[0, 0, 0] = np.nan
    grid[1, 0, 0] = -2.0
    grid[2, 0, 0] = -3.0
    penumbra.write_vdb(str(tmp_path / "repaired.vdb"), {"density": grid}, cube_transform())
    stage = new_stage()
    add_camera(stage)
    add_volume(stage, "/World/smoke", {"density": tmp_path / "repaired.vdb"})
    renderer, _ = new_renderer(stage)
    _, messages = render(renderer)
    repaired = [m for m in messages if "voxels read as 0" in m]
    assert repaired == [
        f"/World/smoke: field slot 'density' (file {tmp_path / 'repaired.vdb'}, grid 'density' #0)"
        ": 1 non-finite and 2 negative voxels read as 0"
    ]
    UsdGeom.Xformable(stage.GetPrimAtPath("/World/smoke")).AddTranslateOp().Set(Gf.Vec3d(0.1, 0, 0))
    _, messages = render(renderer)
    assert messages == []


def test_relative_file_paths_resolve_against_their_layer(tmp_path):
    write_cube(tmp_path / "cube.vdb")
    stage = new_stage(tmp_path / "scene.usda")
    add_camera(stage)
    add_volume(stage, "/World/smoke", {"density": "./cube.vdb"})
    renderer, messages = new_renderer(stage)
    color, rendered = render(renderer)
    assert messages + rendered == []
    assert renderer.delegate.sync_statistics()["volumeFieldReads"] == 1
    assert brightness(color, 0.5, 0.5) < 0.5


def test_time_sampled_file_path_reads_the_file_of_the_frame(tmp_path):
    left = write_cube(tmp_path / "left.vdb", centre=(-1.0, 0.0, 0.0))
    right = write_cube(tmp_path / "right.vdb", centre=(1.0, 0.0, 0.0))
    stage = new_stage()
    add_camera(stage)
    add_volume(stage, "/World/smoke", {"density": left})
    file_path = stage.GetPrimAtPath("/World/smoke/density").GetAttribute("filePath")
    file_path.Clear()
    file_path.Set(Sdf.AssetPath(str(left)), 1)
    file_path.Set(Sdf.AssetPath(str(right)), 2)
    file_path.Set(Sdf.AssetPath(str(tmp_path / "frame3.vdb")), 3)
    renderer, _ = new_renderer(stage)
    first, _ = render(renderer, time=1)
    second, _ = render(renderer, time=2)
    assert renderer.delegate.sync_statistics()["volumeFieldReads"] == 2
    assert brightness(first, 0.25, 0.5) < 0.5 < brightness(first, 0.75, 0.5)
    assert brightness(second, 0.75, 0.5) < 0.5 < brightness(second, 0.25, 0.5)
    _, messages = render(renderer, time=3)
    assert any(m.startswith("/World/smoke: field density") and "frame3.vdb not found" in m
               for m in messages)


def test_volume_transform_moves_and_scales_the_medium(tmp_path):
    stage = cube_stage(tmp_path)
    smoke = UsdGeom.Xformable(stage.GetPrimAtPath("/World/smoke"))
    renderer, _ = new_renderer(stage)
    still, _ = render(renderer)
    translate = smoke.AddTranslateOp()
    translate.Set(Gf.Vec3d(1.25, 0, 0))
    scale = smoke.AddScaleOp()
    scale.Set(Gf.Vec3f(0.5, 0.5, 0.5))  # [0.75, 1.75] × [-0.5, 0.5]
    moved, _ = render(renderer)
    assert brightness(still, 0.5, 0.5) < 0.5
    assert brightness(moved, 0.5, 0.5) == pytest.approx(1.0, abs=1e-3)  # the centre is clear
    assert brightness(moved, 0.8, 0.5) < 0.5  # x = 1.2
    assert brightness(moved, 0.8, 0.3) == pytest.approx(1.0, abs=1e-3)  # y = 0.8: above it


def test_moving_volume_renders_deterministically(tmp_path):
    stage = cube_stage(tmp_path)
    stage.SetEndTimeCode(2)
    translate = UsdGeom.Xformable(stage.GetPrimAtPath("/World/smoke")).AddTranslateOp()
    translate.Set(Gf.Vec3d(-1, 0, 0), 1)
    translate.Set(Gf.Vec3d(1, 0, 0), 2)
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/cam"))
    camera.CreateShutterOpenAttr(0.0)
    camera.CreateShutterCloseAttr(1.0)
    first, _ = render(penumbra.Renderer(stage), time=1)
    second, _ = render(penumbra.Renderer(stage), time=1)
    assert np.array_equal(first, second)
    # Smeared over [-2, 2]: the centre is covered all the shutter long, the sides half of it.
    assert brightness(first, 0.5, 0.5) < brightness(first, 0.1, 0.5) < 1.0 - 1e-3
    assert brightness(first, 0.5, 0.0) == pytest.approx(1.0, abs=1e-3)  # above it


def test_field_prim_edits_re_read_the_volume(tmp_path):
    stage = cube_stage(tmp_path)
    renderer, _ = new_renderer(stage)
    render(renderer)
    field = stage.GetPrimAtPath("/World/smoke/density")
    field.GetAttribute("filePath").Set(Sdf.AssetPath(str(tmp_path / "elsewhere.vdb")))
    _, messages = render(renderer)
    assert [m for m in messages if "elsewhere.vdb not found" in m]
    assert not renderer.delegate.has_prim("/World/smoke")
    write_cube(tmp_path / "elsewhere.vdb")
    touch(stage, "/World/smoke/density")
    color, messages = render(renderer)
    assert messages == []
    assert renderer.delegate.has_prim("/World/smoke")
    assert brightness(color, 0.5, 0.5) < 0.5


def test_a_vdb_file_written_again_is_read_again_by_the_next_render(tmp_path):
    # A simulation cached again under the same name, rendered by the same Renderer with no
    # edit of the stage: as a fresh Renderer renders it, its grid read once more, and only once.
    stage = cube_stage(tmp_path)
    renderer, _ = new_renderer(stage)
    dense, _ = render(renderer)
    assert brightness(dense, 0.5, 0.5) < 0.1
    write_cube(tmp_path / "cube.vdb", value=0.2)
    thin, messages = render(renderer)
    assert messages == []
    assert renderer.delegate.sync_statistics()["volumeFieldReads"] == 2
    fresh, _ = render(new_renderer(stage)[0])
    np.testing.assert_array_equal(thin, fresh)
    assert brightness(thin, 0.5, 0.5) > 0.5
    syncs = renderer.delegate.sync_count("/World/smoke")
    render(renderer)
    assert renderer.delegate.sync_count("/World/smoke") == syncs
    assert renderer.delegate.sync_statistics()["volumeFieldReads"] == 2


def test_volumes_in_native_instances_are_skipped_with_a_warning(tmp_path):
    stage = new_stage()
    add_camera(stage)
    UsdGeom.Xform.Define(stage, "/Prototype")
    add_volume(stage, "/Prototype/smoke", {"density": write_cube(tmp_path / "cube.vdb")})
    add_quad(stage, "/Prototype/card", half_size=0.2)
    stage.GetPrimAtPath("/Prototype").SetSpecifier(Sdf.SpecifierClass)
    add_instance(stage, "/World/copy", "/Prototype")
    renderer, messages = new_renderer(stage)
    _, rendered = render(renderer)
    skipped = [m for m in messages + rendered if "volumes in native instances" in m]
    assert len(skipped) == 1 and skipped[0].startswith("/World/copy/smoke:")


def test_set_volume_refuses_bad_keys_and_types_and_changes_nothing():
    delegate = penumbra._core.RenderDelegate()
    delegate.insert_rprims("volume", ["/v"])
    with pytest.raises(ValueError, match="unknown key 'densty'"):
        delegate.set_volume("/v", {"densty": ("a.vdb", "density", 0)}, {})
    with pytest.raises(ValueError, match="density has the wrong type"):
        delegate.set_volume("/v", {"density": "a.vdb"}, {})
    with pytest.raises(ValueError, match="unknown key 'colour'"):
        delegate.set_volume("/v", {}, {"colour": (1, 1, 1)})
    with pytest.raises(ValueError, match="scattering must have 3 components"):
        delegate.set_volume("/v", {}, {"scattering": (1, 1)})
    with pytest.raises(ValueError, match="anisotropy has the wrong type"):
        delegate.set_volume("/v", {}, {"anisotropy": "forward"})
    with pytest.raises(KeyError):
        delegate.set_volume("/nothing", {}, {})
    with pytest.raises(ValueError, match="shape"):
        penumbra.write_vdb("unused.vdb", {"density": np.ones((2, 2), np.float32)})


def test_default_camera_frames_a_volume_by_its_authored_extent(tmp_path):
    stage = new_stage()
    volume = add_volume(stage, "/World/smoke", {"density": write_cube(tmp_path / "cube.vdb")})
    volume.CreateExtentAttr([Gf.Vec3f(-1, -1, -1), Gf.Vec3f(1, 1, 1)])
    renderer, _ = new_renderer(stage)
    color, messages = render(renderer, camera=None)
    assert messages == []
    assert brightness(color, 0.5, 0.5) < 0.5
    assert brightness(color, 0.02, 0.02) == pytest.approx(1.0, abs=1e-3)


def test_volumes_in_point_instancer_prototypes_are_skipped_with_a_warning(tmp_path):
    stage = new_stage()
    add_camera(stage)
    instancer = UsdGeom.PointInstancer.Define(stage, "/World/scatter")
    add_volume(stage, "/World/scatter/smoke", {"density": write_cube(tmp_path / "cube.vdb")})
    add_quad(stage, "/World/scatter/card", half_size=0.2)
    instancer.CreatePrototypesRel().SetTargets(
        [Sdf.Path("/World/scatter/smoke"), Sdf.Path("/World/scatter/card")]
    )
    instancer.CreateProtoIndicesAttr([0, 1])
    instancer.CreatePositionsAttr([Gf.Vec3f(-1, 0, 0), Gf.Vec3f(1, 0, 0)])
    renderer, messages = new_renderer(stage)
    color, rendered = render(renderer)
    skipped = [m for m in messages + rendered if "point-instancer prototypes" in m]
    assert skipped and all(m.startswith("/World/scatter/smoke:") for m in skipped)
    assert not renderer.delegate.has_prim("/World/scatter/smoke")
    assert brightness(color, 0.25, 0.5) == pytest.approx(1.0, abs=1e-3)  # no medium


def test_binding_and_material_edits_re_read_the_volume(tmp_path):
    stage = cube_stage(tmp_path)
    renderer, _ = new_renderer(stage)
    render(renderer)
    syncs = renderer.delegate.sync_count("/World/smoke")
    material = UsdShade.Material.Define(stage, "/World/looks/fog")
    shader = UsdShade.Shader.Define(stage, "/World/looks/fog/node")
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath("/World/smoke")).Bind(material)
    render(renderer)
    assert renderer.delegate.sync_count("/World/smoke") == syncs + 1
    shader.CreateInput("density", Sdf.ValueTypeNames.Float).Set(2.0)  # a node of its material
    render(renderer)
    assert renderer.delegate.sync_count("/World/smoke") == syncs + 2
    add_quad(stage, "/World/looks_elsewhere", half_size=0.1)  # unrelated: nothing re-read
    render(renderer)
    assert renderer.delegate.sync_count("/World/smoke") == syncs + 2


def test_a_volume_is_checked_against_the_memory_budget_before_it_is_read(tmp_path):
    side = 128  # random values: the file does not compress below the voxels' 8 MiB
    grid = np.random.default_rng(1).uniform(0.5, 1.0, (side, side, side)).astype(np.float32)
    to_object = np.diag([2 / side, 2 / side, 2 / side, 1.0])  # [0, 2)³
    penumbra.write_vdb(str(tmp_path / "noise.vdb"), {"density": grid}, to_object)
    stage = new_stage()
    add_camera(stage)
    add_volume(stage, "/World/smoke", {"density": tmp_path / "noise.vdb"})
    renderer, _ = new_renderer(stage)
    estimate = renderer.delegate.estimated_sync_bytes()
    # Twice the grid's size in memory (OpenVDB's metadata): the read and the copy made of it.
    assert estimate >= 2 * side**3 * 4
    budget = resident_memory() + CACHE + WIDTH * WIDTH * FILM_BYTES_PER_PIXEL + estimate // 2
    with pytest.raises(penumbra.SceneError, match="acceleration structures"):
        renderer.render(**RENDER, max_memory=budget, texture_cache=CACHE)
    assert renderer.delegate.sync_statistics()["volumeFieldReads"] == 0  # nothing was read
    renderer.render(**RENDER, texture_cache=CACHE)
    held = renderer.delegate.sync_statistics()["volumeBytes"]
    assert side**3 * 4 < held < estimate  # the voxels, and less than the estimate


def test_a_material_the_renderer_refuses_skips_the_volume_with_a_warning(tmp_path):
    stage = cube_stage(tmp_path)
    renderer, _ = new_renderer(stage)
    fields = {"density": (str(tmp_path / "cube.vdb"), "density", 0)}
    renderer.delegate.set_volume("/World/smoke", fields, {"anisotropy": 1.5})
    color, messages = render(renderer)
    assert len(messages) == 1
    assert messages[0].startswith("/World/smoke: ") and "anisotropy" in messages[0]
    assert messages[0].endswith("; skipped")
    assert brightness(color, 0.5, 0.5) == pytest.approx(1.0, abs=1e-3)
    renderer.delegate.set_volume("/World/smoke", fields, {"anisotropy": 0.5})
    color, messages = render(renderer)
    assert messages == [] and brightness(color, 0.5, 0.5) < 0.5


def test_scattering_volume_is_bit_identical_across_threads_and_regions(tmp_path):
    """Free flights, ratio tracking and scattering draw their random numbers per pixel and
    sample: a grey scattering cube lit by the dome renders the same with 1 or 2 threads, and
    a band of it (as a farm splits frames) equals that band of the whole image."""
    stage = new_stage()
    add_camera(stage)
    add_volume(stage, "/World/cloud", {"density": write_cube(tmp_path / "cloud.vdb", value=2.0)})
    options = dict(RENDER, max_volume_depth=16)
    with penumbra.Renderer(stage) as renderer:
        one = renderer.render(**options, threads=1)["color"]
    with penumbra.Renderer(stage) as renderer:
        two = renderer.render(**options, threads=2)["color"]
        band = renderer.render(**options, region=(0, 5, WIDTH, 6))["color"]
    assert np.array_equal(one, two)
    assert np.array_equal(band, two[5:11])
    # The cube scatters (it is neither black nor the white background behind it).
    assert 0.05 < float(one[WIDTH // 2, WIDTH // 2, :3].mean()) < 0.95


def test_a_volume_outside_a_lights_light_link_scatters_none_of_its_light(tmp_path):
    """Light linking reaches volumes (docs/linking.md): a thin scattering cube lit by a distant
    light alone glows where the light links it and is black where its light link excludes it,
    the rest of the image (black) unchanged."""
    stage = new_stage()
    add_camera(stage)
    grid = write_cube(tmp_path / "thin.vdb", value=1.0)
    add_volume(stage, "/World/smoke", {"density": grid})
    sun = add_distant_light(stage, intensity=5.0)
    renderer, _ = new_renderer(stage)
    linked, _ = render(renderer, samples=32)
    link = UsdLux.LightAPI(sun.GetPrim()).GetLightLinkCollectionAPI()
    link.GetExcludesRel().SetTargets(["/World/smoke"])
    excluded, messages = render(renderer, samples=32)
    assert messages == []
    assert brightness(linked, 0.5, 0.5) > 0.05
    assert excluded.max() == 0.0
    assert linked[0, 0].max() == 0.0  # the black background, both times
    link.GetExcludesRel().ClearTargets(True)
    restored, _ = render(renderer, samples=32)
    np.testing.assert_array_equal(restored, linked)


def black_principled(stage: Usd.Stage, volume: str, **inputs: float | dict[float, float]) -> None:
    """A black (absorbing only) penumbra:PrincipledVolume bound to ``volume``, with float
    ``inputs``: a constant, or time samples (time → value) without a default."""
    material = UsdShade.Material.Define(stage, "/World/looks/black")
    shader = UsdShade.Shader.Define(stage, "/World/looks/black/principled")
    shader.SetShaderId("penumbra:PrincipledVolume")
    shader.CreateInput("color", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.0))
    for name, value in inputs.items():
        attr = shader.CreateInput(name, Sdf.ValueTypeNames.Float).GetAttr()
        if isinstance(value, dict):
            for time, sample in value.items():
                attr.Set(sample, time)
        else:
            attr.Set(value)
    material.CreateVolumeOutput().ConnectToSource(shader.ConnectableAPI(), "volume")
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath(volume)).Bind(material)


CENTRE = slice(WIDTH // 2 - 2, WIDTH // 2 + 2)  # 4 × 4 pixels seeing x, y in [-0.5, 0.5]
_X = ((np.arange(WIDTH) + 0.5) / WIDTH * 4 - 2)[CENTRE]  # their centres on z = 0, seen from z = 5
SLANT = float(np.sqrt(1 + np.add.outer(_X**2, _X**2) / 25).mean())  # ray length per unit depth


@pytest.mark.parametrize("one_renderer", [False, True], ids=["fresh", "one_renderer"])
@pytest.mark.parametrize("keyed", ["emissionStrength", "density"])
def test_keyed_volume_material_inputs_follow_the_frame(tmp_path, keyed, one_renderer):
    """The bound material is read at the frame rendered (not at USD's Default time) and read
    again at the next: a 2-unit black cube whose emissionStrength or density is keyed, its
    centre's mean within the analytic expectation's noise (16 pixels × 64 samples)."""
    stage = new_stage()
    add_camera(stage)
    add_volume(stage, "/World/smoke", {"density": write_cube(tmp_path / "cube.vdb", value=1.0)})
    bounds: dict[int, tuple[float, float]] = {}
    if keyed == "emissionStrength":
        # Thin (σa = 0.001), on black: radiance = strength × the emitting depth, the cube's 2
        # units up to its trilinear fringe (half a voxel each side: 2.25); noise well under 3%.
        black_principled(stage, "/World/smoke", density=0.001, emissionStrength={1: 1.0, 2: 4.0})
        options = dict(samples=64, default_light="none")
        for time, strength in ((1, 1.0), (2, 4.0)):
            bounds[time] = (0.97 * 2.0 * strength * SLANT, 1.03 * 2.25 * strength * SLANT)
    else:
        # Against the white dome: transmittance exp(−density × 2 units) (the trilinear field
        # integrates to exactly 2 through the cube), within 4σ of a fraction of 1024 samples.
        black_principled(stage, "/World/smoke", density={1: 0.1, 2: 2.0})
        options = dict(samples=64)
        for time, density in ((1, 0.1), (2, 2.0)):
            p = math.exp(-2 * density * SLANT)
            margin = 4 * math.sqrt(p * (1 - p) / 1024) + 0.002
            bounds[time] = (p - margin, p + margin)
    renderer = penumbra.Renderer(stage) if one_renderer else None
    syncs = []
    for time in (1, 2):
        color, messages = render(renderer or penumbra.Renderer(stage), time=time, **options)
        assert messages == []
        got = float(color[CENTRE, CENTRE].mean())
        assert bounds[time][0] < got < bounds[time][1], (time, got, bounds[time])
        if renderer is not None:
            syncs.append(renderer.delegate.sync_count("/World/smoke"))
    if renderer is not None:
        assert syncs[1] == syncs[0] + 1  # read again at frame 2
        renderer.close()


def test_a_volume_of_constant_material_is_not_read_again_at_another_frame(tmp_path):
    stage = cube_stage(tmp_path)
    black_principled(stage, "/World/smoke", density=2.0, emissionStrength=1.0)
    renderer, _ = new_renderer(stage)
    render(renderer, time=1)
    syncs = renderer.delegate.sync_count("/World/smoke")
    render(renderer, time=2)
    assert renderer.delegate.sync_count("/World/smoke") == syncs
