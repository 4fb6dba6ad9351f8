"""Cryptomatte AOVs (CryptoObject, CryptoMaterial, CryptoAsset) decoded by the specification's
reference algorithm, written here independently of the renderer: the layer found by its
``cryptomatte/<key>/name`` header entry, ids from the manifest's hex, a name's matte the sum of
the coverage of the ranks holding its id. Mattes are checked against the primId AOV of the same
render, coverage sums to one where no background shows, and farm tiles equal a local render."""

from __future__ import annotations

import json
import re
import struct
import subprocess

import numpy as np
import pytest
from pxr import Gf, Kind, Sdf, Usd, UsdGeom, UsdRender, UsdShade

import penumbra
from penumbra import _core
from penumbra.cli import main
from penumbra.farm import Tile, merge_tiles
from penumbra.image import preview_pixels

from stages import add_camera, add_instance, add_preview_material, add_quad, bind, new_stage

WIDTH = 64
SAMPLES = 16
LAYERS = ("CryptoObject", "CryptoMaterial", "CryptoAsset")


# --------------------------------------------------------------------------------------------
# The specification's algorithms, written from its text (no code of the renderer's)


def murmur3_32(data: bytes, seed: int = 0) -> int:
    """MurmurHash3_x86_32."""
    c1, c2, mask = 0xCC9E2D51, 0x1B873593, 0xFFFFFFFF

    def rotl(x: int, r: int) -> int:
        return ((x << r) | (x >> (32 - r))) & mask

    h = seed
    whole = len(data) // 4 * 4
    for i in range(0, whole, 4):
        k = int.from_bytes(data[i : i + 4], "little")
        k = rotl((k * c1) & mask, 15) * c2 & mask
        h = (rotl(h ^ k, 13) * 5 + 0xE6546B64) & mask
    tail = data[whole:]
    if tail:
        k = int.from_bytes(tail, "little")
        h ^= rotl((k * c1) & mask, 15) * c2 & mask
    h ^= len(data)
    h ^= h >> 16
    h = (h * 0x85EBCA6B) & mask
    h ^= h >> 13
    h = (h * 0xC2B2AE35) & mask
    return h ^ (h >> 16)


def name_to_float(name: str) -> float:
    """The id of a name: its hash's bits as a float, the exponent's lowest bit flipped where
    the exponent is 0 (denormals) or 255 (infinities, NaNs)."""
    hash_32 = murmur3_32(name.encode("utf-8"))
    exponent = (hash_32 >> 23) & 0xFF
    if exponent in (0, 255):
        hash_32 ^= 1 << 23
    return struct.unpack("<f", struct.pack("<I", hash_32))[0]


def layer_key(layer: str) -> str:
    """The header key the specification suggests: 7 hex digits of the layer name's hash."""
    return f"{murmur3_32(layer.encode()):08x}"[:7]


def hex_to_float(hex_id: str) -> np.float32:
    return np.frombuffer(struct.pack("<I", int(hex_id, 16)), dtype=np.float32)[0]


def decode(path, layer_name: str) -> tuple[dict[str, str], np.ndarray]:
    """The manifest and the (H, W, ranks, 2) (id, coverage) of the Cryptomatte layer named
    ``layer_name`` in the EXR at ``path``."""
    pixels, channels, metadata = _core.read_image(str(path))
    keys = [
        key for key, value in metadata.items()
        if re.fullmatch(r"cryptomatte/[0-9a-f]{1,7}/name", key) and value == layer_name
    ]
    assert len(keys) == 1, sorted(metadata)
    prefix = keys[0].removesuffix("name")
    assert metadata[prefix + "hash"] == "MurmurHash3_32"
    assert metadata[prefix + "conversion"] == "uint32_to_float32"
    manifest = json.loads(metadata[prefix + "manifest"])
    rank_layers = sorted(
        {m.group(1) for c in channels if (m := re.fullmatch(rf"{layer_name}(\d\d)\.[RGBA]", c))}
    )
    ranks = []
    for number in rank_layers:
        for pair in ("RG", "BA"):
            ranks.append(
                np.stack([pixels[..., channels.index(f"{layer_name}{number}.{c}")] for c in pair], -1)
            )
    return manifest, np.stack(ranks, axis=2)


