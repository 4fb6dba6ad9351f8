"""Cycles' time to 5 % rRMSE on the cloud of examples/cloud.py, to set beside bench/volume.py's
Penumbra numbers: the same scene built directly with Blender's Python module (not through its USD
importer), the same method (two seeds per rung of an spp ladder, rRMSE against a converged render,
interpolated log-log to 5 %; time = building the Blender scene + Cycles' render call, the mean of
the two seeds).

Run with a Python that has ``bpy`` (PyPI's ``bpy`` wheels are for Python 3.11), after writing the
grid with the project's Python:

    .venv/bin/python examples/cloud.py                 # writes build/examples/cloud.vdb
    /tmp/bpy-venv/bin/python bench/cycles_cloud.py [--quick]

Conversions from the USD scene (Y up) to Blender's (Z up): a point (x, y, z) goes to
(x, -z, y), a rotation of +90° about X applied to every object. The grid keeps its own
index-to-object transform from the file under the Volume's translate, as in Penumbra. The
MaterialX volume (scattering 12·d, absorption 0.04·d, g 0.6) is a Principled Volume of density
12.04·d and colour 12/12.04 (Cycles: σs = density·colour, σa = density·(1 − colour) with a black
absorption colour). The UsdLux sun's intensity is the radiance of its disk; Blender's sun
strength is irradiance: 60000·π·sin²(angle/2). The dome is a constant world background of the
same radiance, seen by the camera. Pixel filter: Gaussian of σ = 0.5 px as Penumbra's (Cycles'
Gaussian of width w has σ = w/12: width 6 px). The converged image is written to
/tmp/cycles_cloud.exr (scene-linear RGBA float; --exr). Progress goes to stderr, the table to
stdout.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import tempfile
import time
import types
from collections.abc import Iterator
from pathlib import Path

import numpy as np

try:
    import bpy
    from mathutils import Euler, Matrix, Vector
except ImportError:
    print("cycles_cloud.py: skipped, Blender's Python module `bpy` cannot be imported by "
          f"{sys.executable} (PyPI serves it for Python 3.11: pip install 'bpy==4.2.*').")
    sys.exit(0)

BENCH = Path(__file__).resolve().parent
REPO = BENCH.parent
sys.path[:0] = [str(BENCH), str(REPO / "examples")]


def import_without_penumbra() -> None:
    """quality.py and cloud.py import penumbra and pxr at their top, which Blender's Python has
    not (and penumbra's USD libraries must not load beside Blender's): their helpers used here
    need only numpy, so empty stand-ins let the modules load."""
    for name in ("pxr", "penumbra", "many_lights"):
        stand_in = types.ModuleType(name)
        stand_in.__getattr__ = lambda attribute: None  # type: ignore[method-assign]
        sys.modules.setdefault(name, stand_in)


import_without_penumbra()
import cloud  # noqa: E402  (examples/cloud.py: the grid's path, size and density)
from provenance import print_provenance  # noqa: E402
from quality import (  # noqa: E402
    Rung, crossing, format_number, mean_luminance, progress, relative_rmse, rrmse_at,
)

CONVERGED_EXR, QUICK_EXR = Path("/tmp/cycles_cloud.exr"), Path("/tmp/cycles_cloud_quick.exr")
ASPECT = 16 / 9  # examples/cloud.py: aperture 36 × 20.25 mm
# From examples/cloud.py, in USD's Y-up coordinates.
CLOUD_TRANSLATE = (0.0, 1.2, 0.0)
SCATTERING, ABSORPTION, ANISOTROPY = 12.0, 0.04, 0.6
GROUND_HALF_SIZE, GROUND_COLOUR = 60.0, (0.16, 0.2, 0.09)
EYE, LOOK_AT, FOCAL_MM, APERTURE_MM = (0.5, 1.0, 9.5), (0.0, 2.6, 0.0), 30.0, 36.0
SKY_COLOUR, SKY_INTENSITY = (0.35, 0.55, 1.0), 0.6
SUN_ANGLE_DEGREES, SUN_INTENSITY, SUN_COLOUR = 0.53, 60000.0, (1.0, 0.8, 0.6)
SUN_ROTATE_XYZ_DEGREES = (-18.0, -60.0, 0.0)
# Penumbra's caps (bench/volume.py: path depth 64, volume depth 64).
BOUNCES = {"max_bounces": 64, "volume_bounces": 64, "diffuse_bounces": 4, "glossy_bounces": 4,
           "transmission_bounces": 8}
GAUSSIAN_WIDTH_PX = 6.0  # σ = width / 12 = 0.5 px, Penumbra's PixelFilter


def z_up(point: tuple[float, float, float] | Vector) -> Vector:
    """USD's Y-up (x, y, z) in Blender's Z-up frame: (x, -z, y)."""
    x, y, z = point
    return Vector((x, -z, y))


Y_TO_Z_UP = Matrix.Rotation(math.pi / 2, 4, "X")  # the same map, as a transform


def sun_direction() -> Vector:
    """Where the sun's light travels (Blender frame): the UsdLux light's -Z after rotateXYZ,
    which rotates about X first, then Y, then Z, as Blender's 'XYZ' Euler does."""
    rotation = Euler([math.radians(a) for a in SUN_ROTATE_XYZ_DEGREES], "XYZ").to_matrix()
    return z_up(rotation @ Vector((0.0, 0.0, -1.0))).normalized()


