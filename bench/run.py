"""Penumbra benchmarks (`make bench`): load and render times of the shared scenes.

The scenes are those of ``../shared/scenes`` beside the repository (benchmark scenes shared
with other renderers, not part of the repository); without it the benchmark says so and stops.

Every scene is rendered in the same run at 640x360 with the same sample count, so the numbers
are comparable side by side (the machines are shared and noisy: compare ratios, not seconds).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from pxr import Usd

import penumbra
from provenance import print_provenance

SCENES = Path(__file__).resolve().parents[2] / "shared" / "scenes"


def bench_scene(path: Path, samples: int, width: int) -> dict[str, float]:
    started = time.perf_counter()
    stage = Usd.Stage.Open(str(path))
    renderer = penumbra.Renderer(stage)
    loaded = time.perf_counter()
    image = renderer.render(width=width, samples=samples)
    rendered = time.perf_counter()
    height, width_px = image["color"].shape[:2]
    render_seconds = rendered - loaded
    return {
        "load_s": loaded - started,
        "render_s": render_seconds,
        "mpaths_per_s": width_px * height * samples / render_seconds / 1e6,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("scenes", nargs="*", default=["cornell.usda"], help="files in shared/scenes")
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--width", type=int, default=640)
    args = parser.parse_args()
    print_provenance()
    if not SCENES.is_dir():
        sys.exit(
            f"bench/run.py: the benchmark scenes are not here: {SCENES} does not exist "
            "(they live beside the repository, in ../shared/scenes; tests and examples do not "
            "need them)"
        )
    print(f"| scene | load (s) | render {args.width}px, {args.samples} spp (s) | Mpaths/s |")
    print("|---|---|---|---|")
    for name in args.scenes:
        result = bench_scene(SCENES / name, args.samples, args.width)
        print(
            f"| {name} | {result['load_s']:.2f} | {result['render_s']:.2f} "
            f"| {result['mpaths_per_s']:.2f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
