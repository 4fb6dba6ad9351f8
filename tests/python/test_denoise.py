"""Denoising with OIDN: closer to a converged image than the raw render, the raw colour kept
as noisyColor on request, deterministic, and from the command line."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import penumbra
from penumbra import _core
from penumbra.cli import main

from stages import CORNELL

RENDER = dict(camera="/cam", time=1.0, width=64, seed=3)


def rrmse(image: np.ndarray, reference: np.ndarray) -> float:
    """bench/quality.py's rRMSE over RGB."""
    difference = image[..., :3] - reference[..., :3]
    return float(np.sqrt(np.mean(difference**2 / (reference[..., :3] ** 2 + 0.01))))


@pytest.fixture(scope="module")
def renders():
    with penumbra.Renderer(CORNELL) as renderer:
        reference = renderer.render(samples=256, **RENDER)["color"]
        raw = renderer.render(samples=8, **RENDER)
        denoised = renderer.render(samples=8, aovs=("color", "noisyColor"), denoise=True, **RENDER)
        again = renderer.render(samples=8, denoise=True, threads=1, **RENDER)
    return reference, raw, denoised, again


def test_denoising_brings_the_image_closer_to_the_converged_one(renders):
    reference, raw, denoised, _ = renders
    raw_error, denoised_error = rrmse(raw["color"], reference), rrmse(denoised["color"], reference)
    # Measured against 256 spp (itself noisy, about 0.04): raw 0.22, denoised 0.087.
    assert denoised_error < 0.5 * raw_error, (raw_error, denoised_error)
    # Alpha is not denoised.
    np.testing.assert_array_equal(denoised["color"][..., 3], raw["color"][..., 3])
    assert denoised.metadata["denoised"] == 1 and raw.metadata["denoised"] == 0


def test_noisy_colour_is_the_raw_render_and_denoising_is_deterministic(renders):
    _, raw, denoised, again = renders
    np.testing.assert_array_equal(denoised["noisyColor"], raw["color"])
    np.testing.assert_array_equal(again["color"], denoised["color"])


def test_pixels_the_render_left_empty_stay_as_rendered():
    # The filter spread a ball's colour into the empty background around it (361 of 784 pixels
    # of alpha 0 got colour, up to 0.049): a halo over any plate it is composited on.
    from pxr import Gf, UsdLux

    from stages import add_camera, add_sphere_mesh, new_stage

    stage = new_stage()
    add_camera(stage)
    add_sphere_mesh(stage, "/ball", radius=1.0)
    bulb = UsdLux.SphereLight.Define(stage, "/bulb")
    bulb.CreateRadiusAttr(0.3)
    bulb.CreateIntensityAttr(30.0)
    bulb.AddTranslateOp().Set(Gf.Vec3d(1.5, 1.5, 2.5))
    image = penumbra.render(stage, camera="/cam", width=32, samples=4, seed=1, denoise=True,
                            aovs=("color", "noisyColor"), dome_light_visibility=False)
    empty = image["color"][..., 3] == 0
    assert empty.sum() > 300
    np.testing.assert_array_equal(image["color"][empty], image["noisyColor"][empty])


PREFILTER_A_NOISY_ALBEDO = """
import runpy, sys
import numpy as np
prefiltered = runpy.run_path(sys.argv[1])["prefiltered"]
noisy = np.clip(0.5 + np.random.default_rng(1).normal(0.0, 0.1, (32, 32, 3)), 0, 1)
smooth = prefiltered("albedo", noisy.astype(np.float32))
print(noisy.std(), smooth.std(), smooth.mean())
"""


def test_the_guides_are_prefiltered_before_they_guide():
    # OIDN's advice for noisy guides (they were passed as they are, although the docs said
    # prefiltered): a noisy flat albedo comes back nearly flat. In a child process, as the
    # renderer runs OIDN: its TBB must not enter this one.
    child = Path(penumbra.__file__).with_name("_oidn.py")
    result = subprocess.run([sys.executable, "-P", "-c", PREFILTER_A_NOISY_ALBEDO, str(child)],
                            capture_output=True, text=True, check=True)
    noisy, smooth, mean = map(float, result.stdout.split())
    assert smooth < 0.25 * noisy and abs(mean - 0.5) < 0.01


def test_noisy_colour_needs_denoising():
    with pytest.raises(ValueError, match="noisyColor AOV needs denoise=True"):
        penumbra.render(CORNELL, samples=1, width=8, aovs=("color", "noisyColor"))


def test_cli_denoise_keeps_the_noisy_layer(tmp_path):
    out = tmp_path / "out.exr"
    argv = [str(CORNELL), str(out), "-w", "32", "-spp", "4", "-q", "--denoise"]
    assert main([*argv, "--aov", "noisyColor"]) == 0
    pixels, names, metadata = _core.read_image(str(out))
    assert sorted(names) == sorted(
        ["R", "G", "B", "A", "noisyColor.R", "noisyColor.G", "noisyColor.B", "noisyColor.A"]
    )
    assert metadata["penumbra:denoised"] == 1
    color = pixels[..., [names.index(c) for c in "RGB"]]
    noisy = pixels[..., [names.index(f"noisyColor.{c}") for c in "RGB"]]
    assert not np.array_equal(color, noisy)
