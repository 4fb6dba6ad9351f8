"""The render options table: the render delegate's settings, penumbra-record's flags,
Renderer.render's keywords, the job records and the render settings prim's ``penumbra:KEY``
attributes all come from ``_core.render_options()``, so they cannot drift apart."""

from __future__ import annotations

import inspect

import numpy as np
import pytest
from pxr import Sdf, UsdLux, UsdRender

import penumbra
from penumbra import _core, render_options
from penumbra.cli import build_parser, main
from penumbra.cli_record import render_job
from penumbra.errors import PenumbraWarning, SceneError
from penumbra.jobs import START_TIME
from penumbra.usd import read_render_settings
from penumbra.usd.lights import light_type
from stages import add_camera, add_preview_material, add_sphere_mesh, bind, lit_quad_stage, \
    new_stage

OPTIONS = render_options.OPTIONS


def other_value(option: render_options.RenderOption) -> render_options.OptionValue:
    """A valid value of ``option`` other than its default."""
    if option.type == "level":
        return option.levels[-1]
    if option.type == "float":
        return 0.5 if option.default != 0.5 else 0.25
    return option.default + 1


def cli_text(value: render_options.OptionValue) -> str:
    return value if isinstance(value, str) else f"{value:g}"


def test_the_table_is_the_render_delegates_settings():
    delegate = _core.RenderDelegate()
    keys = [option.key for option in _core.render_options()]
    assert sorted(keys) == sorted(delegate.render_settings())
    for option in _core.render_options():
        default = option.delegate_default
        expected = option.levels.index(default) if option.type == "level" else default
        assert delegate.render_settings()[option.key] == expected, option.key
    # Only the texture cache's size is the front ends' to derive.
    assert [option.key for option in _core.render_options() if not option.user_set] == [
        "textureCacheMB"
    ]


def test_spellings_are_derived_from_the_key():
    option = render_options.BY_KEYWORD["max_path_depth"]
    assert (option.key, option.flag, option.usd_attribute) == (
        "maxPathDepth",
        "--maxPathDepth",
        "penumbra:maxPathDepth",
    )
    assert render_options.keyword_of("adaptiveMinSamples") == "adaptive_min_samples"


def test_the_options_users_knew_keep_their_spellings_and_defaults():
    """Every flag and keyword of earlier versions, with its default."""
    defaults = {
        "samples": 64,
        "seed": 0,
        "threads": 0,
        "max_path_depth": 8,
        "complexity": "low",
        "adaptive_threshold": 0.0,
        "adaptive_min_samples": 16,
        "indirect_clamp": 0.0,
        "glossy_filter": 0.0,
        # 1 before the branching pilot; 0, its choice, since (1 renders as before).
        "indirect_samples": 0,
    }
    for keyword, default in defaults.items():
        assert render_options.BY_KEYWORD[keyword].default == default
    args = build_parser().parse_args(["in.usda", "out.exr"])
    assert all(getattr(args, render_options.BY_KEYWORD[k].key) is None for k in defaults)
    args = build_parser().parse_args(["in.usda", "out.exr", "-spp", "4", "-c", "high"])
    assert (args.samples, args.complexity) == (4, "high")


def test_the_cli_accepts_every_option(tmp_path):
    """Each option's flag parses, passes the usage checks and reaches the job by keyword."""
    argv = [str(tmp_path / "in.usda"), str(tmp_path / "out.exr")]
    expected = {}
    for option in OPTIONS:
        value = other_value(option)
        argv += [option.flag, cli_text(value)]
        expected[option.keyword] = value
    args = build_parser().parse_args(argv)
    args.aovs = ["color"]
    job = render_job(args, START_TIME)
    assert job.options == expected
    assert sorted(job.options) == sorted(render_options.BY_KEYWORD)


