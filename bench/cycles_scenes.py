"""Cycles' time to 5 % rRMSE on the shared scenes (../shared/scenes), measured on this machine
with bench/quality.py's method, plain and with Cycles' OpenImageDenoise denoiser, to set beside
Penumbra's numbers measured on the same machine.

Run with a Python that has ``bpy`` (PyPI's wheels are for Python 3.11; not installed by the
Makefile; this script does not import penumbra):

    python3.11 -m venv /tmp/bpy-venv && /tmp/bpy-venv/bin/pip install bpy==5.0.1
    /tmp/bpy-venv/bin/python bench/cycles_scenes.py [--shared DIR] [--scenes NAME ...] [--json PATH]

(--shared: the directory holding scenes/ and cycles/, by default ../shared beside the
repository as bench/quality.py finds it.)

Each render imports the scene afresh with Blender's USD importer, then sets it up as
../shared/cycles/README.md says its references were made: Cycles on the CPU with 2 threads,
640x360 at time code 1 (frame 1), Sobol (tabulated), light tree, max bounces 12 (diffuse 4,
glossy 4, transmission 12), indirect clamp 10, direct clamp off, filter glossy 1, caustics on,
Blackman-Harris 1.5 px, no adaptive sampling; denoised renders add Cycles' OIDN denoiser at its
defaults (CPU, albedo and normal passes, accurate prefilter, high quality).

Blender 5.0.1's importer leaves these unlike the USD files; the script puts them right from the
.usda text (Blender's Python has no ``pxr``):
- shutter: the importer turns the animated transforms into Transform Cache constraints (which
  interpolate at subframes) but leaves motion blur off; the camera's ``shutter:open`` and
  ``shutter:close`` (time codes, 24 per second as Blender's frames) become motion blur with a
  shutter of close − open frames starting on the frame.
- glass: UsdPreviewSurface's ``opacity`` < 1 is translucency (dielectric transmission with
  ``ior``), as Penumbra renders it; the importer makes it the Principled BSDF's alpha, which
  leaves the glass sphere invisible. Every Principled BSDF with an unconnected alpha below 1
  gets transmission weight 1 − alpha and alpha 1 (IOR 1.5 and roughness as imported).
- DistantLight: the importer doubles ``angle`` (USD's and Blender's are both the angular
  diameter) and gives the sun 4 × ``intensity``. A normalized DistantLight's intensity is the
  irradiance on a facing surface, which is Blender's sun strength: strength = intensity
  (unnormalized: the irradiance of a disk of radiance intensity, intensity · π sin²(angle / 2)),
  angle and exposure as authored.
- dome: the importer makes no world for a DomeLight without a texture; a constant DomeLight
  becomes the world's Background of its colour, strength intensity · 2^exposure (a textured
  dome is refused).
- lights seen by the camera: UsdLux lights are (cornell's RectLight is in view, and in the
  reference); the importer's lights are not (Blender's default): every light is made visible
  to the camera.
The camera /Render/Settings names becomes the scene camera, at its resolution. Checked by the
brightness column: the mean luminance of the last plain rung against the reference's (on
2026-12-03: within 0.01 % on cornell, dof, motion and instances at 8 to 128 spp, -0.34 % on
glass at 64 spp, whose caustics are still noisy there; cornell was 43 % dark with its light
unseen).

rRMSE = sqrt(mean over pixels and RGB of (x - ref)² / (ref² + 0.01)), ref = the shared
converged Cycles image ../shared/cycles/NAME.exr (2048 spp, seed 1). Plain renders: the
two-seed estimate of bench/quality.py, rRMSE(a - b) / √2 with the reference as the weights.
Denoised renders: their error is mostly not noise that differs between seeds, so each denoised
image is compared with the reference directly, and the two seeds' rRMSEs averaged.
Time: seconds from the end of the USD import to the end of Blender's render call, the mean of
the two seeds: setting the scene up (the fixes above and the render settings) and the render
call (Cycles' sync, BVH build and tracing, and for denoised renders the denoiser), as the shared
README counts; importing the USD file and writing the image out are not counted. Each ladder
is rendered upwards until a rung is below 5 %; time to 5 % interpolates log-log between the
two rungs around 0.05 (bench/quality.py's ``crossing``; * marks an extrapolation); when the
first rung is below 5 % already, that rung is given as an upper bound (≤). The load averages
at the start and at the end are printed with the table.

--json PATH writes {scene: {"seconds": s, "spp": n, "denoised_seconds": s, "denoised_spp": n}}
after every scene (time to 5 % and spp at 5 %, plain and denoised; null when there is no trend
to extrapolate). Progress goes to stderr, the table to stdout.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

try:
    import bpy
except ImportError:
    print("cycles_scenes.py: skipped, Blender's Python module `bpy` cannot be imported by "
          f"{sys.executable} (PyPI serves it for Python 3.11: pip install 'bpy==5.0.1').")
    sys.exit(0)

from cycles_cloud import blender_output_silenced, load_exr_rgb, read_render_result, reset
from provenance import print_provenance
from quality import (
    SHARED, SHARED_SCENES, TARGET_RRMSE, TIME_CODE, Crossing, Rung, crossing, cycles_numbers,
    format_number, mean_luminance, progress, relative_rmse,
)

BOUNCES = {"max_bounces": 12, "diffuse_bounces": 4, "glossy_bounces": 4,
           "transmission_bounces": 12}
THREADS = 2
Value = float | tuple[float, ...] | str


def usda_block(text: str, type_name: str) -> list[tuple[str, dict[str, Value]]]:
    """The prims of ``type_name`` in a .usda text: (name, {attribute: value}) of the attributes
    authored in each prim's braces (numbers, tuples of numbers, asset paths and targets as text;
    time samples are not read)."""
    prims = []
    for match in re.finditer(rf'^\s*def {type_name} "(\w+)"[^{{]*{{', text, re.MULTILINE):
        depth, end = 1, match.end()
        while depth:
            depth += {"{": 1, "}": -1}.get(text[end], 0)
            end += 1
        attributes: dict[str, Value] = {}
        for name, value in re.findall(r"^\s*(?:uniform\s+)?\w+(?:\[\])?\s+([\w:]+)\s*=\s*(.+)$",
                                      text[match.end():end - 1], re.MULTILINE):
            attributes[name] = parse_value(value.strip())
        prims.append((match.group(1), attributes))
    return prims


def parse_value(text: str) -> Value:
    """A number, a flat tuple of numbers, else the text (matrices, paths, targets, tokens)."""
    if text.startswith("(") and text.count("(") == 1:
        return tuple(float(part) for part in text.strip("()").split(","))
    try:
        return float(text)
    except ValueError:
        return text.strip("@<>\"")


def number(attributes: dict[str, Value], name: str, default: float) -> float:
    value = attributes.get(name, default)
    assert isinstance(value, float), f"{name} = {value!r}: expected a number"
    return value


def fix_shutter(scene: bpy.types.Scene, text: str) -> None:
    _, camera = usda_block(text, "Camera")[0]
    shutter_open, shutter_close = (number(camera, f"shutter:{end}", 0.0)
                                   for end in ("open", "close"))
    scene.render.use_motion_blur = shutter_close > shutter_open
    if scene.render.use_motion_blur:
        if shutter_open != 0.0:
            raise ValueError(f"shutter:open {shutter_open}: only a shutter opening on the frame "
                             "is converted")
        scene.render.motion_blur_shutter = shutter_close - shutter_open
        scene.render.motion_blur_position = "START"


def fix_translucency() -> None:
    for material in bpy.data.materials:
        for node in material.node_tree.nodes if material.node_tree else ():
            alpha = node.inputs["Alpha"] if node.type == "BSDF_PRINCIPLED" else None
            if alpha is not None and not alpha.is_linked and alpha.default_value < 1.0:
                node.inputs["Transmission Weight"].default_value = 1.0 - alpha.default_value
                alpha.default_value = 1.0


def fix_distant_lights(text: str) -> None:
    for name, light in usda_block(text, "DistantLight"):
        sun = bpy.data.objects[name].data
        angle = math.radians(number(light, "inputs:angle", 0.53))
        intensity = number(light, "inputs:intensity", 1.0)
        if not number(light, "inputs:normalize", 0.0):
            intensity *= math.pi * math.sin(angle / 2) ** 2
        sun.normalize, sun.energy, sun.angle = True, intensity, angle
        sun.exposure = number(light, "inputs:exposure", 0.0)


def fix_dome(scene: bpy.types.Scene, text: str) -> None:
    domes = usda_block(text, "DomeLight")
    if not domes:
        return
    name, dome = domes[0]
    if "inputs:texture:file" in dome:
        raise ValueError(f"DomeLight {name}: a textured dome is not converted")
    world = bpy.data.worlds.new(name)
    background = world.node_tree.nodes["Background"]
    colour = dome.get("inputs:color", (1.0, 1.0, 1.0))
    assert isinstance(colour, tuple)
    background.inputs["Color"].default_value = (*colour, 1.0)
    background.inputs["Strength"].default_value = (
        number(dome, "inputs:intensity", 1.0) * 2.0 ** number(dome, "inputs:exposure", 0.0))
    scene.world = world


def set_camera_and_resolution(scene: bpy.types.Scene, text: str) -> None:
    _, settings = usda_block(text, "RenderSettings")[0]
    scene.camera = bpy.data.objects[str(settings["camera"]).rsplit("/", 1)[-1]]
    resolution = settings["resolution"]
    assert isinstance(resolution, tuple)
    scene.render.resolution_x, scene.render.resolution_y = (int(n) for n in resolution)
    scene.render.resolution_percentage = 100


def configure_cycles(scene: bpy.types.Scene, samples: int, seed: int, denoise: bool) -> None:
    """../shared/cycles/README.md's settings."""
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    scene.render.threads_mode, scene.render.threads = "FIXED", THREADS
    cycles.samples, cycles.seed, cycles.use_animated_seed = samples, seed, False
    cycles.sampling_pattern = "TABULATED_SOBOL"
    cycles.use_adaptive_sampling = False
    cycles.use_light_tree = True
    for name, value in BOUNCES.items():
        setattr(cycles, name, value)
    cycles.sample_clamp_direct, cycles.sample_clamp_indirect = 0.0, 10.0
    cycles.blur_glossy = 1.0
    cycles.caustics_reflective = cycles.caustics_refractive = True
    cycles.pixel_filter_type, cycles.filter_width = "BLACKMAN_HARRIS", 1.5
    cycles.use_denoising = denoise
    if denoise:
        cycles.denoiser, cycles.denoising_use_gpu = "OPENIMAGEDENOISE", False
        cycles.denoising_input_passes = "RGB_ALBEDO_NORMAL"
        cycles.denoising_prefilter, cycles.denoising_quality = "ACCURATE", "HIGH"
    scene.render.film_transparent = False
    scene.render.use_persistent_data = False
    scene.view_settings.view_transform, scene.view_settings.look = "Standard", "None"
    scene.frame_set(int(TIME_CODE))


