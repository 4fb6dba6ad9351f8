"""usdrecord's FRAMESPECs and ``#`` frame placeholders in output paths.

A FRAMESPEC is ``101``, ``101:110``, ``101:110x2`` or ``101:104x0.5``; several may be joined
with commas. An output path for a frame range holds one placeholder: a run of ``#`` (the
zero-padded width), optionally followed by ``.`` and more ``#`` (the decimals), e.g.
``out.####.exr`` → ``out.0101.exr``, ``out.###.##.exr`` → ``out.101.50.exr``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from dataclasses import dataclass

_PLACEHOLDER = re.compile(r"#+(?:\.#+)?")
_NUMBER = r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)"
_FRAME_SPEC = re.compile(
    rf"\s*(?P<start>{_NUMBER})\s*(?::\s*(?P<end>{_NUMBER})\s*(?:x\s*(?P<stride>{_NUMBER})\s*)?)?"
)


@dataclass(frozen=True)
class FrameRange:
    """``count`` time codes ``start + i * stride``: one FRAMESPEC, not expanded."""

    start: float
    stride: float
    count: int

    def __iter__(self) -> Iterator[float]:
        return (self.start + i * self.stride for i in range(self.count))


def _parse_one(spec: str) -> FrameRange:
    """One FRAMESPEC, with UsdUtils.TimeCodeRange's semantics (a reversed range counts down;
    the stride's sign must match the direction; the same frames, floating-point rounding
    included)."""
    match = _FRAME_SPEC.fullmatch(spec)
    if not match:
        raise ValueError(f"invalid FRAMESPEC {spec.strip()!r}")
    start = float(match["start"])
    end = float(match["end"]) if match["end"] is not None else start
    stride = (
        float(match["stride"]) if match["stride"] is not None else (1.0 if end >= start else -1.0)
    )
    if stride == 0 or (end - start) * stride < 0:
        raise ValueError(
            f"invalid FRAMESPEC {spec.strip()!r}: stride {stride:g} never reaches {end:g}"
        )
    if not all(math.isfinite(value) for value in (start, end, stride)):
        raise ValueError(f"invalid FRAMESPEC {spec.strip()!r}: frames must be finite")
    # TimeCodeRange's iterator's count, to the bit: 0:0.7x0.1 stops at 0.6, as usdrecord does.
    return FrameRange(start, stride, math.floor((end - start + stride) / stride))


def parse_frame_spec(spec: str) -> list[FrameRange]:
    """The ranges of a comma-separated list of FRAMESPECs (validated, not expanded: iterate
    them for the time codes); ``ValueError`` if malformed."""
    return [_parse_one(part) for part in spec.split(",")]


def iter_frames(ranges: list[FrameRange]) -> Iterator[float]:
    """The time codes of ``ranges``, in order, generated one at a time."""
    for frame_range in ranges:
        yield from frame_range


def frame_spec_precision(spec: str) -> int:
    """The decimals needed to tell the frames of ``spec`` apart (those of its strides)."""
    precision = 0
    for part in spec.split(","):
        _, _, stride = part.partition("x")
        if "." in stride:
            precision = max(precision, len(stride.strip().split(".")[1]))
    return precision


def find_placeholder(path: str) -> str | None:
    """The frame placeholder of ``path``; ``None`` if none; ``ValueError`` if several."""
    placeholders = _PLACEHOLDER.findall(path)
    if len(placeholders) > 1:
        raise ValueError(f"{path} holds {len(placeholders)} frame placeholders; use one")
    return placeholders[0] if placeholders else None


def frame_path(path: str, frame: float) -> str:
    """``path`` with its placeholder replaced by ``frame``, zero-padded to the placeholder's
    width (decimals: as many as ``#`` after its dot)."""
    placeholder = find_placeholder(path)
    if placeholder is None:
        return path
    _, _, decimals = placeholder.partition(".")
    text = f"{frame:0{len(placeholder)}.{len(decimals)}f}"
    return path.replace(placeholder, text, 1)
