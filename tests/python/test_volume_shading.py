"""Volume materials → the renderer's volume material (docs/volume-materials.md): the default
without a material, MaterialX ``volume`` nodes authored in the stage and in a referenced
``.mtlx`` document, Penumbra's principled volume shader, one warning for each input that is
approximated or invalid, and keyed inputs read at the frame."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest
from pxr import Sdf, Usd, UsdShade, UsdVol

from penumbra.usd.mtlx_documents import compose_materialx_documents
from penumbra.usd.sampling import SampleReader
from penumbra.usd.volume_shading import VolumeShading, read_volume_shading

T = Sdf.ValueTypeNames
BLACK = (0.0, 0.0, 0.0)
VOLUME, MATERIAL = "/Smoke", "/Looks/SmokeMaterial"


def volume_stage(fields: tuple[str, ...] = ("density", "Cd", "heat")) -> tuple[Usd.Stage,
                                                                               Usd.Prim]:
    """An in-memory stage with volume /Smoke whose ``field:NAME`` relationships name
    ``fields``, and an empty material /Looks/SmokeMaterial."""
    stage = Usd.Stage.CreateInMemory()
    volume = UsdVol.Volume.Define(stage, VOLUME)
    for name in fields:
        asset = UsdVol.OpenVDBAsset.Define(stage, f"{VOLUME}/{name}")
        volume.CreateFieldRelationship(name, asset.GetPath())
    UsdShade.Material.Define(stage, MATERIAL)
    return stage, volume.GetPrim()


def node(stage: Usd.Stage, name: str, shader_id: str, **inputs: Any) -> UsdShade.Shader:
    """Shader ``name`` under the material with ``inputs``: (type, value) pairs, a shader (its
    ``out`` connected) or a ``"geomprop"`` string."""
    shader = UsdShade.Shader.Define(stage, f"{MATERIAL}/{name}")
    shader.SetShaderId(shader_id)
    shader.CreateOutput("out", T.Token)
    for input_name, value in inputs.items():
        if isinstance(value, UsdShade.Shader):
            shader.CreateInput(input_name, T.Token).ConnectToSource(value.GetOutput("out"))
        elif isinstance(value, str):
            shader.CreateInput(input_name, T.String).Set(value)
        else:
            value_type, authored = value
            shader.CreateInput(input_name, value_type).Set(authored)
    return shader


def bind_volume(stage: Usd.Stage, vdf: UsdShade.Shader | None = None,
                edf: UsdShade.Shader | None = None, output: str = "mtlx:volume") -> None:
    """A ``volume`` node of ``vdf`` and ``edf`` on the material's ``outputs:<output>``."""
    inputs = {name: shader for name, shader in (("vdf", vdf), ("edf", edf)) if shader}
    volume = node(stage, "volume", "ND_volume", **inputs)
    UsdShade.Material.Get(stage, MATERIAL).CreateOutput(output, T.Token).ConnectToSource(
        volume.GetOutput("out"))


def read(stage: Usd.Stage, material: str | None = MATERIAL,
         reader: SampleReader | None = None) -> tuple[VolumeShading, list[str]]:
    """The volume's shading and warnings, read by ``reader`` (default: at the Default time)."""
    said: list[str] = []
    prim = stage.GetPrimAtPath(material) if material else None
    reader = reader or SampleReader(Usd.TimeCode.Default())
    return read_volume_shading(stage.GetPrimAtPath(VOLUME), prim, reader, said.append), said


def key(shader: UsdShade.Shader, name: str, samples: dict[float, Any]) -> None:
    """Input ``name`` of ``shader`` keyed with ``samples`` (time → value) and no default."""
    attr = shader.GetInput(name).GetAttr()
    attr.Clear()
    for time, value in samples.items():
        attr.Set(value, time)


def assert_one_warning(said: list[str], *names: str) -> None:
    assert len(said) == 1, said
    for name in (VOLUME, MATERIAL, *names):
        assert name in said[0], (name, said[0])


def color(*values: float) -> tuple[Any, Any]:
    return T.Color3f, values


def number(value: float) -> tuple[Any, Any]:
    return T.Float, value


