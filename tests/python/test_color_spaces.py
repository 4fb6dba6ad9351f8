"""Texture and constant colour spaces through OCIO (docs/materialx.md, "Colour spaces"):
MaterialX ``colorspace`` (on the file, inherited from the document or node graph, on
constants), USD ``colorSpace`` metadata on MaterialX and UsdUVTexture files, unknown names.

Expectations are analytic: cmlib's AP1 → Rec.709 matrix, pure power curves."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from pxr import Sdf, Usd, UsdShade

import penumbra
from penumbra.usd import open_stage
from penumbra.usd.color_spaces import constant_to_scene_linear
from stages import add_camera, add_quad, bind, new_stage
from test_materialx import add_mtlx_material
from test_textures import at, render, textured_stage, write_texture

# MaterialX's AP1 → linear Rec.709 matrix (cmlib's ND_acescg_to_lin_rec709), for column vectors.
AP1_TO_REC709 = np.array([[1.705050992658, -0.621792120657, -0.083258872001],
                          [-0.130256417507, 1.140804736575, -0.010548319068],
                          [-0.024003356805, -0.128968976065, 1.15297233287]])
COLOUR = (0.6, 0.4, 0.2)  # inside Rec.709's gamut once converted from AP1
CODE = 188 / 255  # an 8-bit code value


def constant_texture(path: Path, value: tuple[float, ...]) -> Path:
    return write_texture(path, np.full((8, 8, len(value)), value, dtype=np.float32))


def emissive_image_stage(file: Path, color_space: str | None) -> Usd.Stage:
    """A quad filling the view whose standard_surface emits ``emission_color`` = an
    ND_image_color3 of ``file``, whose file input carries ``color_space`` as metadata; nothing
    else reflects or emits."""
    stage = new_stage()
    add_camera(stage, aperture=(1.6, 1.6))
    quad = add_quad(stage, "/World/quad")
    surface = add_mtlx_material(stage, "/World/Looks/M", "ND_standard_surface_surfaceshader",
                                base=0.0, specular=0.0, emission=1.0)
    image = UsdShade.Shader.Define(stage, "/World/Looks/M/image")
    image.CreateIdAttr("ND_image_color3")
    file_attr = image.CreateInput("file", Sdf.ValueTypeNames.Asset).GetAttr()
    file_attr.Set(Sdf.AssetPath(str(file)))
    if color_space is not None:
        file_attr.SetColorSpace(color_space)
    surface.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        image.CreateOutput("out", Sdf.ValueTypeNames.Color3f))
    bind(quad, UsdShade.Material(stage.GetPrimAtPath("/World/Looks/M")))
    return stage


def rendered(stage: Usd.Stage) -> np.ndarray:
    return at(render(stage, width=16, samples=4), 0, 0)


def quiet(stage: Usd.Stage) -> np.ndarray:
    """``rendered``, failing on any Penumbra warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", penumbra.PenumbraWarning)
        return rendered(stage)


@pytest.mark.parametrize("name", ["acescg", "lin_ap1", "lin_ap1_scene"])
def test_an_acescg_texture_renders_its_rec709_conversion(tmp_path, name):
    file = constant_texture(tmp_path / "ap1.exr", COLOUR)
    np.testing.assert_allclose(quiet(emissive_image_stage(file, name)),
                               AP1_TO_REC709 @ COLOUR, rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("name, power", [("g22_rec709", 2.2), ("g18_rec709", 1.8),
                                         ("rec709_display", 2.4)])
def test_power_encoded_textures_decode_to_the_power_of_their_value(tmp_path, name, power):
    file = constant_texture(tmp_path / "grey.png", (CODE, CODE, CODE))
    np.testing.assert_allclose(quiet(emissive_image_stage(file, name)), [CODE**power] * 3,
                               atol=1e-3)  # 8-bit data is prepared as half floats


@pytest.mark.parametrize("name, expected", [("srgb_texture", 0.50289), (None, CODE),
                                            ("lin_rec709", CODE), ("raw", CODE)])
def test_srgb_and_linear_textures_are_unchanged(tmp_path, name, expected):
    file = constant_texture(tmp_path / "grey.png", (CODE, CODE, CODE))
    np.testing.assert_allclose(quiet(emissive_image_stage(file, name)), [expected] * 3,
                               atol=1e-3)


def test_one_file_in_two_colour_spaces_renders_both(tmp_path):
    file = constant_texture(tmp_path / "grey.png", (CODE, CODE, CODE))
    stage = emissive_image_stage(file, "g22_rec709")
    # A second quad in the view's left half reads the same file raw.
    other = add_quad(stage, "/World/left", center=(-0.5, 0.0, 0.01), half_size=0.4)
    surface = add_mtlx_material(stage, "/World/Looks/Raw", "ND_standard_surface_surfaceshader",
                                base=0.0, specular=0.0, emission=1.0)
    image = UsdShade.Shader.Define(stage, "/World/Looks/Raw/image")
    image.CreateIdAttr("ND_image_color3")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(str(file)))
    surface.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        image.CreateOutput("out", Sdf.ValueTypeNames.Color3f))
    bind(other, UsdShade.Material(stage.GetPrimAtPath("/World/Looks/Raw")))
    image = render(stage, width=32, samples=4)
    np.testing.assert_allclose(at(image, -0.4, 0), [CODE] * 3, atol=1e-3)
    np.testing.assert_allclose(at(image, 0.4, 0), [CODE**2.2] * 3, atol=1e-3)


