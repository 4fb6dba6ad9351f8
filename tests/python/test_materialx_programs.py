"""Pattern networks that do not fold into one texture lookup (docs/materialx.md): a product of
two textures, a texture mixed with a primvar by a mask texture. They reach the renderer as
programs and are evaluated exactly at each shading point.

The quad shows the network's value as emission (base 0, no specular layer), so each quadrant's
radiance is the network's value there; the textures are float EXRs with one value per quadrant
(exact, no transfer function)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

import penumbra
from stages import add_camera, add_quad, bind, new_stage
from test_materialx import add_mtlx_material
from test_textures import at, st_to_xy, write_texture

# Quadrant centres in st (origin bottom-left) → the value each texture holds there.
QUADRANTS = ((0.25, 0.75), (0.75, 0.75), (0.25, 0.25), (0.75, 0.25))
COLOURS = ((0.8, 0.2, 0.4), (0.1, 0.9, 0.5), (0.3, 0.3, 0.7), (1.0, 0.6, 0.0))
FACTORS = ((0.5, 1.0, 0.25), (2.0, 0.5, 1.0), (1.0, 1.0, 1.0), (0.25, 0.5, 4.0))
MASK = (0.0, 0.25, 0.75, 1.0)
TINT = (0.1, 0.6, 0.3)


def quadrant_texture(path: Path, values) -> Path:
    """A float image whose quadrants (top-left, top-right, bottom-left, bottom-right as viewed)
    hold ``values`` in the order of QUADRANTS."""
    channels = len(values[0]) if isinstance(values[0], tuple) else 1
    image = np.zeros((8, 8, channels), dtype=np.float32)
    for (row, column), value in zip(((0, 0), (0, 4), (4, 0), (4, 4)), values):
        image[row:row + 4, column:column + 4] = value
    return write_texture(path, image)


class Network:
    """A standard_surface on a unit quad with st, emitting its emission_color's network."""

    def __init__(self):
        self.stage = new_stage()
        add_camera(self.stage, aperture=(1.6, 1.6))
        self.quad = add_quad(self.stage, "/World/quad")
        UsdGeom.PrimvarsAPI(self.quad).CreatePrimvar(
            "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex
        ).Set([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)])
        self.surface = add_mtlx_material(self.stage, "/World/Looks/m",
                                         "ND_standard_surface_surfaceshader", base=0.0,
                                         specular=0.0, emission=1.0)
        bind(self.quad, UsdShade.Material(self.stage.GetPrimAtPath("/World/Looks/m")))

    def node(self, name: str, node_def: str, output_type=Sdf.ValueTypeNames.Color3f,
             **inputs) -> UsdShade.Output:
        shader = UsdShade.Shader.Define(self.stage, f"/World/Looks/m/{name}")
        shader.CreateIdAttr(node_def)
        for input_name, value in inputs.items():
            if isinstance(value, UsdShade.Output):
                shader.CreateInput(input_name, value.GetTypeName()).ConnectToSource(value)
            elif isinstance(value, Path):
                shader.CreateInput(input_name, Sdf.ValueTypeNames.Asset).Set(
                    Sdf.AssetPath(str(value)))
            elif isinstance(value, float):
                shader.CreateInput(input_name, Sdf.ValueTypeNames.Float).Set(value)
            else:
                shader.CreateInput(input_name, Sdf.ValueTypeNames.String).Set(value)
        return shader.CreateOutput("out", output_type)

    def add_tint(self) -> None:
        """The quad's constant colour primvar ``tint`` (TINT), for geompropvalue nodes."""
        UsdGeom.PrimvarsAPI(self.quad).CreatePrimvar(
            "tint", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.constant
        ).Set([Gf.Vec3f(*TINT)])

    def render(self, emission_color: UsdShade.Output) -> list[np.ndarray]:
        """The radiance at each quadrant's centre, in the order of QUADRANTS."""
        self.surface.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(
            emission_color)
        with warnings.catch_warnings():
            warnings.simplefilter("error", penumbra.PenumbraWarning)  # nothing left unevaluated
            image = penumbra.render(self.stage, camera="/cam", width=40, samples=4)["color"]
        return [at(image, *st_to_xy(s, t)) for s, t in QUADRANTS]


def test_a_product_of_two_textures_is_evaluated_per_shading_point(tmp_path):
    network = Network()
    colours = network.node("colours", "ND_image_color3",
                           file=quadrant_texture(tmp_path / "colours.exr", COLOURS))
    factors = network.node("factors", "ND_image_color3",
                           file=quadrant_texture(tmp_path / "factors.exr", FACTORS))
    product = network.node("product", "ND_multiply_color3", in1=colours, in2=factors)
    for radiance, colour, factor in zip(network.render(product), COLOURS, FACTORS):
        np.testing.assert_allclose(radiance, np.multiply(colour, factor), atol=1e-3)


