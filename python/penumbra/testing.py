"""Golden-image tests for pytest (docs/design.md §2.4).

Enable the plugin in a ``conftest.py`` with ``pytest_plugins = ["penumbra.testing"]``; then::

    def test_showcase(golden):
        image = penumbra.render("showcase.usda", width=160, samples=32)
        golden.check(image, "showcase", fail=0.02, failpercent=0.1)

compares the image's colour with ``goldens/showcase.exr`` next to the test file, with
``penumbra-diff``'s semantics (per-pixel error = largest channel difference; the test fails when
more than ``failpercent`` % of the pixels differ by more than ``fail``, or any by more than
``hardfail``). ``pytest --update-goldens`` rewrites the golden images instead of comparing.
Rendering is deterministic, so a golden only changes when the renderer's output does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from . import _core
from .diff import compare, write_difference
from .image import Image

CHANNELS = ["R", "G", "B", "A"]


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--update-goldens",
        action="store_true",
        default=False,
        help="rewrite the golden images of penumbra.testing instead of comparing with them",
    )


@dataclass
class Golden:
    """Compares rendered images with the golden images of one test module."""

    directory: Path
    update: bool
    failures: Path | None = None
    """Where a failing check saves the render (``NAME.actual.exr``) and the difference
    (``NAME.diff.exr``, golden minus render) named in its report; ``None``: not saved."""

    def path(self, name: str) -> Path:
        return self.directory / f"{name}.exr"

    def check(
        self,
        image: Image,
        name: str,
        *,
        fail: float = 0.02,
        failpercent: float = 0.0,
        hardfail: float = math.inf,
    ) -> None:
        """Compare ``image["color"]`` with the golden ``name`` (or rewrite it with
        ``--update-goldens``); fails the test with the error statistics when it differs."""
        color = np.ascontiguousarray(image["color"], dtype=np.float32)
        golden = self.path(name)
        if self.update:
            golden.parent.mkdir(parents=True, exist_ok=True)
            _core.write_image(str(golden), color, CHANNELS, {"penumbra:golden": name})
            return
        if not golden.exists():
            pytest.fail(f"{golden}: no golden image; create it with pytest --update-goldens")
        baseline, names, _ = _core.read_image(str(golden))
        if baseline.shape != color.shape:
            saved = self._save_failure(name, baseline, color, names)
            pytest.fail(
                f"{golden}: size {baseline.shape} differs from the render's {color.shape}{saved}"
            )
        result = compare(baseline, color, names, warn=fail, fail=fail)
        failed_percent = 100.0 * result.fail_pixels / result.pixels
        if failed_percent > failpercent or result.max_error > hardfail:
            saved = self._save_failure(name, baseline, color, names)
            pytest.fail(
                f"{golden}: {result.fail_pixels} of {result.pixels} pixels "
                f"({failed_percent:.3f} %, allowed {failpercent} %) differ by more than {fail}; "
                f"max error {result.max_error:.4g} at {result.max_location}, "
                f"mean {result.mean_error:.3g}, rms {result.rms_error:.3g}{saved}"
            )

    def _save_failure(
        self, name: str, baseline: np.ndarray, color: np.ndarray, names: list[str]
    ) -> str:
        """Save the render and the difference image; the report's sentence naming them."""
        if self.failures is None:
            return ""
        self.failures.mkdir(parents=True, exist_ok=True)
        actual = self.failures / f"{name}.actual.exr"
        difference = self.failures / f"{name}.diff.exr"
        _core.write_image(str(actual), color, CHANNELS, {"penumbra:golden": name})
        write_difference(str(difference), baseline, color, names, absolute=False, scale=1.0)
        return f"; saved {actual} and {difference}"


@pytest.fixture
def golden(request: pytest.FixtureRequest, tmp_path: Path) -> Golden:
    """A :class:`Golden` for the requesting test, with images in ``goldens/`` beside its file;
    a failing check saves the render and the difference in the test's ``tmp_path``."""
    return Golden(
        directory=Path(request.node.fspath).parent / "goldens",
        update=request.config.getoption("--update-goldens"),
        failures=tmp_path,
    )
