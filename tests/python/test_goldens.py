"""Golden images (penumbra.testing): small renders of the bundled examples, compared with the
images in goldens/. Rendering is deterministic, so any change to what a sample computes shows
here; when the change is intended, regenerate with ``pytest --update-goldens`` and look at the
new images before committing them."""

from __future__ import annotations

from pathlib import Path

import pytest

import penumbra

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_showcase_materials_and_lights(golden):
    # The sky sampled at the first surface as every light (docs/dome-sampling.md) and the path
    # tracer alone: the estimator this golden was made with, which `mis` and `caustics="path"`
    # keep bit for bit.
    image = penumbra.render(
        str(EXAMPLES / "showcase.usda"), width=96, samples=8, threads=2, dome_sampling="mis",
        caustics="path",
    )
    golden.check(image, "showcase", fail=0.02, failpercent=0.0)


def test_showcase_with_the_dome_pilot(golden):
    # The dome's pilot leaves the sky to the BSDF ray at the first surface here, and at this
    # size, where the pixels' own noise is most of it, the branching pilot keeps one path per
    # sample (docs/branching.md); the path tracer alone, as when this golden was made.
    image = penumbra.render(
        str(EXAMPLES / "showcase.usda"), width=96, samples=8, threads=2, caustics="path"
    )
    assert image.metadata["constantDomeShare"] == 0.0
    assert image.metadata["indirectSamplesUsed"] == 1
    assert image.metadata["lightSamplesUsed"] == 1
    golden.check(image, "showcase_dome_pilot", fail=0.02, failpercent=0.0)


def test_showcase_with_light_traced_caustics(golden):
    # The defaults: the lamps' light through the flint and frosted glass balls onto the floor is
    # light-traced in every wavelength, the shaped RectLight's too (docs/caustics.md).
    image = penumbra.render(str(EXAMPLES / "showcase.usda"), width=96, samples=8, threads=2)
    assert image.metadata["caustics"] == "light"
    assert image.metadata["lightPaths"] > 0
    golden.check(image, "showcase_caustics", fail=0.02, failpercent=0.0)


def test_showcase_with_photons_seen_through_glass(golden):
    # As the README's image: where the camera sees the floor through the flint and frosted balls,
    # the light paths' photons are gathered (docs/caustics.md). Elsewhere it is the defaults'
    # image, bit for bit.
    image = penumbra.render(
        str(EXAMPLES / "showcase.usda"), width=96, samples=8, threads=2, caustics="photons"
    )
    assert image.metadata["caustics"] == "photons"
    default = penumbra.render(str(EXAMPLES / "showcase.usda"), width=96, samples=8, threads=2)
    differs = (image["color"] != default["color"]).any(axis=2)
    assert 0 < differs.mean() < 0.25
    golden.check(image, "showcase_photons", fail=0.02, failpercent=0.0)


def test_cornell_box(golden):
    # One path per camera sample and the path tracer alone: the estimator this golden was made
    # with, which `indirect_samples=1` and `caustics="path"` keep bit for bit.
    image = penumbra.render(
        str(EXAMPLES / "cornell.usda"), width=96, samples=8, threads=1, indirect_samples=1,
        caustics="path",
    )
    golden.check(image, "cornell", fail=0.02, failpercent=0.0)


def test_cornell_box_with_light_traced_caustics(golden):
    # The default: the metal box's caustics on the floor and walls are light-traced
    # (docs/caustics.md); one path per camera sample, as the golden above.
    image = penumbra.render(
        str(EXAMPLES / "cornell.usda"), width=96, samples=8, threads=1, indirect_samples=1
    )
    assert image.metadata["caustics"] == "light"
    golden.check(image, "cornell_caustics", fail=0.02, failpercent=0.0)


def test_cornell_box_with_the_branching_pilot(golden):
    # The default: its pilot branches about three ways at the first surface, the room's light
    # being nearly all indirect (fewer in the regions where less of it lies beyond: 2.815 on
    # average), and estimates the direct light there twice (docs/branching.md).
    chosen = penumbra.render(
        str(EXAMPLES / "cornell.usda"), width=96, samples=1, threads=1, caustics="path"
    )
    assert chosen.metadata["indirectSamplesUsed"] == 2.815
    assert chosen.metadata["lightSamplesUsed"] == 2
    # The golden is the image of three branches and one estimate, the pilot's choice before it
    # counted the shading of vertices in a sample's cost (set here, so that it stays that image).
    image = penumbra.render(
        str(EXAMPLES / "cornell.usda"), width=96, samples=8, threads=1, indirect_samples=3,
        light_samples=1, caustics="path",
    )
    golden.check(image, "cornell_branching_pilot", fail=0.02, failpercent=0.0)


def test_golden_check_fails_for_a_different_image(golden):
    if golden.update:
        return  # nothing to compare while the goldens are being rewritten
    image = penumbra.render(
        str(EXAMPLES / "cornell.usda"), width=96, samples=8, seed=1, indirect_samples=1
    )
    with pytest.raises(pytest.fail.Exception, match="differ by more than 0.02"):
        golden.check(image, "cornell", fail=0.02, failpercent=0.0)
