"""Images in notebooks: _repr_png_ shows the colour, _repr_html_ every AOV side by side, and
display() gives display-referred pixels through OCIO."""

from __future__ import annotations

import base64
import re

import numpy as np
import pytest

from penumbra import _core
from penumbra.image import Image


def srgb(linear: float) -> float:
    return 12.92 * linear if linear <= 0.0031308 else 1.055 * linear ** (1 / 2.4) - 0.055


def grey_image() -> Image:
    """Colour 0.18 at half coverage (premultiplied: 0.09), a depth ramp and two ids."""
    color = np.zeros((4, 6, 4), np.float32)
    color[..., :3], color[..., 3] = 0.09, 0.5
    depth = np.tile(np.linspace(1, 6, 6, dtype=np.float32), (4, 1))[..., None]
    ids = np.zeros((4, 6, 1), np.float32)
    ids[:, 3:] = 1
    return Image({"color": color, "depth": depth, "primId": ids}, {})


def test_display_goes_through_ocio_on_unpremultiplied_colour():
    image = grey_image()
    standard = image.display()  # the bundled config: sRGB display, Standard view
    assert standard.shape == (4, 6, 3)
    np.testing.assert_allclose(standard, srgb(0.18), atol=1e-4)
    np.testing.assert_allclose(image.display(view="Raw", display="sRGB"), 0.18, atol=1e-6)
    with pytest.raises(RuntimeError, match="OpenColorIO"):
        image.display(view="NoSuchView")


def test_repr_png_is_the_display_colour(tmp_path):
    png = grey_image()._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    (tmp_path / "repr.png").write_bytes(png)
    pixels, names, _ = _core.read_image(str(tmp_path / "repr.png"))
    assert names == ["R", "G", "B"] and pixels.shape == (4, 6, 3)
    np.testing.assert_allclose(pixels, round(srgb(0.18) * 255) / 255, atol=1e-6)


def test_repr_html_shows_every_aov_side_by_side(tmp_path):
    image = grey_image()
    html = image._repr_html_()
    assert re.findall(r"<figcaption[^>]*>([^<]*)</figcaption>", html) == ["color", "depth", "primId"]
    pictures = [base64.b64decode(data) for data in re.findall(r"base64,([^\"]*)\"", html)]
    assert len(pictures) == 3
    decoded = []
    for index, picture in enumerate(pictures):
        path = tmp_path / f"{index}.png"
        path.write_bytes(picture)
        decoded.append(_core.read_image(str(path))[0])
    np.testing.assert_allclose(decoded[0], round(srgb(0.18) * 255) / 255, atol=1e-6)
    # Depth: near bright, far dark; ids: one colour per id.
    assert decoded[1][0, 0, 0] == 1.0 and decoded[1][0, 5, 0] == 0.0
    assert not np.array_equal(decoded[2][0, 0], decoded[2][0, 5])
    assert np.array_equal(decoded[2][0, 0], decoded[2][3, 2])
