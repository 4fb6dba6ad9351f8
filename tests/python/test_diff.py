"""``penumbra-diff``: idiff's thresholds and exit codes."""

from __future__ import annotations

import numpy as np
import pytest

from penumbra import _core
from penumbra.diff import main

RNG = np.random.default_rng(7)
BASE = RNG.uniform(0.1, 0.9, size=(20, 30, 4)).astype(np.float32)


def write(path, pixels) -> str:
    _core.write_image(str(path), np.ascontiguousarray(pixels), ["R", "G", "B", "A"], {})
    return str(path)


@pytest.fixture
def baseline(tmp_path) -> str:
    return write(tmp_path / "baseline.exr", BASE)


def test_identical_images_pass(tmp_path, baseline, capsys):
    assert main([baseline, write(tmp_path / "same.exr", BASE)]) == 0
    assert capsys.readouterr().out.strip().endswith("PASS")


def test_fail_warn_and_percentages(tmp_path, baseline, capsys):
    test = BASE.copy()
    test[0, :6, 1] += 0.01  # 6 of 600 pixels (1 %) off by 0.01…
    test[0, 2, 1] += 0.01  # …one of them by 0.02
    other = write(tmp_path / "test.exr", test)
    assert main([baseline, other]) == 2  # idiff's default thresholds: 1e-6, 0 %
    out = capsys.readouterr().out
    assert (
        "FAILURE" in out
        and "6 pixels (1%) over 1e-06" in out
        and "Max error  = 0.02 @ (2, 0, G)" in out
    )
    assert main([baseline, other, "--fail", "0.02"]) == 1  # still over the warn threshold
    assert main([baseline, other, "--fail", "0.02", "--warn", "0.02"]) == 0
    assert main([baseline, other, "--failpercent", "1"]) == 1  # 1 % may fail, none may warn
    assert main([baseline, other, "-failpercent", "1", "-warnpercent", "1"]) == 0
    assert (
        main([baseline, other, "--failpercent", "1", "--warnpercent", "1", "--hardfail", "0.015"])
        == 2
    )


def test_infinite_depth_compares_equal(tmp_path):
    depth = np.full((4, 4, 1), np.inf, dtype=np.float32)
    names = ["Z"]
    a, b = str(tmp_path / "a.exr"), str(tmp_path / "b.exr")
    _core.write_image(a, depth, names, {})
    _core.write_image(b, depth, names, {})
    assert main([a, b]) == 0
    depth[1, 1, 0] = 3.0
    _core.write_image(b, depth, names, {})
    assert main([a, b, "--fail", "100"]) == 2


def test_size_mismatch(tmp_path, baseline, capsys):
    assert main([baseline, write(tmp_path / "small.exr", BASE[:10])]) == 3
    assert "do not match in size" in capsys.readouterr().out
    assert main([baseline, str(write(tmp_path / "rgb.exr", BASE))]) == 0
    rgb = tmp_path / "three.exr"
    _core.write_image(str(rgb), np.ascontiguousarray(BASE[..., :3]), ["R", "G", "B"], {})
    assert main([baseline, str(rgb)]) == 3


def test_file_errors(tmp_path, baseline, capsys):
    assert main([baseline, str(tmp_path / "missing.exr")]) == 4
    assert "missing.exr" in capsys.readouterr().err
    junk = tmp_path / "junk.exr"
    junk.write_bytes(b"not an image")
    assert main([str(junk), baseline]) == 4


def test_perceptual(tmp_path, baseline):
    faint = BASE * np.float32(1.0005)  # numerically different, perceptually the same
    faint_path = write(tmp_path / "faint.exr", faint)
    assert main([baseline, faint_path, "--fail", "1", "--warn", "1", "-p"]) == 0
    blotch = BASE.copy()
    blotch[5:15, 5:15, :3] = 0.0  # a visible black square
    blotch_path = write(tmp_path / "blotch.exr", blotch)
    assert main([baseline, blotch_path, "--fail", "1", "--warn", "1"]) == 0
    assert main([baseline, blotch_path, "--fail", "1", "--warn", "1", "--perceptual"]) == 2
