"""The malformed-input corpus (malformed_corpus.py): every case ends with its asserted outcome,
no traceback, no partial output; plus malformed files and outputs."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import numpy as np
from pxr import Gf, Sdf, UsdGeom

from malformed_corpus import CASES, SCALE_ONLY, Case, write_case
import penumbra.renderer
from penumbra import _core, _interrupts
from penumbra.usd.camera import camera_problem
from processes import default_sigint
from penumbra.cli import main
from penumbra.errors import PenumbraWarning
from stages import add_preview_material, add_primvar_emission_material, bind, lit_quad_stage

SMALL = ("-w", "64", "-spp", "4", "-q")


@pytest.mark.parametrize("case", CASES, ids=[case.name for case in CASES])
def test_malformed_input(case: Case, tmp_path: Path, capsys) -> None:
    stage = write_case(case, tmp_path)
    out = tmp_path / "out.png"
    status = main([str(stage), str(out), *SMALL, *case.args])
    stderr = capsys.readouterr().err
    assert "Traceback" not in stderr
    assert status == case.exit, stderr
    assert case.expect in stderr
    assert out.exists() == (status == 0)
    if status == 0:
        assert "warning" in stderr


@pytest.mark.parametrize("name", ["mesh at 1e20", "mesh NaN transform", "mesh scaled 1e30"])
def test_a_mesh_out_of_reach_is_reported_once(name: str, tmp_path: Path, capsys) -> None:
    """Its transform (the scene delegate) or its world bounds (the render delegate): one
    warning, not one from each."""
    case = next(case for case in CASES if case.name == name)
    assert main([str(write_case(case, tmp_path)), str(tmp_path / "out.png"), *SMALL]) == 0
    assert capsys.readouterr().err.count("/quad:") == 1


BALL = 'def Sphere "ball"\n{\n    double radius = 0.5\n}'
FLAT_COPY = """def PointInstancer "inst"
{
    rel prototypes = [</inst/proto>]
    int[] protoIndices = %s
    point3f[] positions = %s
    float3[] scales = %s
    def Cube "proto"
    {
        double size = 0.5
    }
}"""


@pytest.mark.parametrize(
    ("flat", "without"),
    [
        (
            Case("", 0, "", mesh="float3 xformOp:scale = (0, 1, 1)\n" + SCALE_ONLY, extra=BALL),
            Case("", 0, "", mesh='token visibility = "invisible"', extra=BALL),
        ),
        (
            Case("", 0, "", extra=FLAT_COPY % ("[0, 0]", "[(0, 0, 1), (0.6, 0, 1)]", "[(1, 1, 1), (1, 0, 1)]")),
            Case("", 0, "", extra=FLAT_COPY % ("[0]", "[(0, 0, 1)]", "[(1, 1, 1)]")),
        ),
    ],
    ids=["mesh", "instance"],
)
def test_an_object_scaled_flat_renders_as_nothing(
    flat: Case, without: Case, tmp_path: Path, capsys
) -> None:
    """A scale of 0 on one axis (a common way to hide an object): nothing to see, and no ray
    may carry the non-finite coordinates its inverse would give (Embree's checks abort)."""
    images = []
    for name, case in (("flat", flat), ("without", without)):
        directory = tmp_path / name
        directory.mkdir()
        out = directory / "out.exr"
        assert main([str(write_case(case, directory)), str(out), *SMALL]) == 0
        images.append(np.asarray(_core.read_image(str(out))[0]))
    assert np.array_equal(images[0], images[1])
    assert images[0].max() > 0


def test_a_scale_too_near_0_to_invert_is_treated_as_0(tmp_path: Path, capsys) -> None:
    """The quad (flat in z) scaled by 1e-20 along z: single precision cannot carry rays through
    that inverse (Embree's checks aborted the whole render on the first ray to meet it), so it
    is not placed, as a scale of 0 is not (docs/design.md), and the render goes on."""
    case = Case("", 0, "", mesh="float3 xformOp:scale = (1, 1, 1e-20)\n" + SCALE_ONLY, extra=BALL)
    out = tmp_path / "out.exr"
    assert main([str(write_case(case, tmp_path)), str(out), *SMALL]) == 0
    image = np.asarray(_core.read_image(str(out))[0])
    assert image[..., 3].max() == 1  # the ball
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.parametrize(
    "content",
    [b"#usda 1.0\n(\x00\xff{{{ def def", b'#usda 1.0\ndef Xform "a\xac" {}\n'],  # 2nd: fuzzer
    ids=["garbage", "not UTF-8"],
)
def test_unreadable_usd_file(content: bytes, tmp_path: Path, capsys) -> None:
    stage = tmp_path / "garbage.usda"
    stage.write_bytes(content)
    assert main([str(stage), str(tmp_path / "out.png"), *SMALL]) == 1
    assert "garbage.usda" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("output", "status", "expect"),
    [
        ("out.xyz", 2, "cannot write .xyz"),
        ("missing/out.png", 1, "does not exist"),
        ("folder.png", 1, "is a directory"),
    ],
)
def test_output_checked_before_rendering(
    output: str, status: int, expect: str, tmp_path: Path, capsys
) -> None:
    (tmp_path / "folder.png").mkdir()
    stage = write_case(CASES[0], tmp_path)  # would fail later (its camera); the output first
    assert main([str(stage), str(tmp_path / output), *SMALL]) == status
    assert expect in capsys.readouterr().err


