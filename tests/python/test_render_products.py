"""UsdRender products from the command line: two EXRs, six vars, read back with OIIO and checked
against analytic values; warnings and errors for what cannot be honoured."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdRender

from penumbra import Renderer, _core
from penumbra.cli import main
from penumbra.products import render_products
from penumbra.usd import read_render_settings
from penumbra.usd.products import product_path, read_products

from stages import add_camera, add_distant_light, add_preview_material, add_quad, bind, new_stage

CAMERA_Z = 5.0  # the camera at (0, 0, 5) looks down -Z and sees [-2, 2]² of the z = 0 plane
SPHERE_CENTER = np.array([0.0, 0.0, 1.0])
SPHERE_RADIUS = 0.8
PLANE_COLOR = (0.2, 0.4, 0.6)
LABELS = {"/World/plane": 0.25, "/World/ball": 0.75}


def products_stage(path):
    """A plane at z = 0 behind a sphere, with a primvar ``label`` of a value per prim, and
    render settings with two products: beauty (color, albedo, depth in half) at 64x64 and data
    (normal, primId, the primvar) at 48x48, the frame in its name."""
    stage = new_stage(path)
    add_camera(stage)
    add_distant_light(stage)
    plane = add_quad(stage, "/World/plane", half_size=3.0, color=PLANE_COLOR)
    ball = UsdGeom.Sphere.Define(stage, "/World/ball")
    ball.CreateRadiusAttr(SPHERE_RADIUS)
    ball.AddTranslateOp().Set(Gf.Vec3d(*SPHERE_CENTER))
    for prim in (plane.GetPrim(), ball.GetPrim()):
        UsdGeom.PrimvarsAPI(prim).CreatePrimvar(
            "label", Sdf.ValueTypeNames.Float, UsdGeom.Tokens.constant
        ).Set(LABELS[str(prim.GetPath())])

    def var(name, source, source_type="raw", data_type="float"):
        render_var = UsdRender.Var.Define(stage, f"/Render/Vars/{name}")
        render_var.CreateSourceNameAttr(source)
        render_var.CreateSourceTypeAttr(source_type)
        render_var.CreateDataTypeAttr(data_type)
        return render_var.GetPath()

    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateResolutionAttr(Gf.Vec2i(64, 64))
    settings.CreateCameraRel().SetTargets(["/cam"])
    beauty = UsdRender.Product.Define(stage, "/Render/Products/beauty")
    beauty.CreateProductNameAttr("beauty.$F4.exr")
    beauty.CreateOrderedVarsRel().SetTargets(
        [var("color", "C.*", "lpe", "color4f"), var("albedo", "albedo", data_type="color3f"),
         var("depth", "depth", data_type="half")]
    )
    data = UsdRender.Product.Define(stage, "/Render/Products/data")
    data.CreateProductNameAttr("data.####.exr")
    data.CreateResolutionAttr(Gf.Vec2i(48, 48))
    data.CreateOrderedVarsRel().SetTargets(
        [var("N", "normal", data_type="normal3f"), var("primId", "primId", data_type="int"),
         var("label", "label", "primvar")]
    )
    settings.CreateProductsRel().SetTargets([beauty.GetPath(), data.GetPath()])
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    stage.GetRootLayer().Save()
    return stage


def pixel_rays(size: int, offset=(0.0, 0.0)) -> np.ndarray:
    """Unit directions of the camera rays through the pixels of a size x size image, at
    ``offset`` pixels (right, down) from their centres."""
    coordinates = np.arange(size) + 0.5
    x = (coordinates + offset[0]) / size * 4.0 - 2.0  # on the z = 0 plane
    y = 2.0 - (coordinates + offset[1]) / size * 4.0
    x, y = np.meshgrid(x, y)
    directions = np.stack([x, y, np.full_like(x, -CAMERA_Z)], axis=-1)
    return directions / np.linalg.norm(directions, axis=-1, keepdims=True)


FILTER_RADIUS = 1.5  # pixels: samples spread this far from a pixel's centre (PixelFilter)


def footprint_range(size: int, function) -> tuple[np.ndarray, np.ndarray]:
    """The least and greatest of ``function(rays)`` over each pixel's filter footprint."""
    steps = np.linspace(-FILTER_RADIUS, FILTER_RADIUS, 7)
    values = [function(pixel_rays(size, (dx, dy))) for dx in steps for dy in steps]
    return np.min(values, axis=0), np.max(values, axis=0)


