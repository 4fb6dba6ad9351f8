"""Denoising with Intel Open Image Denoise (the ``pyoidn`` package), guided by the albedo and
normal AOVs (docs/aovs.md, "Denoising").

OIDN runs in a child process (``_oidn.py``): its wheel brings its own TBB, and loading it beside
the TBB that Embree and the renderer use made later renders in the same process crash. The child
runs the file as a script, not ``-m penumbra._oidn``: that would import the package first (the
renderer's library and USD), which took most of a denoised render's time at 640x360.
"""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import numpy as np

GUIDE_AOVS = ("albedo", "normal")
"""The AOVs the denoiser reads besides colour; a denoised render accumulates them."""
NOISY_COLOR = "noisyColor"
"""The AOV name under which a denoised render keeps its colour as rendered."""


def denoise_color(color: np.ndarray, albedo: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """``color`` (H, W, 4: scene-linear RGB and alpha) with its RGB denoised by OIDN's ``RT``
    filter at high quality, in HDR mode, guided by ``albedo`` and world-space ``normal`` (H, W,
    3) which OIDN prefilters first (they are averages of few samples too). Alpha is kept, and so
    are the pixels of alpha 0 (the filter would spread the objects' colour into the empty
    background, a halo over any plate). ``RuntimeError`` with the denoiser's message when it
    fails."""
    request = io.BytesIO()
    np.savez(
        request,
        rgb=np.ascontiguousarray(np.maximum(color[..., :3], 0.0), dtype=np.float32),
        albedo=np.ascontiguousarray(np.clip(albedo, 0.0, 1.0), dtype=np.float32),
        normal=np.ascontiguousarray(np.clip(normal, -1.0, 1.0), dtype=np.float32),
    )
    result = subprocess.run(
        # -P: the script's folder (this package's, with modules named like the standard
        # library's) does not go on sys.path.
        [sys.executable, "-P", str(Path(__file__).with_name("_oidn.py"))],
        input=request.getvalue(),
        capture_output=True,
        check=False,
    )
    if result.returncode != 0:
        message = result.stderr.decode(errors="replace").strip().splitlines()
        raise RuntimeError(f"the denoiser failed: {message[-1] if message else result.returncode}")
    denoised = np.load(io.BytesIO(result.stdout))["rgb"]
    empty = color[..., 3] == 0
    denoised[empty] = color[..., :3][empty]
    return np.concatenate([denoised, color[..., 3:]], axis=2).astype(np.float32)
