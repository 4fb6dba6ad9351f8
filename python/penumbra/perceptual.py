"""Yee's perceptual image metric (Yee 2004), as OIIO's ``idiff -p`` applies it.

A pixel fails when its luminance difference exceeds the threshold of visibility at the local
adaptation luminance (raised by contrast masking across a Laplacian pyramid), or when its
colour difference is too large. Observer: 45° field of view, 100 cd/m² white.
"""

from __future__ import annotations

import math

import numpy as np

_LEVELS = 8  # Laplacian pyramid levels
_ADOBE_RGB_TO_XYZ = np.array(
    [
        [0.576700, 0.185556, 0.188212],
        [0.297361, 0.627355, 0.0752847],
        [0.0270328, 0.0706879, 0.991248],
    ]
)


def _xyz_to_lab(xyz: np.ndarray) -> np.ndarray:
    white = _ADOBE_RGB_TO_XYZ.sum(axis=1)
    epsilon, kappa = 216.0 / 24389.0, 24389.0 / 27.0
    r = xyz / white
    f = np.where(r > epsilon, np.cbrt(r), (kappa * r + 16.0) / 116.0)
    return np.stack(
        [
            116.0 * f[..., 1] - 16.0,
            500.0 * (f[..., 0] - f[..., 1]),
            200.0 * (f[..., 1] - f[..., 2]),
        ],
        axis=-1,
    )


def _blur(image: np.ndarray) -> np.ndarray:
    """One pyramid step: the separable 5-tap kernel, mirrored at the borders as idiff does."""
    kernel = (0.05, 0.25, 0.4, 0.25, 0.05)
    for axis in (0, 1):
        n = image.shape[axis]
        index = np.arange(-2, n + 2)
        index = np.where(index < 0, -index, index)
        index = np.where(index >= n, 2 * n - index - 1, index)
        padded = np.take(image, index, axis=axis)
        image = sum(
            weight * np.take(padded, np.arange(k, k + n), axis=axis)
            for k, weight in enumerate(kernel)
        )
    return image


def _contrast_sensitivity(cycles_per_degree, luminance):
    """Barten's contrast sensitivity function (SPIE 1989)."""
    a = 440.0 * (1.0 + 0.7 / luminance) ** -0.2
    b = 0.3 * (1.0 + 100.0 / luminance) ** 0.15
    return (
        a
        * cycles_per_degree
        * np.exp(-b * cycles_per_degree)
        * np.sqrt(1.0 + 0.06 * np.exp(b * cycles_per_degree))
    )


def _mask(contrast):
    """Daly's visual masking function (1993)."""
    return (1.0 + (0.0153 * (392.498 * contrast) ** 0.7) ** 4.0) ** 0.25


def _tvi(adaptation):
    """Threshold-versus-intensity (Ward Larson 1997), cd/m²."""
    log_a = np.log10(adaptation)
    r = np.select(
        [log_a < -3.94, log_a < -1.44, log_a < -0.0184, log_a < 1.9],
        [
            np.full_like(log_a, -2.86),
            np.abs(0.405 * log_a + 1.6) ** 2.18 - 2.86,
            log_a - 0.395,
            np.abs(0.249 * log_a + 0.65) ** 2.7 - 0.72,
        ],
        log_a - 1.255,
    )
    return 10.0**r


def perceptual_failures(
    baseline: np.ndarray, test: np.ndarray, luminance: float = 100.0, fov: float = 45.0
) -> int:
    """How many pixels fail Yee's perceptual test (first three channels, scene-linear)."""
    labs, lums = [], []
    for image in (baseline, test):
        rgb = np.nan_to_num(image[..., :3].astype(np.float64))
        if rgb.shape[2] < 3:
            rgb = np.repeat(rgb[..., :1], 3, axis=2)
        xyz = rgb @ _ADOBE_RGB_TO_XYZ.T
        labs.append(_xyz_to_lab(xyz))
        levels = [xyz[..., 1] * luminance]
        for _ in range(1, _LEVELS):
            levels.append(_blur(levels[-1]))
        lums.append(levels)
    la, lb = lums
    one_degree_pixels = 2.0 * math.tan(math.radians(fov * 0.5)) * 180.0 / math.pi
    pixels_per_degree = baseline.shape[1] / one_degree_pixels
    adaptation_level = max(i for i in range(_LEVELS) if 2**i <= one_degree_pixels)
    cpd = [0.5 * pixels_per_degree / 2**i for i in range(_LEVELS)]
    csf_max = _contrast_sensitivity(3.248, 100.0)
    bands = range(_LEVELS - 2)
    contrast = [
        np.maximum(np.abs(la[i] - la[i + 1]), np.abs(lb[i] - lb[i + 1]))
        / np.maximum(np.maximum(np.abs(la[i + 2]), np.abs(lb[i + 2])), 1e-5)
        for i in bands
    ]
    sum_contrast = np.maximum(sum(contrast), 1e-5)
    adapt = np.maximum(0.5 * (la[adaptation_level] + lb[adaptation_level]), 1e-5)
    factor = (
        sum(
            contrast[i]
            * (csf_max / _contrast_sensitivity(cpd[i], 100.0))
            * _mask(contrast[i] * _contrast_sensitivity(cpd[i], adapt))
            for i in bands
        )
        / sum_contrast
    )
    factor = np.clip(factor, 1.0, 10.0)
    fails = np.abs(la[0] - lb[0]) > factor * _tvi(adapt)
    # idiff ramps the colour test down to 1 % below 10 cd/m² (its scotopic ramp).
    color_scale = np.where(adapt < 10.0, 0.01, 1.0)
    delta_ab = labs[0][..., 1:] - labs[1][..., 1:]
    fails |= (delta_ab**2).sum(axis=-1) * color_scale > factor
    return int(np.count_nonzero(fails))