def show_lights_to_camera() -> None:
    for obj in bpy.data.objects:
        if obj.type == "LIGHT":
            obj.visible_camera = True


def set_up(scene: bpy.types.Scene, text: str, samples: int, seed: int, denoise: bool) -> None:
    show_lights_to_camera()
    fix_shutter(scene, text)
    fix_translucency()
    fix_distant_lights(text)
    fix_dome(scene, text)
    set_camera_and_resolution(scene, text)
    configure_cycles(scene, samples, seed, denoise)


def render_rgb(path: Path, samples: int, seed: int, denoise: bool,
               exr: Path) -> tuple[np.ndarray, float]:
    """One render of a freshly imported scene: RGB (float64, top row first) and the seconds from
    the end of the import to the end of the render call."""
    reset()
    with blender_output_silenced():
        bpy.ops.wm.usd_import(filepath=str(path))
    scene = bpy.context.scene
    text = path.read_text()
    with blender_output_silenced():  # choosing the denoiser makes Cycles probe for GPUs aloud
        started = time.perf_counter()
        set_up(scene, text, samples, seed, denoise)
        bpy.ops.render.render()
        seconds = time.perf_counter() - started
    return read_render_result(scene, exr), seconds


def measure_ladder(
    path: Path, ladder: Sequence[int], seeds: Sequence[int], denoise: bool,
    error: Callable[[list[np.ndarray]], float], exr: Path,
) -> tuple[list[Rung], list[np.ndarray]]:
    """Render the rungs of ``ladder`` with every seed, in order, until one is below 5 % (the
    rungs above it would not change where 5 % is crossed); the rungs and the last rung's
    images."""
    rungs: list[Rung] = []
    images: list[np.ndarray] = []
    for samples in ladder:
        images, seconds = [], []
        for seed in seeds:
            rgb, elapsed = render_rgb(path, samples, seed, denoise, exr)
            progress(f"{path.stem}{' denoised' if denoise else ''}: {samples} spp, seed {seed}: "
                     f"{elapsed:.2f} s")
            images.append(rgb)
            seconds.append(elapsed)
        rungs.append(Rung(samples, sum(seconds) / len(seconds), error(images)))
        if rungs[-1].rrmse < TARGET_RRMSE:
            break
    return rungs, images


