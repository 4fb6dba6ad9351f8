"""Timing traces of a render (``penumbra-record --traceToFile``).

A :class:`Tracer` records named, nested spans of wall-clock time and writes them as a Chrome
trace (``chrome://tracing`` or Perfetto: complete events, ``"ph": "X"``, microseconds) or as
a plain-text report (``trace``), the two formats of usdrecord's ``--traceFormat``.
"""

from __future__ import annotations

import json
import os
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

TRACE_FORMATS = ("chrome", "trace")


@dataclass
class Span:
    name: str
    start_us: float
    duration_us: float = 0.0
    depth: int = 0
    args: dict[str, str | int | float] = field(default_factory=dict)


class Tracer:
    """Collects spans; a disabled tracer records nothing and costs nothing."""

    def __init__(self, enabled: bool = True):
        self.enabled = enabled
        self.spans: list[Span] = []
        self._origin = time.perf_counter()
        self._depth = 0

    def _now_us(self) -> float:
        return (time.perf_counter() - self._origin) * 1e6

    @contextmanager
    def span(self, name: str, **args: str | int | float) -> Iterator[None]:
        """Time the ``with`` block as span ``name`` (``args`` are shown with it)."""
        if not self.enabled:
            yield
            return
        record = Span(name, self._now_us(), depth=self._depth, args=dict(args))
        self.spans.append(record)
        self._depth += 1
        try:
            yield
        finally:
            self._depth -= 1
            record.duration_us = self._now_us() - record.start_us

    def now_us(self) -> float:
        """Microseconds since the tracer was made (the clock of its spans)."""
        return self._now_us()

    def add(
        self, name: str, start_us: float, duration_us: float, **args: str | int | float
    ) -> None:
        """Record a span measured elsewhere (e.g. totals the C++ side keeps) inside the span
        open now."""
        if self.enabled:
            self.spans.append(Span(name, start_us, duration_us, self._depth, dict(args)))

    def chrome(self) -> dict:
        """The spans as a Chrome trace event document."""
        pid, tid = os.getpid(), threading.get_ident() % 2**31
        events = [
            {
                "name": span.name,
                "cat": "penumbra",
                "ph": "X",
                "ts": round(span.start_us, 3),
                "dur": round(span.duration_us, 3),
                "pid": pid,
                "tid": tid,
                "args": span.args,
            }
            for span in self.spans
        ]
        return {"traceEvents": events, "displayTimeUnit": "ms"}

    def report(self) -> str:
        """The spans as an indented text report (milliseconds)."""
        lines = ["Penumbra trace (wall-clock milliseconds)"]
        for span in self.spans:
            extra = " ".join(f"{key}={value}" for key, value in span.args.items())
            lines.append(
                f"{'  ' * span.depth}{span.name}: {span.duration_us / 1000:.3f} ms"
                + (f" ({extra})" if extra else "")
            )
        return "\n".join(lines) + "\n"

    def write(self, path: str | os.PathLike, trace_format: str = "chrome") -> None:
        """Write the trace to ``path``; ``OSError`` names the file."""
        if trace_format not in TRACE_FORMATS:
            raise ValueError(f"trace format must be one of {TRACE_FORMATS}, not {trace_format!r}")
        text = json.dumps(self.chrome()) if trace_format == "chrome" else self.report()
        with open(path, "w", encoding="utf-8") as stream:
            stream.write(text)