def test_an_unknown_colour_space_warns_once_by_material_node_and_name_and_reads_raw(tmp_path):
    file = constant_texture(tmp_path / "grey.png", (CODE, CODE, CODE))
    stage = emissive_image_stage(file, "no_such_space")
    with pytest.warns(penumbra.PenumbraWarning,
                      match=r"/World/Looks/M: MaterialX node /World/Looks/M/image: colour space "
                            r"'no_such_space' is not in the OCIO config") as caught:
        colour = rendered(stage)
    assert sum("no_such_space" in str(w.message) for w in caught) == 1
    np.testing.assert_allclose(colour, [CODE] * 3, atol=1e-3)


def test_a_constant_colour_in_acescg_is_converted(tmp_path):
    stage = new_stage()
    add_camera(stage, aperture=(1.6, 1.6))
    quad = add_quad(stage, "/World/quad")
    surface = add_mtlx_material(stage, "/World/Looks/M", "ND_standard_surface_surfaceshader",
                                base=0.0, specular=0.0, emission=1.0, emission_color=COLOUR)
    surface.GetInput("emission_color").GetAttr().SetColorSpace("acescg")
    bind(quad, UsdShade.Material(stage.GetPrimAtPath("/World/Looks/M")))
    np.testing.assert_allclose(quiet(stage), AP1_TO_REC709 @ COLOUR, rtol=1e-4, atol=1e-5)


def test_constants_in_the_working_space_are_kept_exactly():
    report = pytest.fail
    rgba = (0.1, 0.2, 0.3, 0.5)
    for name in ("", "raw", "lin_rec709", "lin_rec709_scene", "scene_linear"):
        assert constant_to_scene_linear(rgba, name, report) is rgba
    converted = constant_to_scene_linear(COLOUR + (0.5,), "lin_ap1", report)
    np.testing.assert_allclose(converted[:3], AP1_TO_REC709 @ COLOUR, rtol=1e-6)
    assert converted[3] == 0.5  # alpha is not a colour


def test_a_conversion_node_decodes_a_raw_texture(tmp_path):
    """cmlib's <space>_to_lin_rec709 nodes on an image without a colour space."""
    file = constant_texture(tmp_path / "grey.png", (CODE, CODE, CODE))
    stage = emissive_image_stage(file, None)
    convert = UsdShade.Shader.Define(stage, "/World/Looks/M/decode")
    convert.CreateIdAttr("ND_g22_rec709_to_lin_rec709_color3")
    convert.CreateInput("in", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        UsdShade.Shader(stage.GetPrimAtPath("/World/Looks/M/image")).GetOutput("out"))
    UsdShade.Shader(stage.GetPrimAtPath("/World/Looks/M/Surface")).GetInput(
        "emission_color").ConnectToSource(
        convert.CreateOutput("out", Sdf.ValueTypeNames.Color3f))
    np.testing.assert_allclose(quiet(stage), [CODE**2.2] * 3, atol=1e-3)


MTLX = """<?xml version="1.0"?>
<materialx version="1.39" colorspace="acescg">
  <nodegraph name="NG_emission">
    <image name="ap1" type="color3">
      <input name="file" type="filename" value="ap1.exr" />
    </image>
    <output name="out" type="color3" nodename="ap1" />
  </nodegraph>
  <nodegraph name="NG_gamma" colorspace="g22_rec709">
    <image name="grey" type="color3">
      <input name="file" type="filename" value="grey.png" />
    </image>
    <output name="out" type="color3" nodename="grey" />
  </nodegraph>
  <standard_surface name="SR_inherited" type="surfaceshader">
    <input name="base" type="float" value="0" />
    <input name="specular" type="float" value="0" />
    <input name="emission" type="float" value="1" />
    <input name="emission_color" type="color3" nodegraph="NG_emission" output="out" />
  </standard_surface>
  <surfacematerial name="M_inherited" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="SR_inherited" />
  </surfacematerial>
  <standard_surface name="SR_graph" type="surfaceshader">
    <input name="base" type="float" value="0" />
    <input name="specular" type="float" value="0" />
    <input name="emission" type="float" value="1" />
    <input name="emission_color" type="color3" nodegraph="NG_gamma" output="out" />
  </standard_surface>
  <surfacematerial name="M_graph" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="SR_graph" />
  </surfacematerial>
</materialx>
"""