def layer(pixels, names, prefix):
    return pixels[..., [i for i, name in enumerate(names) if name.split(".")[0] == prefix]]


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    directory = tmp_path_factory.mktemp("products")
    stage_path = directory / "scene.usda"
    products_stage(stage_path)
    status = main(
        [str(stage_path), str(directory / "out.####.exr"), "--frames", "1", "-spp", "8", "-q"]
    )
    assert status == 0
    return directory


def test_two_products_are_written_with_their_channels(rendered):
    assert sorted(p.name for p in rendered.iterdir()) == [
        "beauty.0001.exr", "data.0001.exr", "out.0001.exr", "scene.usda",
    ]  # fmt: skip
    _, beauty_names, _ = _core.read_image(str(rendered / "beauty.0001.exr"))
    assert sorted(beauty_names) == sorted(
        ["R", "G", "B", "A", "albedo.R", "albedo.G", "albedo.B", "depth"]
    )
    data, data_names, _ = _core.read_image(str(rendered / "data.0001.exr"))
    assert sorted(data_names) == sorted(["N.x", "N.y", "N.z", "primId", "label"])
    assert data.shape[:2] == (48, 48)  # the product's resolution overrides the settings'
    # dataType: half for depth, float for the rest (as OIIO reads the file's header).
    header = subprocess.run(
        ["iinfo", "-v", str(rendered / "beauty.0001.exr")], capture_output=True, text=True
    ).stdout
    assert "depth (half)" in header and "albedo.R (float)" in header and "R (float)" in header


def test_depth_of_the_plane_and_albedo(rendered):
    pixels, names, _ = _core.read_image(str(rendered / "beauty.0001.exr"))
    assert pixels.shape[:2] == (64, 64)
    depth = layer(pixels, names, "depth")[..., 0]
    rays = pixel_rays(64)
    # Pixels whose footprint passes well clear of the sphere see the plane only.
    clear = _miss_distance(rays) > SPHERE_RADIUS + 0.15
    assert clear.sum() > 2000
    # Depth is the distance from the camera to the plane along one of the pixel's sample rays
    # (the nearest), all within the filter footprint; half floats round it by 2^-8 at 4 to 8.
    low, high = footprint_range(64, lambda rays: CAMERA_Z / -rays[..., 2])
    assert np.all(depth[clear] >= low[clear] - 2**-8) and np.all(depth[clear] <= high[clear] + 2**-8)
    # The nearest sample: at most the distance along the centre ray.
    assert np.all(depth[clear] <= CAMERA_Z / -rays[clear][:, 2] + 2**-8)
    albedo = layer(pixels, names, "albedo")
    np.testing.assert_allclose(albedo[clear], np.broadcast_to(PLANE_COLOR, albedo[clear].shape), atol=1e-6)


def _miss_distance(rays: np.ndarray) -> np.ndarray:
    """How far each camera ray passes from the sphere's centre."""
    to_center = SPHERE_CENTER - np.array([0.0, 0.0, CAMERA_Z])
    along = rays @ to_center
    return np.linalg.norm(to_center - along[..., None] * rays, axis=-1)


def test_sphere_normals_ids_and_primvar(rendered):
    pixels, names, metadata = _core.read_image(str(rendered / "data.0001.exr"))
    rays = pixel_rays(48)
    miss = _miss_distance(rays)
    inside = miss < SPHERE_RADIUS - 0.15  # well inside the silhouette: the whole filter sees it
    clear = miss > SPHERE_RADIUS + 0.15
    # The sphere's normal where each pixel's centre ray meets it.
    origin = np.array([0.0, 0.0, CAMERA_Z])
    along = rays @ (SPHERE_CENTER - origin)
    t = along - np.sqrt(np.maximum(SPHERE_RADIUS**2 - miss**2, 0.0))
    expected = (origin + t[..., None] * rays - SPHERE_CENTER) / SPHERE_RADIUS
    normal = layer(pixels, names, "N")
    assert inside.sum() > 300
    np.testing.assert_allclose(normal[inside], expected[inside], atol=0.02)

    ids = layer(pixels, names, "primId")[..., 0]
    manifest = {int(k): v for k, v in json.loads(metadata["penumbra:primIds"]).items()}
    ball_ids, plane_ids = set(ids[inside].tolist()), set(ids[clear].tolist())
    assert len(ball_ids) == 1 and len(plane_ids) == 1 and ball_ids != plane_ids
    assert manifest[int(ball_ids.pop())] == "/World/ball"
    assert manifest[int(plane_ids.pop())] == "/World/plane"

    label = layer(pixels, names, "label")[..., 0]
    assert np.all(label[inside] == LABELS["/World/ball"])
    assert np.all(label[clear] == LABELS["/World/plane"])


