"""MaterialX materials (docs/materialx.md): standard_surface and open_pbr_surface networks
authored in USD and in referenced .mtlx documents, checked against analytic values.

Under a white dome of radiance 1 and nothing else, a Lambertian surface of albedo ρ has radiance
ρ, and a closed object made of an energy-conserving, non-absorbing BSDF has radiance 1 (the
white furnace)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

import penumbra
from penumbra.usd import materialx_values as mv
from penumbra.usd import open_stage
from penumbra.usd.material import bound_material
from stages import SCENES, add_camera, add_preview_material, add_quad, add_sphere_mesh, bind, \
    new_stage
from test_textures import BLUE, GREEN, RED, WHITE, at, quadrants, st_to_xy, write_texture

MATERIALX_ASSETS = SCENES / "materialx"
TERRACOTTA = (0.6, 0.3, 0.2)  # base_color of M_terracotta in materials.mtlx
SURFACES = {  # node definition, and the input that switches the specular layer off
    "standard_surface": ("ND_standard_surface_surfaceshader", {"specular": 0.0}),
    "open_pbr_surface": ("ND_open_pbr_surface_surfaceshader", {"specular_weight": 0.0}),
    "UsdPreviewSurface": ("ND_UsdPreviewSurface_surfaceshader",
                          {"useSpecularWorkflow": 1, "specularColor": (0.0, 0.0, 0.0)}),
}


def _type(value) -> Sdf.ValueTypeName:
    if isinstance(value, bool):
        return Sdf.ValueTypeNames.Bool
    if isinstance(value, int):
        return Sdf.ValueTypeNames.Int
    if isinstance(value, tuple):
        return Sdf.ValueTypeNames.Color3f
    return Sdf.ValueTypeNames.Float


def add_mtlx_material(stage: Usd.Stage, path: str, node_def: str, context: str = "mtlx",
                      **inputs) -> UsdShade.Shader:
    """A material whose ``context`` surface output (``outputs:mtlx:surface``, or
    ``outputs:surface`` for context "") is a ``node_def`` shader with the given inputs."""
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/Surface")
    shader.CreateIdAttr(node_def)
    for name, value in inputs.items():
        shader.CreateInput(name, _type(value)).Set(value)
    material.CreateSurfaceOutput(context).ConnectToSource(
        shader.CreateOutput("out", Sdf.ValueTypeNames.Token)
    )
    return shader


def white_dome(stage: Usd.Stage) -> None:
    UsdLux.DomeLight.Define(stage, "/Dome").CreateIntensityAttr(1.0)


def quad_radiance(stage: Usd.Stage) -> np.ndarray:
    """Mean RGB of a view filled by the quad of :func:`diffuse_quad_stage`."""
    image = penumbra.render(stage, camera="/cam", width=16, samples=64, seed=3)["color"]
    return image[..., :3].reshape(-1, 3).mean(axis=0)


def diffuse_quad_stage() -> Usd.Stage:
    stage = new_stage()
    add_camera(stage, aperture=(1.6, 1.6))  # sees [-0.8, 0.8]² of the unit quad
    add_quad(stage, "/World/quad")
    white_dome(stage)
    return stage


@pytest.mark.parametrize("context", ["mtlx", ""])
@pytest.mark.parametrize("surface", SURFACES)
def test_diffuse_quad_under_a_white_dome_returns_its_base_colour(surface, context):
    node_def, no_specular = SURFACES[surface]
    base_color = "diffuseColor" if surface == "UsdPreviewSurface" else "base_color"
    stage = diffuse_quad_stage()
    add_mtlx_material(stage, "/World/Looks/clay", node_def, context,
                      **{base_color: TERRACOTTA}, **no_specular)
    bind(UsdGeom.Mesh(stage.GetPrimAtPath("/World/quad")),
         UsdShade.Material(stage.GetPrimAtPath("/World/Looks/clay")))
    np.testing.assert_allclose(quad_radiance(stage), TERRACOTTA, rtol=0.02)


def furnace_radiance(material_builder) -> float:
    """Mean radiance of a closed sphere filling the view under a white dome."""
    stage = new_stage()
    add_camera(stage, translate=(0, 0, 4), focal_length=50.0, aperture=(2.0, 2.0))
    sphere = add_sphere_mesh(stage, "/World/ball", rings=48, sectors=96)
    white_dome(stage)
    bind(sphere, material_builder(stage))
    image = penumbra.render(stage, camera="/cam", width=16, samples=256, seed=5,
                            max_path_depth=64)["color"]
    return float(image[..., :3].mean())


def _mtlx(node_def: str, **inputs):
    def build(stage):
        add_mtlx_material(stage, "/World/Looks/m", node_def, **inputs)
        return UsdShade.Material(stage.GetPrimAtPath("/World/Looks/m"))
    return build


def _preview(**inputs):
    return lambda stage: add_preview_material(stage, "/World/Looks/m", **inputs)


@pytest.mark.parametrize(
    "variant, builder",
    [
        ("standard_surface metal",
         _mtlx("ND_standard_surface_surfaceshader", base_color=(1.0, 1.0, 1.0), metalness=1.0,
               specular_roughness=0.5)),
        ("open_pbr_surface metal",
         _mtlx("ND_open_pbr_surface_surfaceshader", base_color=(1.0, 1.0, 1.0),
               base_metalness=1.0, specular_roughness=0.5)),
        ("standard_surface glass",
         _mtlx("ND_standard_surface_surfaceshader", transmission=1.0, specular_roughness=0.0)),
        ("open_pbr_surface glass",
         _mtlx("ND_open_pbr_surface_surfaceshader", transmission_weight=1.0,
               specular_roughness=0.0)),
    ],
)
def test_metal_and_glass_pass_the_white_furnace_like_usd_preview_surface(variant, builder):
    if "metal" in variant:
        counterpart = _preview(diffuseColor=(1.0, 1.0, 1.0), metallic=1.0, roughness=0.5)
    else:
        counterpart = _preview(opacity=0.0, roughness=0.0)
    radiance, preview = furnace_radiance(builder), furnace_radiance(counterpart)
    assert radiance == pytest.approx(1.0, abs=0.03)
    assert radiance == pytest.approx(preview, abs=0.005)


def test_textured_standard_surface_shows_its_quadrants_the_right_way_up(tmp_path):
    """StandardShaderBall's chain: image_color3 (texcoord_vector2) → extract_vector3... here
    convert and extract rebuild the colour channel by channel, which must fold back into one
    texture lookup."""
    file = write_texture(tmp_path / "quadrants.png", quadrants())
    stage = new_stage()
    add_camera(stage, aperture=(1.6, 1.6))
    quad = add_quad(stage, "/World/quad")
    st = UsdGeom.PrimvarsAPI(quad).CreatePrimvar(
        "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex
    )
    st.Set([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)])
    surface = add_mtlx_material(stage, "/World/Looks/tex", "ND_standard_surface_surfaceshader",
                                base=0.0, specular=0.0, emission=1.0)

    def node(name: str, node_def: str, output_type=Sdf.ValueTypeNames.Color3f):
        shader = UsdShade.Shader.Define(stage, f"/World/Looks/tex/{name}")
        shader.CreateIdAttr(node_def)
        return shader, shader.CreateOutput("out", output_type)

    texcoord, texcoord_out = node("uv", "ND_texcoord_vector2", Sdf.ValueTypeNames.Float2)
    image, image_out = node("image", "ND_image_vector3", Sdf.ValueTypeNames.Float3)
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(str(file)))
    image.CreateInput("texcoord", Sdf.ValueTypeNames.Float2).ConnectToSource(texcoord_out)
    channels = []
    for index in range(3):
        extract, extract_out = node(f"extract{index}", "ND_extract_vector3",
                                    Sdf.ValueTypeNames.Float)
        extract.CreateInput("in", Sdf.ValueTypeNames.Float3).ConnectToSource(image_out)
        extract.CreateInput("index", Sdf.ValueTypeNames.Int).Set(index)
        channels.append(extract_out)
    combine, combine_out = node("combine", "ND_combine3_vector3", Sdf.ValueTypeNames.Float3)
    for index, channel in enumerate(channels):
        combine.CreateInput(f"in{index + 1}", Sdf.ValueTypeNames.Float).ConnectToSource(channel)
    convert, convert_out = node("convert", "ND_convert_vector3_color3")
    convert.CreateInput("in", Sdf.ValueTypeNames.Float3).ConnectToSource(combine_out)
    surface.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(convert_out)
    bind(quad, UsdShade.Material(stage.GetPrimAtPath("/World/Looks/tex")))

    image = penumbra.render(stage, camera="/cam", width=40, samples=16)["color"]
    # MaterialX's texture coordinates, like USD's st, start at the image's bottom-left corner.
    for (s, t), color in {(0.25, 0.75): RED, (0.75, 0.75): GREEN, (0.25, 0.25): BLUE,
                          (0.75, 0.25): WHITE}.items():
        np.testing.assert_allclose(at(image, *st_to_xy(s, t)), color, atol=0.02)


def mtlx_reference_stage(tmp_path: Path, material: str) -> Path:
    """A stage file whose /World/Looks references materials.mtlx and whose quad is bound to
    ``material`` in it, under a white dome."""
    stage = diffuse_quad_stage()
    looks = stage.DefinePrim("/World/Looks", "Scope")
    looks.GetReferences().AddReference(str(MATERIALX_ASSETS / "materials.mtlx"), "/MaterialX")
    quad = stage.GetPrimAtPath("/World/quad")
    UsdShade.MaterialBindingAPI.Apply(quad).GetDirectBindingRel().SetTargets(
        [Sdf.Path(f"/World/Looks/Materials/{material}")]
    )
    path = tmp_path / "scene.usda"
    stage.GetRootLayer().Export(str(path))
    return path


def test_a_mtlx_reference_binds_and_renders(tmp_path):
    path = mtlx_reference_stage(tmp_path, "M_terracotta")
    original = path.read_text()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        stage = open_stage(path)
        radiance = quad_radiance(stage)
    messages = [str(w.message) for w in caught if w.category is penumbra.PenumbraWarning]
    assert not messages  # neither the failed arc nor the material is reported
    material = bound_material(stage.GetPrimAtPath("/World/quad"))
    assert material is not None
    assert material.GetPath() == Sdf.Path("/World/Looks/Materials/M_terracotta")
    np.testing.assert_allclose(radiance, TERRACOTTA, rtol=0.02)
    assert path.read_text() == original  # the user's layer is not edited
    assert not stage.GetRootLayer().dirty


def test_variants_switch_between_mtlx_materials():
    stage = open_stage(MATERIALX_ASSETS / "spheres.usda")
    floor = stage.GetPrimAtPath("/World/Floor")
    looks = floor.GetVariantSet("look")
    for look, material in (("checker", "M_checker"), ("terracotta", "M_terracotta")):
        looks.SetVariantSelection(look)
        bound = bound_material(floor)
        assert bound is not None and bound.GetPath().name == material
        assert bound.IsA(UsdShade.Material)


def test_unknown_node_in_a_mtlx_document_warns_by_name_and_keeps_the_default(tmp_path):
    path = mtlx_reference_stage(tmp_path, "M_mystery")
    with pytest.warns(penumbra.PenumbraWarning,
                      match=r"M_mystery: MaterialX node .*/M_mystery/mystery: "
                            r"penumbra_unknown_pattern") as caught:
        radiance = quad_radiance(open_stage(path))
    assert sum("mystery" in str(w.message) for w in caught) == 1
    # base_color falls back to its default (0.8), not to Penumbra's 0.18 grey.
    np.testing.assert_allclose(radiance, (0.8, 0.8, 0.8), rtol=0.02)


def test_unknown_node_in_usd_warns_by_name():
    stage = diffuse_quad_stage()
    surface = add_mtlx_material(stage, "/World/Looks/odd", "ND_standard_surface_surfaceshader",
                                specular=0.0)
    odd = UsdShade.Shader.Define(stage, "/World/Looks/odd/Noise")
    odd.CreateIdAttr("ND_penumbra_nonexistent_color3")
    surface.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        odd.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    )
    bind(UsdGeom.Mesh(stage.GetPrimAtPath("/World/quad")),
         UsdShade.Material(stage.GetPrimAtPath("/World/Looks/odd")))
    with pytest.warns(penumbra.PenumbraWarning,
                      match="/World/Looks/odd: MaterialX node /World/Looks/odd/Noise: "
                            "ND_penumbra_nonexistent_color3"):
        radiance = quad_radiance(stage)
    np.testing.assert_allclose(radiance, (0.8, 0.8, 0.8), rtol=0.02)


# The folding of pattern networks into one texture lookup (penumbra.usd.materialx_values).
TEXTURE = mv.identity(3, texture={"file": "t.png"})


def test_arithmetic_on_a_texture_folds_into_scale_and_bias():
    value = mv.add(mv.multiply(TEXTURE, mv.Constant((0.5,))), mv.Constant((0.1, 0.2, 0.3)))
    param = mv.to_parameter(value, vector=True)
    assert param["output"] == "rgb"
    assert param["texture"]["scale"] == (0.5, 0.5, 0.5, 1.0)
    assert param["texture"]["bias"] == pytest.approx((0.1, 0.2, 0.3, 0.0))


def test_mix_of_a_texture_and_a_constant_folds():
    value = mv.mix(TEXTURE, mv.Constant((1.0, 1.0, 1.0)), mv.Constant((0.25,)))
    param = mv.to_parameter(value, vector=True)
    assert param["texture"]["scale"] == (0.25, 0.25, 0.25, 1.0)
    assert param["texture"]["bias"] == (0.75, 0.75, 0.75, 0.0)


def test_constants_fold_and_two_textures_become_a_program():
    assert mv.clamp(mv.add(mv.Constant((0.7,)), mv.Constant((0.6,))), mv.Constant((0.0,)),
                    mv.Constant((1.0,))) == mv.Constant((1.0,))
    product = mv.multiply(TEXTURE, TEXTURE)
    assert isinstance(product, mv.Expression) and product.op == "multiply"
    # One lookup of the texture, read twice.
    assert mv.to_parameter(product, vector=True) == {"program": [
        {"op": "texture", "texture": {"file": "t.png"}}, {"op": "multiply", "in": [0, 0]}]}
    clamped = mv.clamp(mv.multiply(TEXTURE, mv.Constant((2.0,))), mv.Constant((0.0,)),
                       mv.Constant((1.0,)))
    assert isinstance(clamped, mv.Expression) and clamped.op == "clamp"


def test_an_extracted_channel_reads_that_channel():
    param = mv.to_parameter(mv.extract(TEXTURE, 1), vector=False)
    assert param == {"texture": {"file": "t.png"}, "output": "g"}


def test_mtlx_document_parameters_reach_the_delegate():
    """OpenPBR dispersion feeds the spectral path (Abbe number 20 / scale 0.5), tiledimage's
    uvtiling becomes the texture transform, and a constant multiply its scale."""
    from penumbra.usd.material import read_material
    from penumbra.usd.sampling import SampleReader

    stage = open_stage(MATERIALX_ASSETS / "spheres.usda")
    looks = "/World/Looks/Materials/"

    def params(name: str) -> dict:
        data = read_material(stage.GetPrimAtPath(looks + name), SampleReader(Usd.TimeCode(1)),
                             pytest.fail)
        return data.params

    glass = params("M_glass")
    assert glass["opacity"] == 0.0 and glass["penumbra:abbeNumber"] == pytest.approx(40.0)
    checker = params("M_checker")["diffuseColor"]["texture"]
    assert checker["transform"] == {"scale": (2.0, 2.0), "translation": (0.0, 0.0)}
    assert checker["scale"] == pytest.approx((0.8, 0.8, 0.8, 1.0))
    assert checker["sourceColorSpace"] == "sRGB"
    assert checker["file"] == str(MATERIALX_ASSETS / "quadrants.png")
    assert params("M_plastic")["clearcoat"] == 1.0


def test_geompropvalue_reads_a_primvar_and_non_finite_values_warn():
    from penumbra.usd.material import read_material
    from penumbra.usd.sampling import SampleReader

    stage = new_stage()
    surface = add_mtlx_material(stage, "/Looks/m", "ND_standard_surface_surfaceshader",
                                emission_color=(float("inf"), 0.0, 0.0), emission=1.0)
    reader = UsdShade.Shader.Define(stage, "/Looks/m/tint")
    reader.CreateIdAttr("ND_geompropvalue_color3")
    reader.CreateInput("geomprop", Sdf.ValueTypeNames.String).Set("tint")
    reader.CreateInput("default", Sdf.ValueTypeNames.Color3f).Set((0.1, 0.2, 0.3))
    surface.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        reader.CreateOutput("out", Sdf.ValueTypeNames.Color3f))
    messages = []
    params = read_material(stage.GetPrimAtPath("/Looks/m"), SampleReader(Usd.TimeCode(1)),
                           messages.append).params
    assert params["diffuseColor"] == {"primvar": "tint", "fallback": pytest.approx((0.1, 0.2, 0.3))}
    assert "emissiveColor" not in params
    assert messages == ["/Looks/m: MaterialX node /Looks/m/Surface: emissiveColor is not "
                        "finite; its default is used"]


def test_mix_of_a_value_with_itself_or_by_0_or_1_needs_no_folding():
    other = mv.identity(3, texture={"file": "u.png"})
    assert mv.mix(TEXTURE, TEXTURE, other) == TEXTURE  # OpenChessSet's subsurface mix
    assert mv.mix(TEXTURE, other, mv.Constant((1.0,))) == TEXTURE
    assert mv.mix(TEXTURE, other, mv.Constant((0.0,))) == other
    assert mv.mix(TEXTURE, other, mv.Constant((0.5,))).op == "mix"  # type: ignore[union-attr]


@pytest.mark.parametrize(
    "node_def, inputs, expected",
    [
        # Geometric opacity is a cut-out at 0.5.
        ("ND_standard_surface_surfaceshader", {"opacity": (0.2, 0.2, 0.2)},
         {"opacity": 0.2, "opacityThreshold": 0.5}),
        ("ND_open_pbr_surface_surfaceshader", {"geometry_opacity": 0.0},
         {"opacity": 0.0, "opacityThreshold": 0.5}),
        # Transmission is the translucent part; thin_walled makes it a sheet.
        ("ND_standard_surface_surfaceshader",
         {"transmission": 0.75, "thin_walled": True, "transmission_dispersion": 30.0},
         {"opacity": 0.25, "opacityThreshold": 0.0, "penumbra:thinWalled": 1,
          "penumbra:abbeNumber": 30.0}),
        # The specular weight scales the lobe whole; a tinted dielectric specular goes through
        # the specular workflow: F0(1.5) = 0.04 times the colour.
        ("ND_standard_surface_surfaceshader", {"specular": 0.5},
         {"penumbra:specularWeight": 0.5}),
        ("ND_open_pbr_surface_surfaceshader",
         {"specular_weight": 0.25, "specular_color": (1.0, 0.5, 0.5)},
         {"penumbra:specularWeight": 0.25, "useSpecularWorkflow": 1,
          "specularColor": (0.04, 0.02, 0.02)}),
        ("ND_open_pbr_surface_surfaceshader", {"emission_luminance": 4.0,
                                               "emission_color": (1.0, 0.5, 0.25)},
         {"emissiveColor": (4.0, 2.0, 1.0)}),
        # Coat colour tints what lies under the coat (no warning any more).
        ("ND_standard_surface_surfaceshader", {"coat": 1.0, "coat_color": (0.9, 0.5, 0.2)},
         {"clearcoat": 1.0, "penumbra:clearcoatColor": (0.9, 0.5, 0.2)}),
        ("ND_open_pbr_surface_surfaceshader", {"coat_weight": 0.5, "coat_color": (0.2, 0.4, 0.8)},
         {"clearcoat": 0.5, "penumbra:clearcoatColor": (0.2, 0.4, 0.8)}),
    ],
)
def test_surface_inputs_map_onto_preview_surface_parameters(node_def, inputs, expected):
    from penumbra.usd.material import read_material
    from penumbra.usd.sampling import SampleReader

    stage = new_stage()
    add_mtlx_material(stage, "/Looks/m", node_def, **inputs)
    params = read_material(stage.GetPrimAtPath("/Looks/m"), SampleReader(Usd.TimeCode(1)),
                           pytest.fail).params
    for name, value in expected.items():
        assert params[name] == pytest.approx(value), name


def test_an_unsupported_materialx_surface_warns_and_renders_a_default_standard_surface():
    stage = diffuse_quad_stage()
    add_mtlx_material(stage, "/World/Looks/gltf", "ND_gltf_pbr_surfaceshader",
                      base_color=(0.1, 0.9, 0.1))
    bind(UsdGeom.Mesh(stage.GetPrimAtPath("/World/quad")),
         UsdShade.Material(stage.GetPrimAtPath("/World/Looks/gltf")))
    with pytest.warns(penumbra.PenumbraWarning, match="/World/Looks/gltf: .*"
                      "ND_gltf_pbr_surfaceshader is not supported"):
        radiance = quad_radiance(stage)
    # standard_surface's defaults: 0.8 grey under a specular layer that, over a white dome,
    # gives back what it takes from the diffuse layer only partly (grey, not black, not green).
    assert np.ptp(radiance) < 0.01 and 0.75 < radiance.mean() < 0.9


PAINT = """<?xml version="1.0"?>
<materialx version="1.39">
  <standard_surface name="paint" type="surfaceshader">
    <input name="base_color" type="color3" value="{color}" />
    <input name="specular" type="float" value="0" />
  </standard_surface>
  <surfacematerial name="M_paint" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="paint" />
  </surfacematerial>
