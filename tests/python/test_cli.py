"""``penumbra-record`` end to end: outputs, metadata, frames, errors and exit codes."""

from __future__ import annotations

import os
import subprocess
import sys
from functools import partial
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, UsdGeom, UsdUtils

from penumbra import _core, cli_record
from penumbra.cli import main
from penumbra.cli_output import Progress
from penumbra.frames import iter_frames, parse_frame_spec
from stages import CORNELL, add_quad, lit_quad_stage, new_stage

SMALL = ["-w", "32", "-spp", "4", "-cam", "/cam"]


def luminance(rgb: np.ndarray) -> np.ndarray:
    return rgb[..., :3] @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)


@pytest.fixture(scope="module")
def cornell_exr(tmp_path_factory) -> Path:
    """cornell.usda rendered once at 160×90, 64 spp."""
    out = tmp_path_factory.mktemp("cornell") / "cornell.exr"
    assert main([str(CORNELL), str(out), "-w", "160", "-spp", "64"]) == 0
    return out


def test_cornell_exr_channels_and_metadata(cornell_exr):
    pixels, names, metadata = _core.read_image(str(cornell_exr))
    assert pixels.shape == (90, 160, 4) and names == ["R", "G", "B", "A"]
    assert metadata["penumbra:camera"] == "/cam"
    assert int(metadata["penumbra:samples"]) == 64
    assert int(metadata["penumbra:seed"]) == 0
    assert float(metadata["penumbra:timeCode"]) == 1.0
    assert float(metadata["penumbra:renderTimeSeconds"]) > 0
    assert metadata["penumbra:version"] == _core.version()
    red_wall, green_wall = pixels[45, 20, :3], pixels[45, 140, :3]
    assert red_wall[0] > 2 * red_wall[1] and green_wall[1] > 2 * green_wall[0]


def test_cornell_soft_shadow(cornell_exr):
    """The shadow the short box casts on the floor to its right has a penumbra: across its
    edge the floor's luminance rises through many intermediate values, not in one step."""
    pixels, _, _ = _core.read_image(str(cornell_exr))
    # Floor rows 81-84 at the box's base, from inside the shadow (column 114) to the lit floor.
    profile = luminance(pixels[81:85, 114:138]).mean(axis=0)
    umbra, lit = profile[:3].mean(), profile[-3:].mean()
    assert lit > 2.5 * umbra
    between = (profile > umbra + 0.15 * (lit - umbra)) & (profile < lit - 0.15 * (lit - umbra))
    assert np.count_nonzero(between) >= 6  # a hard shadow would give one or two
    smoothed = profile.reshape(-1, 2).mean(axis=1)
    assert np.all(np.diff(smoothed) > -0.1 * (lit - umbra))  # monotone up to noise


def test_png_output(tmp_path):
    out = tmp_path / "cornell.png"
    assert main([str(CORNELL), str(out), *SMALL]) == 0
    pixels, _, _ = _core.read_image(str(out))
    assert pixels.shape[:2] == (18, 32) and pixels.shape[2] in (3, 4)
    assert 0.0 <= pixels.min() and pixels.max() <= 1.0 and pixels[..., :3].max() > 0.2


def test_png_color_modes_agree(tmp_path):
    """The bundled OCIO config's sRGB display equals the sRGB transfer function."""
    stage_path = tmp_path / "quad.usda"
    lit_quad_stage(stage_path).Save()
    outputs = {}
    for mode in ("sRGB", "openColorIO", "disabled"):
        outputs[mode] = tmp_path / f"{mode}.png"
        assert main([str(stage_path), str(outputs[mode]), *SMALL, "-color", mode]) == 0
    srgb, ocio, linear = (_core.read_image(str(outputs[m]))[0][..., :3] for m in outputs)
    np.testing.assert_allclose(ocio, srgb, atol=1.5 / 255)
    centre = linear[16, 16]
    assert srgb[16, 16] == pytest.approx(1.055 * centre ** (1 / 2.4) - 0.055, abs=1.5 / 255)