def time_to_target(rungs: Sequence[Rung]) -> tuple[Crossing, str]:
    """bench/quality.py's crossing and its mark (* extrapolated); when the first rung is below
    5 % already, that rung, marked ≤ (an upper bound: extrapolating below the first rung would
    assume a denoiser's cost shrinks with the samples)."""
    if len(rungs) == 1:
        return Crossing(rungs[0].seconds, rungs[0].samples, False), "≤"
    found = crossing(rungs)
    return found, "*" if found.extrapolated else ""


def cell(value: float, mark: str, digits: int = 3) -> str:
    text = format_number(value, digits)
    return f"≤ {text}" if mark == "≤" else text + mark


def load_averages() -> str:
    return ", ".join(f"{load:.2f}" for load in os.getloadavg())


def describe(rungs: Sequence[Rung]) -> str:
    return ", ".join(f"{rung.samples}: {rung.rrmse:.3f}" for rung in rungs)


def scene_row(
    name: str, args: argparse.Namespace, anchors: dict[str, tuple[float, float]], exr: Path
) -> tuple[str, dict[str, float]]:
    reference = load_exr_rgb(args.shared / "cycles" / f"{name}.exr")
    scene = args.shared / "scenes" / f"{name}.usda"

    def two_seed(images: list[np.ndarray]) -> float:
        return relative_rmse(images[0] - images[1], reference) / math.sqrt(2)

    def against_reference(images: list[np.ndarray]) -> float:
        return float(np.mean([relative_rmse(image - reference, reference) for image in images]))

    plain, last_images = measure_ladder(scene, args.spp, args.seeds, False, two_seed, exr)
    brightness = 100 * (mean_luminance(sum(last_images) / len(last_images))
                        / mean_luminance(reference) - 1)
    denoised, _ = measure_ladder(scene, args.denoised_spp, args.seeds, True, against_reference,
                                 exr)
    (quality, mark), (denoised_quality, denoised_mark) = map(time_to_target, (plain, denoised))
    anchor_seconds, anchor_samples = anchors.get(name, (None, None))
    cells = [
        name,
        cell(quality.seconds, mark),
        cell(quality.samples, mark),
        format_number(anchor_seconds),
        format_number(anchor_samples),
        cell(denoised_quality.seconds, denoised_mark),
        cell(denoised_quality.samples, denoised_mark),
        f"{brightness:+.2f} ({plain[-1].samples} spp)",
        describe(plain),
        describe(denoised),
    ]
    numbers = {"seconds": quality.seconds, "spp": quality.samples,
               "denoised_seconds": denoised_quality.seconds,
               "denoised_spp": denoised_quality.samples}
    return "| " + " | ".join(cells) + " |", numbers


