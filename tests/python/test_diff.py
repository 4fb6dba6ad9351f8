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
    # idiff 2.4: a comparison in which no pixel fails passes, whatever warns.
    assert main([baseline, other, "--fail", "0.03"]) == 0
    assert main([baseline, other, "--failpercent", "1"]) == 1  # 1 % may fail, none may warn
    assert main([baseline, other, "-failpercent", "1", "-warnpercent", "1"]) == 0
    assert (
        main([baseline, other, "--failpercent", "1", "--warnpercent", "1", "--hardfail", "0.015"])
        == 2
    )
    assert main([baseline, other, "-allowfailures", "6", "-hardfail", "0.015"]) == 0


def test_infinite_depth_compares_equal(tmp_path):
    depth = np.full((4, 4, 1), np.inf, dtype=np.float32)
    names = ["Z"]
    a, b = str(tmp_path / "a.exr"), str(tmp_path / "b.exr")
    _core.write_image(a, depth, names, {})
    _core.write_image(b, depth, names, {})
    assert main([a, b]) == 0
    depth[1, 1, 0] = 3.0
    _core.write_image(b, depth, names, {})
    # A value infinite in one image only is not counted (idiff 2.4), whatever the threshold.
    assert main([a, b]) == 0


def test_size_and_channel_mismatches_fail_by_their_differences(tmp_path, baseline, capsys):
    """As idiff 2.4: the union of the images is compared, missing values being 0."""
    assert main([baseline, write(tmp_path / "small.exr", BASE[:10])]) == 2
    out = capsys.readouterr().out
    assert "Sizes differ: 30x20, 4 channels vs 30x10, 4 channels" in out
    assert "300 pixels (50%) over 1e-06" in out
    rgb = tmp_path / "three.exr"
    _core.write_image(str(rgb), np.ascontiguousarray(BASE[..., :3]), ["R", "G", "B"], {})
    assert main([baseline, str(rgb)]) == 2
    assert main([baseline, str(rgb), "--fail", "1"]) == 0  # alpha < 1 everywhere


def test_nan_in_one_image_is_not_counted(tmp_path, baseline, capsys):
    nan = BASE.copy()
    nan[3, 4, 0] = np.nan
    assert main([baseline, write(tmp_path / "nan.exr", nan), "-v"]) == 0
    out = capsys.readouterr().out
    assert "Max error  = inf @ (4, 3, R)" in out and "0 pixels (0%) over 1e-06" in out


def test_usage_errors_exit_1_as_idiff(baseline, capsys):
    assert main([baseline]) == 1
    assert main(["--bogus", baseline, baseline]) == 1
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("penumbra-diff ")


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
    # 83 pixels (13.8 %) differ by more than 0.5, about 100 (16 %) fail perceptually.
    allow = ["--fail", "0.5", "--failpercent", "15", "--warnpercent", "100"]
    assert main([baseline, blotch_path, *allow]) == 0
    assert main([baseline, blotch_path, *allow, "--perceptual"]) == 2


def test_golden_failure_saves_the_render_and_the_difference(tmp_path):
    from penumbra.image import Image
    from penumbra.testing import Golden

    golden = Golden(directory=tmp_path / "goldens", update=True)
    golden.check(Image({"color": BASE}, {}), "patch")
    failing = Golden(directory=tmp_path / "goldens", update=False, failures=tmp_path / "out")
    changed = BASE.copy()
    changed[0, 0, 0] += 0.5
    with pytest.raises(pytest.fail.Exception, match=r"saved .*patch\.actual\.exr and .*patch\.diff\.exr"):
        failing.check(Image({"color": changed}, {}), "patch", fail=0.1)
    difference = _core.read_image(str(tmp_path / "out" / "patch.diff.exr"))[0]
    assert difference[0, 0, 0] == pytest.approx(-0.5) and np.count_nonzero(difference) == 1
    np.testing.assert_array_equal(_core.read_image(str(tmp_path / "out" / "patch.actual.exr"))[0], changed)