def sun_irradiance() -> float:
    """W/m² of a disk of radiance SUN_INTENSITY and the sun's angular diameter."""
    return SUN_INTENSITY * math.pi * math.sin(math.radians(SUN_ANGLE_DEGREES) / 2) ** 2


def look_at_matrix(eye: Vector, target: Vector) -> Matrix:
    """Camera-to-world for a camera at ``eye`` looking at ``target`` with +Z up (USD's +Y);
    Blender's cameras, as USD's, look down their -Z with +Y up."""
    forward = (target - eye).normalized()
    right = forward.cross(Vector((0.0, 0.0, 1.0))).normalized()
    up = right.cross(forward)
    rotation = Matrix((right, up, -forward)).transposed().to_4x4()
    return Matrix.Translation(eye) @ rotation


def use_nodes(datablock: bpy.types.Material | bpy.types.World) -> None:
    """Shader nodes on (always on, and the switch deprecated, from Blender 5.0)."""
    if bpy.app.version < (5, 0, 0):
        datablock.use_nodes = True


def new_material(name: str) -> tuple[bpy.types.Material, bpy.types.NodeTree]:
    material = bpy.data.materials.new(name)
    use_nodes(material)
    tree = material.node_tree
    tree.nodes.clear()
    return material, tree


def add_cloud(scene: bpy.types.Scene, grid: Path) -> bpy.types.Object:
    volume = bpy.data.volumes.new("cloud")
    volume.filepath = str(grid)
    volume.render.precision = "FULL"  # Penumbra keeps float32 voxels
    volume.render.clipping = 0.0  # every non-zero voxel counts, as in Penumbra
    material, tree = new_material("cloud")
    principled = tree.nodes.new("ShaderNodeVolumePrincipled")
    density = SCATTERING + ABSORPTION
    principled.inputs["Density"].default_value = density
    principled.inputs["Density Attribute"].default_value = "density"
    principled.inputs["Color"].default_value = (*[SCATTERING / density] * 3, 1.0)
    principled.inputs["Absorption Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    principled.inputs["Anisotropy"].default_value = ANISOTROPY
    principled.inputs["Emission Strength"].default_value = 0.0
    principled.inputs["Blackbody Intensity"].default_value = 0.0
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(principled.outputs["Volume"], output.inputs["Volume"])
    volume.materials.append(material)
    obj = bpy.data.objects.new("cloud", volume)
    obj.matrix_world = Y_TO_Z_UP @ Matrix.Translation(CLOUD_TRANSLATE)
    scene.collection.objects.link(obj)
    return obj


def add_ground(scene: bpy.types.Scene) -> None:
    h = GROUND_HALF_SIZE
    mesh = bpy.data.meshes.new("ground")
    mesh.from_pydata([(-h, -h, 0.0), (h, -h, 0.0), (h, h, 0.0), (-h, h, 0.0)], [],
                     [(0, 1, 2, 3)])
    material, tree = new_material("ground")
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (*GROUND_COLOUR, 1.0)
    diffuse.inputs["Roughness"].default_value = 0.0  # Lambertian
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(diffuse.outputs["BSDF"], output.inputs["Surface"])
    mesh.materials.append(material)
    scene.collection.objects.link(bpy.data.objects.new("ground", mesh))


def add_lights_and_camera(scene: bpy.types.Scene, width: int) -> None:
    world = bpy.data.worlds.new("sky")
    use_nodes(world)
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*SKY_COLOUR, 1.0)
    background.inputs["Strength"].default_value = SKY_INTENSITY
    scene.world = world

    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = sun_irradiance()
    sun.color = SUN_COLOUR
    sun.angle = math.radians(SUN_ANGLE_DEGREES)
    sun_object = bpy.data.objects.new("sun", sun)
    sun_object.rotation_mode = "QUATERNION"
    sun_object.rotation_quaternion = sun_direction().to_track_quat("-Z", "Y")
    scene.collection.objects.link(sun_object)

    camera = bpy.data.cameras.new("camera")
    camera.lens, camera.sensor_width, camera.sensor_fit = FOCAL_MM, APERTURE_MM, "HORIZONTAL"
    camera.clip_start, camera.clip_end = 0.1, 500.0
    camera_object = bpy.data.objects.new("camera", camera)
    camera_object.matrix_world = look_at_matrix(z_up(EYE), z_up(LOOK_AT))
    scene.collection.objects.link(camera_object)
    scene.camera = camera_object
    scene.render.resolution_x, scene.render.resolution_y = width, round(width / ASPECT)
    scene.render.resolution_percentage = 100


