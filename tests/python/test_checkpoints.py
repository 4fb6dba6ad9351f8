"""Checkpoints, resume and time limits (``--checkpoint``, ``--resume``, ``--timeLimit`` and the
Python API's ``checkpoint=``, ``time_limit=``): a render killed after a checkpoint and resumed
equals an uninterrupted one bit for bit; a checkpoint of another render, or a damaged one, is
not used; a time limit ends a frame at a whole pass whose image is that sample count's.
"""

from __future__ import annotations

import math
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

import numpy as np
import pytest
from pxr import Sdf, Usd

import penumbra
from penumbra import _core, cli_record
from penumbra.checkpoints import STATE_SUFFIX, read_state, write_state
from penumbra.cli import main
from penumbra.cli_arguments import build_parser
from penumbra.cli_record import render_job
from penumbra.jobs import START_TIME
from stages import CORNELL, lit_quad_stage, new_stage

PENUMBRA_RECORD = [sys.executable, "-m", "penumbra.cli"]
# 16 passes of 2 samples (Renderer.render's steps) on one thread.
FLAGS = ["-w", "64", "-spp", "32", "--threads", "1", "--aov", "normal,variance"]
ADAPTIVE = ["--adaptiveThreshold", "0.05", "--adaptiveMinSamples", "8"]
TIMEOUT = 120  # seconds


def read(path: Path) -> tuple[np.ndarray, dict]:
    pixels, _, metadata = _core.read_image(str(path))
    return pixels, metadata


def state_path(output: Path) -> Path:
    return Path(str(output) + STATE_SUFFIX)


