"""Scene-sync benchmark (`make bench`): how the cost of syncing a stage scales with its prims,
and what an edit costs against an unchanged re-render.

Stages are generated into a temporary directory (nothing from ../shared is read):

* N distinct 6-face meshes (each its own points, transform, displayColor; every tenth bound
  to one of eight UsdPreviewSurface materials), a camera and a distant light. Reported: the
  time from ``Usd.Stage.Open`` to the first sample (one sample per pixel at 64x36), and the
  resident memory it added per mesh prim.
* At 10,000 meshes: an unchanged re-render, and a re-render after editing one mesh's
  displayColor, one material input, one mesh's transform (each one sample per pixel), at
  64x36 (where an edit's fixed costs weigh most) and at 960x540 (a viewport's size); each
  edited re-render follows an unchanged one, and its ratio is to that neighbour (medians of
  five).
* A stage of subdivision surfaces: how many of them are re-diced when the camera moves.
* N sphere lights (bench/many_lights.py's scene): the time from ``Usd.Stage.Open`` to the first
  sample, as for meshes; every light is read input by input through UsdLux.

The machine may be shared: the CPU column (this process's threads) is steadier than wall time.
Targets (docs/architecture.md): 10,000 meshes < 1 s and 100,000 < 10 s to the first sample;
an edited re-render within 1.5x an unchanged one; a camera move re-dices nothing.
"""

from __future__ import annotations

import argparse
import gc
import os
import statistics
import tempfile
import time
from pathlib import Path

from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

import penumbra
from many_lights import write_stage as write_light_stage
from provenance import print_provenance

MATERIALS = 8
WIDTH = 64
EDIT_WIDTHS = (WIDTH, 960)
_CUBE_COUNTS = [4] * 6
_CUBE_INDICES = [0, 1, 3, 2, 2, 3, 7, 6, 6, 7, 5, 4, 4, 5, 1, 0, 1, 5, 7, 3, 4, 0, 2, 6]


def _cube_points(size: float) -> list[Gf.Vec3f]:
    return [Gf.Vec3f(x, y, z) for x in (0, size) for y in (0, size) for z in (0, size)]


def write_mesh_stage(path: Path, count: int, subdivided: bool = False) -> None:
    """A grid of ``count`` distinct cubes under /World, written with Sdf (fast to author)."""
    layer = Sdf.Layer.CreateNew(str(path))
    stage = Usd.Stage.Open(layer)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.Xform.Define(stage, "/World")
    for m in range(MATERIALS):
        material = UsdShade.Material.Define(stage, f"/Looks/m{m}")
        shader = UsdShade.Shader.Define(stage, f"/Looks/m{m}/surface")
        shader.CreateIdAttr("UsdPreviewSurface")
        shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(
            Gf.Vec3f(0.2 + 0.1 * m, 0.5, 0.8 - 0.05 * m)
        )
        material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    side = max(1, int(count**0.5 + 0.999))
    with Sdf.ChangeBlock():
        for i in range(count):
            prim_path = Sdf.Path(f"/World/c{i}")
            spec = Sdf.CreatePrimInLayer(layer, prim_path)
            spec.specifier = Sdf.SpecifierDef
            spec.typeName = "Mesh"

            def attr(name: str, type_name, value, spec=spec) -> None:
                Sdf.AttributeSpec(spec, name, type_name).default = value

            attr("points", Sdf.ValueTypeNames.Point3fArray, _cube_points(0.5 + 0.3 * (i % 7) / 7))
            attr("faceVertexCounts", Sdf.ValueTypeNames.IntArray, _CUBE_COUNTS)
            attr("faceVertexIndices", Sdf.ValueTypeNames.IntArray, _CUBE_INDICES)
            if not subdivided:
                attr("subdivisionScheme", Sdf.ValueTypeNames.Token, "none")
            attr("primvars:displayColor", Sdf.ValueTypeNames.Color3fArray,
                 [Gf.Vec3f((i % 5) / 5, (i % 3) / 3, 0.5)])
            attr("xformOp:translate", Sdf.ValueTypeNames.Double3,
                 Gf.Vec3d(i % side - side / 2, 0, i // side - side / 2))
            attr("xformOpOrder", Sdf.ValueTypeNames.TokenArray, ["xformOp:translate"])
            if i % 10 == 0:
                binding = Sdf.RelationshipSpec(spec, "material:binding")
                binding.targetPathList.explicitItems = [f"/Looks/m{i % MATERIALS}"]
                spec.SetInfo("apiSchemas", Sdf.TokenListOp.Create(["MaterialBindingAPI"]))
    camera = UsdGeom.Camera.Define(stage, "/cam")
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.1, 10 * side + 10))
    camera.AddTranslateOp().Set(Gf.Vec3d(0, side / 3 + 2, side / 2 + 4))
    camera.AddRotateXOp().Set(-35)
    sun = UsdLux.DistantLight.Define(stage, "/sun")
    sun.CreateIntensityAttr(3)
    sun.AddRotateXOp().Set(-50)
    layer.Save()


def resident_mb() -> float:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def render(renderer: penumbra.Renderer, width: int = WIDTH) -> float:
    started = time.perf_counter()
    renderer.render(camera="/cam", width=width, samples=1)
    return time.perf_counter() - started


