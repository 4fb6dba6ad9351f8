"""The client side of a farm render: connects to a Dask cluster (or starts one on loopback),
hands out tiles of frames, puts frames together, writes each once and reports progress.

Workers open the job's stage themselves (same paths: a shared file system) and return pixels;
the client alone writes the images, atomically, as each frame's last tile arrives, so a frame
is written once even when Dask runs one of its tiles twice (a worker lost mid-task: Dask
reschedules its tasks on the workers left, up to ``distributed.scheduler.allowed-failures``
times). Frames are handed out a few at a time, so a sequence of any length costs the same
memory.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import sys
import time
import uuid
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import CancelledError
from contextlib import contextmanager
from dataclasses import dataclass, field

import dask.config
from dask.utils import parse_timedelta
from distributed import Client, Future, KilledWorker, LocalCluster, wait

from ..checkpoints import remove_state, state_file
from ..errors import warn
from ..jobs import FrameTime, RenderJob, frame_label, output_is_complete
from .tiles import Tile, merge_tiles
from .worker import PLUGIN_NAME, FrameFailed, JobRenderers, render_tile

NO_WORKER_TIMEOUT = 60.0
"""Seconds a render waits while the cluster has no worker before it fails (never a hang)."""
POLL_SECONDS = 0.5
MAX_TILES_PER_FRAME = 64
_log = logging.getLogger("penumbra.farm")


class FarmError(RuntimeError):
    """The farm could not render: a frame failed (the message names it and the worker's
    message), the scheduler is unreachable, or the cluster has no workers."""


@dataclass
class FarmSummary:
    """What a farm render did."""

    written: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    tiles: int = 1
    """Bands per frame."""
    workers_used: set[str] = field(default_factory=set)
    """The addresses of the workers whose tiles made the frames written."""


def tiles_per_frame(frames: int, workers: int, denoise: bool = False) -> int:
    """How many bands each frame is cut into: one while there are at least as many frames as
    workers, else enough for about two tiles per worker. Denoised frames are never cut: the
    denoiser looks across the whole frame, so a denoised band would differ near its edges."""
    if frames >= workers or denoise:
        return 1
    return min(MAX_TILES_PER_FRAME, math.ceil(2 * workers / max(frames, 1)))


@contextmanager
def connect(scheduler: str | None, workers: int | None) -> Iterator[Client]:
    """A client of the scheduler at ``scheduler`` (waiting at most Dask's
    ``distributed.comm.timeouts.connect``), or of a new local cluster of ``workers``
    single-threaded worker processes on loopback, closed on exit."""
    if scheduler:
        timeout = parse_timedelta(dask.config.get("distributed.comm.timeouts.connect"))
        try:
            client = Client(scheduler, timeout=timeout)
        except (OSError, TimeoutError) as error:
            raise FarmError(f"cannot reach the Dask scheduler at {scheduler}: {error}") from None
        with client:
            yield client
        return
    with (
        LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            silence_logs=logging.CRITICAL,  # the client reports failures itself
        ) as cluster,
        Client(cluster) as client,
    ):
        yield client


def record_on_farm(
    job: RenderJob,
    frames: Iterable[FrameTime],
    frame_count: int,
    output_path: Callable[[FrameTime], str],
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    resume: bool = False,
    tiles: int | None = None,
    say: Callable[[str], None] = print,
    progress: bool = True,
    no_worker_timeout: float = NO_WORKER_TIMEOUT,
) -> FarmSummary:
    """Render ``frames`` (``frame_count`` of them) of ``job`` on the cluster at ``scheduler``
    or on a local one of ``workers`` processes, writing each to ``output_path(frame)``.

    ``resume`` skips frames whose output holds their key (:func:`output_is_complete`).
    ``tiles``: bands per frame (default :func:`tiles_per_frame`). Raises :class:`FarmError`
    for the first frame that fails, after cancelling the others; frames written by then stay
    (complete), so ``resume`` continues from them.
    """
    if workers and job.options.get("threads", 0) == 0:
        # "Every core" of a machine that a local cluster's workers share: each gets its part
        # rather than N threads per core. Threads change no pixel (nor the resume key).
        threads = max(1, len(os.sched_getaffinity(0)) // workers)
        job = dataclasses.replace(job, options={**job.options, "threads": threads})
    with connect(scheduler, workers) as client:
        client.register_plugin(JobRenderers(), name=PLUGIN_NAME)
        worker_count = _wait_for_workers(
            client, workers or 1, scheduler or "the local cluster", no_worker_timeout
        )
        bands = tiles_per_frame(frame_count, worker_count, job.denoise)
        if tiles and not job.denoise:
            bands = tiles
        reporter = _ProgressReporter(frame_count, bands) if progress else None
        run = _FarmRun(client, job, output_path, bands, resume, say, reporter, no_worker_timeout)
        started = time.perf_counter()
        try:
            run.render(frames)
        finally:
            client.cancel(list(run.pending))
        summary = run.summary
        if summary.written:
            count = len(summary.written)
            split = f" in {bands} tiles" if bands > 1 else ""
            say(
                f"Rendered {count} frame{'s' if count > 1 else ''}{split} on "
                f"{len(summary.workers_used)} worker{'s' if len(summary.workers_used) > 1 else ''} "
                f"in {time.perf_counter() - started:.1f} s"
            )
        return summary


def _wait_for_workers(client: Client, count: int, where: str, timeout: float) -> int:
    """How many workers the cluster has, once it has ``count``."""
    try:
        client.wait_for_workers(count, timeout=timeout)
    except TimeoutError:
        raise FarmError(
            f"{where} has had fewer than {count} Dask workers for {timeout:g} s"
        ) from None
    return len(client.nthreads())


class _FarmRun:
    """One render's bookkeeping: tiles in flight, tiles received per frame, frames written."""

    def __init__(
        self,
        client: Client,
        job: RenderJob,
        output_path: Callable[[FrameTime], str],
        bands: int,
        resume: bool,
        say: Callable[[str], None],
        reporter: _ProgressReporter | None,
        no_worker_timeout: float,
    ):
        self.client = client
        self.job = job
        self.job_id = uuid.uuid4().hex  # workers reopen the stage for each new run
        self.output_path = output_path
        self.bands = bands
        self.resume = resume
        self.say = say
        self.reporter = reporter
        self.no_worker_timeout = no_worker_timeout
        self.pending: dict[Future, tuple[int, int]] = {}  # future -> (frame index, band)
        self.workers_seen: set[str] = set(client.nthreads())
        self.frames: dict[int, tuple[FrameTime, str, list[Tile]]] = {}
        self.warnings_seen: set[str] = set()
        self.camera_named = False
        self.summary = FarmSummary(tiles=bands)

    def render(self, frames: Iterable[FrameTime]) -> None:
        upcoming = enumerate(frames)
        exhausted = False
        while True:
            # Two frames per worker in flight: one rendering, one queued (workers may join).
            while not exhausted and len(self.frames) < 2 * max(1, len(self.workers_seen)):
                entry = next(upcoming, None)
                if entry is None:
                    exhausted = True
                else:
                    self._submit(*entry)
            if not self.pending:
                return
            try:
                done = self._wait_for_some()
            except (CancelledError, OSError):  # OSError: Dask's CommClosedError
                raise FarmError(
                    "lost the connection to the Dask scheduler; the frames written so far are "
                    "complete (--resume renders the others)"
                ) from None
            # Earlier frames first, so that of several failures the first frame's is reported.
            for future in sorted(done, key=lambda finished: self.pending[finished]):
                self._receive(future)

    def _submit(self, index: int, frame: FrameTime) -> None:
        output = self.output_path(frame)
        if self.resume and output_is_complete(output, self.job.frame_key(frame)):
            self.say(f"Skipped time code {frame_label(frame)}: {output} is complete")
            self.summary.skipped.append(output)
            if self.reporter:
                self.reporter.skipped()
            return
        self.frames[index] = (frame, output, [])
        for band in range(self.bands):
            future = self.client.submit(
                render_tile,
                self.job_id,
                self.job,
                frame,
                band,
                self.bands,
                key=f"penumbra-tile-{self.job_id}-{index}-{band}",
                priority=-index,  # earlier frames first: frames finish in order
            )
            self.pending[future] = (index, band)

    def _wait_for_some(self) -> set[Future]:
        """The finished futures, once there is one; :class:`FarmError` after
        ``no_worker_timeout`` seconds without a worker in the cluster."""
        without_workers_since: float | None = None
        while True:
            if self._check_workers():
                without_workers_since = None
            else:
                now = time.monotonic()
                without_workers_since = without_workers_since or now
                if now - without_workers_since > self.no_worker_timeout:
                    index = min(index for index, _ in self.pending.values())
                    raise FarmError(
                        f"time code {frame_label(self.frames[index][0])}: the cluster has had "
                        f"no worker for {self.no_worker_timeout:g} s"
                    )
            try:
                done, _ = wait(
                    list(self.pending), timeout=POLL_SECONDS, return_when="FIRST_COMPLETED"
                )
                return done
            except TimeoutError:
                pass

    def _check_workers(self) -> int:
        """How many workers the cluster has; logs those that left it since the last look."""
        workers = set(self.client.nthreads())
        for address in sorted(self.workers_seen - workers):
            _log.info("worker %s left the cluster; Dask gives its tiles to the others", address)
        self.workers_seen = workers
        return len(workers)

    def _receive(self, future: Future) -> None:
        index, _band = self.pending.pop(future)
        frame, output, tiles = self.frames[index]
        if future.status != "finished":
            raise FarmError(f"time code {frame_label(frame)}: {_failure(future)}")
        tile: Tile = future.result()
        self._report_worker_news(tile)
        tiles.append(tile)
        self.summary.workers_used.add(tile.worker)
        if self.reporter:
            self.reporter.tile_done()
        if len(tiles) < self.bands:
            return
        del self.frames[index]
        merge_tiles(tiles).write(output, color_mode=self.job.color_mode)
        # A checkpoint left by an earlier, killed local render would mark it unfinished.
        remove_state(state_file(output))
        self.summary.written.append(output)
        self.say(f"Wrote {os.path.abspath(output)}")
        if self.reporter:
            self.reporter.frame_done()

    def _report_worker_news(self, tile: Tile) -> None:
        """The camera (once) and each distinct warning the workers gave."""
        if not self.camera_named:
            self.say(f"Camera: {tile.camera}")
            self.camera_named = True
        for message in tile.warnings:
            if message not in self.warnings_seen:
                self.warnings_seen.add(message)
                warn(message)


