"""Depth of field against the thin-lens law (docs/design.md §3), in a metre and a centimetre scene.

A camera at the origin looks down −Z through a lens of focal length f = 0.1·focalLength and
aperture diameter A = f/N. A point at distance d, with the focus at d_f, images to a disk of
diameter A·f·|d − d_f| / (d·d_f) on the film (pinhole-mapped), i.e. that times W / h pixels for
an image W pixels wide and a film h = 0.1·horizontalAperture wide. A small emissive sphere of
radius r images to a sharp disk of radius s = f·r/d · W/h; the measured disk comes from the
second moment of the image (see measure.py).
"""

from __future__ import annotations

import pytest
from pxr import Sdf

import penumbra
from measure import FILTER_VARIANCE, disk_diameter, intensity, mean_square_radius
from stages import add_camera, add_emissive_sphere, emitter_stage

WIDTH = 256
SAMPLES = 32
FOCAL = 0.1  # metres
FILM = 0.036  # metres, square
F_STOP = 1.0
FOCUS = 2.0  # metres
RENDER = dict(camera="/cam", width=WIDTH, samples=SAMPLES, max_path_depth=0)
UNITS = {"m": 1.0, "cm": 0.01}  # metersPerUnit


def lens_stage(meters_per_unit: float, distance: float, radius: float, f_stop: float = F_STOP):
    """A sphere of ``radius`` (metres) on the axis at ``distance`` (metres), in a stage whose
    unit is ``meters_per_unit``: every length is authored in that unit."""
    unit = 1.0 / meters_per_unit  # scene units per metre
    stage = emitter_stage(meters_per_unit)
    camera = add_camera(
        stage,
        translate=(0, 0, 0),
        focal_length=10 * FOCAL * unit,  # tenths of a scene unit
        aperture=(10 * FILM * unit, 10 * FILM * unit),
    )
    camera.CreateFStopAttr(f_stop)
    camera.CreateFocusDistanceAttr(FOCUS * unit)
    add_emissive_sphere(stage, "/ball", (0, 0, -distance * unit), radius * unit)
    return stage


def to_pixels(film_length: float) -> float:
    return film_length / FILM * WIDTH


def sharp_radius(distance: float, radius: float) -> float:
    return to_pixels(FOCAL * radius / distance)


@pytest.mark.parametrize("units", UNITS)
@pytest.mark.parametrize("distance, radius", [(1.0, 0.003), (4.0, 0.012)])
def test_circle_of_confusion_follows_thin_lens(units, distance, radius):
    image = penumbra.Renderer(lens_stage(UNITS[units], distance, radius)).render(**RENDER)
    aperture = FOCAL / F_STOP
    expected = to_pixels(aperture * FOCAL * abs(distance - FOCUS) / (distance * FOCUS))
    measured = disk_diameter(intensity(image), sharp_radius(distance, radius))
    assert expected > 15  # pixels: the law is tested, not the sphere's own size
    assert measured == pytest.approx(expected, rel=0.05)


def measured_sharp_radius(image) -> float:
    """The radius of the uniform disk whose second moment the image has (blur removed)."""
    return (2 * (mean_square_radius(intensity(image)) - 2 * FILTER_VARIANCE)) ** 0.5


@pytest.mark.parametrize(
    "distance, f_stop, options",
    [
        (FOCUS, F_STOP, {}),  # on the focus plane
        (1.0, 0.0, {}),  # fStop 0: pinhole
        (1.0, F_STOP, {"disable_depth_of_field": True}),
    ],
    ids=["on-focus-plane", "f-stop-0", "disabled"],
)
def test_sharp_images(distance, f_stop, options):
    radius = 0.01 * distance  # 3.6 px on the film
    stage = lens_stage(UNITS["cm"], distance, radius, f_stop)
    image = penumbra.Renderer(stage).render(**RENDER, **options)
    assert measured_sharp_radius(image) == pytest.approx(
        sharp_radius(distance, radius), rel=0.1
    )


def test_render_settings_disable_depth_of_field():
    stage = lens_stage(UNITS["m"], 1.0, 0.01)
    settings = stage.DefinePrim("/Render/Settings", "RenderSettings")
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    renderer = penumbra.Renderer(stage)
    blurred = measured_sharp_radius(renderer.render(**RENDER))
    settings.CreateAttribute("disableDepthOfField", Sdf.ValueTypeNames.Bool).Set(True)
    sharp = measured_sharp_radius(renderer.render(**RENDER))
    assert sharp == pytest.approx(sharp_radius(1.0, 0.01), rel=0.1)
    assert blurred > 2 * sharp  # the disk of confusion is 17.8 px across