def matte(manifest: dict[str, str], ranks: np.ndarray, name: str) -> np.ndarray:
    """The specification's matte of ``name``: coverage summed over the ranks holding its id."""
    target = hex_to_float(manifest[name])
    return np.where(ranks[..., 0] == target, ranks[..., 1], 0.0).sum(axis=2)


# --------------------------------------------------------------------------------------------
# The scene


def crypto_stage(path):
    """A backdrop filling the view (grey material, no asset) behind: a ball (red material)
    inside a component model inside an assembly, a box (no material, no model), two native
    instances of a pebble (component models themselves) and a point instancer's two cones."""
    stage = new_stage(path)
    add_camera(stage, path="/World/cam")  # sees [-2, 2]² of the z = 0 plane
    grey = add_preview_material(stage, "/World/Looks/Grey", diffuseColor=(0.5, 0.5, 0.5))
    red = add_preview_material(stage, "/World/Looks/Red", diffuseColor=(0.8, 0.1, 0.1))
    bind(add_quad(stage, "/World/Set/backdrop", half_size=3.0), grey)
    Usd.ModelAPI(UsdGeom.Xform.Define(stage, "/World/Props").GetPrim()).SetKind(Kind.Tokens.assembly)
    Usd.ModelAPI(UsdGeom.Xform.Define(stage, "/World/Props/Ball").GetPrim()).SetKind(
        Kind.Tokens.component
    )
    ball = UsdGeom.Sphere.Define(stage, "/World/Props/Ball/geo")
    ball.CreateRadiusAttr(0.6)
    ball.AddTranslateOp().Set(Gf.Vec3d(-0.9, 0.9, 0.5))
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath("/World/Props/Ball")).Bind(red)
    box = UsdGeom.Cube.Define(stage, "/World/box")
    box.CreateSizeAttr(0.9)
    box.AddTranslateOp().Set(Gf.Vec3d(0.9, 0.9, 0.5))
    stage.CreateClassPrim("/Protos")
    pebble = UsdGeom.Xform.Define(stage, "/Protos/Pebble")
    Usd.ModelAPI(pebble.GetPrim()).SetKind(Kind.Tokens.component)
    UsdGeom.Sphere.Define(stage, "/Protos/Pebble/geo").CreateRadiusAttr(0.35)
    add_instance(stage, "/World/Row/a", "/Protos/Pebble", (-1.2, -0.9, 0.3))
    add_instance(stage, "/World/Row/b", "/Protos/Pebble", (-0.3, -0.9, 0.3))
    scatter = UsdGeom.PointInstancer.Define(stage, "/World/Scatter")
    cone = UsdGeom.Cone.Define(stage, "/World/Scatter/Protos/Cone")
    cone.CreateRadiusAttr(0.3)
    cone.CreateHeightAttr(0.6)
    scatter.CreatePrototypesRel().SetTargets([cone.GetPath()])
    scatter.CreateProtoIndicesAttr([0, 0])
    scatter.CreatePositionsAttr([Gf.Vec3f(0.6, -0.9, 0.3), Gf.Vec3f(1.4, -0.9, 0.3)])
    return stage


OBJECTS = {
    "/World/Set/backdrop",
    "/World/Props/Ball/geo",
    "/World/box",
    "/World/Row/a/geo",
    "/World/Row/b/geo",
    "/World/Scatter/Protos/Cone",
}


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    directory = tmp_path_factory.mktemp("crypto")
    stage_path = directory / "scene.usda"
    crypto_stage(stage_path).Save()
    return stage_path