@pytest.mark.parametrize("material, expected", [
    ("M_inherited", AP1_TO_REC709 @ COLOUR),  # the document's colorspace
    ("M_graph", np.full(3, CODE**2.2)),  # the node graph's, overriding it
])
def test_a_mtlx_documents_colour_space_is_inherited_by_its_images(tmp_path, material, expected):
    constant_texture(tmp_path / "ap1.exr", COLOUR)
    constant_texture(tmp_path / "grey.png", (CODE, CODE, CODE))
    (tmp_path / "looks.mtlx").write_text(MTLX)
    stage = new_stage()
    add_camera(stage, aperture=(1.6, 1.6))
    quad = add_quad(stage, "/World/quad")
    looks = stage.DefinePrim("/World/Looks", "Scope")
    looks.GetReferences().AddReference(str(tmp_path / "looks.mtlx"), "/MaterialX")
    UsdShade.MaterialBindingAPI.Apply(quad.GetPrim()).GetDirectBindingRel().SetTargets(
        [Sdf.Path(f"/World/Looks/Materials/{material}")])
    path = tmp_path / "scene.usda"
    stage.GetRootLayer().Export(str(path))
    np.testing.assert_allclose(quiet(open_stage(path)), expected, rtol=1e-3, atol=1e-3)


@pytest.mark.parametrize("texture, expected", [
    ({}, CODE**2.2),  # sourceColorSpace auto: the file's colorSpace decides
    ({"sourceColorSpace": "raw"}, CODE),  # an authored sourceColorSpace wins
    ({"sourceColorSpace": "sRGB"}, 0.50289),
])
def test_usd_uv_texture_honours_its_files_colour_space_metadata(tmp_path, texture, expected):
    file = constant_texture(tmp_path / "grey.png", (CODE, CODE, CODE))
    stage, shader = textured_stage(file, texture=texture)
    shader.GetInput("file").GetAttr().SetColorSpace("g22_rec709")
    np.testing.assert_allclose(quiet(stage), [expected] * 3, atol=1e-3)


def test_usd_uv_texture_with_an_unknown_colour_space_warns_by_material_and_node(tmp_path):
    file = constant_texture(tmp_path / "grey.png", (CODE, CODE, CODE))
    stage, shader = textured_stage(file)
    shader.GetInput("file").GetAttr().SetColorSpace("no_such_space")
    with pytest.warns(penumbra.PenumbraWarning,
                      match=r"/World/Looks/textured: UsdUVTexture /World/Looks/textured/Texture: "
                            r"colour space 'no_such_space'"):
        colour = rendered(stage)
    np.testing.assert_allclose(colour, [CODE] * 3, atol=1e-3)


def test_an_srgb_constant_takes_rec709_primaries_into_an_acescg_working_space(
    tmp_path, monkeypatch
):
    # Under a studio config whose scene_linear is ACEScg, an sRGB-tagged constant is converted
    # as an sRGB texture is (Rec.709 to AP1 primaries too); it took the transfer curve alone.
    from penumbra.image import BUNDLED_OCIO_CONFIG
    from penumbra.usd.color_spaces import constant_to_scene_linear

    config = BUNDLED_OCIO_CONFIG.read_text().replace(
        "  scene_linear: Linear Rec.709 (sRGB)\n", "  scene_linear: ACEScg\n"
    )
    assert "scene_linear: ACEScg" in config
    (tmp_path / "aces.ocio").write_text(config)
    monkeypatch.setenv("OCIO", str(tmp_path / "aces.ocio"))
    reports = []
    srgb_red = constant_to_scene_linear((1.0, 0.0, 0.0), "srgb_texture", reports.append)
    linear_red = constant_to_scene_linear((1.0, 0.0, 0.0), "lin_rec709", reports.append)
    assert reports == []
    np.testing.assert_allclose(srgb_red, linear_red, atol=1e-4)
    np.testing.assert_allclose(srgb_red, (0.6131, 0.0702, 0.0206), atol=1e-3)
