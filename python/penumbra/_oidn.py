"""The denoiser's child process (see penumbra.denoise): reads the colour, albedo and normal
arrays as an ``.npz`` on stdin, writes the denoised colour as an ``.npz`` on stdout.

The guides are averages of few samples too, so each is first denoised on its own by the RT
filter and the colour is then filtered with them marked clean (``cleanAux``), as OIDN's
documentation recommends for the best quality; without that the filter takes them as they
are."""

from __future__ import annotations

import io
import sys

import numpy as np


def prefiltered(name: str, image: np.ndarray) -> np.ndarray:
    """Auxiliary image ``name`` ("albedo" or "normal") denoised alone by OIDN's RT filter."""
    from pyoidn.device import Device
    from pyoidn.filter import OIDN_FORMAT_FLOAT3, OIDN_QUALITY_HIGH, Filter

    device = Device()
    device.commit()
    output = np.empty_like(image)
    guide_filter = Filter(device, "RT")
    guide_filter.set_image(name, image, OIDN_FORMAT_FLOAT3)
    guide_filter.set_image("output", output, OIDN_FORMAT_FLOAT3)
    guide_filter.set_quality(OIDN_QUALITY_HIGH)
    guide_filter.commit()
    guide_filter.execute()
    device.wait()
    error = device.get_error()
    guide_filter.release()
    device.release()
    if error:
        raise RuntimeError(f"prefiltering the {name} guide: {error}")
    return output


def main() -> None:
    import pyoidn  # only here: OIDN and its TBB never enter the renderer's process

    arrays = np.load(io.BytesIO(sys.stdin.buffer.read()))
    denoised = pyoidn.denoise(
        arrays["rgb"],
        albedo=prefiltered("albedo", arrays["albedo"]),
        normal=prefiltered("normal", arrays["normal"]),
        hdr=True,
        clean_aux=True,
        quality="high",
    )
    reply = io.BytesIO()
    np.savez(reply, rgb=np.ascontiguousarray(denoised, dtype=np.float32))
    sys.stdout.buffer.write(reply.getvalue())


if __name__ == "__main__":
    main()
