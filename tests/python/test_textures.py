"""UsdShade networks through the whole stack: UsdUVTexture (orientation, wrap modes, scale and
bias, colour spaces, UDIM, fallback, filtering), UsdPrimvarReader_*, UsdTransform2d, normal maps
and textured cut-outs.

Most scenes show an emissive quad that fills the view: the material has no diffuse or specular
reflection, so each pixel is the emission the network computes there (filtered over the pixel)."""

from __future__ import annotations

import math
import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

import penumbra
from penumbra import _core
from stages import (
    add_camera,
    add_distant_light,
    add_primvar_emission_material,
    add_quad,
    bind,
    new_stage,
)

# The camera sees x, y in [-0.8, 0.8] of the unit quad [-1, 1]², whose st runs 0..1.
VIEW = 0.8
RED, GREEN, BLUE, WHITE = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (1.0, 1.0, 1.0)


def write_texture(path: Path, pixels: np.ndarray) -> Path:
    """Writes an (H, W, C) image, top row first, as the extension says (PNG: 8 bits, no
    transfer function applied: the values are the encoded ones)."""
    channels = pixels.shape[2]
    names = ["R", "G", "B", "A"][:channels] if channels > 1 else ["Y"]
    _core.write_image(str(path), np.ascontiguousarray(pixels, dtype=np.float32), names, {})
    return path


def quadrants(size: int = 64) -> np.ndarray:
    """Top-left red, top-right green, bottom-left blue, bottom-right white (as viewed)."""
    image = np.zeros((size, size, 3), dtype=np.float32)
    half = size // 2
    image[:half, :half] = RED
    image[:half, half:] = GREEN
    image[half:, :half] = BLUE
    image[half:, half:] = WHITE
    return image


def textured_stage(
    file: str | Path,
    *,
    texture: dict | None = None,
    transform: dict | None = None,
    output: str = "rgb",
    input_name: str = "emissiveColor",
    st_range: tuple[float, float] = (0.0, 1.0),
    surface: dict | None = None,
):
    """A quad facing the camera whose ``input_name`` reads ``output`` of a UsdUVTexture of
    ``file`` (extra UsdUVTexture inputs in ``texture``), st from a UsdPrimvarReader_float2 of
    "st" (spanning ``st_range`` across the quad), through a UsdTransform2d if ``transform``
    is given. Returns (stage, texture shader)."""
    stage = new_stage()
    add_camera(stage, aperture=(1.6, 1.6))
    quad = add_quad(stage, "/World/quad")
    low, high = st_range
    st = UsdGeom.PrimvarsAPI(quad).CreatePrimvar(
        "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex
    )
    st.Set([Gf.Vec2f(low, low), Gf.Vec2f(high, low), Gf.Vec2f(high, high), Gf.Vec2f(low, high)])

    material = UsdShade.Material.Define(stage, "/World/Looks/textured")
    surface_shader = UsdShade.Shader.Define(stage, "/World/Looks/textured/Surface")
    surface_shader.CreateIdAttr("UsdPreviewSurface")
    inputs = {"diffuseColor": (0.0, 0.0, 0.0), "specularColor": (0.0, 0.0, 0.0)}
    inputs.update(surface or {})
    for name, value in inputs.items():
        surface_shader.CreateInput(name, Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*value))
    surface_shader.CreateInput("useSpecularWorkflow", Sdf.ValueTypeNames.Int).Set(1)
    material.CreateSurfaceOutput().ConnectToSource(surface_shader.ConnectableAPI(), "surface")

    tex = UsdShade.Shader.Define(stage, "/World/Looks/textured/Texture")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(str(file)))
    for name, value in (texture or {}).items():
        if isinstance(value, str):
            tex.CreateInput(name, Sdf.ValueTypeNames.Token).Set(value)
        else:
            tex.CreateInput(name, Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*value))
    reader = UsdShade.Shader.Define(stage, "/World/Looks/textured/StReader")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    reader_output = reader.CreateOutput("result", Sdf.ValueTypeNames.Float2)
    st_input = tex.CreateInput("st", Sdf.ValueTypeNames.Float2)
    if transform is not None:
        transform_shader = UsdShade.Shader.Define(stage, "/World/Looks/textured/Transform")
        transform_shader.CreateIdAttr("UsdTransform2d")
        transform_shader.CreateInput("in", Sdf.ValueTypeNames.Float2).ConnectToSource(
            reader_output
        )
        for name, value in transform.items():
            type_name = Sdf.ValueTypeNames.Float if name == "rotation" else Sdf.ValueTypeNames.Float2
            transform_shader.CreateInput(name, type_name).Set(value)
        st_input.ConnectToSource(
            transform_shader.CreateOutput("result", Sdf.ValueTypeNames.Float2)
        )
    else:
        st_input.ConnectToSource(reader_output)
    out_type = Sdf.ValueTypeNames.Float3 if output == "rgb" else Sdf.ValueTypeNames.Float
    in_type = (
        Sdf.ValueTypeNames.Color3f
        if input_name in ("diffuseColor", "emissiveColor", "specularColor")
        else (Sdf.ValueTypeNames.Normal3f if input_name == "normal" else Sdf.ValueTypeNames.Float)
    )
    surface_shader.CreateInput(input_name, in_type).ConnectToSource(tex.CreateOutput(output, out_type))
    bind(quad, material)
    return stage, tex