def test_stale_temporary_of_a_killed_writer_is_removed(tmp_path: Path, capsys) -> None:
    case = Case("valid", 0, "")
    stage = write_case(case, tmp_path)
    dead_pid = 2**22 + 1  # above pid_max's default: no such process
    stale = tmp_path / f".out.tmp{dead_pid}-0.png"
    stale.write_bytes(b"partial")
    # A live writer's (the parent process's: this process's own writer may reach any number).
    live = tmp_path / f".out.tmp{os.getppid()}-0.png"
    live.write_bytes(b"partial")
    assert main([str(stage), str(tmp_path / "out.png"), *SMALL]) == 0
    assert not stale.exists() and live.exists()


SIGNALLED_RUNS = 5  # each a new process: later renders in one process never lost one


@pytest.mark.parametrize(("signal_name", "status"), [("SIGINT", 130), ("SIGTERM", 143)])
def test_signal_stops_a_billion_sample_render(signal_name: str, status: int, tmp_path: Path) -> None:
    """The render stops with the signal's status, no traceback and no file left behind, the
    signal sent at once when the CLI names the camera, just before it says it is recording:
    it lands in the render's first reads of the stage (settings, camera), where USD's bindings
    lost it before (penumbra/_interrupts.py; exit 1 naming the camera, or a SystemError): in
    18 of 190 runs on a 2-core machine, from none to 1 in 5 as its load varied (sent at
    'Recording time code', a little later: 9 of 470). The test below makes it certain. How
    soon a render stops is measured by bench/latency.py."""
    stage = write_case(Case("valid", 0, ""), tmp_path)
    out = tmp_path / "out.exr"
    for _ in range(SIGNALLED_RUNS):
        _signal_as_the_camera_is_named(stage, out, getattr(signal, signal_name), status)
    assert list(tmp_path.glob("*out*")) == []


