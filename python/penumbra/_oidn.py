"""The denoiser's child process (see penumbra.denoise): reads the colour, albedo and normal
arrays as an ``.npz`` on stdin, writes the denoised colour as an ``.npz`` on stdout."""

from __future__ import annotations

import io
import sys

import numpy as np


def main() -> None:
    import pyoidn  # only here: OIDN and its TBB never enter the renderer's process

    arrays = np.load(io.BytesIO(sys.stdin.buffer.read()))
    denoised = pyoidn.denoise(
        arrays["rgb"], albedo=arrays["albedo"], normal=arrays["normal"], hdr=True, quality="high"
    )
    reply = io.BytesIO()
    np.savez(reply, rgb=np.ascontiguousarray(denoised, dtype=np.float32))
    sys.stdout.buffer.write(reply.getvalue())


if __name__ == "__main__":
    main()
