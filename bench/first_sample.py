"""What the scale benchmarks (groom.py, points_scale.py) share: a stage written to a temporary
file by a child process (so that authoring costs the measured process no memory), then opened
with ``Usd.Stage.Open``, synced and rendered for one sample per pixel through
``penumbra.Renderer``, with the times of each step and the peak resident memory."""

from __future__ import annotations

import multiprocessing
import resource
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from pxr import Gf, Usd, UsdGeom, UsdLux

import penumbra


def peak_memory_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def add_camera_and_sun(stage: Usd.Stage, distance: float) -> None:
    """Camera /cam on the +z axis at ``distance``, looking down −z, and a normalised sun."""
    camera = UsdGeom.Camera.Define(stage, "/cam")
    camera.CreateFocalLengthAttr(35)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.1, 100))
    camera.AddTranslateOp().Set(Gf.Vec3d(0, 0, distance))
    sun = UsdLux.DistantLight.Define(stage, "/sun")
    sun.CreateIntensityAttr(3)
    sun.CreateNormalizeAttr(True)
    sun.AddRotateXYZOp().Set(Gf.Vec3f(-35, 30, 0))


def author_and_measure(
    write: Callable[[str, int], None], name: str, count: int, width: int
) -> tuple[float, float, FirstSample]:
    """``write(path, count)`` into a temporary ``name`` in a child process, then
    :func:`measure` it through /cam: the write time, the file's size in MB and the result."""
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / name
        written = author_in_child(write, str(path), count)
        size_mb = path.stat().st_size / 2**20
        return written, size_mb, measure(path, "/cam", width)


def author_in_child(write: Callable[..., None], *args) -> float:
    """Run ``write(*args)`` in a forked child process; its wall time in seconds."""
    started = time.perf_counter()
    child = multiprocessing.get_context("fork").Process(target=write, args=args)
    child.start()
    child.join()
    if child.exitcode != 0:
        raise SystemExit(f"writing the stage failed (exit status {child.exitcode})")
    return time.perf_counter() - started


@dataclass
class FirstSample:
    open_seconds: float  # Usd.Stage.Open
    sync_seconds: float  # the scene delegate's first sync
    render_seconds: float  # the first pass: geometry, BVHs, one sample per pixel
    peak_mb: float  # peak resident memory of this process
    before_mb: float  # its peak before the stage was opened
    coverage: float  # mean alpha of the image: the geometry was seen

    @property
    def total_seconds(self) -> float:
        return self.open_seconds + self.sync_seconds + self.render_seconds


def measure(path: Path, camera: str, width: int) -> FirstSample:
    """Open ``path``, sync it and render one sample per pixel through ``camera``."""
    before = peak_memory_mb()
    started = time.perf_counter()
    stage = Usd.Stage.Open(str(path))
    opened = time.perf_counter()
    with penumbra.Renderer(stage) as renderer:
        renderer.sync()
        synced = time.perf_counter()
        image = renderer.render(camera=camera, width=width, samples=1)
        rendered = time.perf_counter()
    return FirstSample(
        opened - started,
        synced - opened,
        rendered - synced,
        peak_memory_mb(),
        before,
        float(image["color"][..., 3].mean()),
    )


def verdict(value: float, target: float) -> str:
    return f"{value:.1f} ({'within' if value < target else 'OVER'} {target:g})"