def test_the_resume_key_holds_every_option_that_changes_pixels(tmp_path):
    def key(*flags: str) -> str:
        args = build_parser().parse_args([str(tmp_path / "in.usda"), "out.exr", *flags])
        args.aovs = ["color"]
        return render_job(args, START_TIME).frame_key(START_TIME)

    default = key()
    assert key("--samples", "64") == default  # the default, given or not
    assert key("--threads", "1") == default  # changes speed, not pixels
    assert key("--samples", "32") != default
    assert key("--maxGlossyDepth", "2") != default


def test_help_lists_every_option_with_its_help(capsys):
    assert main(["--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    for option in OPTIONS:
        assert option.flag in text
        assert " ".join(option.help.split()) in text
    assert "samples per pixel (default: 64)" in text
    assert "render threads (default: 0, every core)" in text
    assert "is then a cap (default: 0, off)" in text
    assert "each level halving that (default: low)" in text


def test_the_api_signature_lists_every_option_with_its_default():
    parameters = inspect.signature(penumbra.Renderer.render).parameters
    for option in OPTIONS:
        parameter = parameters[option.keyword]
        assert parameter.kind is inspect.Parameter.KEYWORD_ONLY
        assert parameter.default == option.default
    assert "options" not in parameters


@pytest.mark.parametrize("option", OPTIONS, ids=lambda option: option.key)
def test_invalid_values_are_usage_errors(tmp_path, capsys, option):
    bad = "extreme" if option.type == "level" else cli_text(option.core.minimum - 1)
    assert main([str(tmp_path / "in.usda"), str(tmp_path / "o.exr"), option.flag, bad]) == 2
    assert option.flag in capsys.readouterr().err


def settings_stage():
    stage = lit_quad_stage()
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets(["/cam"])
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    return stage, settings.GetPrim()


def author(prim, option, value) -> None:
    type_name = {"int": Sdf.ValueTypeNames.Int, "float": Sdf.ValueTypeNames.Float,
                 "level": Sdf.ValueTypeNames.Token}[option.type]
    prim.CreateAttribute(option.usd_attribute, type_name).Set(value)


def test_the_usd_attribute_of_every_option_is_read():
    stage, prim = settings_stage()
    expected = {}
    for option in OPTIONS:
        expected[option.keyword] = other_value(option)
        author(prim, option, expected[option.keyword])
    assert read_render_settings(stage).options == expected


def test_authored_options_render_unless_given():
    stage, prim = settings_stage()
    author(prim, render_options.BY_KEYWORD["samples"], 2)
    author(prim, render_options.BY_KEYWORD["max_path_depth"], 3)
    author(prim, render_options.BY_KEYWORD["complexity"], "high")
    with penumbra.Renderer(stage) as renderer:
        image = renderer.render(width=8, max_path_depth=5)
        settings = renderer.delegate.render_settings()
    assert (settings["samples"], settings["maxPathDepth"], settings["complexity"]) == (2, 5, 2)
    assert (image.metadata["samples"], image.metadata["maxPathDepth"]) == (2, 5)
    assert image.metadata["complexity"] == "high"


def test_unknown_or_invalid_options_are_rejected():
    stage, prim = settings_stage()
    with penumbra.Renderer(stage) as renderer:
        with pytest.raises(TypeError, match="unexpected keyword argument 'max_depth'"):
            renderer.render(width=8, samples=1, max_depth=3)
        with pytest.raises(ValueError, match="samples must be at least 1"):
            renderer.render(width=8, samples=0)
        with pytest.raises(ValueError, match=r"threads must be in \[0, 1024\]"):
            renderer.render(width=8, samples=1, threads=100_000)  # oneTBB crashed past 65536
        with pytest.raises(ValueError, match="unknown render setting 'spp'"):
            renderer.delegate.set_render_setting("spp", 4)
    prim.CreateAttribute("penumbra:maxDepth", Sdf.ValueTypeNames.Int).Set(3)
    with pytest.warns(PenumbraWarning, match="penumbra:maxDepth"):
        read_render_settings(stage)
    prim.RemoveProperty("penumbra:maxDepth")
    author(prim, render_options.BY_KEYWORD["adaptive_threshold"], 2.0)
    with pytest.raises(SceneError, match=r"penumbra:adaptiveThreshold: must be in \[0, 1\]"):
        read_render_settings(stage)


def test_light_types_are_the_delegates_sprim_types():
    stage = new_stage()
    delegate = _core.RenderDelegate()
    for light in _core.light_types():
        schema = getattr(UsdLux, light.schema)
        prim = schema.Define(stage, f"/{light.sprim_type}").GetPrim()
        assert light_type(prim) == light.sprim_type
        delegate.insert_sprim(light.sprim_type, f"/{light.sprim_type}")
    assert {light.sprim_type for light in _core.light_types()} >= {
        "rectLight", "diskLight", "sphereLight", "cylinderLight", "distantLight", "domeLight"
    }
    with pytest.raises(ValueError, match="unsupported sprim type"):
        delegate.insert_sprim("portalLight", "/portal")


# Caps high enough that a path through rough glass ends by escaping, not by a cap.
RAISED_CAPS = {"max_path_depth": 64, "max_glossy_depth": 64, "max_transmission_depth": 64}


def glass_furnace_stage(path=None):
    """A white rough glass sphere (radius 1, seen whole) under a white dome of radiance 1: a
    lossless BSDF there has radiance 1 wherever the sphere is seen."""
    stage = new_stage(path)
    add_camera(stage)  # sees [-2, 2]² of the z = 0 plane
    sphere = add_sphere_mesh(stage, "/World/ball", rings=48, sectors=96)
    UsdLux.DomeLight.Define(stage, "/Dome").CreateIntensityAttr(1.0)
    bind(sphere, add_preview_material(stage, "/Looks/glass", opacity=0.0, ior=1.5,
                                      roughness=0.3))
    return stage


def sphere_mean(rgb: np.ndarray) -> float:
    """Mean luminance over the sphere's interior (radius < 0.9, off the silhouette)."""
    size = rgb.shape[0]
    coordinates = (np.arange(size) + 0.5) / size * 4 - 2
    radius = np.hypot(*np.meshgrid(coordinates, coordinates))
    return float(rgb[radius < 0.9][:, :3].mean())


def test_raised_depth_caps_keep_rough_glass_at_one_through_every_door(tmp_path):
    """The glossy and transmission caps are a flag, a keyword and a render settings attribute
    alike: each lifts the cap under which rough glass in a white furnace loses light, and the
    three give the same pixels."""
    path = tmp_path / "furnace.usda"
    stage = glass_furnace_stage(path)
    stage.GetRootLayer().Save()
    common = {"camera": "/cam", "width": 48, "samples": 64, "seed": 5}
    capped = sphere_mean(penumbra.render(stage, **common)["color"])
    assert capped < 0.97  # the default caps (glossy 4, transmission 8) lose light
    by_keyword = penumbra.render(stage, **common, **RAISED_CAPS)["color"]
    assert sphere_mean(by_keyword) == pytest.approx(1.0, abs=0.02)

    flags = [f"--{render_options.BY_KEYWORD[k].key}={v}" for k, v in RAISED_CAPS.items()]
    out = tmp_path / "furnace.exr"
    assert main([str(path), str(out), "-cam", "/cam", "-w", "48", "-spp", "64", "--seed", "5",
                 "--enableDomeLightVisibility", *flags]) == 0
    by_flag, _, metadata = _core.read_image(str(out))
    assert int(metadata["penumbra:maxGlossyDepth"]) == 64
    np.testing.assert_array_equal(by_flag, by_keyword)

    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    for keyword, value in RAISED_CAPS.items():
        author(settings.GetPrim(), render_options.BY_KEYWORD[keyword], value)
    by_attribute = penumbra.render(stage, **common)["color"]
    np.testing.assert_array_equal(by_attribute, by_keyword)
