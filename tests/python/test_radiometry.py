"""Analytic radiometry through the whole stack: a Lambertian plane (albedo 0.5, displayColor)
under an area light. Its outgoing radiance is albedo/π · E, E the irradiance from the light."""

from __future__ import annotations

import math

import pytest
from pxr import Gf, UsdLux

import penumbra
from stages import add_camera, add_quad, new_stage

ALBEDO = 0.5


def plane_stage():
    """A large grey plane y = 0 seen straight down by a narrow camera at height 0.5."""
    stage = new_stage()
    add_quad(stage, "/World/plane", half_size=20.0, color=(ALBEDO,) * 3, facing="y")
    # rotateX -90 turns the camera's −Z view axis to −Y; its footprint is ±0.01 units.
    add_camera(stage, translate=(0, 0.5, 0), rotate_x=-90.0, focal_length=50.0, aperture=(2.0, 2.0))
    return stage


def mean_radiance(stage) -> float:
    image = penumbra.Renderer(stage).render(camera="/cam", width=24, samples=64, seed=1)
    return float(image["color"][..., :3].mean())


def test_sphere_light_irradiance():
    stage = plane_stage()
    radius, distance, radiance = 0.5, 2.0, 4.0
    light = UsdLux.SphereLight.Define(stage, "/World/bulb")
    light.CreateRadiusAttr(radius)
    light.CreateIntensityAttr(radiance)
    light.AddTranslateOp().Set(Gf.Vec3d(0, distance, 0))
    irradiance = math.pi * radiance * (radius / distance) ** 2  # on axis, sphere fully visible
    assert mean_radiance(stage) == pytest.approx(ALBEDO / math.pi * irradiance, rel=0.02)


def _corner_form_factor(a: float, b: float) -> float:
    """Form factor from a point to a parallel a×b rectangle (in units of the distance) having a
    corner above the point."""
    p, q = math.sqrt(1 + a * a), math.sqrt(1 + b * b)
    return (a / p * math.atan(b / p) + b / q * math.atan(a / q)) / (2 * math.pi)


def test_rect_light_irradiance():
    stage = plane_stage()
    width, height, distance, radiance = 2.0, 1.2, 1.0, 2.0
    light = UsdLux.RectLight.Define(stage, "/World/panel")
    light.CreateWidthAttr(width)
    light.CreateHeightAttr(height)
    light.CreateIntensityAttr(radiance)
    light.AddTranslateOp().Set(Gf.Vec3d(0, distance, 0))
    light.AddRotateXOp().Set(-90.0)  # emits along its −Z: straight down
    form_factor = 4 * _corner_form_factor(width / 2 / distance, height / 2 / distance)
    irradiance = math.pi * radiance * form_factor
    assert mean_radiance(stage) == pytest.approx(ALBEDO / math.pi * irradiance, rel=0.02)


def test_light_exposure_and_normalize():
    """exposure doubles per stop; normalize divides by the light's area (docs/design.md §3)."""
    stage = plane_stage()
    light = UsdLux.SphereLight.Define(stage, "/World/bulb")
    light.CreateRadiusAttr(0.5)
    light.CreateIntensityAttr(1.0)
    light.AddTranslateOp().Set(Gf.Vec3d(0, 2.0, 0))
    base = mean_radiance(stage)
    light.CreateExposureAttr(2.0)
    assert mean_radiance(stage) == pytest.approx(4 * base, rel=0.01)
    light.CreateNormalizeAttr(True)
    area = 4 * math.pi * 0.5**2
    assert mean_radiance(stage) == pytest.approx(4 * base / area, rel=0.01)
