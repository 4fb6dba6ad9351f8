"""UsdLux read as the schemas define it: DomeLight_1 (a DomeLight with a ``poleAxis``) is a dome
light; inputs Penumbra does not render (IES profiles, shadow colour, distance and falloff,
light filters) are named in one warning per light; a cone of 180 degrees or more and a distant
light wider than 360 degrees are clipped as UsdLux says, not refused."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux

import penumbra
from penumbra.usd import lights
from stages import add_camera, add_quad, new_stage, render_with_warnings
from test_input_validation import add_light, lit_stage, skipped_light_image
from test_textures import write_texture

WIDTH = 16
GREY = 0.5


def render(stage: Usd.Stage, samples: int = 64) -> tuple[np.ndarray, list[str]]:
    """The colour of ``stage`` through ``/cam`` (8 pixels wide, seed 1) and the Penumbra
    warnings rendering it gave."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = penumbra.Renderer(stage).render(camera="/cam", width=8, samples=samples, seed=1)
    messages = [str(w.message) for w in caught if issubclass(w.category, penumbra.PenumbraWarning)]
    return np.asarray(image["color"])[..., :3], messages


def plane_stage(facing: str = "z", up_axis: str = "Y") -> Usd.Stage:
    """A grey plane (albedo 0.5) facing +Z or +Y that fills the view of ``/cam``, no light."""
    stage = new_stage()
    UsdGeom.SetStageUpAxis(stage, up_axis)
    if facing == "z":
        add_camera(stage)
    else:
        add_camera(stage, translate=(0.0, 5.0, 0.0), rotate_x=-90.0)  # looking down -Y
    add_quad(stage, "/World/plane", half_size=20.0, color=(GREY,) * 3, facing=facing)
    return stage


@pytest.fixture(scope="module")
def top_bright(tmp_path_factory) -> Path:
    """A latlong texture whose top half (latitudes above the equator) is 1, the rest 0."""
    pixels = np.zeros((32, 64, 3), dtype=np.float32)
    pixels[:16] = 1.0
    return write_texture(tmp_path_factory.mktemp("dome") / "top_bright.exr", pixels)


# DomeLight_1


def test_a_dome_light_1_lights_the_stage_as_a_dome_light() -> None:
    """It was skipped as not supported, and the stage lit by the default white dome."""
    stage = plane_stage()
    dome = UsdLux.DomeLight_1.Define(stage, "/World/sky")
    dome.CreateIntensityAttr(3.0)
    dome.CreateColorAttr(Gf.Vec3f(1.0, 0.0, 0.0))
    image, messages = render(stage)
    assert messages == []
    mean = image.mean(axis=(0, 1))
    np.testing.assert_allclose(mean, [3.0 * GREY, 0.0, 0.0], rtol=0.02, atol=1e-6)


def test_a_dark_dome_light_1_is_the_stages_light_and_no_default_dome_is_added() -> None:
    """Without a light of its own the stage renders under a white dome (radiance 1)."""
    stage = plane_stage()
    UsdLux.DomeLight_1.Define(stage, "/World/sky").CreateIntensityAttr(0.0)
    image, messages = render(stage, samples=4)
    assert messages == []
    assert not image.any()


def test_a_hidden_dome_light_1_is_not_seen_but_lights() -> None:
    """usdrecord's rule for domes (hidden from camera rays) applies to DomeLight_1 too."""
    stage = new_stage()
    add_camera(stage)
    add_quad(stage, "/World/quad")  # the central half of the image; sky around it
    UsdLux.DomeLight_1.Define(stage, "/World/sky").CreateIntensityAttr(2.0)
    renderer = penumbra.Renderer(stage)
    size = dict(camera="/cam", width=16, samples=8)
    seen = renderer.render(**size)["color"]
    hidden = renderer.render(dome_light_visibility=False, **size)["color"]
    np.testing.assert_allclose(seen[0, 0], [2, 2, 2, 1], atol=1e-6)
    np.testing.assert_array_equal(hidden[0, 0], [0, 0, 0, 0])
    np.testing.assert_allclose(hidden[8, 8], seen[8, 8], rtol=1e-6)
    assert hidden[8, 8, 3] == 1.0 and 0.6 < hidden[8, 8, 0] < 1.4