def test_metadata(rendered):
    _, _, metadata = _core.read_image(str(rendered / "beauty.0001.exr"))
    # Written as OIIO's worldtocamera and worldtoscreen, which OpenEXR stores (and OIIO reads
    # back) under its standard attribute names.
    world_to_camera = np.array(metadata["worldToCamera"]).reshape(4, 4)
    # The camera sits at (0, 0, 5) unrotated: world to camera moves the world by -5 along z.
    expected = np.eye(4)
    expected[3, 2] = -CAMERA_Z
    np.testing.assert_allclose(world_to_camera, expected, atol=1e-6)
    # The screen window is the aperture: the plane point (2, 2, 0) lands on the corner (1, 1).
    corner = np.array([2.0, 2.0, 0.0, 1.0]) @ np.array(metadata["worldToScreen"]).reshape(4, 4)
    np.testing.assert_allclose(corner[:2] / corner[3], [1.0, 1.0], atol=1e-6)
    assert metadata["penumbra:samples"] == 8 and metadata["penumbra:seed"] == 0
    assert metadata["penumbra:fStop"] == 0 and metadata["penumbra:focusDistance"] == 0
    # The shutter interval relative to the frame (the camera has no motion blur).
    assert metadata["penumbra:shutterOpen"] == 0.0 and metadata["penumbra:shutterClose"] == 0.0
    assert metadata["penumbra:timeCode"] == 1
    assert metadata["penumbra:renderSettings"] == "/Render/Settings"
    assert metadata["penumbra:renderProduct"] == "/Render/Products/beauty"
    assert metadata["penumbra:stage"].endswith("scene.usda")
    assert metadata["penumbra:version"] == _core.version()
    assert metadata["penumbra:renderTimeSeconds"] > 0


def test_unsupported_attributes_warn_once_naming_prim_and_attribute(tmp_path, capsys):
    stage = products_stage(tmp_path / "scene.usda")
    settings = UsdRender.Settings(stage.GetPrimAtPath("/Render/Settings"))
    settings.CreateRenderingColorSpaceAttr("ACEScg")
    settings.CreateMaterialBindingPurposesAttr(["preview"])
    diffuse = UsdRender.Var.Define(stage, "/Render/Vars/diffuse")
    diffuse.CreateSourceNameAttr("C<RD>L")
    diffuse.CreateSourceTypeAttr("lpe")
    UsdRender.Product(stage.GetPrimAtPath("/Render/Products/data")).GetOrderedVarsRel().AddTarget(
        diffuse.GetPath()
    )
    stage.GetRootLayer().Save()
    assert main([str(tmp_path / "scene.usda"), str(tmp_path / "out.exr"), "-spp", "1", "-q"]) == 0
    err = capsys.readouterr().err
    for message in (
        "/Render/Settings: renderingColorSpace is not supported",
        "/Render/Settings: materialBindingPurposes ['preview'] is not supported",
        "/Render/Vars/diffuse: sourceName 'C<RD>L' (lpe) is not an AOV",
    ):
        assert err.count(message) == 1, err
    # Without --frames the stage's startTimeCode (1) is the frame.
    assert (tmp_path / "beauty.0001.exr").exists() and (tmp_path / "data.0001.exr").exists()


def test_product_without_a_name_is_an_error(tmp_path, capsys):
    stage = products_stage(tmp_path / "scene.usda")
    stage.GetPrimAtPath("/Render/Products/data").GetAttribute("productName").Set("")
    stage.GetRootLayer().Save()
    assert main([str(tmp_path / "scene.usda"), str(tmp_path / "out.exr"), "-spp", "1"]) == 1
    assert "/Render/Products/data: the render product has no productName" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.usda"]