@pytest.fixture(scope="module")
def rendered(scene):
    """The scene rendered by the CLI with the three layers and primId."""
    out = scene.parent / "crypto.exr"
    aovs = ",".join((*LAYERS, "primId", "instanceId"))
    assert main([str(scene), str(out), "-w", str(WIDTH), "-spp", str(SAMPLES), "--aov", aovs, "-q"]) == 0
    return out


# --------------------------------------------------------------------------------------------


def test_hashes_and_float_ids_match_an_independent_implementation():
    # The Cryptomatte specification's example manifest, and MurmurHash3's published values.
    assert f"{murmur3_32(b'bunny'):08x}" == "13851a76"
    assert f"{murmur3_32(b'default'):08x}" == "42c9679f"
    assert murmur3_32(b"The quick brown fox jumps over the lazy dog") == 0x2E4FF723
    for name in ("bunny", "/World/Props/Ball/geo", "(no material)", "é/ünïcode", "", "abc"):
        bits = _core.cryptomatte_bits(_core.murmur_hash3(name))
        assert hex_to_float(f"{bits:08x}") == np.float32(name_to_float(name)), name
    # A hash whose exponent is all ones would be a NaN: its lowest exponent bit is flipped.
    assert _core.cryptomatte_bits(0x7F812345) == 0x7F012345
    assert _core.cryptomatte_bits(0x00012345) == 0x00812345


def test_object_mattes_match_each_objects_visible_region_and_sum_to_one(rendered):
    manifest, ranks = decode(rendered, "CryptoObject")
    assert set(manifest) == OBJECTS
    pixels, channels, metadata = _core.read_image(str(rendered))
    prim_ids = pixels[..., channels.index("primId")]
    by_path = {path: float(id_) for id_, path in json.loads(metadata["penumbra:primIds"]).items()}
    mattes = {name: matte(manifest, ranks, name) for name in manifest}
    total = sum(mattes.values())
    np.testing.assert_allclose(total, 1.0, atol=1e-6)  # the backdrop fills the view
    for name in ("/World/Set/backdrop", "/World/Props/Ball/geo", "/World/box"):
        covered = mattes[name]
        edges = (covered > 0) & (covered < 1)
        assert edges.any(), name  # antialiased edges, shared with the backdrop
        # The sample nearest the pixel centre (primId) hit the object where it covers the
        # whole pixel, and never where it covers none of it.
        assert np.all(prim_ids[covered == 1] == by_path[name]), name
        assert not np.any(prim_ids[covered == 0] == by_path[name]), name
        # Its area is the area the primId AOV gives it, within the edges' pixels.
        assert abs(covered.sum() - (prim_ids == by_path[name]).sum()) <= edges.sum() / 2 + 1
    # Edges between two objects hold both, their coverage summing to one.
    ball, backdrop = mattes["/World/Props/Ball/geo"], mattes["/World/Set/backdrop"]
    shared = (ball > 0) & (ball < 1)
    np.testing.assert_allclose((ball + backdrop)[shared], 1.0, atol=1e-6)
    # Native instances are told apart by their instance proxy paths, side by side.
    a, b = mattes["/World/Row/a/geo"], mattes["/World/Row/b/geo"]
    assert a.sum() > 20 and b.sum() > 20 and not np.any((a > 0) & (b > 0))
    assert np.argwhere(a > 0)[:, 1].mean() < np.argwhere(b > 0)[:, 1].mean()
    # Ranks are ordered by coverage.
    assert np.all(np.diff(ranks[..., 1], axis=2) <= 0)


