"""Measurements of emitters on black in rendered images (intensity-weighted moments).

Pixel coordinates are continuous: column ``i`` covers [i, i+1), its centre is i + 0.5. The
pixel filter (a Gaussian of σ = 0.5 px per axis) adds σ² per axis to every second moment.
"""

from __future__ import annotations

import numpy as np

FILTER_VARIANCE = 0.25
"""σ² of the pixel filter per axis (px²)."""


def intensity(image) -> np.ndarray:
    """Mean of R, G, B as float64 (H, W)."""
    color = image["color"] if hasattr(image, "keys") else image
    return color[..., :3].astype(np.float64).mean(axis=2)


def centroid(weights: np.ndarray) -> tuple[float, float]:
    """Intensity-weighted mean (x, y) in pixels."""
    y, x = np.indices(weights.shape) + 0.5
    total = weights.sum()
    return float((weights * x).sum() / total), float((weights * y).sum() / total)


def mean_square_radius(weights: np.ndarray) -> float:
    """E[r²] about the centroid (px²)."""
    cx, cy = centroid(weights)
    y, x = np.indices(weights.shape) + 0.5
    return float((weights * ((x - cx) ** 2 + (y - cy) ** 2)).sum() / weights.sum())


def disk_diameter(weights: np.ndarray, sharp_radius: float) -> float:
    """Diameter (px) of the uniform disk that, convolved with a sharp image of radius
    ``sharp_radius`` and the pixel filter, gives the measured E[r²]: for a uniform disk of
    radius ρ, E[r²] = ρ²/2, and second moments add."""
    rho2 = 2 * (mean_square_radius(weights) - 2 * FILTER_VARIANCE) - sharp_radius**2
    return 2 * float(np.sqrt(max(rho2, 0.0)))


def streak_ends(weights: np.ndarray, sharp_radius: float) -> tuple[float, float]:
    """Start and end (px, along x) of a horizontal streak of uniform intensity, from the first
    two moments of its column sums: a box [a, b] convolved with a disk of radius
    ``sharp_radius`` (x-variance s²/4) and the filter has mean (a+b)/2 and variance
    (b−a)²/12 + s²/4 + σ²."""
    columns = weights.sum(axis=0)
    x = np.arange(len(columns)) + 0.5
    mean = (columns * x).sum() / columns.sum()
    variance = (columns * (x - mean) ** 2).sum() / columns.sum()
    length = np.sqrt(12 * (variance - sharp_radius**2 / 4 - FILTER_VARIANCE))
    return float(mean - length / 2), float(mean + length / 2)
