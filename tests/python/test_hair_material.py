"""MaterialX hair (docs/materialx.md, "Hair"): a surface node over a chiang_hair_bsdf, fed by
chiang_hair_absorption_from_color, deon_hair_absorption_from_melanin and chiang_hair_roughness,
becomes the renderer's hair BSDF (renderer/include/penumbra/hair_bsdf.h), checked against the
formulas' values at analytic points and by rendering."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

import penumbra
from penumbra.usd.material import read_material
from penumbra.usd.sampling import SampleReader
from stages import add_preview_material, bind
from test_materialx import diffuse_quad_stage, quad_radiance

LOOK = "/World/Looks/hair"


def _value_type(value) -> Sdf.ValueTypeName:
    if isinstance(value, tuple):
        return {2: Sdf.ValueTypeNames.Float2, 3: Sdf.ValueTypeNames.Color3f}[len(value)]
    return Sdf.ValueTypeNames.Float


def node(stage: Usd.Stage, name: str, node_def: str, **inputs) -> UsdShade.Shader:
    shader = UsdShade.Shader.Define(stage, f"{LOOK}/{name}")
    shader.CreateIdAttr(node_def)
    for input_name, value in inputs.items():
        shader.CreateInput(input_name, _value_type(value)).Set(value)
    return shader


def connect(shader: UsdShade.Shader, name: str, source: UsdShade.Shader, output: str,
            value_type: Sdf.ValueTypeName) -> None:
    shader.CreateInput(name, value_type).ConnectToSource(source.CreateOutput(output, value_type))


def hair_material(stage: Usd.Stage, bsdf_def: str = "ND_chiang_hair_bsdf",
                  **inputs) -> UsdShade.Shader:
    """A material whose mtlx surface is a surface node over a ``bsdf_def`` node (returned)."""
    material = UsdShade.Material.Define(stage, LOOK)
    surface = node(stage, "surface", "ND_surface")
    bsdf = node(stage, "bsdf", bsdf_def, **inputs)
    connect(surface, "bsdf", bsdf, "out", Sdf.ValueTypeNames.Token)
    material.CreateSurfaceOutput("mtlx").ConnectToSource(
        surface.CreateOutput("out", Sdf.ValueTypeNames.Token))
    return bsdf


def params_of(stage: Usd.Stage, warn=pytest.fail) -> dict:
    return read_material(stage.GetPrimAtPath(LOOK), SampleReader(Usd.TimeCode(1)), warn).params


def chiang_denominator(beta_n: float) -> float:
    return (5.969 - 0.215 * beta_n + 2.532 * beta_n**2 - 10.73 * beta_n**3
            + 5.574 * beta_n**4 + 0.245 * beta_n**5)


def test_chiang_hair_bsdf_maps_onto_the_hair_parameters():
    stage = Usd.Stage.CreateInMemory()
    bsdf = hair_material(stage, tint_R=(0.9, 0.8, 0.7), tint_TT=(0.5, 0.5, 0.5),
                         tint_TRT=(0.2, 0.3, 0.4), ior=1.6, cuticle_angle=0.6)
    # Colour e^−1 and e^−2 at β_n = 0 give (1/5.969)² and (2/5.969)².
    absorption = node(stage, "absorption", "ND_chiang_hair_absorption_from_color",
                      color=(math.exp(-1), math.exp(-2), 1.0), azimuthal_roughness=0.0)
    connect(bsdf, "absorption_coefficient", absorption, "absorption",
            Sdf.ValueTypeNames.Vector3f)
    roughness = node(stage, "roughness", "ND_chiang_hair_roughness", longitudinal=0.25,
                     azimuthal=0.4, scale_TT=0.7, scale_TRT=1.5)
    for lobe in ("R", "TT", "TRT"):
        connect(bsdf, f"roughness_{lobe}", roughness, f"roughness_{lobe}",
                Sdf.ValueTypeNames.Float2)
    params = params_of(stage)
    assert params["penumbra:hair"] == 1
    assert params["penumbra:hairTintR"] == pytest.approx((0.9, 0.8, 0.7))
    assert params["penumbra:hairTintTT"] == pytest.approx((0.5, 0.5, 0.5))
    assert params["penumbra:hairTintTRT"] == pytest.approx((0.2, 0.3, 0.4))
    assert params["penumbra:hairIor"] == pytest.approx(1.6)
    # MaterialX: α = cuticle_angle·π − π/2, here 0.1π = 18°.
    assert params["penumbra:hairCuticleAngle"] == pytest.approx(18.0)
    assert params["penumbra:hairAbsorption"] == pytest.approx(
        (1 / 5.969**2, 4 / 5.969**2, 0.0), rel=1e-6, abs=1e-12)
    assert params["penumbra:hairLongitudinalRoughness"] == pytest.approx(0.25)
    assert params["penumbra:hairAzimuthalRoughness"] == pytest.approx(0.4)
    assert params["penumbra:hairLongitudinalScaleTT"] == pytest.approx(0.7)
    assert params["penumbra:hairLongitudinalScaleTRT"] == pytest.approx(1.5)
    assert "diffuseColor" not in params


def test_melanin_gives_the_pigments_absorption():
    stage = Usd.Stage.CreateInMemory()
    bsdf = hair_material(stage)
    # One unit of melanin (concentration 1 − 1/e), a quarter of it pheomelanin.
    melanin = node(stage, "melanin", "ND_deon_hair_absorption_from_melanin",
                   melanin_concentration=1 - math.exp(-1), melanin_redness=0.25)
    connect(bsdf, "absorption_coefficient", melanin, "absorption", Sdf.ValueTypeNames.Vector3f)
    expected = tuple(0.75 * e + 0.25 * p for e, p in zip((0.419, 0.697, 1.37), (0.187, 0.4, 1.05)))
    assert params_of(stage)["penumbra:hairAbsorption"] == pytest.approx(expected, abs=2e-5)


def test_constant_lobe_roughness_becomes_betas_and_scales():
    """chiang_hair_bsdf's defaults: (v, s) = (0.1, 0.1), (0.05, 0.05), (0.2, 0.2) for R, TT and
    TRT — β_m with v(β_m) = 0.1, β_n with s(β_n) = 0.1, the others' scales √(v ratio) and the s
    ratio."""
    stage = Usd.Stage.CreateInMemory()
    hair_material(stage)
    params = params_of(stage)
    beta_m = params["penumbra:hairLongitudinalRoughness"]
    beta_n = params["penumbra:hairAzimuthalRoughness"]
    assert (0.726 * beta_m + 0.812 * beta_m**2 + 3.7 * beta_m**20) ** 2 == pytest.approx(0.1)
    assert 0.265 * beta_n + 1.194 * beta_n**2 + 5.372 * beta_n**22 == pytest.approx(0.1)
    assert params["penumbra:hairLongitudinalScaleTT"] == pytest.approx(math.sqrt(0.5))
    assert params["penumbra:hairLongitudinalScaleTRT"] == pytest.approx(math.sqrt(2.0))
    assert params["penumbra:hairAzimuthalScaleTT"] == pytest.approx(0.5)
    assert params["penumbra:hairAzimuthalScaleTRT"] == pytest.approx(2.0)
    assert params["penumbra:hairCuticleAngle"] == pytest.approx(0.0)  # 0.5: no tilt
    assert params["penumbra:hairAbsorption"] == pytest.approx((0.0, 0.0, 0.0))


def test_what_the_hair_bsdf_ignores_warns_once_naming_it():
    stage = Usd.Stage.CreateInMemory()
    bsdf = hair_material(stage)
    tangent = node(stage, "tangent", "ND_constant_vector3")
    connect(bsdf, "curve_direction", tangent, "out", Sdf.ValueTypeNames.Vector3f)
    messages: list[str] = []
    params = params_of(stage, messages.append)
    assert params["penumbra:hair"] == 1
    assert len(messages) == 1
    assert "curve_direction is not supported" in messages[0] and LOOK in messages[0]


def test_a_varying_hair_colour_drives_the_colour_input_converted_per_shading_point():
    """A per-strand colour (a geompropvalue) feeding chiang_hair_absorption_from_color: the
    colour input reads the primvar, σa derives from it at each shading point with the node's
    azimuthal roughness, and nothing warns."""
    stage = Usd.Stage.CreateInMemory()
    bsdf = hair_material(stage)
    absorption = node(stage, "absorption", "ND_chiang_hair_absorption_from_color",
                      azimuthal_roughness=0.35)
    reader = node(stage, "tint", "ND_geompropvalue_color3")
    reader.CreateInput("geomprop", Sdf.ValueTypeNames.String).Set("hairColor")
    connect(absorption, "color", reader, "out", Sdf.ValueTypeNames.Color3f)
    connect(bsdf, "absorption_coefficient", absorption, "absorption",
            Sdf.ValueTypeNames.Vector3f)
    params = params_of(stage)
    assert params["penumbra:hairAbsorptionFromColor"] == 1
    assert "penumbra:hairAbsorptionFromMelanin" not in params
    assert "penumbra:hairAbsorption" not in params
    assert params["penumbra:hairColor"]["primvar"] == "hairColor"
    assert params["penumbra:hairColorAzimuthalRoughness"] == pytest.approx(0.35)


def test_a_varying_melanin_drives_the_melanin_inputs():
    """A per-strand melanin concentration feeding deon_hair_absorption_from_melanin: the
    melanin input reads the primvar, the constant redness is kept as it is."""
    stage = Usd.Stage.CreateInMemory()
    bsdf = hair_material(stage)
    absorption = node(stage, "absorption", "ND_deon_hair_absorption_from_melanin",
                      melanin_redness=0.3)
    reader = node(stage, "melanin", "ND_geompropvalue_float")
    reader.CreateInput("geomprop", Sdf.ValueTypeNames.String).Set("melanin")
    connect(absorption, "melanin_concentration", reader, "out", Sdf.ValueTypeNames.Float)
    connect(bsdf, "absorption_coefficient", absorption, "absorption",
            Sdf.ValueTypeNames.Vector3f)
    params = params_of(stage)
    assert params["penumbra:hairAbsorptionFromMelanin"] == 1
    assert "penumbra:hairAbsorption" not in params
    assert params["penumbra:hairMelanin"]["primvar"] == "melanin"
    assert params["penumbra:hairMelaninRedness"] == pytest.approx(0.3)


def test_melanin_with_other_pigments_than_deons_warns_naming_them():
    stage = Usd.Stage.CreateInMemory()
    bsdf = hair_material(stage)
    absorption = node(stage, "absorption", "ND_deon_hair_absorption_from_melanin",
                      eumelanin_color=(0.5, 0.5, 0.5))
    reader = node(stage, "melanin", "ND_geompropvalue_float")
    reader.CreateInput("geomprop", Sdf.ValueTypeNames.String).Set("melanin")
    connect(absorption, "melanin_concentration", reader, "out", Sdf.ValueTypeNames.Float)
    connect(bsdf, "absorption_coefficient", absorption, "absorption",
            Sdf.ValueTypeNames.Vector3f)
    messages: list[str] = []
    params = params_of(stage, messages.append)
    assert params["penumbra:hairMelanin"]["primvar"] == "melanin"
    assert len(messages) == 1 and "absorption.eumelanin_color is not supported" in messages[0]


def test_an_untranslatable_hair_colour_warns_once_and_keeps_the_default_absorption():
    stage = Usd.Stage.CreateInMemory()
    bsdf = hair_material(stage)
    absorption = node(stage, "absorption", "ND_chiang_hair_absorption_from_color")
    noise = node(stage, "noise", "ND_noise2d_color3")
    connect(absorption, "color", noise, "out", Sdf.ValueTypeNames.Color3f)
    connect(bsdf, "absorption_coefficient", absorption, "absorption",
            Sdf.ValueTypeNames.Vector3f)
    messages: list[str] = []
    params = params_of(stage, messages.append)
    assert params["penumbra:hairAbsorption"] == pytest.approx((0.0, 0.0, 0.0))
    assert "penumbra:hairAbsorptionFromColor" not in params
    assert len(messages) == 1 and f"{LOOK}/noise" in messages[0]


def test_a_usd_preview_surface_reads_the_hair_colour_inputs():
    """The per-point conversion's inputs on a UsdPreviewSurface, the colour from a primvar
    reader."""
    stage = Usd.Stage.CreateInMemory()
    material = add_preview_material(stage, LOOK, **{
        "penumbra:hair": 1, "penumbra:hairAbsorptionFromColor": 1,
        "penumbra:hairColorAzimuthalRoughness": 0.25})
    surface = UsdShade.Shader(stage.GetPrimAtPath(f"{LOOK}/Surface"))
    reader = UsdShade.Shader.Define(stage, f"{LOOK}/colour")
    reader.CreateIdAttr("UsdPrimvarReader_float3")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("strandColor")
    surface.CreateInput("penumbra:hairColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        reader.CreateOutput("result", Sdf.ValueTypeNames.Float3))
    assert material
    params = params_of(stage)
    assert params["penumbra:hairAbsorptionFromColor"] == 1
    assert params["penumbra:hairColorAzimuthalRoughness"] == pytest.approx(0.25)
    assert params["penumbra:hairColor"]["primvar"] == "strandColor"


def test_a_surface_over_another_bsdf_warns_and_renders_a_default_standard_surface():
    stage = Usd.Stage.CreateInMemory()
    hair_material(stage, "ND_oren_nayar_diffuse_bsdf")
    messages: list[str] = []
    params = params_of(stage, messages.append)
    assert "penumbra:hair" not in params
    assert len(messages) == 1 and "ND_oren_nayar_diffuse_bsdf" in messages[0]


def hair_quad_radiance(**inputs) -> np.ndarray:
    """Mean radiance of a quad filling the view under a white dome (one scattering event sees
    the dome on both sides: the radiance is the BSDF's albedo)."""
    stage = diffuse_quad_stage()
    hair_material(stage, **inputs)
    bind(UsdGeom.Mesh(stage.GetPrimAtPath("/World/quad")),
         UsdShade.Material(stage.GetPrimAtPath(LOOK)))
    return quad_radiance(stage)


def test_a_clear_hair_material_passes_the_white_furnace():
    radiance = hair_quad_radiance()
    assert radiance == pytest.approx((1.0, 1.0, 1.0), abs=0.01)


def test_an_opaque_fibre_reflects_only_fresnels_share():
    """Under strong absorption only R is left. On a surface that is not a fibre the shading
    normal is the fibre's normal: seen head-on, every point is met at θo ≈ 0 and h ≈ 0, where R
    reflects Fresnel's normal-incidence share ((η − 1)/(η + 1))² of the dome."""
    radiance = hair_quad_radiance(absorption_coefficient=(200.0, 200.0, 200.0))
    assert radiance == pytest.approx((((1.55 - 1) / (1.55 + 1)) ** 2,) * 3, rel=0.03)


def test_a_usd_preview_surface_becomes_hair_by_its_penumbra_inputs():
    """inputs:penumbra:hair on a UsdPreviewSurface: its diffuse colour no longer matters."""
    stage = diffuse_quad_stage()
    material = add_preview_material(stage, "/World/Looks/preview", diffuseColor=(0.0, 1.0, 0.0),
                                    **{"penumbra:hair": 1,
                                       "penumbra:hairAbsorption": (200.0, 200.0, 200.0)})
    bind(UsdGeom.Mesh(stage.GetPrimAtPath("/World/quad")), material)
    radiance = quad_radiance(stage)
    assert radiance == pytest.approx((((1.55 - 1) / (1.55 + 1)) ** 2,) * 3, rel=0.03)


def fibre_radiance(**inputs) -> tuple[np.ndarray, float]:
    """The mean radiance of the pixels a straight round fibre across the view covers (a hair
    material with ``inputs``) under a white dome hidden from the camera, and the largest |h| (the
    offset across the fibre, in radii) that those pixels reach."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    camera = UsdGeom.Camera.Define(stage, "/cam")
    camera.AddTranslateOp().Set(Gf.Vec3d(0, 0, 10))
    camera.CreateFocalLengthAttr(50.0)
    camera.CreateHorizontalApertureAttr(20.0)
    camera.CreateVerticalApertureAttr(20.0)
    fibre = UsdGeom.BasisCurves.Define(stage, "/World/fibre")
    fibre.CreatePointsAttr([Gf.Vec3f(-1.5, 0, 0), Gf.Vec3f(-0.5, 0, 0), Gf.Vec3f(0.5, 0, 0),
                            Gf.Vec3f(1.5, 0, 0)])
    fibre.CreateCurveVertexCountsAttr([4])
    fibre.CreateWidthsAttr([FIBRE_WIDTH])
    fibre.SetWidthsInterpolation(UsdGeom.Tokens.constant)
    hair_material(stage, **inputs)
    bind(fibre, UsdShade.Material(stage.GetPrimAtPath(LOOK)))
    UsdLux.DomeLight.Define(stage, "/Dome").CreateIntensityAttr(1.0)
    image = penumbra.render(stage, camera="/cam", width=64, samples=64, seed=3,
                            dome_light_visibility=False)["color"]
    covered = image[..., 3] > 0.99
    rows_per_column = covered.sum(axis=0).max()
    pixels_per_unit = 64 / 4.0  # the camera sees [-2, 2]² at the fibre's distance
    return image[covered][:, :3].mean(axis=0), rows_per_column / (FIBRE_WIDTH * pixels_per_unit)


FIBRE_WIDTH = 0.8


def fresnel(cos_incident: np.ndarray, eta: float) -> np.ndarray:
    """Unpolarised Fresnel reflectance of a dielectric of relative index ``eta``."""
    sin_transmitted = np.sqrt(np.maximum(0.0, 1 - cos_incident**2)) / eta
    cos_transmitted = np.sqrt(1 - sin_transmitted**2)
    s = (cos_incident - eta * cos_transmitted) / (cos_incident + eta * cos_transmitted)
    p = (eta * cos_incident - cos_transmitted) / (eta * cos_incident + cos_transmitted)
    return (s**2 + p**2) / 2


def fibre_albedo(absorption, h_max: float, eta: float = 1.55) -> np.ndarray:
    """Chiang et al.'s Σ A_p (R, TT, TRT and the residual series) of a fibre seen at θo = 0,
    averaged over h uniform in [−h_max, h_max]: under a white dome, what each point of it returns
    when light crosses it once."""
    h = np.linspace(-h_max, h_max, 4001)[:, None]
    f = fresnel(np.sqrt(1 - h**2), eta)
    transmittance = np.exp(-np.asarray(absorption)[None, :] * 2 * np.sqrt(1 - (h / eta) ** 2))
    a0 = f
    a1 = (1 - f) ** 2 * transmittance
    a2 = a1 * transmittance * f
    a3 = a2 * transmittance * f / (1 - transmittance * f)
    return (a0 + a1 + a2 + a3).mean(axis=0)


def test_a_clear_fibre_under_a_white_dome_stays_white():
    """A lossless fibre (no absorption, white tints) returns all of the dome's light."""
    radiance, h_max = fibre_radiance()
    assert h_max > 0.7
    np.testing.assert_allclose(radiance, 1.0, rtol=0.02)


def test_an_absorbing_fibre_returns_what_light_crossing_it_once_keeps():
    """Light crosses a fibre once: the transmitted ray leaves from its far wall (it must not
    scatter there again, nor a shadow ray be blocked by it), so an absorbing fibre returns its
    lobes' attenuations Σ A_p(h) averaged over the h its pixels see."""
    absorption = (0.3, 1.0, 3.0)
    radiance, h_max = fibre_radiance(absorption_coefficient=absorption)
    np.testing.assert_allclose(radiance, fibre_albedo(absorption, h_max), rtol=0.02)


def test_a_wrongly_typed_constant_input_takes_its_default_and_the_rest_renders():
    """inputs:penumbra:hair authored as a float (the switch is a bool): one warning naming the
    material and the input, the input takes its default (not hair), and the material's other
    inputs and its primvar reader still apply, instead of the render failing."""
    stage = diffuse_quad_stage()
    material = add_preview_material(stage, "/World/Looks/preview", diffuseColor=(1.0, 0.0, 0.0),
                                    roughness=1.0, **{"penumbra:hair": 1.0})
    bind(UsdGeom.Mesh(stage.GetPrimAtPath("/World/quad")), material)
    with pytest.warns(penumbra.PenumbraWarning) as record:
        radiance = quad_radiance(stage)
    messages = [str(w.message) for w in record if "penumbra:hair" in str(w.message)]
    assert messages == ["/World/Looks/preview: penumbra:hair expects a bool or an int; its "
                        "default is used"]
    assert radiance[0] > 0.9 and radiance[1] < 0.05  # the red diffuse quad


# The strands' y, each across the view; far apart, each hides little of the dome from the other.
STRAND_HEIGHTS = (1.4, -1.4)


def groom_stage(primvar: str, values: list, value_type: Sdf.ValueTypeName,
                ) -> tuple[Usd.Stage, UsdGeom.BasisCurves]:
    """A camera looking at a groom of two straight round strands across the view (the upper one
    first), each with its own value of the uniform primvar ``primvar``."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    camera = UsdGeom.Camera.Define(stage, "/cam")
    camera.AddTranslateOp().Set(Gf.Vec3d(0, 0, 10))
    camera.CreateFocalLengthAttr(50.0)
    camera.CreateHorizontalApertureAttr(20.0)
    camera.CreateVerticalApertureAttr(20.0)
    groom = UsdGeom.BasisCurves.Define(stage, "/World/groom")
    groom.CreatePointsAttr([Gf.Vec3f(x, y, 0) for y in STRAND_HEIGHTS
                            for x in (-1.5, -0.5, 0.5, 1.5)])
    groom.CreateCurveVertexCountsAttr([4, 4])
    groom.CreateWidthsAttr([FIBRE_WIDTH])
    groom.SetWidthsInterpolation(UsdGeom.Tokens.constant)
    UsdGeom.PrimvarsAPI(groom).CreatePrimvar(primvar, value_type,
                                             UsdGeom.Tokens.uniform).Set(values)
    return stage, groom


def render_strands(stage: Usd.Stage, groom: UsdGeom.BasisCurves,
                   ) -> list[tuple[np.ndarray, float]]:
    """The groom with the material at LOOK under a white dome hidden from the camera: each
    strand's mean radiance and the largest |h| its pixels reach, as fibre_radiance measures
    them."""
    bind(groom, UsdShade.Material(stage.GetPrimAtPath(LOOK)))
    UsdLux.DomeLight.Define(stage, "/Dome").CreateIntensityAttr(1.0)
    image = penumbra.render(stage, camera="/cam", width=64, samples=64, seed=3,
                            dome_light_visibility=False)["color"]
    pixels_per_unit = 64 / 4.0  # the camera sees [-2, 2]² at the strands' distance
    strands = []
    for rows in (slice(0, 32), slice(32, 64)):  # image rows run downwards: the upper strand first
        half = image[rows]
        covered = half[..., 3] > 0.99
        rows_per_column = covered.sum(axis=0).max()
        strands.append((half[covered][:, :3].mean(axis=0),
                        rows_per_column / (FIBRE_WIDTH * pixels_per_unit)))
    return strands


def test_each_strand_takes_the_absorption_of_its_own_colour():
    """The production groom: displayColor per strand read by a geompropvalue, through
    chiang_hair_absorption_from_color, into chiang_hair_bsdf: each strand returns what light
    crossing a fibre of σa(its colour) once keeps (as an absorbing fibre does, above)."""
    colours = [(0.3, 0.12, 0.05), (0.9, 0.7, 0.45)]  # red-brown, blond
    beta_n = 0.3
    stage, groom = groom_stage("displayColor", [Gf.Vec3f(*c) for c in colours],
                                    Sdf.ValueTypeNames.Color3fArray)
    bsdf = hair_material(stage)
    absorption = node(stage, "absorption", "ND_chiang_hair_absorption_from_color",
                      azimuthal_roughness=beta_n)
    reader = node(stage, "colour", "ND_geompropvalue_color3")
    reader.CreateInput("geomprop", Sdf.ValueTypeNames.String).Set("displayColor")
    connect(absorption, "color", reader, "out", Sdf.ValueTypeNames.Color3f)
    connect(bsdf, "absorption_coefficient", absorption, "absorption",
            Sdf.ValueTypeNames.Vector3f)
    strands = render_strands(stage, groom)
    for colour, (radiance, h_max) in zip(colours, strands):
        assert h_max > 0.7
        sigma_a = [(math.log(c) / chiang_denominator(beta_n)) ** 2 for c in colour]
        np.testing.assert_allclose(radiance, fibre_albedo(sigma_a, h_max), rtol=0.02)
    # The strands differ as their colours do (the red-brown one's blue is well below the
    # blond one's).
    assert strands[0][0][2] < 0.8 * strands[1][0][2]


def test_each_strand_takes_the_absorption_of_its_own_melanin():
    """The same with a per-strand melanin concentration through
    deon_hair_absorption_from_melanin (a constant redness)."""
    melanin, redness = [0.7, 0.3], 0.2
    stage, groom = groom_stage("melanin", melanin, Sdf.ValueTypeNames.FloatArray)
    bsdf = hair_material(stage)
    absorption = node(stage, "absorption", "ND_deon_hair_absorption_from_melanin",
                      melanin_redness=redness)
    reader = node(stage, "melanin", "ND_geompropvalue_float")
    reader.CreateInput("geomprop", Sdf.ValueTypeNames.String).Set("melanin")
    connect(absorption, "melanin_concentration", reader, "out", Sdf.ValueTypeNames.Float)
    connect(bsdf, "absorption_coefficient", absorption, "absorption",
            Sdf.ValueTypeNames.Vector3f)
    strands = render_strands(stage, groom)
    eumelanin, pheomelanin = (0.657704, 0.498077, 0.254107), (0.829444, 0.670320, 0.349938)
    for concentration, (radiance, h_max) in zip(melanin, strands):
        assert h_max > 0.7
        amount = -math.log(1 - concentration)
        sigma_a = [-amount * ((1 - redness) * math.log(e) + redness * math.log(p))
                   for e, p in zip(eumelanin, pheomelanin)]
        np.testing.assert_allclose(radiance, fibre_albedo(sigma_a, h_max), rtol=0.02)
    assert strands[0][0][2] < 0.8 * strands[1][0][2]