def first_sample(path: Path, count: int) -> tuple[float, float, float, penumbra.Renderer, Usd.Stage]:
    """Wall seconds and CPU seconds (all threads) from Stage.Open to the first sample, bytes
    of resident memory added per prim, the renderer and the stage."""
    gc.collect()
    before = resident_mb()
    started, cpu = time.perf_counter(), time.process_time()
    stage = Usd.Stage.Open(str(path))
    renderer = penumbra.Renderer(stage)
    renderer.render(camera="/cam", width=WIDTH, samples=1)
    seconds, cpu = time.perf_counter() - started, time.process_time() - cpu
    return seconds, cpu, (resident_mb() - before) * 2**20 / count, renderer, stage


def edits(
    renderer: penumbra.Renderer, stage: Usd.Stage, width: int
) -> dict[str, tuple[float, float]]:
    """For an unchanged re-render of ``width`` pixels across and after each kind of edit: the
    median seconds and the median ratio to an unchanged re-render. Each edited re-render
    follows an unchanged one, five rounds of each kind, so that each ratio compares
    neighbours (the machine's speed drifts)."""
    for _ in range(2):
        render(renderer, width)
    color = UsdGeom.Gprim(stage.GetPrimAtPath("/World/c17")).GetDisplayColorAttr()
    shader_input = UsdShade.Shader(stage.GetPrimAtPath("/Looks/m3/surface")).GetInput("diffuseColor")
    translate = stage.GetPrimAtPath("/World/c23").GetAttribute("xformOp:translate")
    kinds = {
        "displayColor": lambda k: color.Set([Gf.Vec3f(1, 0.1 * k, 0)]),
        "material input": lambda k: shader_input.Set(Gf.Vec3f(0.9, 0.1 * k, 0.1)),
        "transform": lambda k: translate.Set(translate.Get() + Gf.Vec3d(0, 0.1, 0)),
    }
    unchanged: list[float] = []
    edited: dict[str, list[float]] = {kind: [] for kind in kinds}
    ratios: dict[str, list[float]] = {kind: [] for kind in kinds}
    for k in range(5):
        for kind, edit in kinds.items():
            unchanged.append(render(renderer, width))
            edit(k)
            edited[kind].append(render(renderer, width))
            ratios[kind].append(edited[kind][-1] / unchanged[-1])
    results = {"unchanged": (statistics.median(unchanged), 1.0)}
    for kind in kinds:
        results[kind] = (statistics.median(edited[kind]), statistics.median(ratios[kind]))
    return results


def camera_move_redice(path: Path) -> tuple[int, int]:
    """(subdivision surfaces, how many of them a camera move re-synced)."""
    stage = Usd.Stage.Open(str(path))
    renderer = penumbra.Renderer(stage)
    render(renderer)
    meshes = [p for p in renderer.delegate.prim_ids() if p.startswith("/World/")]
    before = {p: renderer.delegate.sync_count(p) for p in meshes}
    translate = stage.GetPrimAtPath("/cam").GetAttribute("xformOp:translate")
    translate.Set(translate.Get() + Gf.Vec3d(0.5, 0, -1))
    render(renderer)
    return len(meshes), sum(renderer.delegate.sync_count(p) != before[p] for p in meshes)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--counts", type=int, nargs="+", default=[10_000, 100_000])
    parser.add_argument("--edit-count", type=int, default=10_000)
    parser.add_argument("--edit-widths", type=int, nargs="+", default=list(EDIT_WIDTHS))
    parser.add_argument("--subdivided", type=int, default=200)
    parser.add_argument("--light-counts", type=int, nargs="*", default=[1_000, 10_000])
    args = parser.parse_args()
    print_provenance()
    with tempfile.TemporaryDirectory() as directory:
        print(
            "| distinct meshes | Stage.Open to first sample (s) | CPU (s, all threads) "
            "| memory per mesh prim (KB) |"
        )
        print("|---|---|---|---|")
        edit_times: dict[int, dict[str, tuple[float, float]]] = {}
        for count in args.counts:
            path = Path(directory) / f"meshes_{count}.usdc"
            write_mesh_stage(path, count)
            seconds, cpu, per_mesh, renderer, stage = first_sample(path, count)
            print(f"| {count:,} | {seconds:.2f} | {cpu:.2f} | {per_mesh / 1024:.1f} |", flush=True)
            if count == args.edit_count:
                edit_times = {width: edits(renderer, stage, width) for width in args.edit_widths}
            renderer.close()  # stops listening to the stage: nothing of it stays alive
            del renderer, stage
            gc.collect()
        for width, times in edit_times.items():
            print(f"\n| re-render of {args.edit_count:,} meshes (1 spp, {width} px wide) | s "
                  "| x unchanged |")
            print("|---|---|---|")
            for kind, (seconds, ratio) in times.items():
                print(f"| {kind} | {seconds:.4f} | {ratio:.2f} |", flush=True)
        path = Path(directory) / "subdivided.usdc"
        write_mesh_stage(path, args.subdivided, subdivided=True)
        total, rediced = camera_move_redice(path)
        print(f"\ncamera move: {rediced} of {total} subdivision surfaces re-diced", flush=True)
        if args.light_counts:
            print("\n| sphere lights | Stage.Open to first sample (s) | CPU (s, all threads) |")
            print("|---|---|---|")
        for count in args.light_counts:
            path = write_light_stage(Path(directory) / f"lights_{count}.usda", count)
            seconds, cpu, _, renderer, _ = first_sample(path, count)
            renderer.close()
            print(f"| {count:,} | {seconds:.2f} | {cpu:.2f} |", flush=True)


if __name__ == "__main__":
    main()