@pytest.mark.parametrize("pole_axis", [None, "Y", "scene"])
def test_a_dome_light_1_whose_pole_is_y_reads_its_texture_as_a_dome_light(
    pole_axis: str | None, top_bright: Path
) -> None:
    """The bright top half of the texture is the +Y hemisphere: a plane facing +Y sees all of
    it (radiance 0.5 off albedo 0.5), one facing +Z half of it."""
    for facing, expected in (("y", GREY), ("z", GREY / 2)):
        stage = plane_stage(facing)
        dome = UsdLux.DomeLight_1.Define(stage, "/World/sky")
        dome.CreateTextureFileAttr(Sdf.AssetPath(str(top_bright)))
        if pole_axis is not None:
            dome.CreatePoleAxisAttr(pole_axis)
        image, messages = render(stage)
        assert messages == []
        assert image.mean() == pytest.approx(expected, rel=0.03), facing


def test_the_turn_of_a_z_pole_maps_the_textures_pole_to_z_and_its_centre_to_minus_y() -> None:
    """UsdLux: with poleAxis Z (or "scene" on a Z-up stage) latitudes ±90° are ±Z and latitude
    and longitude 0 is -Y, turned before the dome's own transform (row vectors)."""
    stage = new_stage()
    dome = UsdLux.DomeLight_1.Define(stage, "/sky")
    moved = np.eye(4)
    moved[3, :3] = (1.0, 2.0, 3.0)
    for axis, up, turned in (("Z", "Y", True), ("scene", "Z", True), ("Y", "Z", False),
                             ("scene", "Y", False)):
        UsdGeom.SetStageUpAxis(stage, up)
        dome.CreatePoleAxisAttr(axis)
        assert lights.pole_axis(dome.GetPrim()) == ("Z" if turned else "Y")
        matrix = lights.light_transform(dome.GetPrim(), moved)
        if not turned:
            assert matrix is moved
            continue
        np.testing.assert_allclose([1, 0, 0, 0] @ matrix, [1, 0, 0, 0], atol=1e-12)
        np.testing.assert_allclose([0, 1, 0, 0] @ matrix, [0, 0, 1, 0], atol=1e-12)  # pole
        np.testing.assert_allclose([0, 0, 1, 0] @ matrix, [0, -1, 0, 0], atol=1e-12)  # centre
        np.testing.assert_allclose([0, 0, 0, 1] @ matrix, [1, 2, 3, 1], atol=1e-12)
        samples = lights.light_transform(dome.GetPrim(), np.stack([moved, moved]))
        np.testing.assert_allclose(samples, [matrix, matrix])
    other = UsdLux.DomeLight.Define(stage, "/old").GetPrim()
    assert lights.pole_axis(other) == "Y" and lights.light_transform(other, moved) is moved


def test_the_turn_of_a_z_pole_puts_the_textures_top_over_a_z_up_world(top_bright: Path) -> None:
    """The turn as the light's transform (here a DomeLight's authored one): the bright top half
    lights a plane facing +Z fully, one facing +Y by half."""
    z_up = new_stage()  # held: a prim does not keep its stage alive
    z_pole = UsdLux.DomeLight_1.Define(z_up, "/sky")
    z_pole.CreatePoleAxisAttr("Z")
    turn = lights.light_transform(z_pole.GetPrim(), np.eye(4))
    for facing, expected in (("z", GREY), ("y", GREY / 2)):
        stage = plane_stage(facing)
        dome = UsdLux.DomeLight.Define(stage, "/World/sky")
        dome.CreateTextureFileAttr(Sdf.AssetPath(str(top_bright)))
        dome.AddTransformOp().Set(Gf.Matrix4d(turn.tolist()))
        image, messages = render(stage)
        assert messages == []
        assert image.mean() == pytest.approx(expected, rel=0.03), facing


