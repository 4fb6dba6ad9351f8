"""What a Dask worker runs: one tile (a band of rows) of one frame of a job.

Every worker keeps the :class:`~penumbra.jobs.JobRenderer` of the job it last served (the
:class:`JobRenderers` plugin), so the frames it renders after its first reuse the opened,
synced stage and sync only what changes between frames. Renders on one worker take turns: each
already uses every core the job's ``threads`` setting allows.
"""

from __future__ import annotations

import threading
import warnings
from collections.abc import Iterator
from contextlib import contextmanager

from distributed import WorkerPlugin, get_worker

from ..errors import PenumbraWarning, SceneError
from ..jobs import FrameTime, JobRenderer, RenderJob
from .tiles import Tile, band_rows

PLUGIN_NAME = "penumbra-job-renderers"


class FrameFailed(RuntimeError):
    """A worker could not render a frame; the message starts with the worker's address."""


class JobRenderers(WorkerPlugin):
    """The worker's :class:`JobRenderer` of the last job it served, shared by its tasks one
    at a time."""

    name = PLUGIN_NAME

    def setup(self, worker) -> None:
        self._lock = threading.Lock()
        self._job_id: str | None = None
        self._renderer: JobRenderer | None = None

    def teardown(self, worker) -> None:
        with self._lock:
            self._drop()

    @contextmanager
    def renderer(self, job_id: str, job: RenderJob) -> Iterator[JobRenderer]:
        """The renderer of job ``job_id``, opened on first use, held for one task."""
        with self._lock:
            if self._job_id != job_id:
                self._drop()  # before opening: the old job's layers are released first
                self._renderer = JobRenderer(job)
                self._job_id = job_id
            assert self._renderer is not None
            yield self._renderer

    def _drop(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
        self._renderer = None
        self._job_id = None


def render_tile(job_id: str, job: RenderJob, frame: FrameTime, band: int, bands: int) -> Tile:
    """The Dask task: render band ``band`` of ``bands`` of ``frame``. Any failure becomes
    :class:`FrameFailed` with the worker's address and message (no traceback to ship)."""
    worker = get_worker()
    failure: str | None = None
    try:
        with (
            worker.plugins[PLUGIN_NAME].renderer(job_id, job) as renderer,
            warnings.catch_warnings(record=True) as caught,
        ):
            warnings.simplefilter("always", PenumbraWarning)
            width, height = renderer.image_size(frame)
            first, end = band_rows(height, band, bands)
            image = None
            if end > first:
                region = None if bands == 1 else (0, first, width, end - first)
                image = renderer.render(frame, region=region)
    except Exception as error:  # reported by the client; retrying elsewhere would fail alike
        failure = f"worker {worker.address}: {_describe(error)}"
    if failure is not None:
        # Raised outside the handler: the error's context (e.g. USD's unpicklable Tf errors)
        # would make Dask send a bare Exception instead.
        raise FrameFailed(failure)
    return Tile(
        first_row=first,
        end_row=end,
        width=width,
        height=height,
        aovs={name: image[name] for name in image} if image is not None else {},
        metadata=dict(image.metadata) if image is not None else {},
        camera=renderer.camera,
        worker=worker.address,
        warnings=[str(warning.message) for warning in caught],
    )


def _describe(error: Exception) -> str:
    """An error as the CLI reports it: expected failures by their message, others with their
    type."""
    if isinstance(error, (SceneError, RuntimeError, OSError, ValueError)):
        return str(error)
    return f"{type(error).__name__}: {error}"