def test_material_and_asset_mattes_group_objects(rendered):
    objects_manifest, objects = decode(rendered, "CryptoObject")
    materials_manifest, materials = decode(rendered, "CryptoMaterial")
    assets_manifest, assets = decode(rendered, "CryptoAsset")
    obj = {name: matte(objects_manifest, objects, name) for name in objects_manifest}
    assert set(materials_manifest) == {"/World/Looks/Grey", "/World/Looks/Red", "(no material)"}
    np.testing.assert_array_equal(
        matte(materials_manifest, materials, "/World/Looks/Red"), obj["/World/Props/Ball/geo"]
    )
    unbound = sum(
        obj[name] for name in OBJECTS - {"/World/Set/backdrop", "/World/Props/Ball/geo"}
    )
    np.testing.assert_allclose(
        matte(materials_manifest, materials, "(no material)"), unbound, atol=1e-6
    )
    # The ball's nearest model root is its component, not the assembly above it; each pebble's
    # is its instance; the box, the backdrop and the cones are in no asset.
    assert set(assets_manifest) == {"/World/Props/Ball", "/World/Row/a", "/World/Row/b", "(no asset)"}
    np.testing.assert_array_equal(
        matte(assets_manifest, assets, "/World/Props/Ball"), obj["/World/Props/Ball/geo"]
    )
    np.testing.assert_array_equal(
        matte(assets_manifest, assets, "/World/Row/b"), obj["/World/Row/b/geo"]
    )
    np.testing.assert_allclose(
        matte(assets_manifest, assets, "(no asset)"),
        obj["/World/Set/backdrop"] + obj["/World/box"] + obj["/World/Scatter/Protos/Cone"],
        atol=1e-6,
    )


def test_layers_channels_and_header_as_the_specification_names_them(rendered):
    _, channels, metadata = _core.read_image(str(rendered))
    for layer in LAYERS:  # depth 6 by default: three RGBA layers
        assert [c for c in channels if c.startswith(layer)] == [
            f"{layer}{n:02d}.{c}" for n in range(3) for c in "RGBA"
        ]
        assert metadata[f"cryptomatte/{layer_key(layer)}/name"] == layer
    info = subprocess.run(["iinfo", "-v", str(rendered)], capture_output=True, text=True).stdout
    assert 'cryptomatte/' in info and "MurmurHash3_32" in info


def test_depth_is_a_render_option(scene, tmp_path):
    out = tmp_path / "shallow.exr"
    flags = ["-w", "32", "-spp", "8", "--aov", "CryptoObject", "-q"]
    assert main([str(scene), str(out), *flags, "--cryptomatteDepth", "3"]) == 0
    _, channels, _ = _core.read_image(str(out))
    assert [c for c in channels if c.startswith("Crypto")] == [
        f"CryptoObject{n:02d}.{c}" for n in range(2) for c in "RGBA"
    ]
    manifest, ranks = decode(out, "CryptoObject")
    assert ranks.shape[2] == 4 and np.all(ranks[..., 3, :] == 0)  # 3 ranks, the 4th padding
    image = penumbra.render(scene, width=32, samples=8, aovs=("CryptoObject",), cryptomatte_depth=1)
    assert image["CryptoObject"].shape == (32, 32, 4)
    deep = penumbra.render(scene, width=32, samples=8, aovs=("CryptoObject",))
    np.testing.assert_array_equal(image["CryptoObject"][..., :2], deep["CryptoObject"][..., :2])
    # Notebooks show rank 0's id as a colour, dimmed by its coverage.
    preview = preview_pixels("CryptoObject", image["CryptoObject"])
    assert preview.shape == (32, 32, 3) and 0 < preview.min() and preview.max() <= 1
    assert len(np.unique(preview.reshape(-1, 3)[image["CryptoObject"][..., 1].ravel() == 1], axis=0)) == 6
    assert main([str(scene), str(out), *flags, "--cryptomatteDepth", "0"]) == 2


def test_cryptomatte_goes_to_exr_only(scene, tmp_path, capsys):
    assert main([str(scene), str(tmp_path / "x.png"), "--aov", "CryptoObject", "-q"]) == 2
    assert ".exr" in capsys.readouterr().err
    image = penumbra.render(scene, width=16, samples=1, aovs=("color", "CryptoAsset"))
    with pytest.raises(ValueError, match="Cryptomatte AOVs .*CryptoAsset.* OpenEXR"):
        image.write(tmp_path / "x.png")


