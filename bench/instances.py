"""Million-instance benchmark (`make bench`): a PointInstancer of N copies of a ~5,000-triangle
prototype, built in memory, loaded through the USD scene delegate and rendered for one pass.

Reports the load time (USD read, instance transforms, delegate sync), the BVH build time (first
pass minus second pass: the first builds the BVHs, both trace one sample per pixel), the second
pass and peak memory. Memory must grow with the
number of instances, not with instanced triangles (5,000 per copy would need ~100 GB flattened).
"""

from __future__ import annotations

import argparse
import math
import resource
import time

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdLux, Vt

import penumbra
from penumbra.usd import implicit
from provenance import print_provenance


def prototype_sphere(stage: Usd.Stage, path: str) -> int:
    """A sphere mesh of radius 0.4 with 51 × 50 segments: 4,998 triangles."""
    sphere = implicit.sphere(0.4, segments=51, rings=50)
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(sphere.points))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(sphere.counts))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(sphere.indices))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    return int((sphere.counts - 2).sum())


def build_stage(count: int) -> tuple[Usd.Stage, int]:
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    stage.SetStartTimeCode(1)
    instancer = UsdGeom.PointInstancer.Define(stage, "/World/field")
    triangles = prototype_sphere(stage, "/World/field/Prototypes/ball/mesh")
    instancer.GetPrototypesRel().AddTarget("/World/field/Prototypes/ball")
    side = math.ceil(math.sqrt(count))
    grid = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2)[:count]
    positions = np.zeros((count, 3), dtype=np.float32)
    positions[:, 0] = grid[:, 0] - side / 2
    positions[:, 2] = grid[:, 1] - side / 2
    instancer.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(positions))
    instancer.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(np.zeros(count, dtype=np.int32)))
    camera = UsdGeom.Camera.Define(stage, "/cam")
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.1, 10 * side))
    camera.AddTranslateOp().Set(Gf.Vec3d(0, side / 4, side / 2 + 5))
    camera.AddRotateXOp().Set(-25)
    sun = UsdLux.DistantLight.Define(stage, "/sun")
    sun.CreateIntensityAttr(3)
    sun.CreateNormalizeAttr(True)
    sun.AddRotateXOp().Set(-50)
    return stage, triangles


def peak_memory_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--instances", type=int, default=1_000_000)
    parser.add_argument("--width", type=int, default=320)
    args = parser.parse_args()
    print_provenance()
    stage, triangles = build_stage(args.instances)
    before = peak_memory_mb()
    started = time.perf_counter()
    renderer = penumbra.Renderer(stage)
    renderer.sync()
    loaded = time.perf_counter()
    first = renderer.render(camera="/cam", width=args.width, samples=1)  # BVHs + 1 spp
    first_done = time.perf_counter()
    renderer.render(camera="/cam", width=args.width, samples=1)
    second_done = time.perf_counter()
    first_pass, second_pass = first_done - loaded, second_done - first_done
    coverage = float(first["color"][..., 3].mean())
    print("| instances | prototype triangles | load (s) | BVH build (s) | first pass (s) "
          "| second pass (s) | peak memory (MB) | memory before load (MB) | image coverage |")
    print("|---|---|---|---|---|---|---|---|---|")
    print(
        f"| {args.instances:,} | {triangles:,} | {loaded - started:.2f} "
        f"| {first_pass - second_pass:.2f} | {first_pass:.2f} | {second_pass:.2f} "
        f"| {peak_memory_mb():.0f} | {before:.0f} | {coverage:.2f} |",
        flush=True,
    )


if __name__ == "__main__":
    main()