def test_a_texture_mixed_with_a_primvar_by_a_mask_texture(tmp_path):
    network = Network()
    network.add_tint()
    colours = network.node("colours", "ND_image_color3",
                           file=quadrant_texture(tmp_path / "colours.exr", COLOURS))
    tint = network.node("tint", "ND_geompropvalue_color3", geomprop="tint")
    mask = network.node("mask", "ND_image_float", Sdf.ValueTypeNames.Float,
                        file=quadrant_texture(tmp_path / "mask.exr", MASK))
    mixed = network.node("mixed", "ND_mix_color3", fg=colours, bg=tint, mix=mask)
    for radiance, colour, amount in zip(network.render(mixed), COLOURS, MASK):
        expected = np.add(TINT, np.subtract(colour, TINT) * amount)  # MaterialX mix
        np.testing.assert_allclose(radiance, expected, atol=1e-3)


def test_clamp_subtract_and_combine_of_different_sources(tmp_path):
    """combine3 of a texture's channel, a primvar and a constant, minus another texture,
    clamped to [0, 0.5]."""
    network = Network()
    network.add_tint()
    colours = network.node("colours", "ND_image_color3",
                           file=quadrant_texture(tmp_path / "colours.exr", COLOURS))
    factors = network.node("factors", "ND_image_color3",
                           file=quadrant_texture(tmp_path / "factors.exr", FACTORS))
    red = network.node("red", "ND_extract_color3", Sdf.ValueTypeNames.Float, **{"in": colours})
    tint = network.node("tint", "ND_geompropvalue_float", Sdf.ValueTypeNames.Float,
                        geomprop="tint")
    combined = network.node("combined", "ND_combine3_color3", in1=red, in2=tint)
    difference = network.node("difference", "ND_subtract_color3", in1=combined, in2=factors)
    clamped = network.node("clamped", "ND_clamp_color3", **{"in": difference}, high=0.5)
    for radiance, colour, factor in zip(network.render(clamped), COLOURS, FACTORS):
        combined_value = np.array([colour[0], TINT[0], 0.0])  # combine3's in3 defaults to 0
        np.testing.assert_allclose(radiance, np.clip(combined_value - factor, 0.0, 0.5),
                                   atol=1e-3)


def _delegate_material(program):
    from penumbra import _core

    delegate = _core.RenderDelegate()
    delegate.insert_sprim("material", "/m")
    delegate.set_material("/m", {"diffuseColor": {"program": program}})


@pytest.mark.parametrize("program, message", [
    ([{"op": "add", "in": [0, 0]}], "the first node must be a constant, a texture or a primvar"),
    ([{"op": "constant", "value": (1, 0, 0, 0)}, {"op": "add", "in": [0, 1]}],
     "an operand is not an earlier node"),
    ([{"op": "constant", "value": (float("nan"), 0, 0, 0)}], "must be finite"),
    ([{"op": "constant", "value": (1, 0, 0, 0)}] * 65, "1 to 64 nodes, not 65"),
    ([{"op": "constant", "value": (1, 0, 0, 0)}, {"op": "swizzle", "in": [0], "channels": [4]}],
     "channels are 0 to 3"),
    ([{"op": "texture"}], "a texture node needs a texture"),
    ([{"op": "power", "in": [0, 0]}], "unknown program operation 'power'"),
])
def test_the_delegate_rejects_malformed_programs(program, message):
    with pytest.raises(ValueError, match=message):
        _delegate_material(program)


def test_an_oversized_network_warns_by_name_and_keeps_the_default():
    """A chain of 40 products of a primvar by itself needs more than 64 program nodes."""
    from penumbra.usd.material import read_material
    from penumbra.usd.sampling import SampleReader

    network = Network()
    value = network.node("tint", "ND_geompropvalue_color3", geomprop="tint")
    for index in range(40):
        value = network.node(f"square{index}", "ND_multiply_color3", in1=value,
                             in2=network.node(f"tint{index}", "ND_geompropvalue_color3",
                                              geomprop=f"tint{index}"))
    network.surface.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        value)
    messages: list[str] = []
    params = read_material(network.stage.GetPrimAtPath("/World/Looks/m"),
                           SampleReader(Usd.TimeCode(1)), messages.append).params
    assert "emissiveColor" not in params or not isinstance(params["emissiveColor"], dict)
    assert len(messages) == 1 and "at most 64" in messages[0] and "/World/Looks/m" in messages[0]