def _failure(future: Future) -> str:
    """What went wrong with a future that did not finish."""
    if future.status == "cancelled":
        return "its task was cancelled (the scheduler lost it or shut down)"
    error = future.exception()
    if isinstance(error, KilledWorker):
        return f"every worker that took it died ({error})"
    return str(error) if isinstance(error, FrameFailed) else f"{type(error).__name__}: {error}"


class _ProgressReporter:
    """Frames (and tiles) done across the cluster, elapsed time and time left, on stderr:
    updated in place on a terminal, else a line per frame written."""

    def __init__(self, frames: int, bands: int):
        self.frames = frames
        self.bands = bands
        self.frames_done = 0
        self.frames_skipped = 0
        self.tiles_done = 0
        self.started = time.perf_counter()
        self.interactive = sys.stderr.isatty()

    def skipped(self) -> None:
        self.frames_skipped += 1

    def tile_done(self) -> None:
        self.tiles_done += 1
        if self.interactive and self.bands > 1:
            self._show(final=False)

    def frame_done(self) -> None:
        self.frames_done += 1
        self._show(final=self.frames_done + self.frames_skipped == self.frames)

    def _show(self, final: bool) -> None:
        elapsed = time.perf_counter() - self.started
        to_render = (self.frames - self.frames_skipped) * self.bands
        line = f"frames {self.frames_done + self.frames_skipped}/{self.frames} done"
        if self.frames_skipped:
            line += f" ({self.frames_skipped} skipped)"
        if self.bands > 1:
            line += f", tiles {self.tiles_done}/{to_render}"
        line += f", {elapsed:.1f} s"
        if 0 < self.tiles_done < to_render:
            line += (
                f", about {elapsed * (to_render - self.tiles_done) / self.tiles_done:.0f} s left"
            )
        if self.interactive:
            sys.stderr.write(f"\r\033[K{line}" + ("\n" if final else ""))
        else:
            sys.stderr.write(f"{line}\n")
        sys.stderr.flush()
