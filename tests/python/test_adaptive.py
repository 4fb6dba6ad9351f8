"""Adaptive sampling through the Python API: pixels stop once converged, the image stays a pure
function of (scene, seed, samples, threshold), and the metadata says how many samples were taken."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, UsdLux

import penumbra

from stages import lit_quad_stage


def noisy_stage():
    """The lit quad, plus a small sphere light grazing it: soft, noisy light on the quad, an
    empty (noiseless) background around it."""
    stage = lit_quad_stage()
    bulb = UsdLux.SphereLight.Define(stage, "/bulb")
    bulb.CreateRadiusAttr(0.05)
    bulb.CreateIntensityAttr(2000.0)
    bulb.AddTranslateOp().Set(Gf.Vec3d(1.2, 0.0, 0.3))
    return stage


def test_adaptive_sampling_stops_converged_pixels_deterministically():
    renderer = penumbra.Renderer(noisy_stage())
    kwargs = dict(width=48, samples=256, adaptive_threshold=0.05, adaptive_min_samples=8)
    one = renderer.render(threads=1, **kwargs)
    two = renderer.render(threads=2, **kwargs)
    assert np.array_equal(one["color"], two["color"])
    assert one.metadata["adaptiveThreshold"] == 0.05
    # The background (a quarter of the image at least) stops at 8 samples.
    assert 8 < one.metadata["meanSamples"] < 0.8 * 256
    full = renderer.render(width=48, samples=256)
    assert full.metadata["meanSamples"] == 256
    lit = full["color"][..., 0] > 0
    ratio = one["color"][..., 0][lit].mean() / full["color"][..., 0][lit].mean()
    # The hot little bulb makes the quad's mean vary by ±1.5 % between seeds even at 256 spp.
    assert ratio == pytest.approx(1.0, abs=0.03)


def test_adaptive_threshold_out_of_range_is_an_error():
    renderer = penumbra.Renderer(noisy_stage())
    with pytest.raises(ValueError, match="adaptiveThreshold"):
        renderer.render(width=8, samples=4, adaptive_threshold=-1.0)
