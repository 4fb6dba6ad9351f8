"""Groom benchmark: N cubic Bézier strands of 4 vertices each (one segment) growing from a unit
sphere, tapered (varying widths: a strand's root and tip), a displayColor per strand (uniform),
in one BasisCurves prim written to a temporary .usdc; then opened with ``Usd.Stage.Open`` and
rendered for one sample per pixel through ``penumbra.Renderer`` (bench/first_sample.py).

Prints the load → first-sample time (open, delegate sync, first pass with its BVH build) and the
peak resident memory, against the targets for a million strands: under 10 s and under 2 GB.

    python bench/groom.py                       # 1,000,000 strands
    python bench/groom.py --strands 20000       # a quick run
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from pxr import Gf, Usd, UsdGeom, Vt

from first_sample import add_camera_and_sun, author_and_measure, verdict
from provenance import print_provenance

TARGET_SECONDS = 10.0
TARGET_MB = 2048.0
VERTICES = 4  # per strand: one cubic Bézier segment
LENGTH = 0.15  # of a strand, on a sphere of radius 1
ROOT_WIDTH, TIP_WIDTH = 0.004, 0.0008


def strands(count: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Control points (float32 [count·4, 3]), varying widths (float32 [count·2]: a strand's one
    segment has two ends) and one colour per strand (float32 [count, 3]): roots evenly spread
    over the unit sphere (a Fibonacci lattice), each strand leaving along the normal and bending
    aside."""
    rng = np.random.default_rng(seed)
    k = np.arange(count) + 0.5
    y = 1 - 2 * k / count
    ring = np.sqrt(1 - y * y)
    azimuth = k * math.pi * (3 - math.sqrt(5))
    normal = np.column_stack([ring * np.cos(azimuth), y, ring * np.sin(azimuth)])
    aside = rng.normal(size=(count, 3))
    aside -= normal * (aside * normal).sum(axis=1, keepdims=True)
    aside /= np.linalg.norm(aside, axis=1, keepdims=True)
    length = LENGTH * rng.uniform(0.7, 1.3, size=(count, 1))
    bend = rng.uniform(0.2, 0.6, size=(count, 1))
    points = np.stack(
        [
            normal,
            normal + normal * length / 3,
            normal + (normal + bend * aside) * length * 2 / 3,
            normal + (normal * (1 - bend) + aside * bend * 1.5) * length,
        ],
        axis=1,
    )
    taper = np.array([ROOT_WIDTH, TIP_WIDTH])
    widths = taper[None, :] * rng.uniform(0.8, 1.2, size=(count, 1))
    tint = rng.uniform(0.8, 1.2, size=(count, 1))
    colors = np.clip(np.array([0.45, 0.3, 0.18]) * tint, 0, 1)
    return (
        points.reshape(-1, 3).astype(np.float32),
        widths.reshape(-1).astype(np.float32),
        colors.astype(np.float32),
    )


def write_stage(path: str, count: int) -> None:
    """The groom on a sphere, a camera and a light, saved to ``path``."""
    points, widths, colors = strands(count)
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    stage.SetStartTimeCode(1)
    curves = UsdGeom.BasisCurves.Define(stage, "/World/groom")
    curves.CreateTypeAttr(UsdGeom.Tokens.cubic)
    curves.CreateBasisAttr(UsdGeom.Tokens.bezier)
    curves.CreateWrapAttr(UsdGeom.Tokens.nonperiodic)
    curves.CreateCurveVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(count, VERTICES, np.int32)))
    curves.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    curves.CreateWidthsAttr(Vt.FloatArray.FromNumpy(widths))
    curves.SetWidthsInterpolation(UsdGeom.Tokens.varying)
    curves.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform).Set(Vt.Vec3fArray.FromNumpy(colors))
    reach = float(np.abs(points).max()) + ROOT_WIDTH
    curves.CreateExtentAttr([Gf.Vec3f(-reach), Gf.Vec3f(reach)])
    UsdGeom.Sphere.Define(stage, "/World/head").CreateRadiusAttr(1.0)
    add_camera_and_sun(stage, 5)
    stage.Save()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--strands", type=int, default=1_000_000)
    parser.add_argument("--width", type=int, default=320)
    args = parser.parse_args()
    print_provenance()
    written, size_mb, result = author_and_measure(
        write_stage, "groom.usdc", args.strands, args.width
    )
    print(
        "| strands | vertices | .usdc (MB) | write (s) | open (s) | sync (s) | first pass (s) "
        f"| load → first sample (s), target {TARGET_SECONDS:g} "
        f"| peak memory (MB), target {TARGET_MB:g} | before load (MB) | coverage |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    print(
        f"| {args.strands:,} | {args.strands * VERTICES:,} | {size_mb:.0f} | {written:.2f} "
        f"| {result.open_seconds:.2f} | {result.sync_seconds:.2f} | {result.render_seconds:.2f} "
        f"| {verdict(result.total_seconds, TARGET_SECONDS)} "
        f"| {verdict(result.peak_mb, TARGET_MB)} | {result.before_mb:.0f} "
        f"| {result.coverage:.2f} |",
        flush=True,
    )


if __name__ == "__main__":
    main()