def write_json(path: Path, results: dict[str, dict[str, float]]) -> None:
    clean = {name: {key: None if math.isnan(value) else round(value, 3)
                    for key, value in numbers.items()} for name, numbers in results.items()}
    path.write_text(json.dumps(clean, indent=2) + "\n")


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--scenes", nargs="+", default=list(SHARED_SCENES),
                        help="shared scene names (NAME.usda in SHARED/scenes)")
    parser.add_argument("--shared", type=Path, default=SHARED,
                        help="the directory of scenes/ and cycles/ (default %(default)s)")
    parser.add_argument("--spp", type=int, nargs="+", default=[4, 8, 16, 32, 64, 128, 256],
                        help="the plain ladder of samples per pixel, ascending")
    parser.add_argument("--denoised-spp", type=int, nargs="+",
                        default=[1, 2, 4, 8, 16, 32, 64],
                        help="the ladder of samples per pixel with OIDN, ascending")
    parser.add_argument("--seeds", type=int, nargs=2, default=(1, 2))
    parser.add_argument("--json", type=Path,
                        help="write the times and spp at 5 %% here (after every scene)")
    args = parser.parse_args()
    for ladder in (args.spp, args.denoised_spp):
        if len(ladder) < 2 or sorted(ladder) != ladder:
            parser.error("a ladder needs at least two ascending sample counts")
    if not (args.shared / "cycles").is_dir():
        parser.error(f"{args.shared / 'cycles'} is missing: give --shared")
    return args


