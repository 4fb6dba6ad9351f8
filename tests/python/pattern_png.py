"""Huge 8-bit RGB PNGs of a simple pattern, written row by row: a 16k² one is a few MB on disk
(its rows repeat), and nothing of its size is ever held in memory. For the texture-memory test
and bench/texture_memory.py."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

CHECKER = 256
"""Texels per square of the pattern."""
COLORS = ((200, 40, 40), (40, 60, 200))
"""The two squares' 8-bit sRGB colours."""


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def write_pattern_png(path: Path, size: int) -> None:
    """A ``size``² RGB checkerboard of :data:`COLORS` in squares of :data:`CHECKER` texels."""
    squares = [bytes(color) * CHECKER for color in COLORS]
    count = -(-size // CHECKER)
    rows = [
        b"\0" + b"".join(squares[(i + parity) % 2] for i in range(count))[: 3 * size]
        for parity in (0, 1)
    ]
    compressor = zlib.compressobj(6)
    with path.open("wb") as png:
        png.write(b"\x89PNG\r\n\x1a\n")
        png.write(_chunk(b"IHDR", struct.pack(">IIBBBBB", size, size, 8, 2, 0, 0, 0)))
        data = bytearray()
        for y in range(size):
            data += compressor.compress(rows[(y // CHECKER) % 2])
            if len(data) > 1 << 20:
                png.write(_chunk(b"IDAT", bytes(data)))
                data.clear()
        data += compressor.flush()
        png.write(_chunk(b"IDAT", bytes(data)))
        png.write(_chunk(b"IEND", b""))