@pytest.mark.parametrize(
    "name, frames, message",
    [
        ("data.exr", "1:2", 'productName data.exr needs a frame placeholder such as "####"'),
        ("data.####.exr", "1:2x0.5", "productName data.####.exr: the frames need 1 decimals"),
        ("data.#.$F.#.exr", "1", "productName data.#.$F.#.exr holds 2 frame placeholders"),
    ],
)
def test_product_names_must_tell_the_frames_apart(tmp_path, capsys, name, frames, message):
    """As the output path must: a usage error before anything is rendered, not a product
    overwritten frame after frame."""
    stage = products_stage(tmp_path / "scene.usda")
    stage.GetPrimAtPath("/Render/Products/data").GetAttribute("productName").Set(name)
    stage.GetRootLayer().Save()
    output = str(tmp_path / "out.####.#.exr")
    assert main([str(tmp_path / "scene.usda"), output, "-spp", "1", "-f", frames]) == 2
    assert f"error: /Render/Products/data: {message}" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.usda"]


def test_a_houdini_placeholder_tells_fractional_frames_apart(tmp_path):
    """``$F`` writes a fractional frame's decimals: no ``#`` run is needed."""
    stage = products_stage(tmp_path / "scene.usda")
    stage.GetPrimAtPath("/Render/Products/data").GetAttribute("productName").Set("data.$F4.exr")
    stage.GetRootLayer().Save()
    output = str(tmp_path / "out.####.#.exr")
    argv = [str(tmp_path / "scene.usda"), output, "-w", "8", "-spp", "1", "-q", "-f", "1:1.5x0.5"]
    assert main(argv) == 0
    assert (tmp_path / "data.0001.exr").exists() and (tmp_path / "data.01.5.exr").exists()


def test_each_render_of_a_frame_reports_its_own_progress(tmp_path, capsys):
    """Products in two groups (other resolutions) render apart, each with its own progress."""
    products_stage(tmp_path / "scene.usda")
    output = str(tmp_path / "out.####.exr")
    assert main([str(tmp_path / "scene.usda"), output, "-spp", "4", "-f", "1"]) == 0
    done = [line for line in capsys.readouterr().err.splitlines() if "4/4 samples" in line]
    assert len(done) == 2, done
    assert "/Render/Products/beauty" in done[0] and "/Render/Products/data" in done[1]


@pytest.mark.parametrize(
    "output, flags, message",
    [
        ("out.exr", ["--aov", "normal,bogus"], "--aov bogus: unknown AOV"),
        ("out.exr", ["--aov", "noisyColor"], "--aov noisyColor needs --denoise"),
        ("out.png", ["--aov", "depth"], "--aov needs an .exr output; "),
    ],
)
def test_aov_usage_errors(tmp_path, capsys, output, flags, message):
    stage = new_stage(tmp_path / "scene.usda")
    add_camera(stage)
    stage.GetRootLayer().Save()
    assert main([str(tmp_path / "scene.usda"), str(tmp_path / output), *flags]) == 2
    assert message in capsys.readouterr().err


def test_cli_aovs_without_products(tmp_path):
    stage = new_stage(tmp_path / "scene.usda")
    add_camera(stage)
    add_quad(stage, "/plane", half_size=3.0, color=PLANE_COLOR)
    stage.GetRootLayer().Save()
    out = tmp_path / "out.exr"
    argv = [str(tmp_path / "scene.usda"), str(out), "-w", "16", "-spp", "2", "-q"]
    assert main([*argv, "--aov", "Z,normal,primvars:displayColor"]) == 0
    pixels, names, _ = _core.read_image(str(out))
    assert sorted(names) == sorted(
        ["R", "G", "B", "A", "Z", "normal.x", "normal.y", "normal.z",
         "primvars:displayColor.x", "primvars:displayColor.y", "primvars:displayColor.z"]
    )  # fmt: skip
    np.testing.assert_allclose(layer(pixels, names, "Z"), CAMERA_Z, rtol=1e-6)
    np.testing.assert_allclose(
        layer(pixels, names, "normal"), np.broadcast_to((0, 0, 1), (16, 16, 3)), atol=1e-6
    )
    np.testing.assert_allclose(
        layer(pixels, names, "primvars:displayColor"),
        np.broadcast_to(PLANE_COLOR, (16, 16, 3)),
        atol=1e-6,
    )


