"""Rendering on a Dask cluster (``--scheduler``, ``--workers``, ``--resume``): farm renders are
bit-identical to local ones, frames are written once even when a worker dies, ``--resume``
renders only what is missing, and a worker's failure is reported, never waited on forever.

The clusters are real: a scheduler and worker processes started with Dask's own command line,
on loopback.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import dask.config
import numpy as np
import pytest
from distributed import Client

import penumbra
from penumbra import _core
from penumbra.checkpoints import STATE_SUFFIX
from penumbra.cli import main
from penumbra.farm import Tile, band_rows, merge_tiles, tiles_per_frame
from processes import default_sigint
from stages import CORNELL

ANIMATED = CORNELL.parent / "cornell_animated.usda"
SEQUENCE = ["-f", "1:6", "-w", "96", "-spp", "8"]
DASK = Path(sys.executable).parent / "dask"
PENUMBRA_RECORD = [sys.executable, "-m", "penumbra.cli"]
TIMEOUT = 120  # seconds: a hang fails the test instead of stalling the suite


@dataclass
class Cluster:
    address: str
    scheduler: subprocess.Popen
    workers: list[subprocess.Popen]


@contextmanager
def dask_cluster(directory: Path, workers: int) -> Iterator[Cluster]:
    """A scheduler and ``workers`` single-threaded worker processes without nannies (a killed
    worker stays dead), on loopback, stopped on exit."""
    scheduler_file = directory / "scheduler.json"
    common = ["--no-dashboard", "--host", "127.0.0.1"]
    processes = [
        subprocess.Popen(
            [DASK, "scheduler", "--port", "0", "--scheduler-file", scheduler_file, *common],
            stderr=subprocess.DEVNULL,
        )
    ]
    try:
        for _ in range(workers):
            processes.append(
                subprocess.Popen(
                    [
                        DASK,
                        "worker",
                        "--scheduler-file",
                        scheduler_file,
                        "--nthreads",
                        "1",
                        "--no-nanny",
                        *common,
                    ],
                    stderr=subprocess.DEVNULL,
                )
            )
        deadline = time.monotonic() + TIMEOUT
        while not scheduler_file.exists():
            assert time.monotonic() < deadline, "the scheduler did not start"
            time.sleep(0.1)
        with Client(scheduler_file=str(scheduler_file), set_as_default=False) as client:
            client.wait_for_workers(workers, timeout=TIMEOUT)
            address = client.scheduler.address
        yield Cluster(address, processes[0], processes[1:])
    finally:
        for process in reversed(processes):  # workers first: the scheduler would wait on them
            process.kill()
            process.wait()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory) -> Iterator[Cluster]:
    with dask_cluster(tmp_path_factory.mktemp("cluster"), workers=2) as running:
        yield running


@pytest.fixture(scope="module")
def local_sequence(tmp_path_factory) -> Path:
    """The six frames rendered on this machine alone: the reference."""
    directory = tmp_path_factory.mktemp("local")
    assert main([str(ANIMATED), str(directory / "out.#.exr"), *SEQUENCE, "-q"]) == 0
    return directory


def frame_files(directory: Path) -> list[str]:
    return sorted(path.name for path in directory.iterdir())


def assert_identical(directory: Path, reference: Path) -> None:
    """Same files, same pixels bit for bit, same metadata but for the times."""
    assert frame_files(directory) == frame_files(reference)
    for name in frame_files(reference):
        pixels, channels, metadata = _core.read_image(str(directory / name))
        expected_pixels, expected_channels, expected = _core.read_image(str(reference / name))
        assert channels == expected_channels
        assert np.array_equal(pixels, expected_pixels), name
        for key in ("DateTime", "penumbra:renderTimeSeconds"):
            metadata.pop(key, None), expected.pop(key, None)
        assert metadata == expected, name


def written(stdout: str) -> list[str]:
    return sorted(
        Path(line.removeprefix("Wrote ")).name
        for line in stdout.splitlines()
        if line.startswith("Wrote ")
    )


def test_two_workers_render_a_sequence_bit_identical_to_a_local_render(
    cluster, local_sequence, tmp_path, capsys
):
    output = str(tmp_path / "out.#.exr")
    assert main([str(ANIMATED), output, *SEQUENCE, "--scheduler", cluster.address]) == 0
    captured = capsys.readouterr()
    assert written(captured.out) == frame_files(local_sequence)  # each frame once
    assert "Rendered 6 frames on 2 workers" in captured.out
    assert "frames 6/6 done" in captured.err
    assert_identical(tmp_path, local_sequence)


def test_a_frame_split_into_tiles_is_bit_identical_to_a_local_render(tmp_path, capsys):
    """One frame on a local cluster of two workers (--workers): four bands, with adaptive
    sampling, whose convergence tests look across band edges."""
    flags = ["-w", "96", "-spp", "32", "--adaptiveThreshold", "0.1", "--adaptiveMinSamples", "4"]
    (tmp_path / "local").mkdir()
    (tmp_path / "farm").mkdir()
    assert main([str(CORNELL), str(tmp_path / "local" / "frame.exr"), *flags, "-q"]) == 0
    farm = [str(CORNELL), str(tmp_path / "farm" / "frame.exr"), *flags, "--workers", "2"]
    assert main(farm) == 0
    assert "Rendered 1 frame in 4 tiles on 2 workers" in capsys.readouterr().out
    assert_identical(tmp_path / "farm", tmp_path / "local")
    mean_samples = _core.read_image_header(str(tmp_path / "farm" / "frame.exr"))[3]
    assert 4 < float(mean_samples["penumbra:meanSamples"]) < 32  # pixels did stop early


def test_the_stage_population_and_every_setting_reach_the_workers(cluster, tmp_path, capsys):
    """A session layer, a mask and non-default settings: the farm's frame is the local one,
    and each of them changed it."""
    session = tmp_path / "session.usda"
    session.write_text(
        '#usda 1.0\nover "World" {\n over "ceiling_light" {\n  float inputs:intensity = 40\n }\n}\n'
    )
    flags = [
        "-w",
        "48",
        "-spp",
        "4",
        "--seed",
        "3",
        "--maxPathDepth",
        "2",
        "-color",
        "disabled",
        "--purposes",
        "render",
    ]
    population = ["--sessionLayer", str(session), "--mask", "/cam,/World/room,/World/ceiling_light"]
    for name, extra in (("plain", []), ("local", population), ("farm", population)):
        (tmp_path / name).mkdir()
        farm = ["--scheduler", cluster.address] if name == "farm" else []
        assert main([str(CORNELL), str(tmp_path / name / "out.png"), *flags, *extra, *farm]) == 0
    capsys.readouterr()
    assert_identical(tmp_path / "farm", tmp_path / "local")
    plain, local = (
        _core.read_image(str(tmp_path / name / "out.png"))[0] for name in ("plain", "local")
    )
    assert not np.array_equal(plain, local)


def test_resume_after_an_interrupted_run_renders_only_what_is_missing(
    cluster, local_sequence, tmp_path, capsys
):
    output = str(tmp_path / "out.#.exr")
    run = subprocess.Popen(
        [*PENUMBRA_RECORD, str(ANIMATED), output, *SEQUENCE, "--scheduler", cluster.address],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        preexec_fn=default_sigint,
    )
    writes = (line for line in run.stdout if line.startswith("Wrote "))
    next(writes), next(writes)
    run.send_signal(signal.SIGINT)
    run.stdout.read()
    assert run.wait(timeout=TIMEOUT) == 130
    interrupted = frame_files(tmp_path)
    assert 2 <= len(interrupted) < 6
    missing = sorted(set(frame_files(local_sequence)) - set(interrupted))
    # An image under a missing frame's name that is another frame, and one that is no image:
    # neither is that frame, complete.
    (tmp_path / missing[0]).write_bytes((local_sequence / "out.1.exr").read_bytes())
    if len(missing) > 1:
        (tmp_path / missing[1]).write_bytes(b"not an image")
    before = {name: os.stat(tmp_path / name).st_mtime_ns for name in interrupted}

    assert main([str(ANIMATED), output, *SEQUENCE, "--resume", "--scheduler", cluster.address]) == 0
    out = capsys.readouterr().out
    assert written(out) == missing
    assert out.count("Skipped time code") == len(interrupted)
    assert {name: os.stat(tmp_path / name).st_mtime_ns for name in interrupted} == before
    assert_identical(tmp_path, local_sequence)


@pytest.mark.parametrize("where", ["farm", "local"])
def test_a_complete_frame_removes_a_checkpoint_state_left_beside_it(
    cluster, tmp_path, capsys, where
):
    # A killed --checkpoint render leaves a state file; a later render without checkpoints
    # (on a farm, or here) wrote the frame but left the state, so --resume rendered it again
    # at every run.
    output = tmp_path / "out.1.exr"
    Path(str(output) + STATE_SUFFIX).write_bytes(b"left by a killed render")
    args = [str(ANIMATED), str(tmp_path / "out.#.exr"), "-f", "1", "-w", "32", "-spp", "2"]
    farm = ["--scheduler", cluster.address] if where == "farm" else []
    assert main([*args, *farm]) == 0
    assert not Path(str(output) + STATE_SUFFIX).exists()
    capsys.readouterr()
    assert main([*args, *farm, "--resume"]) == 0
    assert "Skipped time code 1" in capsys.readouterr().out


def test_resume_on_this_machine_checks_the_settings_not_only_the_files(tmp_path, capsys):
    output = str(tmp_path / "out.#.png")
    flags = ["-f", "1:2", "-w", "32", "-spp", "2"]
    assert main([str(ANIMATED), output, *flags]) == 0
    assert main([str(ANIMATED), output, *flags, "--resume"]) == 0
    assert "Skipped time code 2" in capsys.readouterr().out
    assert main([str(ANIMATED), output, *flags, "--resume", "--seed", "7"]) == 0
    out = capsys.readouterr().out
    assert "Skipped" not in out and len(written(out)) == 2
    assert main([str(ANIMATED), output, *flags, "--resume", "--seed", "7", "--threads", "1"]) == 0
    assert capsys.readouterr().out.count("Skipped") == 2  # threads do not change pixels


def busy_worker_pid(client: Client) -> int:
    """The process id of a worker that is rendering a tile."""
    deadline = time.monotonic() + TIMEOUT
    while True:
        busy = [address for address, keys in client.processing().items() if keys]
        if busy:
            return client.run(os.getpid, workers=busy[:1])[busy[0]]
        assert time.monotonic() < deadline, "no worker took a tile"
        time.sleep(0.05)


def test_a_worker_killed_mid_sequence_loses_no_frame(local_sequence, tmp_path):
    """SIGKILL to the worker rendering a frame: the scheduler gives its task to the other
    worker; every frame is still written once, identical to the local render."""
    (tmp_path / "frames").mkdir()
    with (
        dask_cluster(tmp_path, workers=2) as own,
        Client(own.address, set_as_default=False) as client,
    ):
        run = subprocess.Popen(
            [
                *PENUMBRA_RECORD,
                str(ANIMATED),
                str(tmp_path / "frames" / "out.#.exr"),
                *SEQUENCE,
                "--scheduler",
                own.address,
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        lines = [next(line for line in run.stdout if line.startswith("Wrote "))]
        os.kill(busy_worker_pid(client), signal.SIGKILL)
        stdout, stderr = run.communicate(timeout=TIMEOUT)
        assert run.returncode == 0, stderr
        lines += stdout.splitlines()
        assert len(client.nthreads()) == 1  # the killed worker stayed dead
    assert written("\n".join(lines)) == frame_files(local_sequence)  # each frame once
    assert_identical(tmp_path / "frames", local_sequence)


def test_a_lost_scheduler_is_an_error_not_a_hang(tmp_path):
    with dask_cluster(tmp_path, workers=1) as own:
        run = subprocess.Popen(
            [
                *PENUMBRA_RECORD,
                str(ANIMATED),
                str(tmp_path / "out.#.exr"),
                *SEQUENCE,
                "--scheduler",
                own.address,
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        next(line for line in run.stdout if line.startswith("Wrote "))
        own.scheduler.kill()
        _, stderr = run.communicate(timeout=TIMEOUT)
    assert run.returncode == 1
    assert stderr.strip().splitlines()[-1] == (
        "penumbra-record: error: lost the connection to the Dask scheduler; the frames written "
        "so far are complete (--resume renders the others)"
    )


def test_a_worker_that_cannot_open_the_stage_fails_the_frame_with_its_message(cluster, tmp_path):
    broken = tmp_path / "broken.usda"
    broken.write_text("#usda 1.0\ndef Xform (\n")
    for stage, problem in ((broken, "broken.usda"), (tmp_path / "missing.usda", "missing.usda")):
        run = subprocess.run(
            [
                *PENUMBRA_RECORD,
                str(stage),
                str(tmp_path / "out.#.png"),
                "-f",
                "1:3",
                "--scheduler",
                cluster.address,
            ],
            capture_output=True,
            text=True,
            timeout=TIMEOUT,
        )
        assert run.returncode == 1
        error = run.stderr.strip().splitlines()[-1]
        # Both workers fail a frame at once; either may be reported first.
        assert re.match(
            r"penumbra-record: error: time code [12]: worker tcp://127\.0\.0\.1:", error
        )
        assert problem in error and "Traceback" not in run.stderr
    assert not list(tmp_path.glob("out*"))


def test_an_unreachable_scheduler_is_an_error_not_a_hang(tmp_path, capsys):
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        status = main([str(CORNELL), str(tmp_path / "out.exr"), "--scheduler", "tcp://127.0.0.1:9"])
    assert status == 1
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in capsys.readouterr().err


def test_farm_flags_are_checked(tmp_path, capsys):
    out = str(tmp_path / "out.exr")
    assert main([str(CORNELL), out, "--workers", "0"]) == 2
    assert "--workers must be at least 1" in capsys.readouterr().err
    assert main([str(CORNELL), out, "--workers", "2", "--scheduler", "tcp://127.0.0.1:9"]) == 2


def test_regions_render_exactly_the_pixels_of_the_whole_image():
    renderer = penumbra.Renderer(CORNELL)
    settings = dict(width=48, samples=16, adaptive_threshold=0.1, adaptive_min_samples=4)
    whole = renderer.render(**settings)
    part = renderer.render(**settings, region=(5, 7, 30, 11))
    assert np.array_equal(part["color"], whole["color"][7:18, 5:35])
    with pytest.raises(ValueError, match="not a non-empty part of the 48x27 image"):
        renderer.render(**settings, region=(40, 0, 9, 4))


def test_bands_cover_every_row_once_and_merge_back():
    assert [band_rows(10, band, 4) for band in range(4)] == [(0, 2), (2, 5), (5, 7), (7, 10)]
    assert band_rows(2, 0, 3) == (0, 0)  # more bands than rows: some are empty
    assert tiles_per_frame(frames=6, workers=2) == 1
    assert tiles_per_frame(frames=1, workers=2) == 4
    assert tiles_per_frame(frames=1, workers=2, denoise=True) == 1
    image = np.arange(10 * 3 * 4, dtype=np.float32).reshape(10, 3, 4)
    tiles = [
        Tile(
            first_row=first,
            end_row=end,
            width=3,
            height=10,
            aovs={"color": image[first:end]},
            # Adaptive sampling stops bands apart: band 3 ran the most passes (the first band
            # had given the merged frame its own).
            metadata={"samplesTaken": (end - first) * 3, "rays": 1, "renderTimeSeconds": 0.5,
                      "samplesDone": 8 * (band + 1), "lightPaths": 100 * (band + 1)},
            camera="/cam",
            worker="tcp://127.0.0.1:1",
        )
        for band, (first, end) in ((b, band_rows(10, b, 4)) for b in (2, 0, 3, 1))
    ]
    merged = merge_tiles(tiles)
    assert np.array_equal(merged["color"], image)
    assert merged.metadata["meanSamples"] == 1.0 and merged.metadata["rays"] == 4
    assert merged.metadata["samplesDone"] == 32 and merged.metadata["lightPaths"] == 400
    with pytest.raises(ValueError, match="do not cover"):
        merge_tiles(tiles[:3])
