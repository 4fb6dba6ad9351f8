"""Analytic radiometry through the whole stack: a Lambertian plane (albedo 0.5, displayColor)
under an area light. Its outgoing radiance is albedo/π · E, E the irradiance from the light."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from pxr import Gf, UsdGeom, UsdLux

import penumbra
from stages import add_camera, add_distant_light, add_quad, new_stage

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


@pytest.mark.parametrize("radius", [1e-4, 1e-12], ids=["1e-4", "1e-12"])
def test_a_normalized_sphere_light_far_smaller_than_its_distance(radius: float):
    """A normalized sphere light lights as a point of radiant intensity I/4 (its radiance
    I / (4 π r²) over its disc π r²) however small it is: at radius 1e-12 its sampling density
    (3e24) squared overflowed float in the MIS weight, and half the image was NaN."""
    stage = plane_stage()
    height, intensity = 2.0, 1.0
    light = UsdLux.SphereLight.Define(stage, "/World/bulb")
    light.CreateRadiusAttr(radius)
    light.CreateIntensityAttr(intensity)
    light.CreateNormalizeAttr(True)
    light.AddTranslateOp().Set(Gf.Vec3d(0, height, 0))
    irradiance = intensity / 4 / height**2
    assert mean_radiance(stage) == pytest.approx(ALBEDO / math.pi * irradiance, rel=0.01)


@pytest.mark.parametrize("normalize", [False, True], ids=["unnormalized", "normalized"])
@pytest.mark.parametrize("treat_as_point", [False, True], ids=["sphere", "treatAsPoint"])
def test_a_sphere_light_of_radius_0_is_a_point_light(normalize: bool, treat_as_point: bool):
    """Exporters write bulbs as SphereLights of radius 0 (with treatAsPoint or not): each lights
    as the limit of a normalized sphere, radiant intensity I/4 (Cycles' Hydra delegate's too),
    normalized or not. They were skipped with a warning: the scene rendered without them."""
    stage = plane_stage()
    height, intensity = 2.0, 3.0
    light = UsdLux.SphereLight.Define(stage, "/World/bulb")
    light.CreateRadiusAttr(0.0)
    light.CreateIntensityAttr(intensity)
    light.CreateNormalizeAttr(normalize)
    light.CreateTreatAsPointAttr(treat_as_point)
    light.AddTranslateOp().Set(Gf.Vec3d(0, height, 0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        radiance = mean_radiance(stage)
    irradiance = intensity / 4 / height**2
    assert radiance == pytest.approx(ALBEDO / math.pi * irradiance, rel=0.01)


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


@pytest.mark.parametrize("angle", [30.0, 180.0, 270.0, 359.0])
def test_a_normalized_distant_light_of_any_angle(angle: float):
    """UsdLux divides a normalized DistantLight by its cone's solid angle projected by |cos|:
    π sin²(h) up to h = 90°, π (2 − sin²(h)) past it; a facing plane sees the front half."""
    stage = plane_stage()
    light = UsdLux.DistantLight.Define(stage, "/World/sky")
    light.CreateAngleAttr(angle)
    light.CreateNormalizeAttr(True)
    light.CreateIntensityAttr(2.0)
    light.AddRotateXOp().Set(-90.0)  # shines along −Y, onto the plane
    half = math.radians(angle / 2)
    sin2 = math.sin(half) ** 2
    radiance = 2.0 / (math.pi * (sin2 if half <= math.pi / 2 else 2 - sin2))
    irradiance = radiance * math.pi * (sin2 if half <= math.pi / 2 else 1.0)
    assert mean_radiance(stage) == pytest.approx(ALBEDO / math.pi * irradiance, rel=0.02)


SUN_IRRADIANCE = 3.0


def add_telephoto_view_under_a_sun(stage, distance: float) -> None:
    """A camera looking down at 50° onto the origin from ``distance``, with the same ±0.01-unit
    footprint from any distance (the clipping range reaching the origin), and a sun shining
    straight down. Straight down, Embree's distances to an axis-aligned plane come out exact and
    would show nothing."""
    elevation = math.radians(50.0)
    camera = add_camera(
        stage,
        translate=(0, distance * math.sin(elevation), distance * math.cos(elevation)),
        rotate_x=-math.degrees(elevation),
        focal_length=50.0 * distance / 0.5,
        aperture=(2.0, 2.0),
    )
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.01, 2 * distance))
    sun = add_distant_light(stage, intensity=SUN_IRRADIANCE)
    sun.AddRotateXOp().Set(-90.0)  # shines along −Y


@pytest.mark.parametrize("distance", [0.5, 1e4], ids=["near", "from 10^4 units"])
def test_a_sunlit_plane_seen_from_afar(distance: float):
    """A telephoto camera 10^4 units away sees the same radiance as one 0.5 away: the hit points
    of its rays lie on the plane, not up to 10^-3 either side of it (before, shadow rays started
    below the plane at a third of the pixels: 0.31 instead of 0.48)."""
    stage = new_stage()
    add_quad(stage, "/World/plane", half_size=20.0, color=(ALBEDO,) * 3, facing="y")
    add_telephoto_view_under_a_sun(stage, distance)
    assert mean_radiance(stage) == pytest.approx(ALBEDO / math.pi * SUN_IRRADIANCE, rel=0.01)


def add_facing_up_ribbons(stage) -> None:
    """80 straight ribbons 0.05 wide side by side along z, facing +Y: a square of y = 0."""
    ribbons = UsdGeom.BasisCurves.Define(stage, "/World/ribbons")
    ribbons.CreateTypeAttr(UsdGeom.Tokens.linear)
    xs = (np.arange(80) - 39.5) * 0.05
    ribbons.CreatePointsAttr([Gf.Vec3f(float(x), 0, z) for x in xs for z in (-2.0, 2.0)])
    ribbons.CreateCurveVertexCountsAttr([2] * len(xs))
    ribbons.CreateWidthsAttr([0.05])
    ribbons.SetWidthsInterpolation(UsdGeom.Tokens.constant)
    ribbons.CreateNormalsAttr([Gf.Vec3f(0, 1, 0)])
    ribbons.SetNormalsInterpolation(UsdGeom.Tokens.constant)
    ribbons.CreateDisplayColorAttr([Gf.Vec3f(ALBEDO, ALBEDO, ALBEDO)])


def add_facing_up_discs(stage) -> None:
    """A 60 × 60 grid of overlapping discs 0.08 across, 0.05 apart, facing +Y: y = 0 covered."""
    discs = UsdGeom.Points.Define(stage, "/World/discs")
    grid = (np.arange(60) - 29.5) * 0.05
    discs.CreatePointsAttr([Gf.Vec3f(float(x), 0, float(z)) for x in grid for z in grid])
    discs.CreateWidthsAttr([0.08] * grid.size**2)
    discs.CreateNormalsAttr([Gf.Vec3f(0, 1, 0)] * grid.size**2)
    discs.CreateDisplayColorAttr([Gf.Vec3f(ALBEDO, ALBEDO, ALBEDO)])


@pytest.mark.parametrize("distance", [0.5, 1e4], ids=["near", "from 10^4 units"])
@pytest.mark.parametrize("add_surface", [add_facing_up_ribbons, add_facing_up_discs],
                         ids=["ribbons", "discs"])
def test_sunlit_ribbons_and_discs_seen_from_afar(add_surface, distance: float):
    """Ribbons and discs, whose hit points Embree gives only as a distance along the ray, are
    lit as a plane is from any distance: the point is moved onto the surface's tangent plane
    (before, from 10^4 units: 0.34 for ribbons, 0.38 for discs, against 0.48)."""
    stage = new_stage()
    add_surface(stage)
    add_telephoto_view_under_a_sun(stage, distance)
    assert mean_radiance(stage) == pytest.approx(ALBEDO / math.pi * SUN_IRRADIANCE, rel=0.01)


@pytest.mark.parametrize("moving", [False, True], ids=["still", "moving camera"])
def test_lights_smaller_than_a_pixel_seen_directly(moving: bool):
    """Sphere lights a third of a pixel across, seen by the camera against black: each camera
    sample integrates the filter over their image (README, "Lights small in the image"), so the
    image holds their emission, radiance × their image's area, and two seeds agree pixel by
    pixel. Camera rays alone find each light in about one sample of 12: their pixels jump by
    radiance / samples per hit, and two seeds differ by several times that. A camera moving
    0.25 units across the shutter streaks each light over 4 pixels: the same emission, and
    each sample integrates the light where it is at the sample's moment."""
    stage = new_stage()
    camera = add_camera(stage)  # 64 px over 4 units at 5 units away: 0.0125 radians per pixel
    if moving:
        camera.CreateShutterOpenAttr(-0.5)
        camera.CreateShutterCloseAttr(0.5)
        translate = camera.GetOrderedXformOps()[0]
        translate.Set(Gf.Vec3d(-0.125, 0.0, 5.0), 0.5)
        translate.Set(Gf.Vec3d(0.125, 0.0, 5.0), 1.5)
    radius, radiance = 0.01, 50.0
    centres = [(0.1, 0.05, 0.0), (-0.3, 0.2, 0.0), (0.25, -0.35, 0.0)]
    expected = 0.0
    for index, centre in enumerate(centres):
        light = UsdLux.SphereLight.Define(stage, f"/World/lamp{index}")
        light.CreateRadiusAttr(radius)
        light.CreateIntensityAttr(radiance)
        light.AddTranslateOp().Set(Gf.Vec3d(*centre))
        # The light's solid angle over a pixel's there (which shrinks as cos³ off the axis).
        offset = math.hypot(centre[0], centre[1])
        distance = math.hypot(offset, 5.0)
        solid_angle = 2 * math.pi * (1 - math.sqrt(1 - (radius / distance) ** 2))
        cos_off_axis = 5.0 / distance
        expected += radiance * solid_angle / (0.0125**2 * cos_off_axis**3)
    # A moving camera's samples also spread the light over the shutter: more of them (at 64,
    # three seeds' sums spread by 4 %, at 1,024 by 0.8 %).
    samples = 1024 if moving else 64
    images = [
        penumbra.Renderer(stage).render(
            camera="/cam", time=1.0, width=64, samples=samples, seed=seed, default_light="none"
        )["color"][..., 0]
        for seed in (1, 2)
    ]
    # The filter's weights over the pixel grid sum to 1 within 3 % wherever a light lies.
    assert [float(image.sum()) for image in images] == pytest.approx([expected] * 2, rel=0.05)
    # A tenth of what a whole light adds to the image (its pixels' sum over the three lights).
    assert float(abs(images[0] - images[1]).max()) < 0.1 * expected / len(centres)


