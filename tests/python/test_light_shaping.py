"""UsdLuxShapingAPI as its schema defines it, seen directly by a narrow camera (the pixel is the
light's radiance towards the camera times the shaping factor): full emission up to
coneAngle·(1 − coneSoftness) off the light's −Z axis, a smoothstep over the angle to none at
coneAngle; focus as |cos|^focus towards focusTint; a cone of 90° or more on a sphere light
cuts its emission behind the axis."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pxr import Gf, UsdGeom, UsdLux

import penumbra
from stages import new_stage


def smoothstep(edge0: float, edge1: float, x: float) -> float:
    t = min(max((x - edge0) / (edge1 - edge0), 0.0), 1.0)
    return t * t * (3 - 2 * t)


def schema_factor(off_axis: float, cone: float = 90.0, softness: float = 0.0,
                  focus: float = 0.0) -> float:
    """The schema's shaping factor at ``off_axis`` degrees off the axis (focusTint black)."""
    factor = abs(math.cos(math.radians(off_axis))) ** focus if focus > 0 else 1.0
    start = cone * (1 - softness)
    if off_axis > cone:
        return 0.0
    if off_axis > start:
        factor *= 1 - smoothstep(start, cone, off_axis)
    return factor


def seen_at(kind: str, off_axis: float, **shaping) -> float:
    """A shaped light of radiance 1 seen from ``off_axis`` degrees off its −Z axis."""
    stage = new_stage()
    light = (UsdLux.DiskLight if kind == "disk" else UsdLux.SphereLight).Define(stage, "/lamp")
    light.CreateRadiusAttr(0.5)
    api = UsdLux.ShapingAPI.Apply(light.GetPrim())
    for name, value in shaping.items():
        getattr(api, f"CreateShaping{name}Attr")(value)
    angle = math.radians(off_axis)
    eye = Gf.Vec3d(5 * math.sin(angle), 0, -5 * math.cos(angle))
    camera = UsdGeom.Camera.Define(stage, "/cam")
    camera.CreateFocalLengthAttr(50.0)
    camera.CreateHorizontalApertureAttr(1.0)
    camera.CreateVerticalApertureAttr(1.0)
    look = Gf.Matrix4d().SetLookAt(eye, Gf.Vec3d(0, 0, 0), Gf.Vec3d(0, 1, 0)).GetInverse()
    UsdGeom.Xformable(camera).AddTransformOp().Set(look)
    image = penumbra.Renderer(stage).render(camera="/cam", width=8, samples=4)["color"]
    return float(np.asarray(image)[3:5, 3:5, 0].mean())


@pytest.mark.parametrize(
    "kind, off_axis, shaping",
    [
        ("disk", 30.0, dict(ConeAngle=60.0, ConeSoftness=1.0)),  # half way: 0.5
        ("disk", 40.0, dict(ConeAngle=60.0, ConeSoftness=0.5)),
        ("disk", 50.0, dict(ConeAngle=60.0, ConeSoftness=0.5)),
        ("disk", 20.0, dict(ConeAngle=60.0, ConeSoftness=0.5)),  # before the fade: whole
        ("disk", 65.0, dict(ConeAngle=60.0)),  # past the cone: none
        ("sphere", 180.0, dict(ConeAngle=120.0)),
        ("sphere", 150.0, dict(ConeAngle=100.0)),
        ("sphere", 180.0, dict()),  # the fallback cone, 90°: nothing behind
        ("sphere", 180.0, dict(ConeAngle=180.0, Focus=2.0)),  # |cos| behind the axis too
        ("sphere", 135.0, dict(ConeAngle=180.0, Focus=2.0)),
        ("sphere", 60.0, dict(ConeAngle=180.0, Focus=2.0)),
    ],
)
def test_shaping_follows_the_schema(kind, off_axis, shaping):
    expected = schema_factor(off_axis, cone=shaping.get("ConeAngle", 90.0),
                             softness=shaping.get("ConeSoftness", 0.0),
                             focus=shaping.get("Focus", 0.0))
    assert seen_at(kind, off_axis, **shaping) == pytest.approx(expected, abs=2e-3)


def test_a_sphere_light_without_shaping_emits_all_round():
    stage_value = seen_at("sphere", 180.0, ConeAngle=180.0)
    assert stage_value == pytest.approx(1.0, abs=2e-3)
