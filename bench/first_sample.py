"""What the scale benchmarks (groom.py, points_scale.py) share: a stage written to a temporary
file by a child process (so that authoring costs the measured process no memory), then opened
with ``Usd.Stage.Open``, synced and rendered for one sample per pixel through
``penumbra.Renderer``, with the times of each step and the peak resident memory."""

from __future__ import annotations

import multiprocessing
import resource
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from pxr import Usd

import penumbra


def peak_memory_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


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
