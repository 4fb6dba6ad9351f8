"""Display output (issue 11, item 4): the display transform applies to un-premultiplied colour;
PNG stores that (unassociated alpha), TIFF stores it premultiplied again; JPEG, which keeps no
alpha, the image over black."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

import penumbra
from penumbra import _core


def srgb(linear: float) -> float:
    return 12.92 * linear if linear <= 0.0031308 else 1.055 * linear ** (1 / 2.4) - 0.055


def read_png_rgba8(path: Path) -> np.ndarray:
    """The stored bytes of an 8-bit RGBA, non-interlaced PNG (no premultiplication on read)."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    position, idat, header = 8, b"", None
    while position < len(data):
        length, kind = struct.unpack(">I4s", data[position : position + 8])
        body = data[position + 8 : position + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        position += 12 + length
    width, height, depth, color_type, _, _, interlace = header
    assert (depth, color_type, interlace) == (8, 6, 0)
    raw = zlib.decompress(idat)
    stride, bpp = width * 4, 4
    rows, previous = [], bytearray(stride)
    for y in range(height):
        kind, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1 : (y + 1) * (stride + 1)])
        for i in range(stride):
            left = line[i - bpp] if i >= bpp else 0
            up, up_left = previous[i], previous[i - bpp] if i >= bpp else 0
            if kind == 1:
                line[i] = (line[i] + left) & 255
            elif kind == 2:
                line[i] = (line[i] + up) & 255
            elif kind == 3:
                line[i] = (line[i] + (left + up) // 2) & 255
            elif kind == 4:
                p = left + up - up_left
                pa, pb, pc = abs(p - left), abs(p - up), abs(p - up_left)
                predictor = left if pa <= pb and pa <= pc else (up if pb <= pc else up_left)
                line[i] = (line[i] + predictor) & 255
        rows.append(bytes(line))
        previous = line
    return np.frombuffer(b"".join(rows), dtype=np.uint8).reshape(height, width, 4)


def edge_image() -> penumbra.Image:
    """Three pixels of colour 0.5 (scene-linear, premultiplied as rendered) at coverage 1,
    0.5 and 0.1, and an empty one."""
    color = np.zeros((1, 4, 4), dtype=np.float32)
    for x, alpha in enumerate((1.0, 0.5, 0.1)):
        color[0, x] = (0.5 * alpha, 0.5 * alpha, 0.5 * alpha, alpha)
    return penumbra.Image({"color": color}, {})


@pytest.mark.parametrize("mode", ["sRGB", "openColorIO"])
def test_png_holds_the_display_value_of_the_unpremultiplied_colour(tmp_path, mode):
    out = tmp_path / "edge.png"
    edge_image().write(out, color_mode=mode)
    stored = read_png_rgba8(out)
    expected = round(srgb(0.5) * 255)  # the bundled config's sRGB display: the same curve
    for x, alpha in enumerate((1.0, 0.5, 0.1)):
        assert stored[0, x, 3] == round(alpha * 255)
        assert abs(int(stored[0, x, 0]) - expected) <= 1, (x, stored[0, x])
    assert list(stored[0, 3]) == [0, 0, 0, 0]


def test_tiff_holds_the_display_value_premultiplied_again(tmp_path):
    out = tmp_path / "edge.tif"
    edge_image().write(out, color_mode="sRGB")
    pixels = _core.read_image(str(out))[0]
    for x, alpha in enumerate((1.0, 0.5, 0.1)):
        assert pixels[0, x, 0] == pytest.approx(srgb(0.5) * alpha, abs=1.5 / 255)
        assert pixels[0, x, 3] == pytest.approx(alpha, abs=1 / 255)


@pytest.mark.parametrize("mode", ["sRGB", "openColorIO"])
def test_jpeg_holds_the_image_over_black_in_linear_light(tmp_path, mode):
    # JPEG keeps no alpha: its pixels are the premultiplied colour's display values (the image
    # over black, as usdrecord writes it), not the unpremultiplied colour's scaled by alpha.
    color = np.zeros((8, 8, 4), dtype=np.float32)
    color[...] = (0.25, 0.25, 0.25, 0.5)
    out = tmp_path / "half.jpg"
    penumbra.Image({"color": color}, {}).write(out, color_mode=mode)
    pixels = _core.read_image(str(out))[0]
    assert pixels[..., 0].mean() == pytest.approx(srgb(0.25), abs=2 / 255)


def test_outputs_are_checked_before_anything_is_written(tmp_path):
    image = edge_image()
    with pytest.raises(ValueError, match=r"edge\.hdr: cannot write \.hdr; the output formats"):
        image.write(tmp_path / "edge.hdr")
    with pytest.raises(OSError, match="missing does not exist"):
        image.write(tmp_path / "missing" / "edge.exr")