</materialx>
"""


def test_a_variant_that_swaps_mtlx_documents_switches_the_material_on_a_live_renderer(tmp_path):
    """StandardShaderBall's layout: one scope references a standard_surface or an OpenPBR
    document by variant, with the same material names; switching re-renders the other one."""
    colors = {"red": (0.7, 0.1, 0.1), "blue": (0.1, 0.2, 0.7)}
    for name, color in colors.items():
        (tmp_path / f"{name}.mtlx").write_text(PAINT.format(color=", ".join(map(str, color))))
    stage = diffuse_quad_stage()
    looks = stage.DefinePrim("/World/Looks", "Scope")
    palette = looks.GetVariantSets().AddVariantSet("palette")
    for name in colors:
        palette.AddVariant(name)
        palette.SetVariantSelection(name)
        with palette.GetVariantEditContext():
            looks.GetReferences().AddReference(str(tmp_path / f"{name}.mtlx"), "/MaterialX")
    palette.SetVariantSelection("red")
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath("/World/quad")).GetDirectBindingRel(
    ).SetTargets([Sdf.Path("/World/Looks/Materials/M_paint")])

    renderer = penumbra.Renderer(stage)
    for name in ("red", "blue", "red"):
        palette.SetVariantSelection(name)
        image = renderer.render(camera="/cam", width=16, samples=64, seed=3)["color"]
        np.testing.assert_allclose(image[..., :3].reshape(-1, 3).mean(axis=0), colors[name],
                                   rtol=0.02, err_msg=name)


@pytest.mark.parametrize("content, message", [
    ("<materialx version=\"1.39\"><standard_surface", "cannot read the MaterialX document"),
    (None, "MaterialX document not found"),
])
def test_a_broken_or_missing_mtlx_document_warns_naming_the_file(tmp_path, content, message):
    document = tmp_path / "broken.mtlx"
    if content is not None:
        document.write_text(content)
    stage = diffuse_quad_stage()
    stage.DefinePrim("/World/Looks", "Scope").GetReferences().AddReference(str(document))
    with pytest.warns(penumbra.PenumbraWarning, match=f"broken.mtlx: {message}"):
        stage_path = tmp_path / "scene.usda"
        stage.GetRootLayer().Export(str(stage_path))
        opened = open_stage(stage_path)
    assert not opened.GetPrimAtPath("/World/Looks/Materials")


def sheen_sphere_image(node_def: str, **inputs) -> np.ndarray:
    """A unit sphere (dark grey diffuse, no specular layer) under a white dome, seen whole: RGB
    and the radius of each pixel's line of sight in the z = 0 plane."""
    stage = new_stage()
    add_camera(stage)  # sees [-2, 2]² of the z = 0 plane; the sphere's silhouette has radius 1.02
    sphere = add_sphere_mesh(stage, "/World/ball", rings=64, sectors=128)
    white_dome(stage)
    add_mtlx_material(stage, "/World/Looks/cloth", node_def, **inputs)
    bind(sphere, UsdShade.Material(stage.GetPrimAtPath("/World/Looks/cloth")))
    with warnings.catch_warnings():
        warnings.simplefilter("error", penumbra.PenumbraWarning)  # sheen is not ignored any more
        return penumbra.render(stage, camera="/cam", width=64, samples=64, seed=7)["color"][..., :3]


