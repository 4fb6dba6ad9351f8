"""What ``penumbra-record`` prints: frame progress, frame summaries, warnings and notes."""

from __future__ import annotations

import logging
import resource
import sys
import time
import warnings

from .cli_arguments import PROG
from .errors import PenumbraWarning
from .image import Image


class Progress:
    """Prints ``samples done / total``, the elapsed time and an estimate of the time left of a
    frame on stderr: updated in place on a terminal, else one line per quarter of the frame
    (logs stay short). The estimate takes the pace of the samples rendered since the first
    report, so that samples a resumed checkpoint brought (done before this process started)
    and the scene's sync do not count as rendered at this pace."""

    def __init__(self, label: str, interactive: bool | None = None) -> None:
        self.label = label
        self.started = time.perf_counter()
        self.interactive = sys.stderr.isatty() if interactive is None else interactive
        self.quarters_reported = 0
        self.line_open = False
        """Whether the terminal's progress line awaits its end."""
        self.first_report: tuple[float, int] | None = None
        """(seconds since the start, samples done) at the first report."""

    def __call__(self, done: int, total: int) -> None:
        elapsed = time.perf_counter() - self.started
        line = f"{self.label}: {done}/{total} samples, {elapsed:.1f} s"
        if self.first_report is None:
            self.first_report = (elapsed, done)
        if self.interactive:
            first_seconds, first_done = self.first_report
            if first_done < done < total:
                pace = (elapsed - first_seconds) / (done - first_done)
                line += f", about {pace * (total - done):.0f} s left"
            self.line_open = done < total
            end = "" if self.line_open else "\n"
            sys.stderr.write(f"\r\033[K{line}{end}")
        elif 4 * done // total > self.quarters_reported:
            self.quarters_reported = 4 * done // total
            sys.stderr.write(f"{line}\n")
        sys.stderr.flush()

    def end(self) -> None:
        """Call when the render has finished: ends the terminal's line if the render stopped
        short of its last sample (``--timeLimit``), so that what follows starts a line."""
        if self.line_open:
            sys.stderr.write("\n")
            sys.stderr.flush()
            self.line_open = False


class RendersProgress:
    """The progress of a frame rendered in several renders (render products in several
    groups): a :class:`Progress` per render, labelled with its products, since each counts its
    own samples."""

    def __init__(self, label: str, interactive: bool | None = None) -> None:
        self.label = label
        self.interactive = interactive
        self.current: Progress | None = None

    def __call__(self, products: str) -> Progress:
        """The progress callback of the render of ``products``; the one before has ended."""
        self.end()
        self.current = Progress(f"{self.label} ({products})", self.interactive)
        return self.current

    def end(self) -> None:
        if self.current is not None:
            self.current.end()


def peak_memory_bytes() -> int:
    """The process's peak resident set size so far."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: kilobytes


def frame_summary(label: str, image: Image) -> str:
    """One line about a finished frame: time, samples per pixel (their mean where adaptive
    sampling or the time limit stopped pixels early), rays per second, peak memory."""
    seconds = max(float(image.metadata["renderTimeSeconds"]), 1e-9)
    samples = int(image.metadata["samples"])
    mean = float(image.metadata["meanSamples"])
    stopped = bool(image.metadata.get("stoppedByTimeLimit"))
    cap = int(image.metadata["samplesDone"]) if stopped else samples
    taken = f"{cap}" if mean == cap else f"{mean:.1f} (at most {cap})"
    if stopped:
        taken += f" of {samples} (time limit reached)"
    rays = int(image.metadata["rays"]) / seconds
    return (
        f"{label}: {image.width}x{image.height}, {taken} samples/pixel in {seconds:.2f} s "
        f"({rays / 1e6:.2f} M rays/s), peak memory {peak_memory_bytes() / 2**20:.0f} MB"
    )


def show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Penumbra warnings as ``penumbra-record: warning: …`` lines on stderr."""
    if issubclass(category, PenumbraWarning):
        sys.stderr.write(f"{PROG}: warning: {message}\n")
    else:
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


def report_information() -> None:
    """Show the library's informational messages (e.g. default lighting) on stderr."""
    logger = logging.getLogger("penumbra")
    if not any(isinstance(handler, _StderrHandler) for handler in logger.handlers):
        handler = _StderrHandler()
        handler.setFormatter(logging.Formatter(f"{PROG}: note: %(message)s"))
        logger.addHandler(handler)
    logger.setLevel(logging.INFO)


class _StderrHandler(logging.StreamHandler):
    """Writes to the current sys.stderr (which tests may capture after import)."""

    def emit(self, record: logging.LogRecord) -> None:
        self.stream = sys.stderr
        super().emit(record)