def test_frames_substitution(tmp_path):
    stage_path = tmp_path / "quad.usda"
    lit_quad_stage(stage_path).Save()
    pattern = tmp_path / "out.###.exr"
    assert main([str(stage_path), str(pattern), *SMALL, "-f", "1:3x2,10"]) == 0
    written = sorted(p.name for p in tmp_path.glob("out.*.exr"))
    assert written == ["out.001.exr", "out.003.exr", "out.010.exr"]
    _, _, metadata = _core.read_image(str(tmp_path / "out.010.exr"))
    assert float(metadata["penumbra:timeCode"]) == 10.0


@pytest.mark.parametrize(
    "spec", ["0:0.7x0.1", "0.1:0.3x0.1", "1:2x0.1", "10:9.7x-0.1", "1:10x3", "3:1", "1:2x0.5"]
)
def test_frame_specs_give_usd_cores_time_codes(spec):
    """UsdUtils.TimeCodeRange's frames, floating-point rounding included (no tolerance)."""
    expected = [code.GetValue() for code in UsdUtils.TimeCodeRange.CreateFromFrameSpec(spec)]
    assert list(iter_frames(parse_frame_spec(spec))) == expected


def test_a_placeholder_may_name_the_directory(tmp_path, capsys):
    """As usdrecord's: each frame's directory is checked, the first before the stage is read."""
    stage_path = tmp_path / "quad.usda"
    lit_quad_stage(stage_path).Save()
    for shot in ("s_01", "s_02"):
        (tmp_path / shot).mkdir()
    assert main([str(stage_path), str(tmp_path / "s_##" / "o.exr"), *SMALL, "-f", "1:2"]) == 0
    assert (tmp_path / "s_01" / "o.exr").exists() and (tmp_path / "s_02" / "o.exr").exists()
    assert main([str(stage_path), str(tmp_path / "s_##" / "o.exr"), *SMALL, "-f", "2:3"]) == 1
    assert f"directory {tmp_path / 's_03'} does not exist" in capsys.readouterr().err


@pytest.mark.parametrize(
    "output, frames, message",
    [
        ("out.exr", ["-f", "1:2"], "needs a frame placeholder"),
        ("out.#.exr", [], "so --frames is needed"),
        ("out.#.exr", ["-f", "1:2x0.5"], "need 1 decimals"),
        ("out.#.exr", ["-f", "1:"], "invalid FRAMESPEC '1:'"),
        ("o#ut.#.exr", ["-f", "1"], "2 frame placeholders"),
    ],
)
def test_frame_usage_errors(tmp_path, capsys, output, frames, message):
    assert main([str(CORNELL), str(tmp_path / output), *frames]) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_usage_errors(tmp_path, capsys):
    assert main([str(CORNELL)]) == 2
    assert main([str(CORNELL), str(tmp_path / "o.exr"), "-color", "ACES"]) == 2
    assert main([str(CORNELL), str(tmp_path / "o.exr"), "-w", "0"]) == 2
    assert main(["--help"]) == 0
    assert "--samples" in capsys.readouterr().out