def main() -> None:
    args = parse_args()
    print_provenance()
    print(f"Cycles (Blender {bpy.app.version_string}, CPU, {THREADS} threads) on the shared "
          "scenes, set up as ../shared/cycles/README.md says; plain: two-seed rRMSE over "
          f"{', '.join(map(str, args.spp))} spp; OIDN: each denoised image against the "
          f"reference, mean of the seeds, over {', '.join(map(str, args.denoised_spp))} spp; "
          f"seeds {args.seeds[0]} and {args.seeds[1]}; each ladder stops at its first rung "
          "below 5 %; * extrapolated beyond the ladder, ≤ below 5 % at the first rung. Load "
          f"averages (1, 5, 15 min) at the start: {load_averages()}.\n")
    print("| scene | time to 5 % (s) | spp at 5 % | README (s) | README spp "
          "| OIDN: time to 5 % (s) | OIDN: spp at 5 % | brightness vs reference (%) "
          "| plain rungs (spp: rRMSE) | OIDN rungs (spp: rRMSE) |")
    print("|---|" + "---:|" * 7 + "---|---|", flush=True)
    anchors = cycles_numbers(args.shared / "cycles" / "README.md")
    results: dict[str, dict[str, float]] = {}
    with tempfile.TemporaryDirectory(prefix="cycles-scenes-") as directory:
        exr = Path(directory) / "render.exr"
        for name in args.scenes:
            row, results[name] = scene_row(name, args, anchors, exr)
            print(row, flush=True)
            if args.json:
                write_json(args.json, results)
    print(f"\nLoad averages (1, 5, 15 min) at the end: {load_averages()}. README: "
          "../shared/cycles/README.md's anchors (another machine and day). Brightness: the "
          "mean luminance of the last plain rung's two images against the reference's.")


if __name__ == "__main__":
    main()