def _signal_as_the_camera_is_named(stage: Path, out: Path, signum: int, status: int) -> None:
    process = subprocess.Popen(
        [sys.executable, "-u", "-m", "penumbra.cli", str(stage), str(out)]
        + ["-w", "64", "-spp", "1000000000"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=default_sigint,
    )
    # Should the line below never come, the render is killed (and the status assert fails).
    watchdog = threading.Timer(120, process.kill)
    watchdog.start()
    try:
        # Once the stage is open and the CLI renders: a fixed wait lost the race on a loaded
        # machine, and a signal before Python has installed its handlers ends any Python
        # program by the signal's default action.
        for line in process.stdout:
            if line.startswith("Camera:"):
                break
        process.send_signal(signum)
        # Without the signal the render would take days: the bound only stops a hung test.
        stderr = process.communicate(timeout=120)[1]
        assert process.returncode == status, stderr
        assert "Traceback" not in stderr
    finally:  # a render that missed the signal would run on, and slow every later test
        watchdog.cancel()
        if process.poll() is None:
            process.kill()
            process.wait()


@pytest.mark.parametrize(("signal_name", "status"), [("SIGINT", 130), ("SIGTERM", 143)])
def test_a_signal_while_the_camera_is_read_stops_the_run(
    signal_name: str, status: int, tmp_path: Path, monkeypatch
) -> None:
    """The race above made certain: the signal comes while the camera is read before the
    render, and the read swallows the exception its handler raises, as USD's bindings do
    (penumbra/_interrupts.py). Held until the reads end, it stops the run; lost, the short
    render would end and write its image."""
    signum = getattr(signal, signal_name)
    swallowed = []

    def camera_problem_signalled(prim, time_code):
        try:
            os.kill(os.getpid(), signum)
            time.sleep(0.05)  # the handler runs by now
        except (KeyboardInterrupt, _interrupts.Terminated):
            swallowed.append(signum)
        return camera_problem(prim, time_code)

    monkeypatch.setattr(penumbra.renderer, "camera_problem", camera_problem_signalled)
    stage = write_case(Case("valid", 0, ""), tmp_path)
    out = tmp_path / "out.png"
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # as in the foreground
    try:
        # SIGTERM arrives only while main() has its own handler in place.
        assert main([str(stage), str(out), *SMALL]) == status
    finally:
        signal.signal(signal.SIGINT, previous)
    assert swallowed == [] and not out.exists()


def test_a_ctrl_c_while_usd_loads_is_raised_once_it_has_loaded() -> None:
    """USD's module loader turns exceptions raised while it imports into warnings
    (penumbra/_interrupts.py): a Ctrl-C then was lost and the render ran on. Held, it is raised
    as the imports end, and Python's own handler is back."""
    swallowed = []
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # as in the foreground
    try:
        with pytest.raises(KeyboardInterrupt):
            with _interrupts.deferred():
                try:
                    os.kill(os.getpid(), signal.SIGINT)
                    time.sleep(0.05)  # the handler runs by now
                except KeyboardInterrupt:  # as USD's loader does
                    swallowed.append(True)
        assert not swallowed
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, previous)


def test_a_sigterm_while_usd_runs_is_raised_once_the_outer_block_ends() -> None:
    """penumbra-record's SIGTERM (Terminated) is held as Ctrl-C is, while the stage is read;
    a block nested in another (a Renderer made by a JobRenderer) holds it to the outer end."""
    swallowed, ends = [], []
    with _interrupts.TerminateAsInterrupt():
        handler = signal.getsignal(signal.SIGTERM)
        with pytest.raises(_interrupts.Terminated):
            with _interrupts.deferred():
                with _interrupts.deferred():
                    try:
                        os.kill(os.getpid(), signal.SIGTERM)
                        time.sleep(0.05)  # the handler runs by now
                    except _interrupts.Terminated:  # as USD's bindings do
                        swallowed.append(True)
                ends.append("inner")
        assert not swallowed and ends == ["inner"]
        assert signal.getsignal(signal.SIGTERM) is handler


@pytest.mark.parametrize("signal_name", ["SIGINT", "SIGTERM"])
def test_a_programs_own_handler_is_left_alone(signal_name: str) -> None:
    signum = getattr(signal, signal_name)
    received = []
    previous = signal.signal(signum, lambda number, _frame: received.append(number))
    try:
        with _interrupts.deferred():
            os.kill(os.getpid(), signum)
            time.sleep(0.05)
        assert received == [signum]
    finally:
        signal.signal(signum, previous)