def configure_cycles(scene: bpy.types.Scene, samples: int, seed: int) -> None:
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    scene.render.threads_mode, scene.render.threads = "FIXED", 2
    cycles.samples, cycles.seed, cycles.use_animated_seed = samples, seed, False
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.sample_clamp_direct = cycles.sample_clamp_indirect = 0.0
    cycles.blur_glossy = 0.0  # Penumbra's glossy filter is off in bench/volume.py
    cycles.use_light_tree = True
    for name, value in BOUNCES.items():
        setattr(cycles, name, value)
    cycles.pixel_filter_type, cycles.filter_width = "GAUSSIAN", GAUSSIAN_WIDTH_PX
    scene.render.film_transparent = False
    scene.render.use_persistent_data = False
    scene.view_settings.view_transform, scene.view_settings.look = "Standard", "None"
    scene.view_settings.exposure, scene.view_settings.gamma = 0.0, 1.0


def build_scene(grid: Path, width: int, samples: int, seed: int) -> bpy.types.Scene:
    scene = bpy.context.scene
    add_cloud(scene, grid)
    add_ground(scene)
    add_lights_and_camera(scene, width)
    configure_cycles(scene, samples, seed)
    return scene


@contextlib.contextmanager
def blender_output_silenced() -> Iterator[None]:
    """Blender prints its render progress on the process's standard output, where the table
    goes: send it to /dev/null meanwhile."""
    sys.stdout.flush()
    saved = os.dup(1)
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), 1)
        try:
            yield
        finally:
            os.dup2(saved, 1)
            os.close(saved)


def reset() -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)


def render_rgb(
    grid: Path, width: int, samples: int, seed: int, exr: Path
) -> tuple[np.ndarray, float]:
    """One render in a fresh Blender scene: RGB (float64, top row first; also saved to ``exr``)
    and seconds from building the scene to the end of the render."""
    reset()
    started = time.perf_counter()
    scene = build_scene(grid, width, samples, seed)
    with blender_output_silenced():
        bpy.ops.render.render()
    seconds = time.perf_counter() - started
    return read_render_result(scene, exr), seconds


def read_render_result(scene: bpy.types.Scene, path: Path) -> np.ndarray:
    """The render result as scene-linear float: saved as a float EXR (no view transform),
    loaded back (Blender cannot read the render result's pixels in background mode)."""
    settings = scene.render.image_settings
    settings.file_format, settings.color_mode, settings.color_depth = "OPEN_EXR", "RGBA", "32"
    settings.exr_codec = "ZIP"
    bpy.data.images["Render Result"].save_render(str(path), scene=scene)
    return load_exr_rgb(path)


