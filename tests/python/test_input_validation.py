"""Light and camera inputs the render delegate cannot take: a value blocked at the frame reads as
the schema's fallback; a light input out of range skips the light with one warning naming it
and the attribute; a camera or render settings value that would make the frame impossible (or
abort the process in Embree) fails the render with a message naming the prim and attribute."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux

import penumbra
from malformed_corpus import Case, write_case
from stages import add_camera, add_quad, new_stage, render_with_warnings

RENDER = dict(camera="/cam", width=16, samples=4, seed=1)


def render(stage: Usd.Stage) -> tuple[np.ndarray, list[str]]:
    return render_with_warnings(stage, RENDER["width"])


def lit_stage() -> Usd.Stage:
    """A grey quad lit by a sphere light, seen by ``/cam``."""
    stage = new_stage()
    add_camera(stage)
    add_quad(stage, "/World/quad", half_size=2.0, color=(0.5, 0.5, 0.5))
    key = UsdLux.SphereLight.Define(stage, "/World/key")
    key.CreateIntensityAttr(20.0)
    key.AddTranslateOp().Set(Gf.Vec3d(0, 0, 2))
    return stage


def add_rect_light(stage: Usd.Stage) -> Usd.Prim:
    """A rect light 1 above the quad, facing it."""
    light = UsdLux.RectLight.Define(stage, "/World/L")
    light.AddTranslateOp().Set(Gf.Vec3d(0, 0, 1))
    return light.GetPrim()


def add_mesh_light(stage: Usd.Stage) -> Usd.Prim:
    """A card 1 above the quad emitting as a UsdLuxMeshLightAPI light."""
    card = add_quad(stage, "/World/L", center=(0.0, 0.0, 1.0), half_size=0.3)
    UsdLux.MeshLightAPI.Apply(card.GetPrim())
    return card.GetPrim()


BLOCKED = [
    (add_rect_light, "inputs:intensity", Sdf.ValueTypeNames.Float, 50.0),
    (add_rect_light, "inputs:color", Sdf.ValueTypeNames.Color3f, Gf.Vec3f(1, 0, 0)),
    (add_rect_light, "inputs:width", Sdf.ValueTypeNames.Float, 3.0),
    (add_rect_light, "inputs:normalize", Sdf.ValueTypeNames.Bool, True),
    (add_mesh_light, "inputs:intensity", Sdf.ValueTypeNames.Float, 50.0),
    (add_mesh_light, "inputs:color", Sdf.ValueTypeNames.Color3f, Gf.Vec3f(1, 0, 0)),
]


def block_at_frame(attr: Usd.Attribute, earlier) -> None:
    """``{0: earlier, 1: None}``: a value before the frame, then no opinion at it."""
    attr.Set(earlier, 0)
    attr.Set(Sdf.ValueBlock(), 1)


def assert_renders_as(stage: Usd.Stage, expected_stage: Usd.Stage) -> None:
    """``stage`` renders bit for bit as ``expected_stage``, without a warning."""
    expected, _ = render(expected_stage)
    image, messages = render(stage)
    assert messages == []
    assert np.array_equal(image, expected)


@pytest.mark.parametrize(
    ("add_light", "name", "type_name", "earlier"),
    BLOCKED,
    ids=[f"{add.__name__[4:]} {name}" for add, name, _, _ in BLOCKED],
)
def test_a_value_blocked_at_the_frame_reads_as_the_schemas_fallback(
    add_light, name: str, type_name: Sdf.ValueTypeName, earlier
) -> None:
    """``{0: earlier, 1: None}``: no opinion at frame 1, as if the input were not authored
    (it raised a TypeError, or the render delegate refused None)."""
    expected_stage, blocked_stage = lit_stage(), lit_stage()
    add_light(expected_stage)
    block_at_frame(add_light(blocked_stage).CreateAttribute(name, type_name), earlier)
    assert_renders_as(blocked_stage, expected_stage)


def test_a_blocked_shutter_open_reads_as_its_fallback() -> None:
    """shutter:open ``{0: -0.25, 1: None}`` is the fallback 0 at frame 1 (float(None) raised)."""
    expected_stage, blocked_stage = lit_stage(), lit_stage()
    camera = UsdGeom.Camera(blocked_stage.GetPrimAtPath("/cam"))
    block_at_frame(camera.CreateShutterOpenAttr(), -0.25)
    assert_renders_as(blocked_stage, expected_stage)


def test_a_focal_length_blocked_inside_the_shutter_renders() -> None:
    """Sampled over the shutter, the block reads as the fallback (the camera was dropped, and
    the render failed with a KeyError)."""
    stage = lit_stage()
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/cam"))
    camera.CreateShutterOpenAttr(-0.25)
    camera.CreateShutterCloseAttr(0.25)
    focal = camera.GetFocalLengthAttr()
    focal.Clear()
    for time, value in ((1, 5.0), (1.1, Sdf.ValueBlock()), (1.2, 4.0)):
        focal.Set(value, time)
    image, messages = render(stage)
    assert messages == []
    assert np.isfinite(image).all() and image[..., :3].max() > 0


def add_light(stage: Usd.Stage, light_type: str) -> Usd.Prim:
    """A light of ``light_type`` (a UsdLux light schema, or MeshLightAPI) 1 above the quad."""
    if light_type == "MeshLightAPI":
        return add_mesh_light(stage)
    light = getattr(UsdLux, light_type).Define(stage, "/World/L")
    light.AddTranslateOp().Set(Gf.Vec3d(0, 0, 1))
    return light.GetPrim()


def author(prim: Usd.Prim, name: str, type_name: Sdf.ValueTypeName, value) -> None:
    """Author attribute ``name`` of ``prim`` as ``type_name``, as a file may whatever the schema
    says (the Usd API would convert the value to the schema's type)."""
    spec = prim.GetStage().GetRootLayer().GetPrimAtPath(prim.GetPath())
    Sdf.AttributeSpec(spec, name, type_name).default = value


def skipped_light_image(light_type: str) -> np.ndarray:
    """The image of :func:`lit_stage` with a light of ``light_type`` skipped: of intensity 0,
    its other inputs their fallbacks."""
    stage = lit_stage()
    UsdLux.LightAPI(add_light(stage, light_type)).CreateIntensityAttr(0.0)
    return render(stage)[0]


def test_treat_as_point_of_the_wrong_type_is_named_and_the_light_skipped() -> None:
    """treatAsPoint has no ``inputs:`` prefix: the warning named inputs:treatAsPoint, and the
    fallback looked up for it was None, which the render delegate refused."""
    stage = lit_stage()
    author(add_light(stage, "SphereLight"), "treatAsPoint", Sdf.ValueTypeNames.Float, 1.0)
    image, messages = render(stage)
    assert messages == [
        "/World/L: treatAsPoint has a value of type float, not bool; the light is skipped "
        "(intensity 0)"
    ]
    assert np.array_equal(image, skipped_light_image("SphereLight"))


OUT_OF_RANGE = [
    ("SphereLight", "inputs:intensity", Sdf.ValueTypeNames.Float, 3e38, "inputs:intensity"),
    ("SphereLight", "inputs:color", Sdf.ValueTypeNames.Color3f, Gf.Vec3f(3e38), "inputs:color"),
    ("SphereLight", "inputs:exposure", Sdf.ValueTypeNames.Float, 200.0, "inputs:exposure"),
    ("SphereLight", "inputs:intensity", Sdf.ValueTypeNames.Double, 1e300, "inputs:intensity"),
    ("SphereLight", "inputs:color", Sdf.ValueTypeNames.Color3f, Gf.Vec3f(float("nan"), 1, 1),
     "inputs:color"),
    ("SphereLight", "inputs:radius", Sdf.ValueTypeNames.Float, -1.0, "inputs:radius"),
    ("CylinderLight", "inputs:length", Sdf.ValueTypeNames.Float, -1.0, "inputs:length"),
    ("RectLight", "inputs:width", Sdf.ValueTypeNames.Float, -1.0, "inputs:width"),
    ("DistantLight", "inputs:angle", Sdf.ValueTypeNames.Float, -5.0, "inputs:angle"),
    ("MeshLightAPI", "inputs:intensity", Sdf.ValueTypeNames.Float, 3e38, "inputs:intensity"),
]


@pytest.mark.parametrize(
    ("light_type", "name", "type_name", "value", "named"),
    OUT_OF_RANGE,
    ids=[f"{kind} {name} {value}" for kind, name, _, value, _ in OUT_OF_RANGE],
)
def test_a_light_input_out_of_range_skips_the_light_with_one_warning(
    light_type: str, name: str, type_name: Sdf.ValueTypeName, value, named: str
) -> None:
    """The image is the one of the light skipped: huge emission gave inf pixels; negative
    sizes and angles beyond [0, 360] changed the image silently; a NaN colour was warned of
    twice (here, then by the render delegate)."""
    stage = lit_stage()
    author(add_light(stage, light_type), name, type_name, value)
    image, messages = render(stage)
    assert len(messages) == 1, messages
    assert messages[0].startswith("/World/L: ") and named in messages[0], messages
    assert messages[0].endswith("the light is skipped (intensity 0)")
    assert np.array_equal(image, skipped_light_image(light_type))


MOVING = "double shutter:open = -0.25\ndouble shutter:close = 0.25\n"
IMPOSSIBLE_FRAMES = [
    Case("focal length NaN in the shutter", 1,
         "/cam: focalLength must be a positive number, not nan at time 1.25",
         camera=MOVING + "float focalLength.timeSamples = {1: 35, 1.25: nan}"),
    Case("focal length negative in the shutter", 1,
         "/cam: focalLength must be a positive number, not -35 at time 1.25",
         camera=MOVING + "float focalLength.timeSamples = {1: 35, 1.25: -35}"),
    Case("focus distance negative in the shutter", 1,
         "/cam: focusDistance must be a finite number >= 0, not -5 at time 1.25",
         camera=MOVING + "float fStop = 2\nfloat focusDistance.timeSamples = {1: 5, 1.25: -5}"),
    Case("aperture offset 1e30", 1, "/cam: horizontalAperture / 2 + |horizontalApertureOffset|",
         camera="float horizontalApertureOffset = 1e30"),
    Case("orthographic aperture 1e30", 1,
         "/cam: horizontalAperture / 2 + |horizontalApertureOffset|",
         camera='token projection = "orthographic"\nfloat horizontalAperture = 1e30'),
    Case("focal length 1e-30", 1, "/cam: focalLength 1e-30 is too short for the film",
         camera="float focalLength = 1e-30"),
    Case("fStop 1e-30", 1, "/cam: fStop 1e-30 is too small for focalLength 35",
         camera="float fStop = 1e-30\nfloat focusDistance = 5"),
    Case("focus distance 1e30", 1, "/cam: focusDistance must be in (0, 1e+12]",
         camera="float fStop = 2\nfloat focusDistance = 1e30"),
    Case("shutter open NaN", 1, "/cam: shutter:open must be a finite number, not nan",
         camera="double shutter:open = nan\ndouble shutter:close = 0.25"),
    Case("shutter close inf", 1, "/cam: shutter:close must be a finite number, not inf",
         camera="double shutter:open = -0.25\ndouble shutter:close = inf"),
    Case("pixel aspect ratio 1e-30", 1, "/rs: pixelAspectRatio must be in [0.01, 100], not 1e-30",
         extra='def RenderSettings "rs"\n{\n    rel camera = </cam>\n'
               "    uniform float pixelAspectRatio = 1e-30\n}",
         args=("-rs", "/rs")),
]


@pytest.mark.parametrize("case", IMPOSSIBLE_FRAMES, ids=[case.name for case in IMPOSSIBLE_FRAMES])
def test_a_camera_value_that_makes_the_frame_impossible_fails_cleanly(
    case: Case, tmp_path: Path
) -> None:
    """In a child process: several aborted it in Embree (a ray not finite, or starting behind
    the lens); the others failed with a KeyError or a message without the camera, or rendered
    silently without motion blur."""
    stage = write_case(case, tmp_path)
    out = tmp_path / "out.png"
    result = subprocess.run(
        [sys.executable, "-m", "penumbra.cli", str(stage), str(out)]
        + ["-w", "32", "-spp", "2", "-q", *case.args],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == case.exit, result.stderr[-2000:]
    assert "Traceback" not in result.stderr
    assert case.expect in result.stderr
    assert not out.exists()
