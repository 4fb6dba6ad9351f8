"""Denoising benchmark (`make bench`): rRMSE against Cycles' converged references
(`../shared/cycles/`) of Penumbra's raw and OIDN-denoised colour, on the shared scenes.

One render per scene and sample count gives both: ``denoise=True`` with the ``noisyColor``
AOV keeps the raw colour beside the denoised one. rRMSE and the reference loading are
bench/quality.py's. The rRMSE against Cycles includes the small difference between the two
renderers' converged images (quality.py's last column), which no denoiser removes.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from pxr import Usd

import penumbra
from quality import CYCLES, SCENES, SHARED_SCENES, TIME_CODE, read_rgb, relative_rmse
from provenance import print_provenance


def scene_row(name: str, samples: int, width: int, seed: int) -> str:
    reference_path = CYCLES / f"{name}.exr"
    if not reference_path.is_file():
        return f"| {name} | {samples} | – | – | – | (no {reference_path}) |"
    reference = read_rgb(reference_path)
    stage = Usd.Stage.Open(str(SCENES / f"{name}.usda"))
    with penumbra.Renderer(stage) as renderer:
        started = time.perf_counter()
        image = renderer.render(
            time=TIME_CODE, width=width, samples=samples, seed=seed,
            aovs=("color", "noisyColor"), denoise=True,
        )  # fmt: skip
        seconds = time.perf_counter() - started
    raw = image["noisyColor"][..., :3].astype(np.float64)
    denoised = image["color"][..., :3].astype(np.float64)
    if raw.shape != reference.shape:
        return f"| {name} | {samples} | – | – | – | (reference is {reference.shape[1]} px wide) |"
    raw_error = relative_rmse(raw - reference, reference)
    denoised_error = relative_rmse(denoised - reference, reference)
    print(f"{name}, {samples} spp: {seconds:.1f} s", file=sys.stderr, flush=True)
    return (
        f"| {name} | {samples} | {raw_error:.4f} | {denoised_error:.4f} | "
        f"{denoised_error / raw_error:.2f} | {seconds:.1f} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenes", nargs="+", default=list(SHARED_SCENES))
    parser.add_argument("--spp", type=int, nargs="+", default=[16, 64])
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    print_provenance()
    if not SCENES.is_dir():
        print(f"denoise.py: skipped, the shared scenes are needed and {SCENES} is missing.")
        return
    print(f"Denoising (OIDN, guided by albedo and normal), {args.width} px wide, seed {args.seed}:"
          " rRMSE against Cycles' converged reference.\n")
    print("| scene | spp | raw rRMSE | denoised rRMSE | denoised / raw | render + denoise (s) |")
    print("|---|---:|---:|---:|---:|---:|")
    for name in args.scenes:
        for samples in args.spp:
            print(scene_row(name, samples, args.width, args.seed), flush=True)


if __name__ == "__main__":
    main()