def load_exr_rgb(path: Path) -> np.ndarray:
    """An EXR's R, G, B as float64, top row first (Blender's pixels start at the bottom)."""
    image = bpy.data.images.load(str(path))
    height, width = image.size[1], image.size[0]
    pixels = np.empty(width * height * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    bpy.data.images.remove(image)
    return pixels.reshape(height, width, 4)[::-1, :, :3].astype(np.float64)


def placement_check(grid: Path) -> None:
    """Blender's world box of the cloud beside where Penumbra puts its voxels: voxel (i, j, k)
    at the Volume's translate + the grid's index-to-object transform (examples/cloud.py), in
    Z up. Blender's box spans the active voxels' tree leaves (8³ voxels), so the expected box is
    of the leaves holding the non-zero voxels."""
    reset()
    obj = add_cloud(bpy.context.scene, grid)
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    corners = [evaluated.matrix_world @ Vector(c) for c in evaluated.bound_box]
    blender = np.array([[min(c[i] for c in corners), max(c[i] for c in corners)]
                        for i in range(3)])
    z, y, x = np.nonzero(cloud.cloud_density())
    leaf = 8
    first = np.array([x.min(), y.min(), z.min()]) // leaf * leaf
    last = np.array([x.max(), y.max(), z.max()]) // leaf * leaf + leaf - 1
    nx, _, nz = cloud.RESOLUTION
    offset = np.array([-nx * cloud.VOXEL / 2, 0.0, -nz * cloud.VOXEL / 2]) + CLOUD_TRANSLATE
    ends = [z_up(first * cloud.VOXEL + offset), z_up(last * cloud.VOXEL + offset)]
    penumbra_box = np.sort(np.array(ends, dtype=np.float64).T, axis=1)
    # Blender 4.2's box runs from centre to centre, 5.0's over the voxels' cells.
    half = cloud.VOXEL / 2
    verdict = next(
        (f"match ({convention})" for grow, convention in
         ((0.0, "voxel centres"), (half, "voxel cells, half a voxel beyond the centres"))
         if np.allclose(blender, penumbra_box + [-grow, grow], atol=1e-4)),
        "DIFFER",
    )
    progress(f"placement: grids {[g.name for g in evaluated.data.grids]}; world box (x, y, z) "
             f"in Blender {blender.round(4).tolist()}, by Penumbra's transform "
             f"{penumbra_box.round(4).tolist()}: {verdict}")


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--spp", type=int, nargs="+", default=[4, 16, 64])
    parser.add_argument("--seeds", type=int, nargs=2, default=(1, 2))
    parser.add_argument("--converged-spp", type=int, default=512)
    parser.add_argument("--width", type=int, default=480)
    parser.add_argument("--grid", type=Path, default=cloud.GRID)
    parser.add_argument("--exr", type=Path, help=f"the converged image (default {CONVERGED_EXR}, "
                        f"with --quick {QUICK_EXR})")
    parser.add_argument("--quick", action="store_true", help="smoke test: 2 and 8 spp, 160 px")
    args = parser.parse_args()
    if args.quick:
        args.spp, args.converged_spp, args.width = [2, 8], 32, 160
    args.exr = args.exr or (QUICK_EXR if args.quick else CONVERGED_EXR)
    return args


def main() -> None:
    args = parse_args()
    if not args.grid.is_file():
        print(f"cycles_cloud.py: {args.grid} is missing: write it first with the project's "
              "Python: .venv/bin/python examples/cloud.py", file=sys.stderr)
        sys.exit(1)
    print_provenance()
    placement_check(args.grid)
    progress(f"sun: direction {tuple(round(c, 4) for c in sun_direction())} (Z up), "
             f"irradiance {sun_irradiance():.4f} W/m²")
    converged, seconds = render_rgb(args.grid, args.width, args.converged_spp, 99, args.exr)
    progress(f"cycles cloud: converged, {args.converged_spp} spp: {seconds:.1f} s")
    rungs = []
    rung_exr = Path(tempfile.gettempdir()) / "cycles_cloud_rung.exr"
    for samples in args.spp:
        images, times = [], []
        for seed in args.seeds:
            rgb, elapsed = render_rgb(args.grid, args.width, samples, seed, rung_exr)
            progress(f"cycles cloud: {samples} spp, seed {seed}: {elapsed:.2f} s")
            images.append(rgb)
            times.append(elapsed)
        error = relative_rmse(images[0] - images[1], converged) / math.sqrt(2)
        rungs.append(Rung(samples, sum(times) / len(times), error))
    rung_exr.unlink(missing_ok=True)
    quality = crossing(rungs)
    print(f"Cycles (Blender {bpy.app.version_string}, CPU, 2 threads) on the cloud of "
          f"examples/cloud.py, {args.width} px wide, spp ladder {', '.join(map(str, args.spp))}, "
          f"seeds {args.seeds[0]} and {args.seeds[1]}, converged {args.converged_spp} spp; "
          "* extrapolated beyond the ladder.\n")
    print("| renderer | spp at 5 % | time to 5 % (s) | 64-spp rRMSE | converged mean luminance |")
    print("|---|---:|---:|---:|---:|")
    print(f"| Cycles {bpy.app.version_string.split()[0]} "
          f"| {format_number(quality.samples, marked=quality.extrapolated)} "
          f"| {format_number(quality.seconds, marked=quality.extrapolated)} "
          f"| {format_number(rrmse_at(rungs, 64), 2)} "
          f"| {mean_luminance(converged):.4f} |")
    print("\n| spp | seconds (mean of 2 seeds) | rRMSE |\n|---:|---:|---:|")
    for rung in rungs:
        print(f"| {rung.samples} | {rung.seconds:.2f} | {rung.rrmse:.4f} |")
    print(f"\nConverged image: {args.exr}")


if __name__ == "__main__":
    main()