def test_farm_tiles_merge_to_the_local_render(scene, tmp_path, capsys):
    flags = ["-w", "48", "-spp", "8", "--aov", ",".join(LAYERS), "-q"]
    local, farm = tmp_path / "local.exr", tmp_path / "farm.exr"
    assert main([str(scene), str(local), *flags]) == 0
    assert main([str(scene), str(farm), *flags, "--workers", "2"]) == 0
    pixels, channels, metadata = _core.read_image(str(farm))
    expected_pixels, expected_channels, expected = _core.read_image(str(local))
    assert channels == expected_channels
    assert np.array_equal(pixels, expected_pixels)
    for layer in LAYERS:
        assert decode(farm, layer)[0] == decode(local, layer)[0]
    # Each band's manifest holds only what it shows; the merge is their union.
    renderer = penumbra.Renderer(scene)
    tiles = [
        Tile(first, end, 48, 48, dict(image), image.metadata, "/World/cam", "local")
        for first, end in ((0, 24), (24, 48))
        for image in [renderer.render(width=48, samples=8, aovs=LAYERS, region=(0, first, 48, end - first))]
    ]
    key = f"cryptomatte/{layer_key('CryptoObject')}/manifest"
    top, bottom = (set(json.loads(tile.metadata[key])) for tile in tiles)
    assert "/World/Props/Ball/geo" in top - bottom and "/World/Row/a/geo" in bottom - top
    assert set(json.loads(merge_tiles(tiles).metadata[key])) == OBJECTS


def test_render_vars_name_their_layer(scene, tmp_path, capsys):
    stage = Usd.Stage.Open(str(scene))
    var = UsdRender.Var.Define(stage, "/Render/Vars/objects")
    var.CreateSourceNameAttr("crypto_object")  # Arnold's name, an alias
    var.CreateSourceTypeAttr("raw")
    color = UsdRender.Var.Define(stage, "/Render/Vars/color")
    color.CreateSourceNameAttr("C.*")
    color.CreateSourceTypeAttr("lpe")
    product = UsdRender.Product.Define(stage, "/Render/Products/mattes")
    product.CreateProductNameAttr("mattes.exr")
    product.CreateOrderedVarsRel().SetTargets([color.GetPath(), var.GetPath()])
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateResolutionAttr(Gf.Vec2i(32, 32))
    settings.CreateCameraRel().SetTargets(["/World/cam"])
    settings.CreateProductsRel().SetTargets([product.GetPath()])
    settings.GetPrim().CreateAttribute("penumbra:cryptomatteDepth", Sdf.ValueTypeNames.Int).Set(2)
    path = tmp_path / "products.usda"
    stage.Export(str(path))
    assert main([str(path), str(tmp_path / "beauty.exr"), "-rs", "/Render/Settings", "-spp", "4", "-q"]) == 0
    manifest, ranks = decode(tmp_path / "mattes.exr", "objects")
    assert set(manifest) <= OBJECTS and "/World/Props/Ball/geo" in manifest
    assert ranks.shape[2] == 2  # penumbra:cryptomatteDepth 2: one RGBA layer
    np.testing.assert_allclose(
        sum(matte(manifest, ranks, name) for name in manifest), 1.0, atol=1e-6
    )
    product.GetProductNameAttr().Set("mattes.png")  # no Cryptomatte outside OpenEXR
    stage.Export(str(path))
    assert main([str(path), str(tmp_path / "beauty.exr"), "-rs", "/Render/Settings", "-spp", "1", "-q"]) == 1
    assert "mattes.png: Cryptomatte AOVs (CryptoObject) are written to OpenEXR" in capsys.readouterr().err