def killed_after_first_checkpoint(output: Path, flags: list[str]) -> int:
    """Run penumbra-record with a checkpoint after every pass, SIGKILL it as soon as the first
    checkpoint's state file appears; returns the samples that state holds."""
    state = state_path(output)
    child = subprocess.Popen(
        [*PENUMBRA_RECORD, str(CORNELL), str(output), *flags, "--checkpoint", "0"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + TIMEOUT
    try:
        # The state file is written first, then the image: both are there once the image is.
        while not (state.exists() and output.exists()) and child.poll() is None and (
            time.monotonic() < deadline
        ):
            time.sleep(0.002)
        child.send_signal(signal.SIGKILL)
    finally:
        child.wait(TIMEOUT)
    assert child.returncode == -signal.SIGKILL, "the render ended before it could be killed"
    saved = read_state(str(state))
    assert saved is not None and 0 < saved.samples_done < 32
    return saved.samples_done


@pytest.fixture(scope="module", params=["fixed", "adaptive"])
def killed(request, tmp_path_factory):
    """An uninterrupted render and a render killed after its first checkpoint, both with
    FLAGS (plus adaptive sampling or not): (directory, flags, reference, samples saved)."""
    directory = tmp_path_factory.mktemp(request.param)
    flags = FLAGS + (ADAPTIVE if request.param == "adaptive" else [])
    reference = directory / "reference.exr"
    assert main([str(CORNELL), str(reference), *flags]) == 0
    saved = killed_after_first_checkpoint(directory / "killed.exr", flags)
    return directory, flags, reference, saved


def copy_killed(killed, to: Path) -> Path:
    """The killed render's image and state, copied to ``to`` (each test changes its own)."""
    directory = killed[0]
    shutil.copy(directory / "killed.exr", to / "out.exr")
    shutil.copy(state_path(directory / "killed.exr"), state_path(to / "out.exr"))
    return to / "out.exr"


def test_a_killed_render_resumes_bit_identical_to_an_uninterrupted_one(killed, tmp_path, capfd):
    _, flags, reference, saved = killed
    output = copy_killed(killed, tmp_path)
    partial, metadata = read(output)
    assert int(metadata["penumbra:partial"]) == 1
    assert int(metadata["penumbra:samplesDone"]) >= saved  # the image is written first
    expected, expected_metadata = read(reference)
    assert partial.shape == expected.shape and not np.array_equal(partial, expected)

    assert main([str(CORNELL), str(output), *flags, "--resume", "--checkpoint", "0"]) == 0
    assert f"resuming from {saved} samples" in capfd.readouterr().err
    resumed, metadata = read(output)
    assert np.array_equal(resumed, expected)  # every channel: colour, normal, variance
    assert "penumbra:partial" not in metadata
    for key in ("penumbra:samplesTaken", "penumbra:meanSamples", "penumbra:rays"):
        assert metadata[key] == expected_metadata[key]
    assert not state_path(output).exists()
    # The resumed output is complete: --resume skips it now.
    assert main([str(CORNELL), str(output), *flags, "--resume"]) == 0
    assert "is complete" in capfd.readouterr().out


def test_the_resumed_render_goes_on_from_the_state_it_loaded(killed, tmp_path):
    """A render from scratch would equal the reference too: stop the last pixel in the state
    (its active flag is the state's last byte), and only that pixel differs after resuming."""
    _, flags, reference, _ = killed
    if ADAPTIVE[0] in flags:
        pytest.skip("adaptive sampling may have stopped the last pixel already")
    output = copy_killed(killed, tmp_path)
    state = state_path(output)
    saved = read_state(str(state))
    about = {"edited": "last pixel stopped"}
    stopped = saved.state[:-1] + b"\0"
    write_state(str(state), saved.key, saved.samples_done, saved.render_seconds, about, stopped)
    assert main([str(CORNELL), str(output), *flags, "--resume"]) == 0
    resumed, expected = read(output)[0], read(reference)[0]
    assert not np.array_equal(resumed[-1, -1], expected[-1, -1])
    resumed[-1, -1] = expected[-1, -1]
    assert np.array_equal(resumed, expected)


@pytest.mark.parametrize("change", [["--seed", "7"], ["-spp", "48"]])
def test_a_checkpoint_of_another_render_is_not_used(killed, tmp_path, capfd, change):
    _, flags, _, _ = killed
    output = copy_killed(killed, tmp_path)
    assert main([str(CORNELL), str(output), *flags, *change, "--resume"]) == 0
    err = capfd.readouterr().err
    assert "saved by another render" in err and "resuming" not in err
    fresh = tmp_path / "fresh.exr"
    assert main([str(CORNELL), str(fresh), *flags, *change]) == 0
    assert np.array_equal(read(output)[0], read(fresh)[0])
    assert not state_path(output).exists()


@pytest.mark.parametrize("damage", ["truncate", "garbage"])
def test_a_damaged_checkpoint_warns_and_renders_from_scratch(killed, tmp_path, capfd, damage):
    _, flags, reference, _ = killed
    output = copy_killed(killed, tmp_path)
    state = state_path(output)
    data = state.read_bytes()
    state.write_bytes(data[: len(data) // 2] if damage == "truncate" else b"\0" * 100)
    assert main([str(CORNELL), str(output), *flags, "--resume"]) == 0
    err = capfd.readouterr().err
    assert f"warning: {state}:" in err and "rendering from scratch" in err
    assert np.array_equal(read(output)[0], read(reference)[0])


def test_a_state_file_of_another_format_version_is_reported(tmp_path):
    state = tmp_path / ("out.exr" + STATE_SUFFIX)
    state.write_bytes(b"penumbra checkpoint\n\x05\x00\x00\x00{}")
    with pytest.raises(ValueError, match="header"):
        read_state(str(state))


def test_each_frame_has_its_own_checkpoint_removed_when_it_is_complete(tmp_path, capfd):
    output = tmp_path / "frame.#.png"
    flags = ["-f", "1:2", "-w", "32", "-spp", "8", "--checkpoint", "0"]
    assert main([str(CORNELL.parent / "cornell_animated.usda"), str(output), *flags]) == 0
    assert "checkpoint at 4 samples" in capfd.readouterr().err  # passes of 1 sample
    assert sorted(os.listdir(tmp_path)) == ["frame.1.png", "frame.2.png"]


def test_a_time_limit_of_zero_renders_one_pass_as_that_sample_count_does(tmp_path):
    for adaptive in ([], ADAPTIVE):
        limited, one_pass = tmp_path / "limited.exr", tmp_path / "one_pass.exr"
        flags = ["-w", "48", "--aov", "normal", *adaptive]
        assert main([str(CORNELL), str(limited), *flags, "-spp", "160", "--timeLimit", "0"]) == 0
        assert main([str(CORNELL), str(one_pass), *flags, "-spp", "10"]) == 0
        pixels, metadata = read(limited)
        assert int(metadata["penumbra:samplesDone"]) == 10  # one pass: 160 / 16
        assert int(metadata["penumbra:stoppedByTimeLimit"]) == 1
        assert float(metadata["penumbra:timeLimitSeconds"]) == 0
        expected, expected_metadata = read(one_pass)
        assert np.array_equal(pixels, expected)
        assert metadata["penumbra:meanSamples"] == expected_metadata["penumbra:meanSamples"]


def test_a_time_limit_ends_the_frame_after_the_last_pass_that_fits(tmp_path, capsys):
    output = tmp_path / "limited.exr"
    flags = ["-w", "32", "-spp", "2048", "--threads", "1"]
    assert main([str(CORNELL), str(output), *flags, "--timeLimit", "1.5"]) == 0
    assert "time limit reached" in capsys.readouterr().out
    _, metadata = read(output)
    done = int(metadata["penumbra:samplesDone"])
    assert int(metadata["penumbra:stoppedByTimeLimit"]) == 1
    assert 128 <= done < 2048 and done % 128 == 0  # whole passes of 2048 / 16
    assert float(metadata["penumbra:meanSamples"]) == done
    # The limit may be overrun by the pass that was estimated to fit (a shared machine's load
    # makes estimates wobble, hence the slack of half a pass more), and by the first pass.
    seconds = float(metadata["penumbra:renderTimeSeconds"])
    assert seconds <= 1.5 + 1.5 * seconds / (done // 128)


def test_a_time_limit_not_reached_says_so(tmp_path):
    output = tmp_path / "out.exr"
    assert main([str(CORNELL), str(output), "-w", "16", "-spp", "4", "--timeLimit", "600"]) == 0
    metadata = read(output)[1]
    assert int(metadata["penumbra:stoppedByTimeLimit"]) == 0
    assert int(metadata["penumbra:samplesDone"]) == 4


@pytest.mark.parametrize(
    "flags",
    [
        ["--checkpoint", "-1"],
        ["--checkpoint", "nan"],
        ["--timeLimit", "inf"],
        ["--timeLimit", "-0.5"],
        ["--timeLimit", "10", "--workers", "2"],
        ["--checkpoint", "10", "--scheduler", "tcp://127.0.0.1:1"],
    ],
)
def test_bad_seconds_and_farm_renders_are_usage_errors(tmp_path, capsys, flags):
    assert main([str(CORNELL), str(tmp_path / "out.png"), *flags]) == 2
    err = capsys.readouterr().err
    assert flags[0] in err and not (tmp_path / "out.png").exists()


class Interrupted(Exception):
    pass


def interrupt_after(passes: int):
    """A progress callback that stops the render after ``passes`` passes."""
    calls = []

    def progress(_done: int, _total: int) -> None:
        calls.append(1)
        if len(calls) > passes:
            raise Interrupted

    return progress


def test_the_python_api_checkpoints_and_resumes_bit_identically(tmp_path, caplog):
    caplog.set_level("INFO", logger="penumbra")
    renderer = penumbra.Renderer(lit_quad_stage())
    kwargs = dict(
        width=40,
        samples=64,
        threads=1,
        aovs=("color", "albedo"),
        adaptive_threshold=0.05,
        adaptive_min_samples=8,
    )
    expected = renderer.render(**kwargs)
    path = tmp_path / "out.exr"
    every_pass = penumbra.Checkpoint(path, 0)
    with pytest.raises(Interrupted):
        renderer.render(**kwargs, checkpoint=every_pass, progress=interrupt_after(3))
    assert "checkpoint at 12 samples" in caplog.text
    partial = _core.read_image(str(path))[2]
    assert int(partial["penumbra:partial"]) == 1 and int(partial["penumbra:samplesDone"]) == 12
    resume = penumbra.Checkpoint(path, resume=True)
    other_seed = renderer.render(**kwargs, seed=3, checkpoint=resume)
    assert "saved by another render" in caplog.text  # and that render removed the state
    assert not np.array_equal(other_seed["color"], expected["color"])
    with pytest.raises(Interrupted):
        renderer.render(**kwargs, checkpoint=every_pass, progress=interrupt_after(5))
    resumed = renderer.render(**kwargs, checkpoint=resume)
    assert "resuming from 20 samples" in caplog.text
    for aov in ("color", "albedo"):
        assert np.array_equal(resumed[aov], expected[aov])
    assert resumed.metadata["samplesTaken"] == expected.metadata["samplesTaken"]
    written, _, metadata = _core.read_image(str(path))
    assert np.array_equal(written[..., :4], expected["color"])
    assert "penumbra:partial" not in metadata
    assert not state_path(path).exists()


SMALL = dict(width=32, samples=32, threads=1)  # 16 passes of 2 samples


def interrupted_at_a_checkpoint(render: Callable[..., penumbra.Image], path: Path) -> None:
    """``render(checkpoint=..., progress=...)`` with a checkpoint at ``path`` after every pass,
    stopped after 3 passes: its state holds 6 samples."""
    with pytest.raises(Interrupted):
        render(checkpoint=penumbra.Checkpoint(path, 0), progress=interrupt_after(3))
    assert read_state(str(state_path(path))).samples_done == 6


@pytest.mark.parametrize(
    "changed", [dict(disable_depth_of_field=True), dict(dome_light_visibility=False)]
)
def test_an_explicit_key_does_not_resume_a_render_of_other_arguments(tmp_path, changed):
    # The render pass checked its options, size, crop and AOVs only: a state saved with depth
    # of field on (or the dome seen) resumed a render without it under the same explicit
    # key, and the image mixed the two (colour up to 0.19 off).
    renderer = penumbra.Renderer(lit_quad_stage())
    path = tmp_path / "out.exr"
    with pytest.raises(Interrupted):
        renderer.render(**SMALL, checkpoint=penumbra.Checkpoint(path, 0, key="mine"),
                        progress=interrupt_after(3))
    resume = penumbra.Checkpoint(path, resume=True, key="mine")
    with pytest.warns(penumbra.PenumbraWarning, match="rendering from scratch"):
        resumed = renderer.render(**SMALL, **changed, checkpoint=resume)
    assert np.array_equal(resumed["color"], renderer.render(**SMALL, **changed)["color"])


def set_intensity(stage: Usd.Stage, layer: Sdf.Layer, intensity: float) -> None:
    """Author lit_quad_stage's light's intensity in ``layer``, without saving it."""
    with Usd.EditContext(stage, layer):
        stage.GetPrimAtPath("/sun").GetAttribute("inputs:intensity").Set(intensity)


@pytest.mark.parametrize("edited", ["in-memory root layer", "file sublayer, unsaved"])
def test_a_stage_edited_in_memory_renders_from_scratch(tmp_path, caplog, edited):
    """The default key hashes the text of every anonymous or dirty layer the stage uses: the
    edited scene does not continue the samples of the one before (which it would mix in)."""
    caplog.set_level("INFO", logger="penumbra")
    if edited == "in-memory root layer":
        stage = lit_quad_stage()
        layer = stage.GetRootLayer()
    else:
        lit_quad_stage(tmp_path / "scene.usda").Save()
        shot = new_stage(tmp_path / "shot.usda")
        shot.GetRootLayer().subLayerPaths.append("scene.usda")
        shot.Save()
        stage = Usd.Stage.Open(str(tmp_path / "shot.usda"))
        layer = Sdf.Layer.Find(str(tmp_path / "scene.usda"))
    renderer = penumbra.Renderer(stage)
    output = tmp_path / "out.exr"
    interrupted_at_a_checkpoint(partial(renderer.render, **SMALL), output)
    before = renderer.render(**SMALL)
    set_intensity(stage, layer, 1.5)
    assert layer.dirty
    resumed = renderer.render(**SMALL, checkpoint=penumbra.Checkpoint(output, resume=True))
    fresh = penumbra.Renderer(stage).render(**SMALL)
    assert not np.array_equal(fresh["color"], before["color"])
    assert np.array_equal(resumed["color"], fresh["color"])
    assert "saved by another render" in caplog.text and "resuming" not in caplog.text


def test_the_same_in_memory_scene_built_again_resumes(tmp_path, caplog):
    """Anonymous root and session layers count by their text, not their identifiers (which hold
    an address): a script that builds the same stage again goes on from its checkpoint."""
    caplog.set_level("INFO", logger="penumbra")
    output = tmp_path / "out.exr"
    first, again = lit_quad_stage(), lit_quad_stage()  # both alive: other addresses
    expected = penumbra.render(first, **SMALL)
    interrupted_at_a_checkpoint(partial(penumbra.render, first, **SMALL), output)
    assert again.GetRootLayer().identifier != first.GetRootLayer().identifier
    resumed = penumbra.render(again, **SMALL, checkpoint=penumbra.Checkpoint(output, resume=True))
    assert "resuming from 6 samples" in caplog.text
    assert np.array_equal(resumed["color"], expected["color"])


def test_a_stage_file_resumes_until_it_is_edited_on_disk(tmp_path, caplog):
    """A saved layer counts by its identifier and its file's size and modification time."""
    caplog.set_level("INFO", logger="penumbra")
    scene, output = tmp_path / "scene.usda", tmp_path / "out.exr"
    lit_quad_stage(scene).Save()
    resume = penumbra.Checkpoint(output, resume=True)
    expected = penumbra.render(scene, **SMALL)
    interrupted_at_a_checkpoint(partial(penumbra.render, scene, **SMALL), output)
    # Opened again, unchanged: the render goes on from its checkpoint.
    resumed = penumbra.render(scene, **SMALL, checkpoint=resume)
    assert "resuming from 6 samples" in caplog.text
    assert np.array_equal(resumed["color"], expected["color"])

    interrupted_at_a_checkpoint(partial(penumbra.render, scene, **SMALL), output)
    caplog.clear()
    # Edited on disk, the file keeps its size; its modification time is a second later, as an
    # edit's would be on a file system that keeps coarse times.
    text = scene.read_text()
    edited = text.replace("inputs:intensity = 3\n", "inputs:intensity = 5\n")
    assert edited != text and len(edited) == len(text)
    modified = scene.stat().st_mtime_ns
    scene.write_text(edited)
    os.utime(scene, ns=(modified + 10**9, modified + 10**9))
    assert Sdf.Layer.Find(str(scene)) is None  # nothing holds the layer: opening reads the file
    resumed = penumbra.render(scene, **SMALL, checkpoint=resume)
    fresh = penumbra.render(scene, **SMALL)
    assert not np.array_equal(fresh["color"], expected["color"])
    assert np.array_equal(resumed["color"], fresh["color"])
    assert "saved by another render" in caplog.text and "resuming" not in caplog.text


def test_the_python_api_time_limit_and_its_validation(tmp_path):
    renderer = penumbra.Renderer(lit_quad_stage())
    image = renderer.render(width=16, samples=32, time_limit=0)
    assert image.metadata["samplesDone"] == 2 and image.metadata["stoppedByTimeLimit"] == 1
    for bad in (-1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="time_limit"):
            renderer.render(width=16, samples=4, time_limit=bad)
        with pytest.raises(ValueError, match="checkpoint interval"):
            penumbra.Checkpoint(tmp_path / "out.exr", bad)
    with pytest.raises(TypeError, match="Checkpoint"):
        renderer.render(width=16, samples=4, checkpoint=str(tmp_path / "out.exr"))


def test_the_render_pass_refuses_a_state_of_another_render():
    delegate_stage = lit_quad_stage()
    renderer = penumbra.Renderer(delegate_stage)
    renderer.render(width=16, samples=8, seed=1)
    (render_pass,) = renderer._passes.values()
    state = render_pass.save_state("key")
    with pytest.raises(ValueError, match="render key"):
        render_pass.load_state(state, "another key")
    with pytest.raises(ValueError, match="truncated"):
        render_pass.load_state(state[: len(state) - 9], "key")
    renderer.delegate.set_render_setting("seed", 2)
    render_pass.execute(0)
    with pytest.raises(ValueError, match="other settings"):
        render_pass.load_state(state, "key")
    renderer.delegate.set_render_setting("seed", 1)
    render_pass.execute(0)
    render_pass.set_aovs(["albedo"])
    with pytest.raises(ValueError, match="AOVs"):
        render_pass.load_state(state, "key")
    render_pass.set_aovs([])
    render_pass.load_state(state, "key")
    assert render_pass.samples_done == 8


def test_the_frame_key_holds_the_time_limit_not_the_checkpoint_interval(tmp_path):
    def key(*flags: str) -> str:
        args = build_parser().parse_args([str(tmp_path / "in.usda"), "out.exr", *flags])
        args.aovs = ["color"]
        return render_job(args, START_TIME).frame_key(START_TIME)

    assert key("--checkpoint", "60") == key()
    assert key("--timeLimit", "60") != key()


@pytest.mark.parametrize("extension", ["png", "tif", "jpg"])
def test_a_partly_rendered_frame_in_any_format_is_resumed_not_skipped(
    tmp_path, monkeypatch, capfd, extension
):
    """PNG, TIFF and JPEG keep the checkpoint image's key but drop ``penumbra:partial``: the
    state file beside the image says the frame is unfinished."""
    output = tmp_path / f"out.{extension}"
    flags = ["-w", "32", "-spp", "32", "--threads", "1", "--checkpoint", "0"]
    monkeypatch.setattr(cli_record, "Progress", lambda _label: interrupt_after(2))
    assert main([str(CORNELL), str(output), *flags]) != 0
    monkeypatch.undo()
    assert state_path(output).exists()
    metadata = read(output)[1]
    assert "Exif:ImageUniqueID" in metadata and "penumbra:partial" not in metadata
    capfd.readouterr()
    assert main([str(CORNELL), str(output), *flags, "--resume"]) == 0
    out, err = capfd.readouterr()
    assert "is complete" not in out and "resuming from 4 samples" in err
    assert not state_path(output).exists()


# A process that dies right after the first of a checkpoint's two writes (state, image).
DIES_AFTER_ONE_WRITE = """
import os, sys
import penumbra.renderer as renderer
from penumbra.cli import main

def then_die(write):
    def written_then_killed(*args, **kwargs):
        write(*args, **kwargs)
        os._exit(9)
    return written_then_killed

renderer.write_state = then_die(renderer.write_state)
renderer.Image.write = then_die(renderer.Image.write)
sys.exit(main(sys.argv[1:]))
"""


def test_a_render_killed_between_a_checkpoints_two_writes_is_not_taken_for_finished(
    tmp_path, capfd
):
    # The image was written before its state: killed between the two, a PNG (which drops
    # penumbra:partial) with the frame's key and no state file was skipped by --resume.
    output = tmp_path / "out.png"
    flags = ["-w", "32", "-spp", "32", "--threads", "1", "--checkpoint", "0"]
    killed = subprocess.run(
        [sys.executable, "-c", DIES_AFTER_ONE_WRITE, str(CORNELL), str(output), *flags],
        capture_output=True, timeout=TIMEOUT,
    )
    assert killed.returncode == 9
    capfd.readouterr()
    assert main([str(CORNELL), str(output), *flags, "--resume"]) == 0
    out, err = capfd.readouterr()
    assert "is complete" not in out and "resuming from" in err
    assert read(output)[1].get("penumbra:partial") is None and not state_path(output).exists()


def test_resume_keys_do_not_depend_on_the_first_frame_of_the_range(tmp_path, capsys):
    output = tmp_path / "frame.#.exr"
    flags = ["-w", "8", "-spp", "1"]
    animated = str(CORNELL.parent / "cornell_animated.usda")
    assert main([animated, str(output), *flags, "-f", "1:3"]) == 0
    capsys.readouterr()
    assert main([animated, str(output), *flags, "-f", "2:3", "--resume"]) == 0
    out = capsys.readouterr().out
    assert "Skipped time code 2" in out and "Skipped time code 3" in out
    assert "Recording" not in out