@pytest.mark.parametrize(
    "name, frame, expected",
    [
        ("beauty.$F4.exr", 1.0, "beauty.0001.exr"),
        ("beauty.$F.exr", 12.0, "beauty.12.exr"),
        ("beauty.###.exr", 7.0, "beauty.007.exr"),
        ("beauty.###.#.exr", 1.5, "beauty.001.5.exr"),
        ("beauty.exr", 3.0, "beauty.exr"),
        ("beauty.$F4.exr", None, "beauty.$F4.exr"),
    ],
)
def test_product_path(name, frame, expected):
    assert product_path(name, frame) == expected


def test_product_camera_and_included_purposes(tmp_path):
    """The product's camera overrides the settings'; includedPurposes replaces --purposes (whose
    default renders proxies): the plane is seen from 10 units, not the proxy in front of it."""
    stage = new_stage(tmp_path / "scene.usda")
    add_camera(stage)
    add_camera(stage, "/far", translate=(0.0, 0.0, 10.0))
    add_quad(stage, "/plane", half_size=6.0, color=PLANE_COLOR)
    proxy = add_quad(stage, "/proxy", center=(0.0, 0.0, 1.0), half_size=6.0)
    proxy.CreatePurposeAttr(UsdGeom.Tokens.proxy)
    z = UsdRender.Var.Define(stage, "/Render/Vars/Z")
    z.CreateSourceNameAttr("Z")
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets(["/cam"])
    settings.CreateIncludedPurposesAttr(["default"])
    product = UsdRender.Product.Define(stage, "/Render/Products/far")
    product.CreateProductNameAttr("far.exr")
    product.CreateCameraRel().SetTargets(["/far"])
    product.CreateResolutionAttr(Gf.Vec2i(8, 8))
    product.CreateOrderedVarsRel().SetTargets([z.GetPath()])
    settings.CreateProductsRel().SetTargets([product.GetPath()])
    stage.GetRootLayer().Save()
    argv = [str(tmp_path / "scene.usda"), str(tmp_path / "out.exr"), "-spp", "1", "-q"]
    assert main([*argv, "-rs", "/Render/Settings"]) == 0
    pixels, names, metadata = _core.read_image(str(tmp_path / "far.exr"))
    assert pixels.shape[:2] == (8, 8) and metadata["penumbra:camera"] == "/far"
    np.testing.assert_allclose(layer(pixels, names, "Z"), 10.0, rtol=1e-6)


def test_per_product_motion_blur_and_depth_of_field_switches(tmp_path):
    """A product's disableMotionBlur renders its frame alone (the shutter in its metadata is
    one instant) and disableDepthOfField renders through a pinhole: the defocused quad's edges,
    a band of grey pixels in the other product, are sharp."""
    stage = new_stage(tmp_path / "scene.usda")
    camera = add_camera(stage)
    camera.CreateFStopAttr(0.5)
    camera.CreateFocusDistanceAttr(1.0)  # the quad, 5 units away, is far out of focus
    camera.CreateShutterOpenAttr(0.0)
    camera.CreateShutterCloseAttr(0.5)
    quad = add_quad(stage, "/quad", half_size=1.0)
    quad.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(1.0, 1.0, 1.0)])
    add_distant_light(stage)
    color = UsdRender.Var.Define(stage, "/Render/Vars/color")
    color.CreateSourceNameAttr("C.*")
    color.CreateSourceTypeAttr("lpe")
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets(["/cam"])
    products = []
    for name, motion_blur, depth_of_field in (("lens", True, True), ("pinhole", False, False)):
        product = UsdRender.Product.Define(stage, f"/Render/Products/{name}")
        product.CreateProductNameAttr(f"{name}.exr")
        product.CreateResolutionAttr(Gf.Vec2i(32, 32))
        product.CreateDisableMotionBlurAttr(not motion_blur)
        product.CreateDisableDepthOfFieldAttr(not depth_of_field)
        product.CreateOrderedVarsRel().SetTargets([color.GetPath()])
        products.append(product.GetPath())
    settings.CreateProductsRel().SetTargets(products)
    stage.GetRootLayer().Save()
    argv = [str(tmp_path / "scene.usda"), str(tmp_path / "out.exr"), "-spp", "16", "-q"]
    assert main([*argv, "-rs", "/Render/Settings"]) == 0
    grey = {}
    for name in ("lens", "pinhole"):
        pixels, names, metadata = _core.read_image(str(tmp_path / f"{name}.exr"))
        red = pixels[..., names.index("R")]
        grey[name] = int(np.count_nonzero((red > 0.1 * red.max()) & (red < 0.9 * red.max())))
        shutter = float(metadata["penumbra:shutterOpen"]), float(metadata["penumbra:shutterClose"])
        assert (shutter[0] == shutter[1]) == (name == "pinhole"), (name, shutter)
    assert grey["lens"] > 3 * grey["pinhole"], grey