def render(stage, width: int = 40, samples: int = 16) -> np.ndarray:
    return penumbra.render(stage, camera="/cam", width=width, samples=samples)["color"]


def at(image: np.ndarray, x: float, y: float) -> np.ndarray:
    """The RGB at quad coordinates (x, y) in [-VIEW, VIEW] (y up), averaged over 3×3 pixels."""
    h, w = image.shape[:2]
    column = int((x / VIEW + 1) / 2 * w)
    row = int((1 - y / VIEW) / 2 * h)
    return image[row - 1 : row + 2, column - 1 : column + 2, :3].reshape(-1, 3).mean(axis=0)


def st_to_xy(s: float, t: float) -> tuple[float, float]:
    return 2 * s - 1, 2 * t - 1


def test_textures_show_their_top_left_at_st_0_1(tmp_path):
    stage, _ = textured_stage(write_texture(tmp_path / "quadrants.png", quadrants()))
    image = render(stage)
    # USD's st origin is the image's bottom-left corner.
    for (s, t), color in {(0.25, 0.75): RED, (0.75, 0.75): GREEN, (0.25, 0.25): BLUE,
                          (0.75, 0.25): WHITE}.items():
        np.testing.assert_allclose(at(image, *st_to_xy(s, t)), color, atol=0.02)


def test_transform2d_scales_then_rotates_then_translates(tmp_path):
    # st' = rotate90(st * (1, 1)) + (1, 0): st (0.25, 0.25) → (-0.25, 0.25) → (0.75, 0.25).
    stage, _ = textured_stage(
        write_texture(tmp_path / "quadrants.png", quadrants()),
        transform={"rotation": 90.0, "translation": Gf.Vec2f(1, 0)},
        texture={"wrapS": "repeat", "wrapT": "repeat"},
    )
    image = render(stage)
    # Quad point st → texture lookup (1 - t, s): (0.25, 0.25) → (0.75, 0.25) white;
    # (0.25, 0.75) → (0.25, 0.25) blue; (0.75, 0.75) → (0.25, 0.75) red; (0.75, 0.25) → green.
    for (s, t), color in {(0.25, 0.25): WHITE, (0.25, 0.75): BLUE, (0.75, 0.75): RED,
                          (0.75, 0.25): GREEN}.items():
        np.testing.assert_allclose(at(image, *st_to_xy(s, t)), color, atol=0.02)


@pytest.mark.parametrize(
    "wrap, expected_at_1_25",
    [("repeat", BLUE), ("mirror", WHITE), ("clamp", WHITE), ("black", (0.0, 0.0, 0.0))],
)
def test_wrap_modes(tmp_path, wrap, expected_at_1_25):
    # st spans [-0.5, 1.5]; the sample at s = 1.25, t = 0.25 lies beyond the right edge.
    stage, _ = textured_stage(
        write_texture(tmp_path / "quadrants.png", quadrants()),
        texture={"wrapS": wrap, "wrapT": wrap},
        st_range=(-0.5, 1.5),
    )
    image = render(stage)
    x, y = (1.25 + 0.5) / 2 * 2 - 1, (0.25 + 0.5) / 2 * 2 - 1  # quad coordinates of that st
    np.testing.assert_allclose(at(image, x, y), expected_at_1_25, atol=0.02)
    # Inside [0, 1] every mode shows the texture itself.
    np.testing.assert_allclose(at(image, (0.25 + 0.5) - 1, (0.75 + 0.5) - 1), RED, atol=0.02)