def test_deferring_in_another_thread_changes_nothing() -> None:
    """A Renderer used in a thread (only the main thread may set signal handlers)."""
    failures = []

    def read() -> None:
        try:
            with _interrupts.deferred():
                pass
        except Exception as error:
            failures.append(error)

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # a handler it defers
    try:
        thread = threading.Thread(target=read)
        thread.start()
        thread.join()
        assert failures == []  # not "signal only works in main thread"
    finally:
        signal.signal(signal.SIGINT, previous)


FUZZ_HARNESS = Path(__file__).resolve().parents[1] / "fuzz" / "fuzz_scene.py"


@pytest.mark.parametrize("failing", [False, True], ids=["clean", "error"])
def test_fuzz_harness_leaves_no_scratch_directory(failing: bool, tmp_path: Path) -> None:
    """libFuzzer ends its process with C's exit(), which skips Python's clean-up: the harness's
    scratch directory must go all the same, and libFuzzer's exit status must come through."""
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    arguments = [sys.executable, str(FUZZ_HARNESS), "-runs=2", "-seed=1"]
    if failing:  # libFuzzer stops with an error status when its dictionary cannot be read
        arguments.append(f"-dict={tmp_path / 'missing.dict'}")
    environment = {**os.environ, "TMPDIR": str(scratch)}
    result = subprocess.run(
        arguments, cwd=tmp_path, env=environment, capture_output=True, text=True, timeout=300
    )
    assert (result.returncode != 0) == failing, result.stderr[-2000:]
    assert list(scratch.iterdir()) == []


@pytest.mark.parametrize(
    "mesh",
    [
        "int[] faceVertexIndices = [0, 1, 2, 9]",
        "point3f[] points = [(nan, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]",
    ],
)
def test_a_subdivision_surface_whose_cage_is_malformed_is_reported_once(
    mesh: str, tmp_path: Path, capsys
) -> None:
    # USD's default scheme is catmullClark: the subdivision failed first, and its warning said
    # the cage would render, before the cage failed with a second warning that skipped it.
    stage = write_case(Case("malformed cage", 0, "/quad", mesh=mesh), tmp_path)
    assert main([str(stage), str(tmp_path / "out.png"), *SMALL]) == 0
    warnings = [line for line in capsys.readouterr().err.splitlines() if "/quad" in line]
    assert len(warnings) == 1, warnings
    assert "the mesh is skipped" in warnings[0]


def test_an_emission_that_is_not_finite_renders_no_nan() -> None:
    # emissiveColor is added to the image as it is: a NaN constant or a NaN a network reads
    # (here a primvar) made NaN pixels without a word.
    constant = lit_quad_stage()
    quad = UsdGeom.Mesh(constant.GetPrimAtPath("/World/quad"))
    bind(quad, add_preview_material(constant, "/World/glow", emissiveColor=(math.nan, 1.0, 1.0)))
    with pytest.warns(PenumbraWarning, match="/World/glow: emissiveColor must be finite"):
        image = penumbra.Renderer(constant).render(camera="/cam", width=16, samples=4)
    assert np.isfinite(image["color"]).all()

    read = lit_quad_stage()
    quad = UsdGeom.Mesh(read.GetPrimAtPath("/World/quad"))
    UsdGeom.PrimvarsAPI(quad).CreatePrimvar(
        "glow", Sdf.ValueTypeNames.Float3, UsdGeom.Tokens.constant
    ).Set(Gf.Vec3f(math.nan, 1, 1))
    bind(quad, add_primvar_emission_material(read, "/World/glow", "glow"))
    image = penumbra.Renderer(read).render(camera="/cam", width=16, samples=4)
    assert np.isfinite(image["color"]).all()
