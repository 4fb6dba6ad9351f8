"""Denoising with Intel Open Image Denoise (the ``pyoidn`` package), guided by the albedo and
normal AOVs (docs/aovs.md, "Denoising")."""

from __future__ import annotations

import numpy as np

GUIDE_AOVS = ("albedo", "normal")
"""The AOVs the denoiser reads besides colour; a denoised render accumulates them."""
NOISY_COLOR = "noisyColor"
"""The AOV name under which a denoised render keeps its colour as rendered."""


def denoise_color(color: np.ndarray, albedo: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """``color`` (H, W, 4: scene-linear RGB and alpha) with its RGB denoised by OIDN's ``RT``
    filter at high quality, in HDR mode, guided by ``albedo`` and world-space ``normal`` (H, W,
    3) which are prefiltered by OIDN (they are averages of few samples too). Alpha is kept."""
    import pyoidn  # imported here: only denoising renders load OIDN's ~100 MB of weights

    rgb = np.ascontiguousarray(np.maximum(color[..., :3], 0.0), dtype=np.float32)
    denoised = pyoidn.denoise(
        rgb,
        albedo=np.ascontiguousarray(np.clip(albedo, 0.0, 1.0), dtype=np.float32),
        normal=np.ascontiguousarray(np.clip(normal, -1.0, 1.0), dtype=np.float32),
        hdr=True,
        quality="high",
    )
    return np.concatenate([denoised, color[..., 3:]], axis=2).astype(np.float32)