def close(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    return all(math.isclose(x, y, rel_tol=1e-6, abs_tol=1e-7) for x, y in zip(a, b, strict=True))


# Defaults.
def test_without_a_material_the_default_is_cycles_principled_like():
    stage, _ = volume_stage()
    shading, said = read(stage, None)
    assert said == []
    assert shading == VolumeShading()
    assert (shading.density, shading.scattering, shading.principled_absorption) == (
        1.0, (0.5, 0.5, 0.5), (1.0, 1.0, 1.0))
    assert (shading.blackbody_intensity, shading.temperature) == (1.0, 1000.0)
    assert shading.density_fields == ("density",)
    assert shading.color_fields == ("color", "Cd")
    assert shading.temperature_fields == ("temperature", "heat")


def test_without_a_material_or_a_temperature_field_the_default_does_not_glow():
    stage, _ = volume_stage(fields=("density",))
    shading, said = read(stage, None)
    assert said == []
    assert shading == VolumeShading(blackbody_intensity=0.0, temperature_fields=())


def test_a_material_without_a_volume_shader_warns_and_gives_the_default():
    stage, _ = volume_stage()
    shading, said = read(stage)
    assert shading == VolumeShading()
    assert_one_warning(said, "no volume shader")


def test_an_unknown_volume_shader_warns_and_gives_the_default():
    stage, _ = volume_stage()
    shader = node(stage, "volume", "ND_mystery_volume")
    UsdShade.Material.Get(stage, MATERIAL).CreateOutput("mtlx:volume", T.Token).ConnectToSource(
        shader.GetOutput("out"))
    shading, said = read(stage)
    assert shading == VolumeShading()
    assert_one_warning(said, "ND_mystery_volume")


# MaterialX volumes.
def test_anisotropic_vdf_constants_map_directly():
    stage, _ = volume_stage()
    vdf = node(stage, "vdf", "ND_anisotropic_vdf", scattering=(T.Vector3f, (0.2, 0.3, 0.4)),
               absorption=color(0.1, 0.05, 0.0), anisotropy=number(0.5))
    bind_volume(stage, vdf)
    shading, said = read(stage)
    assert said == []
    assert close(shading.scattering, (0.2, 0.3, 0.4))
    assert close(shading.absorption, (0.1, 0.05, 0.0))
    assert shading.anisotropy == 0.5
    assert shading.principled_absorption == BLACK
    assert shading.density == 1.0
    assert (shading.density_fields, shading.color_fields, shading.temperature_fields,
            shading.emission_fields) == ((), (), (), ())
    assert shading.emission == BLACK and shading.blackbody_intensity == 0.0


def test_the_universal_volume_output_is_read_too():
    stage, _ = volume_stage()
    bind_volume(stage, node(stage, "vdf", "ND_absorption_vdf", absorption=color(0.7, 0.7, 0.7)),
                output="volume")
    shading, said = read(stage)
    assert said == []
    assert close(shading.absorption, (0.7, 0.7, 0.7)) and shading.scattering == BLACK


def density_scaled(stage: Usd.Stage, name: str, constant: tuple[float, ...],
                   density: UsdShade.Shader) -> UsdShade.Shader:
    return node(stage, name, "ND_multiply_color3FA", in1=color(*constant), in2=density)


def test_a_scalar_field_multiplying_scattering_and_absorption_is_the_density_field():
    stage, _ = volume_stage()
    density = node(stage, "density", "ND_geompropvalue_float", geomprop="density")
    vdf = node(stage, "vdf", "ND_anisotropic_vdf",
               scattering=density_scaled(stage, "s", (0.8, 0.6, 0.4), density),
               absorption=density_scaled(stage, "a", (0.1, 0.2, 0.3), density))
    bind_volume(stage, vdf)
    shading, said = read(stage)
    assert said == []
    assert shading.density_fields == ("density",) and shading.density == 1.0
    assert close(shading.scattering, (0.8, 0.6, 0.4))
    assert close(shading.absorption, (0.1, 0.2, 0.3))


def test_a_colour_field_multiplying_scattering_is_the_colour_field():
    stage, _ = volume_stage()
    density = node(stage, "density", "ND_geompropvalue_float", geomprop="density")
    tint = node(stage, "tint", "ND_geompropvalue_color3", geomprop="Cd")
    scaled = node(stage, "scaled", "ND_multiply_float", in1=number(2.0), in2=density)
    scattering = node(stage, "s", "ND_multiply_color3", in1=tint,
                      in2=density_scaled(stage, "sd", (0.25, 0.5, 0.5), scaled))
    vdf = node(stage, "vdf", "ND_anisotropic_vdf", scattering=scattering,
               absorption=density_scaled(stage, "a", (0.1, 0.1, 0.1), scaled))
    bind_volume(stage, vdf)
    shading, said = read(stage)
    assert said == []
    assert (shading.density_fields, shading.color_fields) == (("density",), ("Cd",))
    assert close(shading.scattering, (0.5, 1.0, 1.0))
    assert close(shading.absorption, (0.2, 0.2, 0.2))


def test_uniform_edf_gives_emission_and_its_field():
    stage, _ = volume_stage()
    heat = node(stage, "heat", "ND_geompropvalue_float", geomprop="heat")
    edf = node(stage, "edf", "ND_uniform_edf", color=density_scaled(stage, "e", (4, 2, 1), heat))
    bind_volume(stage, edf=edf)
    shading, said = read(stage)
    assert said == []
    assert close(shading.emission, (4.0, 2.0, 1.0))
    assert shading.emission_fields == ("heat",)
    # No VDF: an empty medium that only emits.
    assert (shading.scattering, shading.absorption, shading.density_fields) == (BLACK, BLACK, ())


def test_a_volume_material_from_a_referenced_mtlx_document(tmp_path: Path):
    document = tmp_path / "smoke.mtlx"
    document.write_text("""<?xml version="1.0"?>
<materialx version="1.39">
  <geompropvalue name="density" type="float"><input name="geomprop" type="string"
    value="density"/></geompropvalue>
  <multiply name="scattering" type="vector3"><input name="in1" type="vector3"
    value="0.9, 0.8, 0.7"/><input name="in2" type="float" nodename="density"/></multiply>
  <multiply name="absorption" type="vector3"><input name="in1" type="vector3"
    value="0.05, 0.05, 0.05"/><input name="in2" type="float" nodename="density"/></multiply>
  <anisotropic_vdf name="smoke_vdf" type="VDF">
    <input name="scattering" type="vector3" nodename="scattering"/>
    <input name="absorption" type="vector3" nodename="absorption"/>
    <input name="anisotropy" type="float" value="0.3"/>
  </anisotropic_vdf>
  <uniform_edf name="glow" type="EDF"><input name="color" type="color3"
    value="0.5, 0.25, 0"/></uniform_edf>
  <volume name="smoke_shader" type="volumeshader">
    <input name="vdf" type="VDF" nodename="smoke_vdf"/>
    <input name="edf" type="EDF" nodename="glow"/>
  </volume>
  <volumematerial name="Smoke" type="material">
    <input name="volumeshader" type="volumeshader" nodename="smoke_shader"/>
  </volumematerial>
</materialx>
""")
    stage, volume = volume_stage()
    looks = stage.DefinePrim("/Looks/Mtlx", "Scope")
    looks.GetReferences().AddReference(str(document), "/MaterialX")
    said: list[str] = []
    compose_materialx_documents(stage, said.append)
    material = stage.GetPrimAtPath("/Looks/Mtlx/Materials/Smoke")
    shading = read_volume_shading(volume, material, SampleReader(Usd.TimeCode.Default()),
                                  said.append)
    assert said == []
    assert close(shading.scattering, (0.9, 0.8, 0.7))
    assert close(shading.absorption, (0.05, 0.05, 0.05))
    assert math.isclose(shading.anisotropy, 0.3, rel_tol=1e-6)
    assert shading.density_fields == ("density",)
    assert close(shading.emission, (0.5, 0.25, 0.0)) and shading.emission_fields == ()


# MaterialX approximations, one warning each.
def test_a_density_field_on_scattering_only_is_applied_to_absorption_too():
    stage, _ = volume_stage()
    density = node(stage, "density", "ND_geompropvalue_float", geomprop="density")
    vdf = node(stage, "vdf", "ND_anisotropic_vdf",
               scattering=density_scaled(stage, "s", (0.5, 0.5, 0.5), density),
               absorption=color(0.2, 0.2, 0.2))
    bind_volume(stage, vdf)
    shading, said = read(stage)
    assert shading.density_fields == ("density",)
    assert close(shading.absorption, (0.2, 0.2, 0.2))
    assert_one_warning(said, f"{MATERIAL}/vdf", "absorption", "'density'")


def test_a_colour_field_on_absorption_is_ignored():
    stage, _ = volume_stage()
    tint = node(stage, "tint", "ND_geompropvalue_color3", geomprop="Cd")
    absorption = node(stage, "a", "ND_multiply_color3", in1=tint, in2=color(0.3, 0.3, 0.3))
    bind_volume(stage, node(stage, "vdf", "ND_absorption_vdf", absorption=absorption))
    shading, said = read(stage)
    assert close(shading.absorption, (0.3, 0.3, 0.3)) and shading.color_fields == ()
    assert_one_warning(said, f"{MATERIAL}/vdf", "absorption", "'Cd'")


def test_a_missing_field_reads_the_geompropvalue_default():
    stage, _ = volume_stage(fields=())
    density = node(stage, "density", "ND_geompropvalue_float", geomprop="density",
                   default=number(0.5))
    vdf = node(stage, "vdf", "ND_absorption_vdf",
               absorption=density_scaled(stage, "a", (0.4, 0.2, 0.0), density))
    bind_volume(stage, vdf)
    shading, said = read(stage)
    assert shading.density_fields == ()
    assert close(shading.absorption, (0.2, 0.1, 0.0))
    assert_one_warning(said, f"{MATERIAL}/vdf", "absorption", "'density'")


@pytest.mark.parametrize("network, named", [
    ("offset", "an offset field"),  # a field plus a constant
    ("unknown", "ND_made_up_color3"),  # no such node definition
    ("texture", "a texture"),
])
def test_an_unreducible_network_gives_the_input_its_default(network, named):
    stage, _ = volume_stage()
    if network == "offset":
        tint = node(stage, "tint", "ND_geompropvalue_color3", geomprop="Cd")
        scattering = node(stage, "bad", "ND_add_color3", in1=tint, in2=color(0.1, 0.1, 0.1))
    elif network == "unknown":
        scattering = node(stage, "bad", "ND_made_up_color3")
    else:
        scattering = node(stage, "bad", "ND_image_color3",
                          file=(T.Asset, Sdf.AssetPath("smoke.png")))
    vdf = node(stage, "vdf", "ND_anisotropic_vdf", scattering=scattering,
               absorption=color(0.3, 0.2, 0.1))
    bind_volume(stage, vdf)
    shading, said = read(stage)
    assert shading.scattering == BLACK  # anisotropic_vdf's default
    assert close(shading.absorption, (0.3, 0.2, 0.1))
    assert_one_warning(said, named, "scattering")


def test_two_scalar_fields_in_one_product_keep_the_first():
    stage, _ = volume_stage()
    density = node(stage, "density", "ND_geompropvalue_float", geomprop="density")
    heat = node(stage, "heat", "ND_geompropvalue_float", geomprop="heat")
    both = node(stage, "both", "ND_multiply_float", in1=density, in2=heat)
    vdf = node(stage, "vdf", "ND_absorption_vdf",
               absorption=density_scaled(stage, "a", (0.5, 0.5, 0.5), both))
    bind_volume(stage, vdf)
    shading, said = read(stage)
    assert shading.density_fields == ("density",)
    assert close(shading.absorption, (0.5, 0.5, 0.5))
    assert_one_warning(said, f"{MATERIAL}/vdf", "absorption", "'heat'")


def test_an_emission_with_a_scalar_and_a_colour_field_keeps_the_colour_field():
    stage, _ = volume_stage()
    heat = node(stage, "heat", "ND_geompropvalue_float", geomprop="heat")
    tint = node(stage, "tint", "ND_geompropvalue_color3", geomprop="Cd")
    edf = node(stage, "edf", "ND_uniform_edf",
               color=node(stage, "e", "ND_multiply_color3FA", in1=tint, in2=heat))
    bind_volume(stage, edf=edf)
    shading, said = read(stage)
    assert shading.emission_fields == ("Cd",) and shading.emission == (1.0, 1.0, 1.0)
    assert_one_warning(said, f"{MATERIAL}/edf", "color", "'heat'")


def test_a_varying_anisotropy_is_zero():
    stage, _ = volume_stage()
    density = node(stage, "density", "ND_geompropvalue_float", geomprop="density")
    bind_volume(stage, node(stage, "vdf", "ND_anisotropic_vdf", anisotropy=density))
    shading, said = read(stage)
    assert shading.anisotropy == 0.0
    assert_one_warning(said, f"{MATERIAL}/vdf", "anisotropy")


def test_a_bound_prim_that_is_not_a_material_gives_the_default():
    stage, _ = volume_stage()
    stage.DefinePrim(f"{MATERIAL}/scope", "Scope")
    shading, said = read(stage, f"{MATERIAL}/scope")
    assert shading == VolumeShading()
    assert_one_warning(said, "not a Material")


def test_an_unsupported_vdf_gives_the_default_medium():
    stage, _ = volume_stage()
    bind_volume(stage, node(stage, "vdf", "ND_add_vdf"))
    shading, said = read(stage)
    assert shading == VolumeShading(blackbody_intensity=0.0, temperature_fields=())
    assert_one_warning(said, f"{MATERIAL}/vdf", "ND_add_vdf")


def test_an_unsupported_edf_does_not_emit():
    stage, _ = volume_stage()
    bind_volume(stage, edf=node(stage, "edf", "ND_conical_edf", color=color(5, 5, 5)))
    shading, said = read(stage)
    assert shading.emission == BLACK
    assert_one_warning(said, f"{MATERIAL}/edf", "ND_conical_edf")


@pytest.mark.parametrize("authored, expected", [((-0.5, 0.5, 0.5), BLACK),
                                                 ((math.nan, 0.5, 0.5), BLACK),
                                                 ((math.inf, 0.5, 0.5), BLACK)])
def test_negative_or_non_finite_coefficients_take_their_default(authored, expected):
    stage, _ = volume_stage()
    vdf = node(stage, "vdf", "ND_anisotropic_vdf", scattering=color(*authored),
               absorption=color(0.2, 0.2, 0.2))
    bind_volume(stage, vdf)
    shading, said = read(stage)
    assert shading.scattering == expected
    assert close(shading.absorption, (0.2, 0.2, 0.2))
    assert_one_warning(said, f"{MATERIAL}/vdf", "scattering")


@pytest.mark.parametrize("authored, expected", [(1.5, 0.99), (-1.0, -0.99), (math.nan, 0.0)])
def test_anisotropy_outside_the_open_interval_is_clamped(authored, expected):
    stage, _ = volume_stage()
    bind_volume(stage, node(stage, "vdf", "ND_anisotropic_vdf", anisotropy=number(authored)))
    shading, said = read(stage)
    assert shading.anisotropy == expected
    assert_one_warning(said, f"{MATERIAL}/vdf", "anisotropy")


def test_an_input_of_the_wrong_type_takes_its_default():
    stage, _ = volume_stage()
    edf = node(stage, "edf", "ND_uniform_edf", color=(T.String, "orange"))
    bind_volume(stage, edf=edf)
    shading, said = read(stage)
    assert shading.emission == (1.0, 1.0, 1.0)  # uniform_edf's default colour
    assert_one_warning(said, f"{MATERIAL}/edf", "color", "string")


# Penumbra's principled volume.
def principled(stage: Usd.Stage, **inputs: Any) -> UsdShade.Shader:
    shader = node(stage, "principled", "penumbra:PrincipledVolume", **inputs)
    UsdShade.Material.Get(stage, MATERIAL).CreateOutput("volume", T.Token).ConnectToSource(
        shader.GetOutput("out"))
    return shader


def test_principled_volume_defaults_are_cycles_defaults():
    stage, _ = volume_stage()
    principled(stage)
    shading, said = read(stage)
    assert said == []
    assert shading == VolumeShading(blackbody_intensity=0.0, color_fields=(),
                                    temperature_fields=("temperature",))


def test_principled_volume_maps_as_cycles_does():
    stage, _ = volume_stage()
    principled(stage, color=color(0.9, 0.5, 0.1), density=number(3.0),
               absorptionColor=color(0.25, 1.0, 0.0), anisotropy=number(-0.4),
               emissionStrength=number(2.0), emissionColor=color(1.0, 0.5, 0.25),
               blackbodyIntensity=number(0.5), blackbodyTint=color(1.0, 0.8, 0.6),
               temperature=number(1500.0), densityAttribute="", colorAttribute="Cd",
               temperatureAttribute="heat")
    shading, said = read(stage)
    assert said == []
    assert close(shading.scattering, (0.9, 0.5, 0.1)) and shading.absorption == BLACK
    assert close(shading.principled_absorption, (0.5, 0.0, 1.0))  # 1 − √absorptionColor
    assert (shading.density, shading.temperature, shading.blackbody_intensity) == (
        3.0, 1500.0, 0.5)
    assert math.isclose(shading.anisotropy, -0.4, rel_tol=1e-6)
    assert close(shading.emission, (2.0, 1.0, 0.5))
    assert close(shading.blackbody_tint, (1.0, 0.8, 0.6))
    assert (shading.density_fields, shading.color_fields, shading.temperature_fields,
            shading.emission_fields) == ((), ("Cd",), ("heat",), ())


@pytest.mark.parametrize("name, authored, field_name, expected", [
    ("density", number(-1.0), "density", 1.0),
    ("temperature", number(math.inf), "temperature", 1000.0),
    ("anisotropy", number(1.0), "anisotropy", 0.99),
    ("color", (T.String, "grey"), "scattering", (0.5, 0.5, 0.5)),
    ("blackbodyTint", color(1.0, math.nan, 1.0), "blackbody_tint", (1.0, 1.0, 1.0)),
    ("colorAttribute", number(2.0), "color_fields", ()),
])
def test_principled_volume_bad_inputs_take_their_default(name, authored, field_name, expected):
    stage, _ = volume_stage()
    principled(stage, **{name: authored})
    shading, said = read(stage)
    assert getattr(shading, field_name) == expected
    assert_one_warning(said, f"{MATERIAL}/principled", f"inputs:{name}")


def test_principled_volume_inputs_connected_to_nodes_keep_their_default():
    stage, _ = volume_stage()
    tint = node(stage, "tint", "ND_geompropvalue_color3", geomprop="Cd")
    principled(stage, color=tint)
    shading, said = read(stage)
    assert shading.scattering == (0.5, 0.5, 0.5)
    assert_one_warning(said, f"{MATERIAL}/principled", "inputs:color", f"{MATERIAL}/tint")


# Animated inputs: read at the reader's time (the frame rendered), and noted as varying so that
# the volume is read again at the next frame.
def test_keyed_principled_inputs_are_read_at_the_frame_and_vary():
    stage, _ = volume_stage()
    shader = principled(stage, density=number(1.0), emissionStrength=number(0.0),
                        color=color(0.5, 0.5, 0.5), anisotropy=number(0.0),
                        temperature=number(1000.0))
    key(shader, "density", {1: 0.1, 2: 2.0})  # time samples only: no default to fall back on
    key(shader, "emissionStrength", {1: 1.0, 2: 4.0})
    key(shader, "color", {1: (0.2, 0.4, 0.6), 2: (0.6, 0.4, 0.2)})
    key(shader, "anisotropy", {1: -0.5, 2: 0.5})
    key(shader, "temperature", {1: 1200.0, 2: 1800.0})
    for time, density, strength, scattering, g, kelvin in (
        (1, 0.1, 1.0, (0.2, 0.4, 0.6), -0.5, 1200.0),
        (2, 2.0, 4.0, (0.6, 0.4, 0.2), 0.5, 1800.0),
        (1.5, 1.05, 2.5, (0.4, 0.4, 0.4), 0.0, 1500.0),  # interpolated between the keys
    ):
        reader = SampleReader(Usd.TimeCode(time))
        shading, said = read(stage, reader=reader)
        assert said == []
        assert math.isclose(shading.density, density, rel_tol=1e-6)
        assert close(shading.emission, (strength,) * 3)
        assert close(shading.scattering, scattering)
        assert math.isclose(shading.anisotropy, g, abs_tol=1e-7)
        assert math.isclose(shading.temperature, kelvin, rel_tol=1e-6)
        assert reader.varying


def test_keyed_materialx_volume_inputs_are_read_at_the_frame_and_vary():
    stage, _ = volume_stage()
    vdf = node(stage, "vdf", "ND_anisotropic_vdf", absorption=color(0.0, 0.0, 0.0),
               anisotropy=number(0.0))
    edf = node(stage, "edf", "ND_uniform_edf", color=color(0.0, 0.0, 0.0))
    bind_volume(stage, vdf, edf)
    key(vdf, "absorption", {1: (0.1, 0.1, 0.1), 2: (0.3, 0.2, 0.1)})
    key(vdf, "anisotropy", {1: 0.25, 2: -0.25})
    key(edf, "color", {1: (1.0, 2.0, 3.0), 2: (3.0, 2.0, 1.0)})
    for time, absorption, g, emission in ((1, (0.1, 0.1, 0.1), 0.25, (1.0, 2.0, 3.0)),
                                          (2, (0.3, 0.2, 0.1), -0.25, (3.0, 2.0, 1.0))):
        reader = SampleReader(Usd.TimeCode(time))
        shading, said = read(stage, reader=reader)
        assert said == []
        assert close(shading.absorption, absorption)
        assert math.isclose(shading.anisotropy, g, rel_tol=1e-6)
        assert close(shading.emission, emission)
        assert reader.varying


def test_a_material_of_constants_does_not_vary():
    stage, _ = volume_stage()
    principled(stage, density=number(2.0), emissionStrength=number(1.0))
    reader = SampleReader(Usd.TimeCode(1))
    shading, said = read(stage, reader=reader)
    assert said == [] and shading.density == 2.0
    assert not reader.varying