def _zones(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean RGB of the sphere's rim (grazing view, radius 0.85–0.95, away from the silhouette
    at 1.02 where the pixel filter sees the dome) and of its centre (radius < 0.4)."""
    size = image.shape[0]
    coordinates = (np.arange(size) + 0.5) / size * 4 - 2
    radius = np.hypot(*np.meshgrid(coordinates, coordinates))
    rim = image[(radius > 0.85) & (radius < 0.95)].mean(axis=0)
    centre = image[radius < 0.4].mean(axis=0)
    return rim, centre


@pytest.mark.parametrize(
    "node_def, base, sheen",
    [
        ("ND_standard_surface_surfaceshader",
         {"base_color": (0.1, 0.1, 0.1), "specular": 0.0},
         {"sheen": 1.0, "sheen_color": (1.0, 0.2, 0.2), "sheen_roughness": 0.3}),
        ("ND_open_pbr_surface_surfaceshader",
         {"base_color": (0.1, 0.1, 0.1), "specular_weight": 0.0},
         {"fuzz_weight": 1.0, "fuzz_color": (1.0, 0.2, 0.2), "fuzz_roughness": 0.5}),
    ],
)
def test_sheen_and_fuzz_light_a_coloured_rim_at_grazing_angles(node_def, base, sheen):
    """Under a white dome the sheen reflects its colour most at grazing angles, and the base
    loses what the sheen reflects (albedo scaling): the rim turns red, the centre barely
    changes. The sheen's albedo (docs/materialx.md) is 0.04–0.09 at normal incidence and
    0.4–0.8 towards grazing for these roughnesses. Measured (standard_surface): rim red 0.38
    against 0.16 without sheen, centre red 0.15 against 0.10."""
    rim_plain, centre_plain = _zones(sheen_sphere_image(node_def, **base))
    rim, centre = _zones(sheen_sphere_image(node_def, **base, **sheen))
    np.testing.assert_allclose(centre_plain, 0.1, atol=0.01)  # the 0.1 grey base
    assert np.ptp(rim_plain) < 0.005  # grey, brighter by the (white) Fresnel at F0 = 0
    assert rim[0] > rim_plain[0] + 0.15  # brighter …
    assert rim[0] > 2 * rim[1] and rim[1] == pytest.approx(rim[2], abs=0.01)  # … and red
    assert abs(centre[0] - centre_plain[0]) < 0.5 * (rim[0] - rim_plain[0])


@pytest.mark.parametrize("node_def, weight_name", [
    ("ND_standard_surface_surfaceshader", "specular"),
    ("ND_open_pbr_surface_surfaceshader", "specular_weight"),
])
def test_the_specular_weight_scales_the_reflection_at_grazing_angles_too(node_def, weight_name):
    # Under a white dome a 0.18-grey sphere whose specular weight is 0 is a Lambertian 0.18 out
    # to its silhouette (it read 0.247 at the rim when the weight scaled F0 alone); at weight
    # 0.5 its rim reflects about half the extra of weight 1's. A white base stays white (1)
    # at any weight: what the specular lobe does not reflect, the diffuse layer does.
    rims = {}
    for weight in (0.0, 0.5, 1.0):
        rim, centre = _zones(sheen_sphere_image(node_def, base_color=(0.18, 0.18, 0.18),
                                                **{weight_name: weight}))
        rims[weight] = rim.mean()
        if weight == 0.0:
            np.testing.assert_allclose(rim, 0.18, atol=0.004)
            np.testing.assert_allclose(centre, 0.18, atol=0.004)
        white_rim, white_centre = _zones(sheen_sphere_image(node_def, base_color=(1.0, 1.0, 1.0),
                                                            **{weight_name: weight}))
        np.testing.assert_allclose([white_rim.mean(), white_centre.mean()], 1.0, atol=0.01)
    assert rims[1.0] > rims[0.0] + 0.04
    assert (rims[0.5] - rims[0.0]) / (rims[1.0] - rims[0.0]) == pytest.approx(0.5, abs=0.1)


def test_sheen_parameters_reach_the_delegate_and_a_metal_has_no_standard_surface_sheen():
    from penumbra.usd.material import read_material
    from penumbra.usd.sampling import SampleReader

    stage = new_stage()
    add_mtlx_material(stage, "/Looks/velvet", "ND_standard_surface_surfaceshader", sheen=0.8,
                      sheen_color=(0.2, 0.3, 0.9), sheen_roughness=0.6, metalness=0.25)
    add_mtlx_material(stage, "/Looks/gold", "ND_standard_surface_surfaceshader", sheen=1.0,
                      metalness=1.0)
    add_mtlx_material(stage, "/Looks/dust", "ND_open_pbr_surface_surfaceshader",
                      fuzz_weight=0.5)

    def params(path: str) -> dict:
        return read_material(stage.GetPrimAtPath(path), SampleReader(Usd.TimeCode(1)),
                             pytest.fail).params

    velvet = params("/Looks/velvet")
    assert velvet["penumbra:sheen"] == pytest.approx(0.6)  # 0.8 × (1 − metalness)
    assert velvet["penumbra:sheenColor"] == pytest.approx((0.2, 0.3, 0.9))
    assert velvet["penumbra:sheenRoughness"] == pytest.approx(0.6)
    assert not any(name.startswith("penumbra:sheen") for name in params("/Looks/gold"))
    dust = params("/Looks/dust")  # OpenPBR's fuzz defaults: white, roughness 0.5
    assert (dust["penumbra:sheen"], dust["penumbra:sheenColor"],
            dust["penumbra:sheenRoughness"]) == (0.5, (1.0, 1.0, 1.0), 0.5)


def test_the_delegate_takes_sheen_and_coat_colour_inputs_and_rejects_non_finite_ones():
    from penumbra import _core

    delegate = _core.RenderDelegate()
    delegate.insert_sprim("material", "/m")
    delegate.set_material("/m", {"penumbra:sheen": 1.0, "penumbra:sheenColor": (1.0, 0.5, 0.2),
                                 "penumbra:sheenRoughness": 0.4})
    delegate.set_material("/m", {"penumbra:sheen": {"primvar": "fuzz"},
                                 "penumbra:sheenColor": {"primvar": "fuzzColor"}})
    delegate.set_material("/m", {"penumbra:clearcoatColor": (0.9, 0.5, 0.2)})
    for name, value in (("penumbra:sheen", float("nan")),
                        ("penumbra:clearcoatColor", (float("inf"), 1.0, 1.0)),
                        ("penumbra:sheenRoughness", float("inf")),
                        ("penumbra:sheenColor", (1.0, float("nan"), 0.0))):
        with pytest.raises(ValueError, match=f"/m: {name} must be finite"):
            delegate.set_material("/m", {name: value})


def _matches_a_reopened_stage(stage: Usd.Stage, renderer: penumbra.Renderer) -> np.ndarray:
    """The live renderer's image, checked equal to a renderer's on the stage opened anew from
    its root layer (which composes its .mtlx arcs from scratch)."""
    view = dict(camera="/cam", width=16, samples=16, seed=3)
    image = renderer.render(**view)["color"]
    reopened = penumbra.Renderer(Usd.Stage.Open(stage.GetRootLayer())).render(**view)["color"]
    np.testing.assert_array_equal(image, reopened)
    return image


def test_a_mtlx_reference_retargeted_within_its_document_renders_as_a_reopened_stage(tmp_path):
    # The composition errors of the arc name the file and the introducing prim, not the
    # target: the same before and after the retarget.
    stage = open_stage(mtlx_reference_stage(tmp_path, "M_terracotta"))
    renderer = penumbra.Renderer(stage)
    before = _matches_a_reopened_stage(stage, renderer)
    looks = stage.GetPrimAtPath("/World/Looks").GetReferences()
    looks.ClearReferences()
    looks.AddReference(str(MATERIALX_ASSETS / "materials.mtlx"), "/MaterialX/Materials")
    UsdShade.MaterialBindingAPI(stage.GetPrimAtPath("/World/quad")).GetDirectBindingRel(
    ).SetTargets([Sdf.Path("/World/Looks/M_gold")])
    after = _matches_a_reopened_stage(stage, renderer)
    assert stage.GetPrimAtPath("/World/Looks/M_gold").IsA(UsdShade.Material)
    assert not np.array_equal(before, after)


def test_an_instance_added_to_a_mtlx_referencing_asset_renders_as_a_reopened_stage(tmp_path):
    from test_mtlx_instances import instanced_scene  # it imports this module

    stage = open_stage(instanced_scene(tmp_path))
    renderer = penumbra.Renderer(stage)
    before = _matches_a_reopened_stage(stage, renderer)
    added = UsdGeom.Xform.Define(stage, "/World/C")  # its prototype lacks the others' patch
    added.AddTranslateOp().Set((0.0, 1.2, 0.0))
    added.GetPrim().GetReferences().AddReference(str(tmp_path / "asset.usda"))
    added.GetPrim().SetInstanceable(True)
    after = _matches_a_reopened_stage(stage, renderer)
    assert bound_material(stage.GetPrimAtPath("/World/C/quad")) is not None
    assert not np.array_equal(before, after)