def test_scale_bias_and_channel_outputs(tmp_path):
    file = write_texture(tmp_path / "quadrants.png", quadrants())
    stage, _ = textured_stage(
        file, texture={"scale": (0.5, 2.0, 1.0, 1.0), "bias": (0.25, 0.0, 0.1, 0.0)}
    )
    np.testing.assert_allclose(
        at(render(stage), *st_to_xy(0.75, 0.25)), (0.75, 2.0, 1.1), atol=0.03
    )
    # A single channel feeding a colour input is grey.
    stage, _ = textured_stage(file, output="g")
    image = render(stage)
    np.testing.assert_allclose(at(image, *st_to_xy(0.75, 0.75)), (1.0, 1.0, 1.0), atol=0.02)
    np.testing.assert_allclose(at(image, *st_to_xy(0.25, 0.75)), (0.0, 0.0, 0.0), atol=0.02)


@pytest.mark.parametrize(
    "color_space, expected",
    [("sRGB", 0.5029), ("auto", 0.5029), ("raw", 188 / 255)],
)
def test_source_color_space(tmp_path, color_space, expected):
    # sRGB code value 188 decodes to 0.5029 linear (IEC 61966-2-1).
    grey = np.full((8, 8, 3), 188 / 255, dtype=np.float32)
    stage, _ = textured_stage(
        write_texture(tmp_path / "grey.png", grey), texture={"sourceColorSpace": color_space}
    )
    assert at(render(stage), 0, 0) == pytest.approx([expected] * 3, abs=0.003)


def test_mip_mapping_filters_fine_detail_to_its_average(tmp_path):
    # 1-texel black/white checks, sRGB-encoded, far smaller than a pixel (512 texels over 40
    # pixels): filtered lookups average them to linear 0.5 even at one sample per pixel, where
    # point sampling would give 0 or 1 per pixel.
    size = 512
    checks = ((np.indices((size, size)).sum(axis=0) % 2) * 1.0).astype(np.float32)
    stage, _ = textured_stage(
        write_texture(tmp_path / "checks.png", np.repeat(checks[..., None], 3, axis=2)),
        texture={"sourceColorSpace": "sRGB"},
    )
    image = render(stage, samples=1)[5:-5, 5:-5, 0]
    assert image.mean() == pytest.approx(0.5, abs=0.03)
    assert image.std() < 0.05


def test_udim_tiles(tmp_path):
    for tile, color in ((1001, RED), (1002, GREEN)):
        write_texture(tmp_path / f"paint.{tile}.png", np.tile(np.float32(color), (8, 8, 1)))
    stage, _ = textured_stage(tmp_path / "paint.<UDIM>.png")
    st = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/World/quad")).GetPrimvar("st")
    st.Set([Gf.Vec2f(0, 0), Gf.Vec2f(2, 0), Gf.Vec2f(2, 1), Gf.Vec2f(0, 1)])
    image = render(stage)
    np.testing.assert_allclose(at(image, -0.5, 0), RED, atol=0.02)  # s = 0.5: tile 1001
    np.testing.assert_allclose(at(image, 0.5, 0), GREEN, atol=0.02)  # s = 1.5: tile 1002


