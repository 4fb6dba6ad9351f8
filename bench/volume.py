"""Volume benchmark (`make bench`): time to 5 % rRMSE on the cloud of examples/cloud.py (an
OpenVDB density grid under a low sun and a sky, seen above a field), and the memory its grid
takes per million active voxels.

Same method as bench/quality.py: two seeds per rung of an spp ladder, rRMSE against a converged
render, interpolated log-log to 5 %. Volume scattering is capped at 64 events per path (the
example's setting), paths at 64 bounces. Cycles' numbers on the same cloud: bench/cycles_cloud.py
(run with a Python 3.11 that has PyPI's ``bpy``).

    .venv/bin/python bench/volume.py [--quick]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
from pxr import Usd

import penumbra
from provenance import print_provenance
from quality import (
    Setting, crossing, format_number, measure_ladder, progress, render_rgb, rrmse_at,
)

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
import cloud  # noqa: E402  (examples/cloud.py: the stage and its grid)

RENDER_OPTIONS = {"max_volume_depth": 64, "max_path_depth": 64}


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--spp", type=int, nargs="+", default=[4, 16, 64])
    parser.add_argument("--seeds", type=int, nargs=2, default=(1, 2))
    parser.add_argument("--converged-spp", type=int, default=512)
    parser.add_argument("--width", type=int, default=480)
    parser.add_argument("--quick", action="store_true", help="smoke test: 2 and 8 spp, 160 px")
    args = parser.parse_args()
    if args.quick:
        args.spp, args.converged_spp, args.width = [2, 8], 32, 160
    # What quality.render_rgb reads beyond these.
    args.adaptive_min_samples, args.indirect_clamp, args.glossy_filter = 8, 0.0, 0.0
    args.render_options = RENDER_OPTIONS
    return args


def main() -> None:
    args = parse_args()
    print_provenance()
    with tempfile.TemporaryDirectory(prefix="penumbra-volume-bench-") as directory:
        stage_path = Path(directory) / "cloud.usda"
        cloud.write_grid(Path(directory) / cloud.GRID.name)
        cloud.write_stage(stage_path)
        stage = Usd.Stage.Open(str(stage_path))
        with penumbra.Renderer(stage) as renderer:
            renderer.render(time=1.0, width=16, samples=1)
            grid_bytes = renderer.delegate.sync_statistics()["volumeBytes"]
        # write_vdb leaves zero voxels inactive: the active ones are the non-zero densities.
        voxels = int(np.count_nonzero(cloud.cloud_density()))
        converged, seconds, _ = render_rgb(stage, args, Setting(args.converged_spp), 99)
        progress(f"cloud: converged, {args.converged_spp} spp: {seconds:.1f} s")
        rungs = measure_ladder(
            stage, "cloud", [Setting(n) for n in args.spp], args, converged
        )
    quality = crossing(rungs)
    print(f"Cloud (examples/cloud.py), {args.width} px wide, spp ladder "
          f"{', '.join(map(str, args.spp))}, converged {args.converged_spp} spp; "
          "* extrapolated beyond the ladder.\n")
    print("| scene | active voxels | volume memory (MB) | bytes per voxel | spp at 5 % "
          "| time to 5 % (s) | 64-spp rRMSE |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    print(f"| cloud | {voxels:,} | {grid_bytes / 1e6:.1f} | {grid_bytes / max(voxels, 1):.2f} "
          f"| {format_number(quality.samples, marked=quality.extrapolated)} "
          f"| {format_number(quality.seconds, marked=quality.extrapolated)} "
          f"| {format_number(rrmse_at(rungs, 64), 2)} |")


if __name__ == "__main__":
    main()