def test_faces_bound_by_subsets_take_their_material_name(tmp_path):
    """A mesh of two faces (grey), its right face bound red by a GeomSubset: the material layer
    names each half by its own material, the object layer names the whole mesh."""
    stage = new_stage(tmp_path / "subsets.usda")
    add_camera(stage)  # sees [-2, 2]² of the z = 0 plane
    grey = add_preview_material(stage, "/World/Looks/Grey", diffuseColor=(0.5, 0.5, 0.5))
    red = add_preview_material(stage, "/World/Looks/Red", diffuseColor=(0.8, 0.1, 0.1))
    mesh = UsdGeom.Mesh.Define(stage, "/World/halves")
    mesh.CreatePointsAttr([(-3, -3, 0), (0, -3, 0), (3, -3, 0), (-3, 3, 0), (0, 3, 0), (3, 3, 0)])
    mesh.CreateFaceVertexCountsAttr([4, 4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 4, 3, 1, 2, 5, 4])
    bind(mesh, grey)
    subset = UsdShade.MaterialBindingAPI(mesh.GetPrim()).CreateMaterialBindSubset("right", [1])
    UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(red)
    stage.Save()
    out = tmp_path / "subsets.exr"
    command = [str(stage.GetRootLayer().realPath), str(out), "-w", "32", "-spp", "4", "-q"]
    assert main([*command, "--aov", "CryptoObject,CryptoMaterial"]) == 0
    materials, ranks = decode(out, "CryptoMaterial")
    assert set(materials) == {"/World/Looks/Grey", "/World/Looks/Red"}
    grey, red = (matte(materials, ranks, f"/World/Looks/{name}") for name in ("Grey", "Red"))
    # Away from the seam (the pixel filter reaches past a pixel) each half is one material.
    assert (grey[:, :14] == 1).all() and (red[:, :14] == 0).all()
    assert (red[:, 18:] == 1).all() and (grey[:, 18:] == 0).all()
    np.testing.assert_array_equal(grey + red, np.ones((32, 32)))
    objects, object_ranks = decode(out, "CryptoObject")
    assert set(objects) == {"/World/halves"}
    np.testing.assert_array_equal(matte(objects, object_ranks, "/World/halves"), np.ones((32, 32)))


@pytest.mark.parametrize("own", ["/World/Looks/Grey", "/World/Looks/BadA"])
def test_faces_bound_to_a_material_penumbra_cannot_render_are_named_by_it(tmp_path, own):
    # Faces whose subset material is not UsdPreviewSurface were named by the mesh's material,
    # or "(no material)", where a mesh's own such binding is named by its path.
    stage = new_stage(tmp_path / "unusable.usda")
    add_camera(stage)
    add_preview_material(stage, "/World/Looks/Grey", diffuseColor=(0.5, 0.5, 0.5))
    for name in ("BadA", "BadB"):
        material = UsdShade.Material.Define(stage, f"/World/Looks/{name}")
        shader = UsdShade.Shader.Define(stage, f"/World/Looks/{name}/Surface")
        shader.CreateIdAttr("ArnoldStandardSurface")
        material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    mesh = UsdGeom.Mesh.Define(stage, "/World/halves")
    mesh.CreatePointsAttr([(-3, -3, 0), (0, -3, 0), (3, -3, 0), (-3, 3, 0), (0, 3, 0), (3, 3, 0)])
    mesh.CreateFaceVertexCountsAttr([4, 4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 4, 3, 1, 2, 5, 4])
    bind(mesh, UsdShade.Material(stage.GetPrimAtPath(own)))
    subset = UsdShade.MaterialBindingAPI(mesh.GetPrim()).CreateMaterialBindSubset("right", [1])
    UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(
        UsdShade.Material(stage.GetPrimAtPath("/World/Looks/BadB"))
    )
    stage.Save()
    out = tmp_path / "unusable.exr"
    command = [str(stage.GetRootLayer().realPath), str(out), "-w", "32", "-spp", "4", "-q"]
    assert main([*command, "--aov", "CryptoMaterial"]) == 0
    materials, ranks = decode(out, "CryptoMaterial")
    assert set(materials) == {own, "/World/Looks/BadB"}
    assert (matte(materials, ranks, own)[:, :14] == 1).all()
    assert (matte(materials, ranks, "/World/Looks/BadB")[:, 18:] == 1).all()