def test_lights_small_in_the_image_are_bit_identical_across_threads_and_regions():
    """The draws that integrate small lights over their image are the pixel's and sample's own,
    whatever the light's kind: a sphere, a rect and a cylinder light a pixel or two across render
    the same with 1 or 2 threads, and a band of rows through them (as the farm splits frames)
    equals that band of the whole image."""
    stage = new_stage()
    add_camera(stage)  # 64 px over 4 units at 5 units away: 0.0625 units per pixel
    sphere = UsdLux.SphereLight.Define(stage, "/World/sphere")
    sphere.CreateRadiusAttr(0.03)
    sphere.AddTranslateOp().Set(Gf.Vec3d(0.1, 0.05, 0.0))
    rect = UsdLux.RectLight.Define(stage, "/World/rect")
    rect.CreateWidthAttr(0.1)
    rect.CreateHeightAttr(0.06)
    rect.AddTranslateOp().Set(Gf.Vec3d(0.6, -0.1, 0.0))
    rect.AddRotateYOp().Set(180.0)  # its emitting -Z side towards the camera
    cylinder = UsdLux.CylinderLight.Define(stage, "/World/cylinder")
    cylinder.CreateLengthAttr(0.15)
    cylinder.CreateRadiusAttr(0.02)
    cylinder.AddTranslateOp().Set(Gf.Vec3d(-0.5, 0.1, 0.0))
    for light in (sphere, rect, cylinder):
        light.CreateIntensityAttr(20.0)
    options = dict(camera="/cam", width=64, samples=16, seed=3, default_light="none")
    with penumbra.Renderer(stage) as renderer:
        one = renderer.render(**options, threads=1)["color"]
    with penumbra.Renderer(stage) as renderer:
        two = renderer.render(**options, threads=2)["color"]
        band = renderer.render(**options, region=(0, 28, 64, 8))["color"]
    assert np.array_equal(one, two)
    assert np.array_equal(band, two[28:36])
    # All three lights are in the band: it holds the whole image's light.
    columns = two[28:36, :, 0].sum(axis=0)
    assert columns[:28].sum() > 0 and columns[28:38].sum() > 0 and columns[38:].sum() > 0
    assert float(band[..., 0].sum()) == pytest.approx(float(two[..., 0].sum()))
