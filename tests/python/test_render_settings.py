"""UsdRenderSettings' image rules: ``resolution``, ``aspectRatioConformPolicy``,
``pixelAspectRatio`` and ``dataWindowNDC``, with expectations worked out from the UsdRender
schema (UsdRenderSettingsBase) by hand."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest
from pxr import Gf, UsdGeom, UsdRender

import penumbra
from penumbra import _core
from penumbra.errors import SceneError
from penumbra.usd.settings import conform_aperture

from stages import add_preview_material, bind, new_stage

APERTURE = (40.0, 20.0)  # tenths of a unit: an orthographic view of 4 x 2 units
QUAD = (0.2, 0.8, 0.1, 0.4)  # an emissive rectangle: x from, x to, y from, y to


def settings_stage(resolution, policy=None, pixel_aspect_ratio=None, data_window=None):
    """An orthographic camera (APERTURE, looking down −Z) on a white emissive QUAD, and
    render settings with the given attributes."""
    stage = new_stage()
    camera = UsdGeom.Camera.Define(stage, "/cam")
    camera.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
    camera.CreateHorizontalApertureAttr(APERTURE[0])
    camera.CreateVerticalApertureAttr(APERTURE[1])
    camera.AddTranslateOp().Set(Gf.Vec3d(0, 0, 5))
    x0, x1, y0, y1 = QUAD
    quad = UsdGeom.Mesh.Define(stage, "/quad")
    quad.CreatePointsAttr([(x0, y0, 0), (x1, y0, 0), (x1, y1, 0), (x0, y1, 0)])
    quad.CreateFaceVertexCountsAttr([4])
    quad.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    quad.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    bind(quad, add_preview_material(stage, "/lit", diffuseColor=(0.0, 0.0, 0.0),
                                    emissiveColor=(1.0, 1.0, 1.0)))
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets(["/cam"])
    settings.CreateResolutionAttr(Gf.Vec2i(*resolution))
    if policy is not None:
        settings.CreateAspectRatioConformPolicyAttr(policy)
    if pixel_aspect_ratio is not None:
        settings.CreatePixelAspectRatioAttr(pixel_aspect_ratio)
    if data_window is not None:
        settings.CreateDataWindowNDCAttr(Gf.Vec4f(*data_window))
    return stage


# resolution, policy, pixelAspectRatio -> the conformed aperture (tenths) and pixel aspect ratio.
# The aperture's aspect is 2. A square image: expanding grows the height, cropping shrinks the
# width; a 4:1 image: expanding grows the width, cropping shrinks the height.
CONFORMED = [
    ((100, 100), "expandAperture", 1.0, (40, 40), 1.0),
    ((100, 100), "cropAperture", 1.0, (20, 20), 1.0),
    ((100, 100), "adjustApertureWidth", 1.0, (20, 20), 1.0),
    ((100, 100), "adjustApertureHeight", 1.0, (40, 40), 1.0),
    ((100, 100), "adjustPixelAspectRatio", 1.0, (40, 20), 2.0),
    ((100, 100), "adjustPixelAspectRatio", 3.0, (40, 20), 2.0),  # the authored one is ignored
    ((100, 100), "expandAperture", 2.0, (40, 20), 2.0),  # wide pixels: the aspects agree
    ((100, 25), "expandAperture", 1.0, (80, 20), 1.0),
    ((100, 25), "cropAperture", 1.0, (40, 10), 1.0),
    ((100, 25), "adjustApertureWidth", 1.0, (80, 20), 1.0),
    ((100, 25), "adjustApertureHeight", 1.0, (40, 10), 1.0),
    ((100, 25), "cropAperture", 0.5, (40, 20), 0.5),  # narrow pixels: the aspects agree
]


@pytest.mark.parametrize("resolution, policy, pixel_aspect, aperture, conformed_pixel_aspect",
                         CONFORMED)
def test_conform_policies_follow_the_schema(resolution, policy, pixel_aspect, aperture,
                                            conformed_pixel_aspect):
    got_aperture, got_pixel_aspect = conform_aperture(policy, resolution, pixel_aspect, APERTURE)
    assert got_aperture == pytest.approx(aperture)
    assert got_pixel_aspect == pytest.approx(conformed_pixel_aspect)


def quad_on_image(image) -> tuple[float, float, float]:
    """The emissive quad's area in pixels and its centroid (column, row; pixel centres at
    i + 0.5): the pixel filter keeps both."""
    coverage = image["color"][..., :3].mean(axis=2).astype(np.float64)
    rows, columns = np.indices(coverage.shape) + 0.5
    area = coverage.sum()
    return area, (coverage * columns).sum() / area, (coverage * rows).sum() / area


def expected_quad(window, size, pixel_window=(0, 0)):
    """Area and centroid of QUAD on a ``size`` image whose film covers the orthographic
    ``window`` (x from, x to, y from, y to, in scene units), shifted by ``pixel_window`` (the
    crop's first column and row)."""
    (wx0, wx1, wy0, wy1), (width, height) = window, size
    sx, sy = width / (wx1 - wx0), height / (wy1 - wy0)  # pixels per unit
    x0, x1, y0, y1 = QUAD
    area = (x1 - x0) * sx * (y1 - y0) * sy
    column = ((x0 + x1) / 2 - wx0) * sx - pixel_window[0]
    row = (wy1 - (y0 + y1) / 2) * sy - pixel_window[1]
    return area, column, row


@pytest.mark.parametrize("resolution, policy, pixel_aspect, aperture, _", CONFORMED)
def test_the_image_covers_the_conformed_aperture(resolution, policy, pixel_aspect, aperture, _):
    stage = settings_stage(resolution, policy, pixel_aspect)
    image = penumbra.render(stage, render_settings="/Render/Settings", samples=16,
                            default_light="none")
    assert image["color"].shape[:2] == (resolution[1], resolution[0])
    half_width, half_height = aperture[0] / 20, aperture[1] / 20  # scene units
    expected = expected_quad((-half_width, half_width, -half_height, half_height), resolution)
    area, column, row = quad_on_image(image)
    assert area == pytest.approx(expected[0], rel=0.03)
    assert (column, row) == pytest.approx(expected[1:], abs=0.25)


@pytest.mark.parametrize(
    "settings",
    [
        dict(resolution=(64, 32), pixel_aspect_ratio=2.0),
        # The aperture's aspect (2) over the image's (1); the authored ratio (1) is ignored.
        dict(resolution=(32, 32), policy="adjustPixelAspectRatio"),
    ],
)
def test_an_exr_says_its_pixels_aspect_ratio(tmp_path, settings):
    # Rendered with pixels twice as wide as high, the file said 1: a compositor showed the image
    # squeezed.
    stage = settings_stage(**settings)
    image = penumbra.render(stage, render_settings="/Render/Settings", samples=1,
                            default_light="none")
    image.write(tmp_path / "wide.exr")
    header = subprocess.run(["iinfo", "-v", str(tmp_path / "wide.exr")], capture_output=True,
                            text=True).stdout
    assert "PixelAspectRatio: 2" in header, header


@pytest.mark.parametrize(
    "data_window, size, first_pixel",
    [
        ((0.5, 0.5, 1.0, 1.0), (50, 50), (50, 0)),  # the top-right quarter
        ((0.0, 0.0, 0.752, 1.0), (75, 100), (0, 0)),  # centres 0.745 in, 0.755 out
        ((-0.1, -0.1, 1.1, 1.1), (120, 120), (-10, -10)),  # overscan
    ],
)
def test_the_data_window_crops_or_overscans(data_window, size, first_pixel):
    # A square image expands the aperture to 4 x 4 units; the crop keeps the pixels whose
    # centres lie in the window (NDC: (0, 0) bottom left).
    stage = settings_stage((100, 100), data_window=data_window)
    image = penumbra.render(stage, render_settings="/Render/Settings", samples=16,
                            default_light="none")
    assert image["color"].shape[:2] == (size[1], size[0])
    area, column, row = quad_on_image(image)
    expected = expected_quad((-2, 2, -2, 2), (100, 100), first_pixel)
    assert area == pytest.approx(expected[0], rel=0.03)
    assert (column, row) == pytest.approx(expected[1:], abs=0.25)


@pytest.mark.parametrize(
    "data_window, expected",
    [
        ((0.5, 0.5, 1.0, 1.0), "pixel data origin: x=50, y=0"),  # the top-right quarter
        ((-0.1, -0.1, 1.1, 1.1), "pixel data origin: x=-10, y=-10"),  # overscan
    ],
)
def test_an_exr_of_a_crop_keeps_its_frame_as_display_window(tmp_path, data_window, expected):
    # As husk writes a dataWindowNDC crop: the data window is the crop's pixels, the display
    # window the whole frame, so compositors place it (the file was a standalone 50 x 50 image
    # whose camera matrices described the 100 x 100 frame). PNG holds the crop alone.
    stage = settings_stage((100, 100), data_window=data_window)
    image = penumbra.render(stage, render_settings="/Render/Settings", samples=1,
                            default_light="none")
    image.write(tmp_path / "crop.exr")
    header = subprocess.run(["iinfo", "-v", str(tmp_path / "crop.exr")], capture_output=True,
                            text=True).stdout
    assert expected in header and "full/display size: 100 x 100" in header, header
    assert "full/display origin: 0, 0" in header, header
    assert "dataWindow" not in header  # said by the windows, not by an attribute as well
    image.write(tmp_path / "crop.png")
    width, height, _, _ = _core.read_image_header(str(tmp_path / "crop.png"))
    assert (width, height) == image["color"].shape[1::-1]
    whole = penumbra.render(settings_stage((100, 100)), render_settings="/Render/Settings",
                            samples=1, default_light="none")
    assert "dataWindow" not in whole.metadata


def test_a_width_scales_the_resolution_and_keeps_the_window():
    stage = settings_stage((100, 100), data_window=(0.5, 0.5, 1.0, 1.0))
    image = penumbra.render(stage, width=200, render_settings="/Render/Settings", samples=4,
                            default_light="none")
    assert image["color"].shape[:2] == (100, 100)


def test_bad_settings_are_scene_errors():
    stage = settings_stage((100, 100), data_window=(0.2, 0.2, 0.2, 0.9))
    with pytest.raises(SceneError, match="dataWindowNDC"):
        penumbra.render(stage, render_settings="/Render/Settings", samples=1)
    stage = settings_stage((100, 100), data_window=(0.2, 0.2, 0.204, 0.9))  # no pixel centre
    with pytest.raises(SceneError, match="holds no pixel centre"):
        penumbra.render(stage, render_settings="/Render/Settings", samples=1)
    stage = settings_stage((100, 100), policy="stretch")
    with pytest.raises(SceneError, match="aspectRatioConformPolicy"):
        penumbra.render(stage, render_settings="/Render/Settings", samples=1)
