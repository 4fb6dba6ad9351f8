"""The render options table: the render delegate's settings, penumbra-record's flags,
Renderer.render's keywords, the job records and the render settings prim's ``penumbra:KEY``
attributes all come from ``_core.render_options()``, so they cannot drift apart."""

from __future__ import annotations

import inspect

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
from stages import lit_quad_stage, new_stage

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
