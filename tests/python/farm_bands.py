"""The check that a frame rendered as bands on a farm is the frame rendered locally."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from penumbra import _core
from penumbra.cli import main


def assert_farm_bands_match_local(
    stage: Path, flags: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Renders `stage` with the CLI's `flags` locally and in bands on a local cluster of two
    workers (--workers 2), and asserts that the two images are bit-identical and count the same
    rays (the bands' counts add up to the whole frame's)."""
    local, farm = tmp_path / "local.exr", tmp_path / "farm.exr"
    assert main([str(stage), str(local), *flags, "-q"]) == 0
    assert main([str(stage), str(farm), *flags, "--workers", "2"]) == 0
    assert "tiles on 2 workers" in capsys.readouterr().out
    farm_image, local_image = _core.read_image(str(farm)), _core.read_image(str(local))
    assert np.array_equal(farm_image[0], local_image[0])
    assert farm_image[2]["penumbra:rays"] == local_image[2]["penumbra:rays"]
