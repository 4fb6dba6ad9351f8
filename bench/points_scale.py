"""Points at scale: N UsdGeomPoints (a width per point, a displayColor per point) filling a
slab, in one prim written to a temporary .usdc; then opened with ``Usd.Stage.Open`` and
rendered for one sample per pixel through ``penumbra.Renderer`` (bench/first_sample.py).

Prints the load → first-sample time (open, delegate sync, first pass with its BVH build) and the
peak resident memory, against the memory target for ten million points: under 2 GB.

    python bench/points_scale.py                      # 10,000,000 points
    python bench/points_scale.py --points 200000      # a quick run
"""

from __future__ import annotations

import argparse

import numpy as np
from pxr import Gf, Usd, UsdGeom, Vt

from first_sample import add_camera_and_sun, author_and_measure, verdict
from provenance import print_provenance

TARGET_MB = 2048.0


def write_stage(path: str, count: int, seed: int = 1) -> None:
    """``count`` points uniformly in a 4 × 4 × 1 slab facing the camera, diameters 0.002 to
    0.006, colours by position; a camera and a light; saved to ``path``."""
    rng = np.random.default_rng(seed)
    positions = (rng.random((count, 3), dtype=np.float32) - 0.5) * np.float32([4, 4, 1])
    widths = rng.uniform(0.002, 0.006, size=count).astype(np.float32)
    colors = np.clip(positions / np.float32([4, 4, 1]) + 0.5, 0, 1)
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    stage.SetStartTimeCode(1)
    points = UsdGeom.Points.Define(stage, "/World/cloud")
    points.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(positions))
    points.CreateWidthsAttr(Vt.FloatArray.FromNumpy(widths))
    points.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    points.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set(Vt.Vec3fArray.FromNumpy(colors))
    points.CreateExtentAttr([Gf.Vec3f(-2.01, -2.01, -0.51), Gf.Vec3f(2.01, 2.01, 0.51)])
    add_camera_and_sun(stage, 8)
    stage.Save()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--points", type=int, default=10_000_000)
    parser.add_argument("--width", type=int, default=320)
    args = parser.parse_args()
    print_provenance()
    written, size_mb, result = author_and_measure(
        write_stage, "points.usdc", args.points, args.width
    )
    print(
        "| points | .usdc (MB) | write (s) | open (s) | sync (s) | first pass (s) "
        f"| load → first sample (s) | peak memory (MB), target {TARGET_MB:g} "
        "| before load (MB) | coverage |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    print(
        f"| {args.points:,} | {size_mb:.0f} | {written:.2f} | {result.open_seconds:.2f} "
        f"| {result.sync_seconds:.2f} | {result.render_seconds:.2f} "
        f"| {result.total_seconds:.2f} | {verdict(result.peak_mb, TARGET_MB)} "
        f"| {result.before_mb:.0f} | {result.coverage:.2f} |",
        flush=True,
    )


if __name__ == "__main__":
    main()