def test_pixel_aspect_ratio_metadata_is_the_rendered_one(tmp_path):
    """A product conforming by adjustPixelAspectRatio renders a 36 x 24 aperture on a square
    image with pixels 1.5 as wide as high (aperture aspect over image aspect, UsdRender's rule);
    its file said the settings' 1, and a compositor showed it squashed. The settings' own
    policy (expandAperture) keeps square pixels in the other product."""
    stage = new_stage(tmp_path / "scene.usda")
    add_camera(stage, aperture=(36.0, 24.0))
    add_quad(stage, "/plane", half_size=3.0, color=PLANE_COLOR)
    color = UsdRender.Var.Define(stage, "/Render/Vars/color")
    color.CreateSourceNameAttr("color")
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets(["/cam"])
    settings.CreateResolutionAttr(Gf.Vec2i(12, 12))
    products = []
    for name in ("adjusted", "expanded"):
        product = UsdRender.Product.Define(stage, f"/Render/Products/{name}")
        product.CreateProductNameAttr(f"{name}.exr")
        product.CreateOrderedVarsRel().SetTargets([color.GetPath()])
        products.append(product)
    products[0].CreateAspectRatioConformPolicyAttr(UsdRender.Tokens.adjustPixelAspectRatio)
    settings.CreateProductsRel().SetTargets([product.GetPath() for product in products])
    stage.GetRootLayer().Save()
    argv = [str(tmp_path / "scene.usda"), str(tmp_path / "out.exr"), "-spp", "1", "-q"]
    assert main([*argv, "-rs", "/Render/Settings"]) == 0
    ratios = {
        name: _core.read_image(str(tmp_path / f"{name}.exr"))[2]["PixelAspectRatio"]
        for name in ("adjusted", "expanded")
    }
    assert ratios == {"adjusted": pytest.approx(1.5), "expanded": pytest.approx(1.0)}


def test_ids_asked_for_in_half_floats_are_written_in_32_bits(tmp_path, capsys):
    # Cryptomatte's ids are uint32 bits read as float32, and primId counts past 2048: half
    # floats turned them into zeros, infinities and denormals no manifest entry matched.
    stage = new_stage(tmp_path / "scene.usda")
    add_camera(stage)
    add_distant_light(stage)
    add_quad(stage, "/World/plane", half_size=3.0, color=PLANE_COLOR)
    variables = []
    for name, source, data_type in (("color", "color", "color4f"),
                                    ("objects", "CryptoObject", "half4"),
                                    ("primId", "primId", "half")):
        render_var = UsdRender.Var.Define(stage, f"/Render/Vars/{name}")
        render_var.CreateSourceNameAttr(source)
        render_var.CreateDataTypeAttr(data_type)
        variables.append(render_var.GetPath())
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateResolutionAttr(Gf.Vec2i(16, 16))
    settings.CreateCameraRel().SetTargets(["/cam"])
    product = UsdRender.Product.Define(stage, "/Render/Products/ids")
    product.CreateProductNameAttr("ids.exr")
    product.CreateOrderedVarsRel().SetTargets(variables)
    settings.CreateProductsRel().SetTargets([product.GetPath()])
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    stage.GetRootLayer().Save()
    assert main([str(tmp_path / "scene.usda"), str(tmp_path / "out.exr"), "-spp", "2", "-q"]) == 0
    err = capsys.readouterr().err
    assert "/Render/Vars/objects: CryptoObject needs 32-bit floats" in err
    assert "/Render/Vars/primId: primId needs 32-bit floats" in err
    header = subprocess.run(
        ["iinfo", "-v", str(tmp_path / "ids.exr")], capture_output=True, text=True
    ).stdout
    # iinfo names a channel's type where the file mixes them: here every channel is float.
    assert "objects00.R" in header and "primId" in header and "(half)" not in header, header