def test_help_prints_where_the_terminal_takes_only_ascii():
    """Every option's help is ASCII: --help must not fail where stdout cannot encode more."""
    result = subprocess.run(
        [sys.executable, "-m", "penumbra.cli", "--help"],
        env={**os.environ, "PYTHONIOENCODING": "ascii"},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 0, result.stderr
    assert "--adaptiveThreshold" in result.stdout


def test_missing_and_unreadable_files(tmp_path, capsys):
    missing = tmp_path / "missing.usda"
    assert main([str(missing), str(tmp_path / "o.exr")]) == 1
    assert f"{missing}: no such file" in capsys.readouterr().err
    broken = tmp_path / "broken.usda"
    broken.write_text('#usda 1.0\ndef Xform "a" {\n  float x =\n}\n')
    assert main([str(broken), str(tmp_path / "o.exr")]) == 1
    assert f"{broken}: cannot read the file" in capsys.readouterr().err
    assert not (tmp_path / "o.exr").exists()


def test_camera_errors(tmp_path, capsys):
    empty = tmp_path / "empty.usda"
    new_stage(empty).Save()
    assert main([str(empty), str(tmp_path / "o.exr")]) == 1
    err = capsys.readouterr().err
    assert str(empty) in err and "no camera" in err and "no geometry to frame" in err
    assert not (tmp_path / "o.exr").exists()

    assert main([str(CORNELL), str(tmp_path / "o.exr"), "--camera", "/World/tall_box"]) == 1
    assert "/World/tall_box is not a camera (it is a Mesh)" in capsys.readouterr().err
    assert main([str(CORNELL), str(tmp_path / "o.exr"), "-cam", "/nowhere"]) == 1
    assert "no prim at camera path /nowhere" in capsys.readouterr().err
    assert main([str(CORNELL), str(tmp_path / "o.exr"), "-rs", "/World"]) == 1
    assert "/World is not a RenderSettings prim" in capsys.readouterr().err


def test_stage_without_camera_or_lights_is_framed_and_lit(tmp_path, capsys):
    no_camera = tmp_path / "no_camera.usda"
    stage = new_stage(no_camera)
    add_quad(stage, "/World/quad")
    stage.Save()
    assert main([str(no_camera), str(tmp_path / "o.exr"), "-w", "32", "-spp", "4"]) == 0
    err = capsys.readouterr().err
    assert "the stage has no lights" in err
    pixels, _, metadata = _core.read_image(str(tmp_path / "o.exr"))
    assert metadata["penumbra:camera"] == "/PenumbraFramingCamera"
    # The quad fills the middle of the frame (alpha 1) and is lit by the default dome.
    height, width = pixels.shape[:2]
    assert pixels[height // 2, width // 2, 3] == 1.0
    assert pixels[height // 2, width // 2, 0] > 0.1
    # The user's file is not modified: the camera lives in the session layer.
    assert "PenumbraFramingCamera" not in no_camera.read_text()


def test_a_framing_camera_is_placed_at_each_frame(tmp_path):
    """As usdrecord places it: a cube that moves away from where frame 1 framed it is in view at
    frame 10, as when frame 10 is rendered alone."""
    stage_path = tmp_path / "moving.usda"
    stage = new_stage(stage_path)
    translate = UsdGeom.Cube.Define(stage, "/cube").AddTranslateOp()
    translate.Set(Gf.Vec3d(0, 0, 0), 1)
    translate.Set(Gf.Vec3d(5, 0, 0), 10)
    stage.Save()
    size = ["-w", "32", "-spp", "1"]
    assert main([str(stage_path), str(tmp_path / "range.#.exr"), *size, "-f", "1,10"]) == 0
    assert main([str(stage_path), str(tmp_path / "alone.#.exr"), *size, "-f", "10"]) == 0

    def alpha(name: str) -> np.ndarray:
        return _core.read_image(str(tmp_path / name))[0][..., 3]

    assert np.count_nonzero(alpha("alone.10.exr")) > 50
    np.testing.assert_array_equal(alpha("range.10.exr"), alpha("alone.10.exr"))


def test_camera_by_name_and_main_cam(tmp_path):
    stage_path = tmp_path / "quad.usda"
    stage = lit_quad_stage(stage_path)
    UsdGeom.Camera.Define(stage, "/rig/main_cam").CreateFocalLengthAttr(5.0)
    stage.Save()
    size = ["-w", "16", "-spp", "1"]
    assert main([str(stage_path), str(tmp_path / "a.exr"), *size, "-cam", "cam"]) == 0
    assert _core.read_image(str(tmp_path / "a.exr"))[2]["penumbra:camera"] == "/cam"
    assert main([str(stage_path), str(tmp_path / "b.exr"), *size]) == 0
    assert _core.read_image(str(tmp_path / "b.exr"))[2]["penumbra:camera"] == "/rig/main_cam"


def test_out_of_range_indices_warn_and_render(tmp_path, capsys):
    stage_path = tmp_path / "bad.usda"
    stage = lit_quad_stage(stage_path)
    bad = add_quad(stage, "/World/bad", center=(1.5, 1.5, 0.1), half_size=0.3)
    bad.GetFaceVertexIndicesAttr().Set([0, 1, 2, 7])
    stage.Save()
    out = tmp_path / "o.exr"
    assert main([str(stage_path), str(out), *SMALL]) == 0
    err = capsys.readouterr().err
    warnings = [line for line in err.splitlines() if line.startswith("penumbra-record: warning:")]
    assert len(warnings) == 1 and "/World/bad" in warnings[0]
    pixels = _core.read_image(str(out))[0]
    assert luminance(pixels[16, 16]) > 0.05  # the good quad


def test_console_script_progress(tmp_path):
    """The installed console script runs and reports progress on stderr."""
    script = Path(sys.executable).with_name("penumbra-record")
    stage_path = tmp_path / "quad.usda"
    lit_quad_stage(stage_path).Save()
    out = tmp_path / "o.exr"
    result = subprocess.run(
        [str(script), str(stage_path), str(out), "-w", "16", "-spp", "8", "-cam", "/cam"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 0, result.stderr
    assert "8/8 samples" in result.stderr
    assert out.exists()


def test_a_frame_stopped_by_its_time_limit_ends_the_progress_line(tmp_path, capsys, monkeypatch):
    """On a terminal the progress line is rewritten in place: a frame that ends before all its
    samples (--timeLimit) still ends the line before the summary."""
    monkeypatch.setattr(cli_record, "Progress", partial(Progress, interactive=True))
    stage_path = tmp_path / "quad.usda"
    lit_quad_stage(stage_path).Save()
    flags = [*SMALL[:2], "-spp", "64", *SMALL[4:], "--timeLimit", "0"]
    assert main([str(stage_path), str(tmp_path / "o.exr"), *flags]) == 0
    err = capsys.readouterr().err
    assert "4/64 samples" in err and err.endswith("\n")


def test_the_time_left_follows_the_pace_of_this_processs_samples(capsys, monkeypatch):
    # A frame resumed at 48 of 64 samples, then 2 samples a second: 4 s left after 56, where the
    # elapsed time over every sample done said 0 s (the resumed 48 counted at this pace).
    clock = iter([0.0, 1.0, 3.0])
    monkeypatch.setattr("penumbra.cli_output.time.perf_counter", lambda: next(clock))
    progress = Progress("frame", interactive=True)
    progress(52, 64)
    progress(56, 64)
    assert capsys.readouterr().err.endswith("frame: 56/64 samples, 3.0 s, about 4 s left")


def test_adaptive_sampling_and_clamp_flags(tmp_path, capsys):
    """--adaptiveThreshold stops converged pixels (the summary gives the mean samples taken),
    --indirectClamp, --glossyFilter and --indirectSamples reach the render; out-of-range values
    are usage errors."""
    stage_path = tmp_path / "quad.usda"
    lit_quad_stage(stage_path).Save()
    out = tmp_path / "o.exr"
    args = [str(stage_path), str(out), "-w", "32", "-spp", "64", "-cam", "/cam"]
    assert main([*args, "--adaptiveThreshold", "0.1", "--adaptiveMinSamples", "8"]) == 0
    assert "(at most 64) samples/pixel" in capsys.readouterr().out
    _, _, metadata = _core.read_image(str(out))
    assert 8 <= float(metadata["penumbra:meanSamples"]) < 64
    assert main([*args, "--indirectClamp", "10"]) == 0
    assert float(_core.read_image(str(out))[2]["penumbra:indirectClamp"]) == 10
    assert main([*args, "--glossyFilter", "1"]) == 0
    assert float(_core.read_image(str(out))[2]["penumbra:glossyFilter"]) == 1
    assert main([*args, "--indirectSamples", "2"]) == 0
    assert float(_core.read_image(str(out))[2]["penumbra:indirectSamples"]) == 2
    for flag, value in (
        ("--adaptiveThreshold", "2"),
        ("--adaptiveMinSamples", "1"),
        ("--indirectClamp", "-1"),
        ("--indirectClamp", "nan"),
        ("--glossyFilter", "-0.5"),
        ("--glossyFilter", "inf"),
        ("--indirectSamples", "-1"),
        ("--indirectSamples", "17"),
    ):
        assert main([*args, flag, value]) == 2
        assert f"{flag} must" in capsys.readouterr().err