@pytest.mark.parametrize("file", ["tex/paint.<UDIM>.png", "./tex/paint.<UDIM>.png"])
def test_udim_paths_resolve_against_the_layer_that_authored_them(tmp_path, file):
    # A search path (no "./") in a referenced layer found no tiles (the fallback), or the
    # tiles of the working directory.
    asset = tmp_path / "asset"
    (asset / "tex").mkdir(parents=True)
    write_texture(asset / "tex" / "paint.1001.png", np.tile(np.float32(RED), (8, 8, 1)))
    stage, _ = textured_stage(file)
    stage.GetRootLayer().Export(str(asset / "asset.usda"))
    root = Usd.Stage.CreateInMemory()
    for path in ("/World", "/cam"):
        root.DefinePrim(path).GetReferences().AddReference(str(asset / "asset.usda"), path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        image = render(root)
    np.testing.assert_allclose(at(image, 0, 0), RED, atol=0.02)


def test_textures_inside_a_usdz_package_are_read(tmp_path):
    # OpenImageIO cannot open "asset.usdz[red.png]": it rendered the fallback, warning that the
    # file did not exist. A dome's texture inside a package too.
    from pxr import UsdLux, UsdUtils

    def packaged(stage: Usd.Stage, name: str, *files: str) -> Usd.Stage:
        stage.GetRootLayer().Export(str(tmp_path / f"{name}.usda"))
        package = str(tmp_path / f"{name}.usdz")
        assert UsdUtils.CreateNewUsdzPackage(str(tmp_path / f"{name}.usda"), package)
        for file in files:
            os.remove(tmp_path / file)
        return Usd.Stage.Open(package)

    write_texture(tmp_path / "red.png", np.tile(np.float32(RED), (8, 8, 1)))
    write_texture(tmp_path / "sky.exr", np.full((4, 8, 3), 0.25, np.float32))
    quad = packaged(textured_stage("./red.png")[0], "quad", "red.png")
    sky = new_stage()
    add_camera(sky)
    UsdLux.DomeLight.Define(sky, "/sky").CreateTextureFileAttr(Sdf.AssetPath("./sky.exr"))
    sky = packaged(sky, "sky", "sky.exr")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_allclose(at(render(quad), 0, 0), RED, atol=0.02)
        np.testing.assert_allclose(render(sky)[..., :3], 0.25, atol=0.01)


def test_an_unreadable_udim_tile_falls_back_alone(tmp_path):
    # One truncated tile threw the whole set away (every tile the fallback).
    write_texture(tmp_path / "paint.1001.png", np.tile(np.float32(RED), (8, 8, 1)))
    write_texture(tmp_path / "paint.1003.png", np.tile(np.float32(BLUE), (8, 8, 1)))
    good = write_texture(tmp_path / "good.png", np.tile(np.float32(GREEN), (8, 8, 1)))
    (tmp_path / "paint.1002.png").write_bytes(good.read_bytes()[:60])
    fallback = (0.2, 0.4, 0.6, 1.0)
    stage, _ = textured_stage(tmp_path / "paint.<UDIM>.png", texture={"fallback": fallback})
    st = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/World/quad")).GetPrimvar("st")
    st.Set([Gf.Vec2f(0, 0), Gf.Vec2f(3, 0), Gf.Vec2f(3, 1), Gf.Vec2f(0, 1)])
    with pytest.warns(penumbra.PenumbraWarning) as record:
        image = render(stage, width=60)
    messages = [str(w.message) for w in record if "paint.1002.png" in str(w.message)]
    assert len(messages) == 1 and messages[0].endswith("those UDIM tiles give the fallback value")
    third = 2 * 0.8 / 3  # the view, x in [-0.8, 0.8], holds s from 0.3 to 2.7
    for x, expected in ((-0.8 + third / 2, RED), (0.0, fallback[:3]), (0.8 - third / 2, BLUE)):
        np.testing.assert_allclose(at(image, x, 0), expected, atol=0.02)


def test_an_unreadable_udim_tile_mended_after_a_render_is_read_by_the_next(tmp_path):
    # The set's other tiles were read again on changes, the unreadable one never.
    write_texture(tmp_path / "paint.1001.png", np.tile(np.float32(RED), (8, 8, 1)))
    good = write_texture(tmp_path / "good.png", np.tile(np.float32(GREEN), (8, 8, 1)))
    (tmp_path / "paint.1002.png").write_bytes(good.read_bytes()[:60])
    stage, _ = textured_stage(tmp_path / "paint.<UDIM>.png")
    st = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/World/quad")).GetPrimvar("st")
    st.Set([Gf.Vec2f(0, 0), Gf.Vec2f(2, 0), Gf.Vec2f(2, 1), Gf.Vec2f(0, 1)])
    renderer = penumbra.Renderer(stage)
    with pytest.warns(penumbra.PenumbraWarning, match="paint.1002.png"):
        renderer.render(camera="/cam", width=40, samples=4)
    (tmp_path / "paint.1002.png").write_bytes(good.read_bytes())
    mended = renderer.render(camera="/cam", width=40, samples=4)["color"]
    np.testing.assert_allclose(at(mended, 0.4, 0), GREEN, atol=0.02)


def test_tile_tokens_other_than_udim_are_named_when_nothing_is_found(tmp_path):
    # Mari's <UVTILE> read as a file name: the warning said only "no such file".
    stage, _ = textured_stage(tmp_path / "paint.<UVTILE>.png")
    with pytest.warns(penumbra.PenumbraWarning,
                      match=r"the tile token <UVTILE> is not supported: USD's is <UDIM>"):
        render(stage)


def test_missing_texture_warns_and_uses_the_fallback(tmp_path):
    missing = tmp_path / "nowhere.png"
    stage, _ = textured_stage(missing, texture={"fallback": (0.2, 0.4, 0.6, 1.0)})
    with pytest.warns(penumbra.PenumbraWarning, match="nowhere.png"):
        image = render(stage)
    np.testing.assert_allclose(at(image, 0, 0), (0.2, 0.4, 0.6), atol=0.01)


def test_a_missing_texture_driving_two_inputs_warns_once(tmp_path):
    stage, _ = textured_stage(tmp_path / "nowhere.png")
    surface = UsdShade.Shader.Get(stage, "/World/Looks/textured/Surface")
    texture = UsdShade.Shader.Get(stage, "/World/Looks/textured/Texture")
    texture.CreateOutput("r", Sdf.ValueTypeNames.Float)
    surface.CreateInput("roughness", Sdf.ValueTypeNames.Float).ConnectToSource(
        texture.ConnectableAPI(), "r"
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        render(stage)
    messages = [str(w.message) for w in caught if "nowhere.png" in str(w.message)]
    assert len(messages) == 1, messages


def test_textured_opacity_cuts_out_per_hit(tmp_path):
    # Alpha 0 on the left half of the texture: with opacityThreshold 0.5 the quad is cut out
    # there, and the camera sees the default white dome (radiance 1) behind it. With a
    # threshold, opacity is presence: the right half (alpha 0.75) is opaque, showing only its
    # emission.
    rgba = np.ones((8, 8, 4), dtype=np.float32)
    rgba[:, :4, 3] = 0
    rgba[:, 4:, 3] = 0.75  # above the threshold: fully present, not translucent
    stage, _ = textured_stage(
        write_texture(tmp_path / "mask.png", rgba),
        output="a",
        input_name="opacity",
        surface={"emissiveColor": (0.0, 0.0, 4.0)},
    )
    surface = UsdShade.Shader.Get(stage, "/World/Looks/textured/Surface")
    surface.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(0.5)
    image = render(stage)
    np.testing.assert_allclose(at(image, -0.5, 0), (1.0, 1.0, 1.0), atol=0.01)
    np.testing.assert_allclose(at(image, 0.5, 0), (0.0, 0.0, 4.0), atol=0.01)


def cut_out_stage(file: Path, connect_alpha: bool = True):
    """A quad whose emission reads ``file``'s colour (scaled to red 3, blue 0) and, if
    ``connect_alpha``, whose opacity reads its alpha, cut out at 0.5: where it is cut out, the
    white dome behind shows blue."""
    stage, tex = textured_stage(file, texture={"scale": (3.0, 3.0, 0.0, 1.0)})
    if connect_alpha:
        surface = UsdShade.Shader.Get(stage, "/World/Looks/textured/Surface")
        surface.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(
            tex.CreateOutput("a", Sdf.ValueTypeNames.Float)
        )
        surface.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(0.5)
    return stage


@pytest.mark.parametrize("extension", ["png", "exr"])
def test_cut_out_edges_keep_the_colour_of_their_opaque_texels(tmp_path, extension):
    # White opaque columns between transparent black ones (as painted cut-outs often are). A
    # pixel shows the surface's red emission, 3 where white, over the share of it the cut-out
    # covers, and the dome (red 1, blue 1) over the rest: red = 3 (1 - blue) + blue, so the
    # surface's colour is (red - blue) / (1 - blue). The colour filtered across an edge is
    # weighed by alpha, so it is 3 everywhere; filtered as stored, the black texels pulled it
    # down to 1.9 at the edges (magnified, 4 texels across) and to 2 everywhere (minified, 2
    # of 3 columns opaque).
    magnified = np.zeros((4, 4, 4), dtype=np.float32)
    magnified[:, ::2] = 1.0
    minified = np.zeros((256, 256, 4), dtype=np.float32)
    minified[:, np.arange(256) % 3 != 2] = 1.0
    for name, rgba in (("magnified", magnified), ("minified", minified)):
        stage = cut_out_stage(write_texture(tmp_path / f"{name}.{extension}", rgba))
        inner = render(stage, samples=64)[4:-4, 4:-4, :3].reshape(-1, 3)
        red, blue = inner[:, 0], inner[:, 2]
        covered = blue < 0.8
        assert covered.mean() > 0.3, name
        colour = (red[covered] - blue[covered]) / (1 - blue[covered])
        np.testing.assert_allclose(colour, 3.0, rtol=2e-3, err_msg=name)


def test_colour_is_read_as_stored_where_alpha_is_not_opacity(tmp_path):
    # Colour painted under alpha 0 (a texture whose alpha is a mask for something else, or not
    # used): with no opacity reading the alpha, colour comes back as stored.
    rgba = np.zeros((4, 4, 4), dtype=np.float32)
    rgba[..., :3] = 1.0
    rgba[:, ::2, 3] = 1.0
    image = render(cut_out_stage(write_texture(tmp_path / "bleed.png", rgba), connect_alpha=False))
    np.testing.assert_allclose(image[4:-4, 4:-4, 0], 3.0, rtol=2e-3)


def test_a_repainted_texture_is_read_again_by_the_next_render(tmp_path):
    # The lookdev loop: paint, render, paint again, render with the same Renderer. The second
    # render kept the first file's texels (0.2 where 0.8 was painted) until a new Renderer.
    path = write_texture(tmp_path / "paint.png", np.full((8, 8, 3), 0.2, np.float32))
    stage, _ = textured_stage(path, texture={"sourceColorSpace": "raw"})
    renderer = penumbra.Renderer(stage)
    first = renderer.render(camera="/cam", width=16, samples=1)["color"]
    write_texture(path, np.full((8, 8, 3), 0.8, np.float32))
    stamp = path.stat()
    os.utime(path, ns=(stamp.st_atime_ns, stamp.st_mtime_ns + 2_000_000_000))  # any clock
    second = renderer.render(camera="/cam", width=16, samples=1)["color"]
    np.testing.assert_allclose(at(first, 0, 0), 0.2, atol=3e-3)
    np.testing.assert_allclose(at(second, 0, 0), 0.8, atol=3e-3)
    fresh = penumbra.Renderer(stage).render(camera="/cam", width=16, samples=1)["color"]
    np.testing.assert_array_equal(second, fresh)


def test_primvar_readers_drive_any_input():
    # UsdPrimvarReader_float3 of a per-face "tint", and UsdPrimvarReader_float of a constant
    # "glow" scaling... read as emission on two faces.
    stage = new_stage()
    add_camera(stage, aperture=(1.6, 1.6))
    mesh = UsdGeom.Mesh.Define(stage, "/World/strip")
    mesh.CreatePointsAttr([(-1, -1, 0), (0, -1, 0), (0, 1, 0), (-1, 1, 0), (1, -1, 0), (1, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([4, 4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3, 1, 4, 5, 2])
    mesh.CreateSubdivisionSchemeAttr("none")
    primvars = UsdGeom.PrimvarsAPI(mesh)
    tint = primvars.CreatePrimvar("tint", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.uniform)
    tint.Set([Gf.Vec3f(1, 0.5, 0), Gf.Vec3f(0, 0.5, 1)])
    material = add_primvar_emission_material(stage, "/World/Looks/tinted", "tint")
    bind(mesh, material)
    image = render(stage)
    np.testing.assert_allclose(at(image, -0.5, 0), (1, 0.5, 0), atol=0.01)
    np.testing.assert_allclose(at(image, 0.5, 0), (0, 0.5, 1), atol=0.01)

    # Where the primvar is missing the reader's fallback is used; editing the primvar re-renders.
    reader = UsdShade.Shader.Get(stage, "/World/Looks/tinted/Reader")
    reader.CreateInput("fallback", Sdf.ValueTypeNames.Float3).Set(Gf.Vec3f(0.25, 0.25, 0.25))
    reader.GetInput("varname").Set("absent")
    np.testing.assert_allclose(at(render(stage), 0.5, 0), (0.25, 0.25, 0.25), atol=0.01)


def test_normal_maps_bend_the_shading_normal(tmp_path):
    # The quad faces +Z, lit by a distant light 45° towards +X. A constant normal map tilting
    # the normal 45° towards +s (= +X here) turns it to face the light: the radiance rises by
    # 1/cos 45°. Tilted the other way it faces 90° away and goes black. Normal maps are encoded
    # as the spec says: raw values, scale 2, bias -1.
    def radiance(tilt_degrees: float | None) -> float:
        """``None``: the same material with the normal map disconnected."""
        tilt = math.radians(tilt_degrees or 0.0)
        encoded = np.tile(np.float32([(math.sin(tilt) + 1) / 2, 0.5, (math.cos(tilt) + 1) / 2]), (8, 8, 1))
        stage, _ = textured_stage(
            write_texture(tmp_path / f"normal{tilt_degrees}.exr", encoded),
            input_name="normal",
            texture={"scale": (2, 2, 2, 1), "bias": (-1, -1, -1, 0), "sourceColorSpace": "raw"},
            surface={"diffuseColor": (0.5, 0.5, 0.5)},
        )
        if tilt_degrees is None:
            surface = UsdShade.Shader.Get(stage, "/World/Looks/textured/Surface")
            surface.GetInput("normal").GetAttr().ClearConnections()
        light = add_distant_light(stage, intensity=2.0)
        light.AddRotateYOp().Set(45.0)  # light travels along -Z turned 45° about Y: from +X
        return float(render(stage, samples=64)[5:-5, 5:-5, :3].mean())

    flat = radiance(0.0)
    assert radiance(None) == pytest.approx(flat, rel=0.01)  # the identity map changes nothing
    assert radiance(45.0) / flat == pytest.approx(math.sqrt(2), rel=0.03)
    assert radiance(-45.0) / flat < 0.05


def srgb_to_linear(value: float) -> float:
    return value / 12.92 if value <= 0.04045 else ((value + 0.055) / 1.055) ** 2.4


@pytest.mark.parametrize(
    "extension, srgb",
    [("png", True), ("jpg", True), ("tif", True), ("tga", True), ("exr", False), ("hdr", False)],
)
def test_file_formats(tmp_path, extension, srgb):
    # The quadrant texture in each format OIIO reads; 8-bit formats are sRGB-encoded under
    # "auto", float ones are linear. JPEG is lossy: its tolerance covers the compression.
    levels = {RED: (0.8, 0.2, 0.1), GREEN: (0.1, 0.6, 0.3), BLUE: (0.2, 0.3, 0.9), WHITE: (0.9,) * 3}
    image = quadrants()
    for key, value in levels.items():
        image[np.all(image == np.float32(key), axis=2)] = value
    stage, _ = textured_stage(write_texture(tmp_path / f"quadrants.{extension}", image))
    rendered = render(stage)
    tolerance = 0.03 if extension == "jpg" else 0.01
    for (s, t), key in {(0.25, 0.75): RED, (0.75, 0.75): GREEN, (0.25, 0.25): BLUE,
                        (0.75, 0.25): WHITE}.items():
        expected = [srgb_to_linear(c) if srgb else c for c in levels[key]]
        np.testing.assert_allclose(at(rendered, *st_to_xy(s, t)), expected, atol=tolerance)


@pytest.mark.parametrize("channels", [1, 3])
def test_an_srgb_label_without_evidence_does_not_make_a_tx_srgb(tmp_path, channels):
    # maketx copies OIIO's default "sRGB" label of a PNG into the .tx (TIFF) it makes: under
    # "auto" a grey map then follows the bits and channels rule, as Storm reads it (it was
    # decoded: 0.50 where 0.74); an 8-bit RGB one is sRGB by that rule anyway.
    pixels = np.full((8, 8, channels), 188 / 255, np.float32)
    names = ["Y"] if channels == 1 else ["R", "G", "B"]
    file = tmp_path / "map.tx"
    _core.write_image(str(tmp_path / "map.tif"), pixels, names, {"oiio:ColorSpace": "sRGB"})
    os.rename(tmp_path / "map.tif", file)
    stage, _ = textured_stage(file)
    expected = 188 / 255 if channels == 1 else srgb_to_linear(188 / 255)
    np.testing.assert_allclose(at(render(stage), 0, 0), (expected,) * 3, atol=0.005)


@pytest.mark.parametrize(
    "texture, message",
    [
        ({"wrapS": "periodic"}, "unknown wrap mode 'periodic'"),
        ({"sourceColorSpace": "linear"}, "unknown sourceColorSpace 'linear'"),
    ],
)
def test_malformed_networks_warn_and_keep_the_constants(tmp_path, texture, message):
    stage, _ = textured_stage(write_texture(tmp_path / "q.png", quadrants()), texture=texture)
    with pytest.warns(penumbra.PenumbraWarning, match=f"/World/Looks/textured.*{message}"):
        image = render(stage)
    np.testing.assert_allclose(at(image, 0, 0), (0.0, 0.0, 0.0), atol=0.01)  # no emission


def test_malformed_values_warn_and_keep_the_default(tmp_path):
    stage, tex = textured_stage(write_texture(tmp_path / "q.png", quadrants()))
    tex.CreateInput("scale", Sdf.ValueTypeNames.Float).Set(2.0)  # UsdUVTexture's scale is float4
    with pytest.warns(penumbra.PenumbraWarning, match="/World/Looks/textured"):
        image = render(stage)
    np.testing.assert_allclose(at(image, 0, 0), (0.0, 0.0, 0.0), atol=0.01)


def test_edits_through_a_node_graph_interface_re_render(tmp_path):
    red = write_texture(tmp_path / "red.png", np.tile(np.float32(RED), (4, 4, 1)))
    blue = write_texture(tmp_path / "blue.png", np.tile(np.float32(BLUE), (4, 4, 1)))
    stage, tex = textured_stage(red)
    graph = UsdShade.NodeGraph.Define(stage, "/World/Looks/textured/Graph")
    file_input = graph.CreateInput("texfile", Sdf.ValueTypeNames.Asset)
    file_input.Set(Sdf.AssetPath(str(red)))
    tex.GetInput("file").ConnectToSource(file_input)
    renderer = penumbra.Renderer(stage)
    np.testing.assert_allclose(at(renderer.render(camera="/cam", width=40, samples=4)["color"], 0, 0), RED, atol=0.01)
    file_input.Set(Sdf.AssetPath(str(blue)))
    np.testing.assert_allclose(at(renderer.render(camera="/cam", width=40, samples=4)["color"], 0, 0), BLUE, atol=0.01)


@pytest.mark.parametrize("kept", [2 / 3, 0.03])  # of the pixels, or of the header
@pytest.mark.parametrize("extension", ["png", "jpg", "tif", "exr"])
def test_a_truncated_texture_is_named_and_gives_the_fallback(tmp_path, extension, kept):
    # JPEG and TIFF readers filled in the missing rows (grey, or garbage) without a word; the
    # others named a temporary file of Penumbra's in the warning, over several lines.
    good = write_texture(tmp_path / f"good.{extension}", quadrants(256))
    truncated = tmp_path / f"truncated.{extension}"
    truncated.write_bytes(good.read_bytes()[: int(good.stat().st_size * kept)])
    fallback = (0.2, 0.4, 0.6, 1.0)
    stage, _ = textured_stage(truncated, texture={"fallback": fallback})
    with pytest.warns(penumbra.PenumbraWarning) as record:
        image = render(stage)
    messages = [str(w.message) for w in record if "truncated" in str(w.message)]
    assert len(messages) == 1, messages
    assert f"{truncated}: cannot " in messages[0]
    assert "\n" not in messages[0] and "penumbra-textures" not in messages[0]
    for x, y in ((-0.5, 0.5), (0.5, -0.5)):
        np.testing.assert_allclose(at(image, x, y), fallback[:3], atol=0.01)


def test_a_texture_mended_after_a_render_is_read_by_the_next(tmp_path):
    # A file that could not be read stayed at its fallback in that Renderer once mended.
    good = write_texture(tmp_path / "good.jpg", quadrants(256))
    paint = tmp_path / "paint.jpg"
    paint.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    fallback = (0.2, 0.4, 0.6, 1.0)
    stage, _ = textured_stage(paint, texture={"fallback": fallback})
    renderer = penumbra.Renderer(stage)
    with pytest.warns(penumbra.PenumbraWarning, match="paint.jpg"):
        broken = renderer.render(camera="/cam", width=40, samples=16)["color"]
    np.testing.assert_allclose(at(broken, 0.5, -0.5), fallback[:3], atol=0.01)
    paint.write_bytes(good.read_bytes())
    mended = renderer.render(camera="/cam", width=40, samples=16)["color"]
    fresh = penumbra.Renderer(stage).render(camera="/cam", width=40, samples=16)["color"]
    np.testing.assert_array_equal(mended, fresh)
    assert not np.allclose(at(mended, 0.5, -0.5), fallback[:3], atol=0.05)
