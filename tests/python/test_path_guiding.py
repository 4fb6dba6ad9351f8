"""Path guiding from the front ends (docs/path-guiding.md): the option reaches the renderer,
guided images are unbiased and deterministic, and crops and farm bands train the same field
as the whole image."""

from __future__ import annotations

import numpy as np
import pytest

import penumbra
from farm_bands import assert_farm_bands_match_local
from stages import CORNELL

GUIDED = dict(width=64, samples=16, guiding_training_samples=4)


def test_guiding_changes_the_noise_not_the_image():
    renderer = penumbra.Renderer(CORNELL)
    plain = renderer.render(width=64, samples=256)["color"][..., :3]
    guided = renderer.render(width=64, samples=256, guiding_training_samples=4)["color"][..., :3]
    assert not np.array_equal(plain, guided)
    assert guided.mean() == pytest.approx(plain.mean(), rel=0.02)


def test_a_region_of_a_guided_render_is_the_whole_images_pixels():
    renderer = penumbra.Renderer(CORNELL)
    whole = renderer.render(**GUIDED)["color"]
    part = renderer.render(**GUIDED, region=(3, 10, 40, 9))["color"]
    assert np.array_equal(part, whole[10:19, 3:43])
    assert np.array_equal(whole, renderer.render(**GUIDED, threads=1)["color"])


def test_farm_bands_of_a_guided_frame_are_bit_identical_to_a_local_render(tmp_path, capsys):
    flags = ["-w", "64", "-spp", "12", "--guidingTrainingSamples", "4"]
    assert_farm_bands_match_local(CORNELL, flags, tmp_path, capsys)


def test_a_negative_training_budget_is_refused():
    with pytest.raises(ValueError, match="guidingTrainingSamples"):
        penumbra.Renderer(CORNELL).render(width=16, samples=4, guiding_training_samples=-1)