@pytest.mark.parametrize(("pole_axis", "up_axis"), [("Z", "Y"), ("scene", "Z")])
def test_a_textured_dome_whose_pole_is_z_turns_its_texture_over_z(
    pole_axis: str, up_axis: str, top_bright: Path
) -> None:
    """The bright top half of the texture is the +Z hemisphere: a plane facing +Z sees all of
    it, one facing +Y half of it; an edit of poleAxis alone turns it back."""
    for facing, expected in (("z", GREY), ("y", GREY / 2)):
        stage = plane_stage(facing, up_axis=up_axis)
        dome = UsdLux.DomeLight_1.Define(stage, "/World/sky")
        dome.CreateTextureFileAttr(Sdf.AssetPath(str(top_bright)))
        dome.CreatePoleAxisAttr(pole_axis)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            renderer = penumbra.Renderer(stage)
            image = np.asarray(renderer.render(camera="/cam", width=8, samples=64, seed=1)["color"])
            assert image[..., :3].mean() == pytest.approx(expected, rel=0.03), facing
            dome.CreatePoleAxisAttr("Y")
            image = np.asarray(renderer.render(camera="/cam", width=8, samples=64, seed=1)["color"])
            turned_back = GREY if facing == "y" else GREY / 2
            assert image[..., :3].mean() == pytest.approx(turned_back, rel=0.03), facing
        assert [w for w in caught if issubclass(w.category, penumbra.PenumbraWarning)] == []


def test_an_untextured_dome_whose_pole_is_z_is_uniform_and_not_warned_of() -> None:
    stage = plane_stage()
    UsdLux.DomeLight_1.Define(stage, "/World/sky").CreatePoleAxisAttr("Z")
    image, messages = render(stage)
    assert messages == []
    assert image.mean() == pytest.approx(GREY, rel=0.02)


# Inputs Penumbra does not render


def author_shadow(name: str, value):
    def author(light: Usd.Prim) -> None:
        shadow = UsdLux.ShadowAPI.Apply(light)
        getattr(shadow, f"CreateShadow{name}Attr")(value)

    return author


def author_filters(light: Usd.Prim) -> None:
    UsdLux.LightFilter.Define(light.GetStage(), "/World/filter")
    UsdLux.LightAPI(light).CreateFiltersRel().SetTargets(["/World/filter"])


IGNORED = [
    ("inputs:shadow:color", author_shadow("Color", Gf.Vec3f(1.0, 0.0, 0.0))),
    ("inputs:shadow:distance", author_shadow("Distance", 2.0)),
    ("inputs:shadow:distance", author_shadow("Distance", 0.0)),
    ("inputs:shadow:falloff", author_shadow("Falloff", 0.5)),
    ("light:filters", author_filters),
]


@pytest.mark.parametrize("light_type", ["SphereLight", "MeshLightAPI"])
@pytest.mark.parametrize(
    ("name", "author"), IGNORED, ids=[f"{n} {k}" for k, (n, _) in enumerate(IGNORED)]
)
def test_an_input_penumbra_does_not_render_is_named_once_and_ignored(
    light_type: str, name: str, author
) -> None:
    """They changed nothing, without a word (IES profiles, once among them, are rendered:
    tests/python/test_ies_profiles.py)."""
    stage = lit_stage()
    light = add_light(stage, light_type)
    UsdLux.LightAPI(light).CreateIntensityAttr(5.0)
    UsdLux.ShapingAPI.Apply(light)  # its fallback cone shapes both renders alike
    expected, messages = render_with_warnings(stage, WIDTH)
    assert messages == []
    author(light)
    image, messages = render_with_warnings(stage, WIDTH)
    assert messages == [f"/World/L: {name} is not supported yet; ignored"]
    assert np.array_equal(image, expected)


def test_every_ignored_input_of_a_light_is_named_in_one_warning() -> None:
    stage = lit_stage()
    light = add_light(stage, "RectLight")
    for _, author in IGNORED:
        author(light)
    _, messages = render_with_warnings(stage, WIDTH)
    assert messages == [
        "/World/L: light:filters, inputs:shadow:color, inputs:shadow:distance, "
        "inputs:shadow:falloff are not supported yet; ignored"
    ]