EMISSION = 0.18  # scene-linear; its 8-bit encodings below
QUARTER_POWER_OCIO = """ocio_profile_version: 2.1
roles:
  default: linear
  scene_linear: linear
displays:
  test:
    - !<View> {name: Quarter power, colorspace: quarter power}
colorspaces:
  - !<ColorSpace> {name: linear, isdata: false}
  - !<ColorSpace>
    name: quarter power
    isdata: false
    from_scene_reference: !<ExponentTransform> {value: [4, 4, 4, 1], direction: inverse}
"""
"""An $OCIO config whose display (the first, with its first view) encodes x as x^(1/4), so that
openColorIO tells itself apart from the sRGB transfer function, which the bundled config's is."""
ENCODED = {
    "disabled": round(EMISSION * 255),  # 46
    "sRGB": round((1.055 * EMISSION ** (1 / 2.4) - 0.055) * 255),  # 118
    "openColorIO": round(EMISSION ** 0.25 * 255),  # 166, through QUARTER_POWER_OCIO
}


@pytest.fixture
def quarter_power_ocio(tmp_path, monkeypatch):
    (tmp_path / "config.ocio").write_text(QUARTER_POWER_OCIO)
    monkeypatch.setenv("OCIO", str(tmp_path / "config.ocio"))


def emission_products_stage(path):
    """A quad emitting :data:`EMISSION` (black otherwise) filling the view, with a PNG product
    of its colour var."""
    stage = new_stage(path)
    add_camera(stage)
    quad = add_quad(stage, "/World/quad", half_size=3.0)
    bind(quad, add_preview_material(
        stage, "/Looks/glow", diffuseColor=(0.0, 0.0, 0.0), specularColor=(0.0, 0.0, 0.0),
        useSpecularWorkflow=1, emissiveColor=(EMISSION,) * 3,
    ))
    color = UsdRender.Var.Define(stage, "/Render/Vars/color")
    color.CreateSourceNameAttr("color")
    color.CreateDataTypeAttr("color4f")
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateResolutionAttr(Gf.Vec2i(8, 8))
    settings.CreateCameraRel().SetTargets(["/cam"])
    product = UsdRender.Product.Define(stage, "/Render/Products/beauty")
    product.CreateProductNameAttr("beauty.png")
    product.CreateOrderedVarsRel().SetTargets([color.GetPath()])
    settings.CreateProductsRel().SetTargets([product.GetPath()])
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    stage.GetRootLayer().Save()
    return stage


def encoded(path) -> list[int]:
    """The 8-bit R, G, B, A of a PNG's centre pixel."""
    pixels = _core.read_image(str(path))[0]
    return [round(float(value) * 255) for value in pixels[4, 4]]


@pytest.mark.parametrize("mode", ["disabled", "sRGB", "openColorIO"])
def test_png_products_honour_the_color_correction_mode(tmp_path, quarter_power_ocio, mode):
    # A .png product always went through the OCIO transform (Image.write's default): 118 with
    # the bundled config, not the 46 of `-color disabled`'s output beside it.
    expected = ENCODED[mode]
    emission_products_stage(tmp_path / "scene.usda")
    argv = [str(tmp_path / "scene.usda"), str(tmp_path / "out.png"), "-spp", "1", "-q"]
    assert main([*argv, "--disableCameraLight", "-color", mode]) == 0
    assert encoded(tmp_path / "out.png") == [expected] * 3 + [255]
    assert encoded(tmp_path / "beauty.png") == [expected] * 3 + [255]


def test_render_products_takes_the_color_mode_of_image_write(tmp_path, quarter_power_ocio):
    """Python: ``color_mode`` as :meth:`penumbra.Image.write`'s, openColorIO by default,
    checked before anything renders."""
    stage = emission_products_stage(tmp_path / "scene.usda")
    plan = read_products(stage, read_render_settings(stage))
    values = {}
    with Renderer(stage) as renderer:
        for mode in (None, "disabled", "sRGB", "openColorIO"):
            keywords = {} if mode is None else {"color_mode": mode}
            render_products(
                renderer, plan, Usd.TimeCode(1), str(tmp_path),
                samples=1, default_light="none", **keywords,
            )
            values[mode] = encoded(tmp_path / "beauty.png")[0]
    assert values == {None: ENCODED["openColorIO"], **ENCODED}
    renders = []
    with Renderer(stage) as renderer, pytest.raises(ValueError, match="color_mode must be"):
        render_products(
            renderer, plan, Usd.TimeCode(1), str(tmp_path), samples=1, default_light="none",
            on_render=renders.append, color_mode="ACES",
        )
    assert renders == []