def test_inputs_at_values_that_change_nothing_are_not_warned_of() -> None:
    """The schemas' fallbacks authored (no profile, black shadows without a limit or falloff, no
    filters), a negative distance (no limit) and the shadow inputs of a light casting none."""
    stage = lit_stage()
    light = add_light(stage, "SphereLight")
    UsdLux.ShapingAPI.Apply(light).CreateShapingIesFileAttr(Sdf.AssetPath(""))
    shadow = UsdLux.ShadowAPI.Apply(light)
    shadow.CreateShadowColorAttr(Gf.Vec3f(0.0))
    shadow.CreateShadowDistanceAttr(-5.0)
    shadow.CreateShadowFalloffAttr(0.0)
    UsdLux.LightAPI(light).CreateFiltersRel().SetTargets([])
    _, messages = render_with_warnings(stage, WIDTH)
    assert messages == []
    shadow.CreateShadowEnableAttr(False)
    shadow.CreateShadowColorAttr(Gf.Vec3f(1.0, 0.0, 0.0))
    shadow.CreateShadowDistanceAttr(2.0)
    _, messages = render_with_warnings(stage, WIDTH)
    assert messages == []


# Values UsdLux clips


@pytest.mark.parametrize(
    ("light_type", "name", "value", "clipped"),
    [
        ("SphereLight", "inputs:shaping:cone:angle", 200.0, 180.0),
        ("SphereLight", "inputs:shaping:cone:angle", 1e6, 180.0),
        ("MeshLightAPI", "inputs:shaping:cone:angle", 270.0, 180.0),
        ("DistantLight", "inputs:angle", 400.0, 360.0),
        ("DistantLight", "inputs:angle", 720.0, 360.0),
    ],
)
def test_an_angle_beyond_usdlux_clip_renders_as_the_clipped_angle(
    light_type: str, name: str, value: float, clipped: float
) -> None:
    """Such lights were skipped as out of range (a distant light normalized too: UsdLux's
    normalisation holds at 360 degrees)."""
    images = []
    for angle in (value, clipped):
        stage = lit_stage()
        light = add_light(stage, light_type)
        UsdLux.LightAPI(light).CreateIntensityAttr(0.5 if light_type == "DistantLight" else 5.0)
        if name.startswith("inputs:shaping"):
            UsdLux.ShapingAPI.Apply(light).CreateShapingConeAngleAttr(angle)
        else:
            UsdLux.DistantLight(light).CreateAngleAttr(angle)
            UsdLux.DistantLight(light).CreateNormalizeAttr(True)
        image, messages = render_with_warnings(stage, WIDTH)
        assert messages == []
        images.append(image)
    assert np.array_equal(images[0], images[1])
    assert not np.array_equal(images[0], skipped_light_image(light_type))


# Shapes the delegate approximates


@pytest.mark.parametrize(
    ("kind", "scale", "warned"),
    [
        ("SphereLight", (4.0, 1.0, 1.0), "a sphere of the scales' geometric mean radius"),
        ("SphereLight", (2.0, 2.0, 2.0), None),
        ("CylinderLight", (1.0, 2.0, 1.0), "a circular cylinder of the two scales' mean radius"),
        ("CylinderLight", (3.0, 1.0, 1.0), None),  # along its axis: its length, exactly
    ],
)
def test_an_unevenly_scaled_sphere_or_cylinder_light_is_named(kind, scale, warned) -> None:
    # UsdLux scales the shape itself (an ellipsoid); the delegate keeps a sphere (the geometric
    # mean radius), which was not said.
    stage = plane_stage()
    light = getattr(UsdLux, kind).Define(stage, "/World/L")
    light.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 3.0))
    light.AddScaleOp().Set(Gf.Vec3f(*scale))
    _, messages = render(stage, samples=1)
    if warned is None:
        assert messages == []
    else:
        across = scale if kind == "SphereLight" else scale[1:]  # a cylinder's cross-section
        shown = ", ".join(f"{v:g}" for v in across)
        assert messages == [f"/World/L: scaled unevenly ({shown}); rendered as {warned}, not "
                            f"{'an ellipsoid' if kind == 'SphereLight' else 'an elliptic one'}"]
