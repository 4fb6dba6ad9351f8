"""Time-to-quality benchmark (`make bench`): how long Penumbra takes to reach 5 % rRMSE on the
shared scenes, side by side with Cycles (`../shared/cycles/README.md`), on a many-light scene,
and the speed-up from 1 to 2 threads.

rRMSE = sqrt(mean over pixels and RGB of (x - ref)² / (ref² + 0.01)). Penumbra's is estimated
from two renders with different seeds, a and b: rRMSE ≈ rRMSE(a - b) / √2, the weights taken
from the converged image when one is rendered (--converged-spp), else from the mean of the two
renders at the highest sample count.

Time: seconds from constructing a fresh `penumbra.Renderer` on the opened stage to the end of
its `render` call (sync, BVH build and tracing, as Cycles' numbers; reading the USD file is not
counted), the mean of the two seeds. Time to 5 % interpolates rRMSE against time log-log between
the two rungs of the spp ladder around 0.05; when the ladder does not reach (or starts below)
0.05, it is extrapolated from the last (or first) two rungs and marked with *.

Denoised (--denoised-spp, with a converged image): the same renders with ``denoise=True`` (OIDN,
guided by albedo and normal: docs/aovs.md), each compared with the converged image directly,
since a denoiser's error is mostly not noise that differs between seeds; the two seeds' rRMSEs
are averaged and the time includes the denoiser, as bench/cycles_scenes.py measures Cycles with
OIDN. Its ladder is rendered upwards until a rung is below 5 %; when the first is already, that
rung is given as an upper bound (≤).

Every image is rendered at time code 1 (as Cycles' were). Progress goes to stderr, the
markdown tables to stdout.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pxr import Usd

import penumbra
from penumbra import _core

from many_lights import write_stage
from provenance import commit, print_provenance

SHARED = Path(__file__).resolve().parents[2] / "shared"
SCENES = SHARED / "scenes"
CYCLES = SHARED / "cycles"
SHARED_SCENES = ("cornell", "dof", "motion", "glass", "instances")
TARGET_RRMSE = 0.05
TIME_CODE = 1.0
REC709 = np.array([0.2126, 0.7152, 0.0722])
MANY_LIGHT_COUNTS = (10, 1000)
THREADS_SCENE, THREADS_WIDTH, THREADS_SAMPLES = "cornell", 320, 16
QUICK_LADDER = (4, 16)


def progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def relative_rmse(difference: np.ndarray, reference: np.ndarray) -> float:
    """sqrt(mean(difference² / (reference² + 0.01))) over pixels and RGB."""
    return float(np.sqrt(np.mean(difference**2 / (reference**2 + 0.01))))


def mean_luminance(rgb: np.ndarray) -> float:
    return float(np.mean(rgb @ REC709))


@dataclass
class Setting:
    """How one rung renders: a sample count, or a sample cap with an adaptive threshold."""

    samples: int
    adaptive_threshold: float = 0.0

    def describe(self) -> str:
        if self.adaptive_threshold:
            return f"adaptive {self.adaptive_threshold:g} (≤ {self.samples} spp)"
        return f"{self.samples} spp"


@dataclass
class Crossing:
    """Where rRMSE crosses 5 %: in seconds and samples per pixel."""

    seconds: float
    samples: float
    extrapolated: bool


def render_rgb(
    stage: Usd.Stage, args: argparse.Namespace, setting: Setting, seed: int,
    denoise: bool = False,
) -> tuple[np.ndarray, float, float]:
    """One render by a fresh Renderer: its RGB (float64), seconds (construction + render, and
    the denoiser with ``denoise``) and the samples per pixel it took on average (fewer than
    ``samples`` with adaptive sampling). ``args.render_options``, when set, are more keywords
    of ``render``."""
    started = time.perf_counter()
    with penumbra.Renderer(stage) as renderer:
        image = renderer.render(
            time=TIME_CODE, width=args.width, samples=setting.samples, seed=seed,
            adaptive_threshold=setting.adaptive_threshold,
            adaptive_min_samples=args.adaptive_min_samples, indirect_clamp=args.indirect_clamp,
            glossy_filter=args.glossy_filter, denoise=denoise,
            **getattr(args, "render_options", {}),
        )
        seconds = time.perf_counter() - started
    return image["color"][..., :3].astype(np.float64), seconds, image.metadata["meanSamples"]


@dataclass
class Rung:
    """One rung of a ladder: samples per pixel taken (on average), mean seconds of the two
    seeds' renders, and rRMSE (of RGB, and of luminance alone where measured: the difference
    between the two is colour noise)."""

    samples: float
    seconds: float
    rrmse: float
    luminance_rrmse: float | None = None


def measure_ladder(
    stage: Usd.Stage,
    label: str,
    ladder: Sequence[Setting],
    args: argparse.Namespace,
    reference: np.ndarray | None,
) -> list[Rung]:
    """Render every rung of ``ladder`` with both seeds; rRMSE by the two-seed estimate."""
    renders: list[tuple[float, list[np.ndarray], float]] = []
    for setting in ladder:
        images, seconds, samples = [], [], []
        for seed in args.seeds:
            rgb, elapsed, taken = render_rgb(stage, args, setting, seed)
            progress(f"{label}: {setting.describe()}, seed {seed}: {elapsed:.2f} s, "
                     f"{taken:.1f} spp")
            images.append(rgb)
            seconds.append(elapsed)
            samples.append(taken)
        renders.append((sum(samples) / len(samples), images, sum(seconds) / len(seconds)))
    if reference is None:
        reference = (renders[-1][1][0] + renders[-1][1][1]) / 2
    return [
        Rung(samples, seconds, relative_rmse(a - b, reference) / math.sqrt(2),
             relative_rmse((a - b) @ REC709, reference @ REC709) / math.sqrt(2))
        for samples, (a, b), seconds in renders
    ]


def measure_denoised_ladder(
    stage: Usd.Stage, label: str, args: argparse.Namespace, converged: np.ndarray
) -> tuple[Crossing, bool]:
    """Denoised renders of ``args.denoised_spp`` rungs upwards until one is below 5 %, each
    image's rRMSE against ``converged``; where 5 % is crossed, and whether the first rung is
    below it already (the crossing is then that rung: an upper bound)."""
    rungs: list[Rung] = []
    for samples in args.denoised_spp:
        errors, seconds = [], []
        for seed in args.seeds:
            rgb, elapsed, _ = render_rgb(stage, args, Setting(samples), seed, denoise=True)
            errors.append(relative_rmse(rgb - converged, converged))
            seconds.append(elapsed)
            progress(f"{label} denoised: {samples} spp, seed {seed}: {elapsed:.2f} s, "
                     f"rRMSE {errors[-1]:.4f}")
        rungs.append(Rung(samples, sum(seconds) / len(seconds), sum(errors) / len(errors)))
        if rungs[-1].rrmse < TARGET_RRMSE:
            break
    if len(rungs) == 1 and rungs[0].rrmse < TARGET_RRMSE:
        return Crossing(rungs[0].seconds, rungs[0].samples, False), True
    return crossing(rungs), False


def log_log_crossing(
    xs: Sequence[float], errors: Sequence[float], target: float = TARGET_RRMSE
) -> tuple[float, bool]:
    """The x at which ``errors`` reaches ``target``, interpolated log-log between the first
    pair of points around it, else extrapolated from the nearest pair (then True)."""
    pairs = [(i, i + 1) for i in range(len(xs) - 1)]
    around = [(i, j) for i, j in pairs if errors[i] >= target >= errors[j]]
    if around:
        i, j = around[0]
    else:
        i, j = pairs[0] if errors[0] < target else pairs[-1]
        if errors[j] >= errors[i]:  # not converging: no trend to extrapolate
            return math.nan, True
    slope = (math.log(xs[j]) - math.log(xs[i])) / (math.log(errors[j]) - math.log(errors[i]))
    x = math.exp(math.log(xs[i]) + slope * (math.log(target) - math.log(errors[i])))
    return x, not around


def crossing(rungs: Sequence[Rung], target: float = TARGET_RRMSE) -> Crossing:
    errors = [rung.rrmse for rung in rungs]
    seconds, extrapolated = log_log_crossing([rung.seconds for rung in rungs], errors, target)
    samples, _ = log_log_crossing([rung.samples for rung in rungs], errors, target)
    return Crossing(seconds, samples, extrapolated)


def read_rgb(path: Path) -> np.ndarray:
    """The R, G, B channels of an image file (Cycles' references are RGBA) as float64."""
    pixels, names, _ = _core.read_image(str(path))
    channels = [list(names).index(name) for name in ("R", "G", "B")]
    return np.asarray(pixels, dtype=np.float64)[..., channels]


def cycles_numbers(readme: Path, measured: Path | None = None) -> dict[str, tuple[float, float]]:
    """Cycles' (time to 5 % in seconds, spp at 5 %) per scene: from ``measured``, the JSON file
    bench/cycles_scenes.py --json wrote on this machine, when given, else from the shared
    README's table."""
    if measured is not None:
        numbers = json.loads(measured.read_text())
        return {name: (row["seconds"], row["spp"]) for name, row in numbers.items()
                if row.get("seconds") is not None}
    if not readme.is_file():
        return {}
    row = re.compile(r"^\|\s*(\w+)\s*\|\s*([\d.]+)\s*\|\s*([\d.]+)\s*\|", re.MULTILINE)
    return {name: (float(t), float(spp)) for name, t, spp in row.findall(readme.read_text())}


def cycles_denoised_seconds(measured: Path | None) -> dict[str, float]:
    """Cycles+OIDN's time to 5 % per scene from bench/cycles_scenes.py --json's file (the
    shared README has none)."""
    if measured is None:
        return {}
    numbers = json.loads(measured.read_text())
    return {name: row["denoised_seconds"] for name, row in numbers.items()
            if row.get("denoised_seconds") is not None}


def format_number(value: float | None, digits: int = 3, marked: bool = False) -> str:
    if value is None:
        return "–"
    text = f"{value:.{digits}g}" if abs(value) < 10**digits else f"{value:.0f}"
    return text + ("*" if marked else "")


def rrmse_at(rungs: Sequence[Rung], samples: int, luminance: bool = False) -> float | None:
    return next((rung.luminance_rrmse if luminance else rung.rrmse
                 for rung in rungs if rung.samples == samples), None)


def fixed_ladder(args: argparse.Namespace) -> list[Setting]:
    return [Setting(samples) for samples in args.spp]


def adaptive_ladder(args: argparse.Namespace) -> list[Setting]:
    return [Setting(args.adaptive_cap, threshold) for threshold in args.adaptive]


def converged_image(stage: Usd.Stage, name: str, args: argparse.Namespace) -> np.ndarray:
    """The scene's converged image: rendered here, or read from ``args.converged_cache`` when an
    earlier run left one rendered with the same settings there (it is written there otherwise).
    The cache is keyed by the settings, not the commit: it is for a reference that takes many
    minutes, rendered while the machine is busy and reused by the timed runs later; the commit
    that rendered it is printed."""
    cache, seed = args.converged_cache, max(args.seeds) + 1  # a seed neither ladder uses
    key = (f"{name}_{args.width}px_{args.converged_spp}spp_seed{seed}"
           f"_clamp{args.indirect_clamp:g}_glossy{args.glossy_filter:g}"
           f"_guiding{args.guiding_training_samples}"
           + (f"_branches{args.indirect_samples}" if args.indirect_samples else "")
           + (f"_lights{args.light_samples}" if args.light_samples else "")
           + (f"_dome{args.dome_sampling}" if args.dome_sampling != "auto" else "")
           + (f"_caustics{args.caustics}" if args.caustics != "light" else ""))
    if cache is not None and (cache / f"{key}.npy").is_file():
        rendered_at = json.loads((cache / f"{key}.json").read_text())["commit"]
        progress(f"{name}: converged image read from {cache / key}.npy (commit {rendered_at})")
        return np.load(cache / f"{key}.npy")
    converged, seconds, _ = render_rgb(stage, args, Setting(args.converged_spp), seed)
    progress(f"{name}: converged, {args.converged_spp} spp: {seconds:.1f} s")
    if cache is not None:
        cache.mkdir(parents=True, exist_ok=True)
        np.save(cache / f"{key}.npy", converged)
        (cache / f"{key}.json").write_text(json.dumps({"commit": commit()}))
    return converged


def shared_scene_row(
    name: str, args: argparse.Namespace, cycles: dict[str, tuple[float, float]],
    cycles_denoised: dict[str, float],
) -> str:
    stage = Usd.Stage.Open(str(SCENES / f"{name}.usda"))
    converged: np.ndarray | None = None
    luminance_difference = converged_rrmse = None
    if args.converged_spp:
        converged = converged_image(stage, name, args)
        reference_path = CYCLES / f"{name}.exr"
        reference = read_rgb(reference_path) if reference_path.is_file() else None
        if reference is not None and reference.shape != converged.shape:
            progress(f"{name}: {reference_path} is {reference.shape[1]} px wide: not compared")
        elif reference is not None:
            luminance_difference = 100 * (mean_luminance(converged) / mean_luminance(reference) - 1)
            converged_rrmse = relative_rmse(converged - reference, reference)
    rungs = measure_ladder(stage, name, fixed_ladder(args), args, converged)
    quality = crossing(rungs)
    cycles_seconds, cycles_samples = cycles.get(name, (None, None))
    ratio = quality.seconds / cycles_seconds if cycles_seconds else None
    cells = [
        name,
        format_number(quality.samples, marked=quality.extrapolated),
        format_number(cycles_samples),
        format_number(quality.seconds, marked=quality.extrapolated),
        format_number(cycles_seconds),
        format_number(ratio, 2, marked=quality.extrapolated),
    ]
    if args.adaptive:
        adaptive = crossing(measure_ladder(stage, f"{name} adaptive", adaptive_ladder(args), args,
                                           converged))
        cells += [
            format_number(adaptive.seconds, marked=adaptive.extrapolated),
            format_number(adaptive.seconds / cycles_seconds if cycles_seconds else None, 2,
                          marked=adaptive.extrapolated),
        ]
    if args.converged_spp and args.denoised_spp:
        denoised, bound = measure_denoised_ladder(stage, name, args, converged)
        cycles_denoised_time = cycles_denoised.get(name)
        prefix = "≤ " if bound else ""
        cells += [
            prefix + format_number(denoised.seconds, marked=denoised.extrapolated),
            format_number(cycles_denoised_time),
            format_number(denoised.seconds / cycles_denoised_time if cycles_denoised_time
                          else None, 2, marked=denoised.extrapolated),
        ]
    cells += [
        format_number(rrmse_at(rungs, 64), 2),
        format_number(luminance_difference, 2),
        format_number(converged_rrmse, 2),
    ]
    return "| " + " | ".join(cells) + " |"


def shared_scenes_table(args: argparse.Namespace) -> None:
    cycles = cycles_numbers(CYCLES / "README.md", args.cycles_json)
    cycles_denoised = cycles_denoised_seconds(args.cycles_json)
    source = (
        "measured here, in this run (bench/cycles_scenes.py above)"
        if args.cycles_python
        else f"measured here ({args.cycles_json})"
        if args.cycles_json
        else "the shared README, measured on another machine and day (Cycles' own seconds have "
        "moved by up to 3 × between sittings here: time it beside this run with "
        "bench/cycles_scenes.py --json and pass --cycles-json for ratios that compare)"
    )
    print(f"Cycles' numbers: {source}.\n")
    clamp = f"indirect clamp {args.indirect_clamp:g}" if args.indirect_clamp else "no clamp"
    if args.glossy_filter:
        clamp += f", glossy filter {args.glossy_filter:g}"
    if args.guiding_training_samples:
        clamp += f", path guiding trained on {args.guiding_training_samples} spp"
    if args.indirect_samples:
        clamp += f", {args.indirect_samples} indirect samples"
    if args.light_samples:
        clamp += f", {args.light_samples} light samples"
    if args.dome_sampling != "auto":
        clamp += f", dome sampling {args.dome_sampling}"
    print(f"Shared scenes, {args.width} px wide, spp ladder {', '.join(map(str, args.spp))}, "
          f"seeds {args.seeds[0]} and {args.seeds[1]}, {clamp}; converged: "
          f"{args.converged_spp or 'not'} rendered; * extrapolated beyond the ladder.\n")
    adaptive = ""
    if args.adaptive:
        print(f"Adaptive: thresholds {', '.join(f'{t:g}' for t in args.adaptive)}, at most "
              f"{args.adaptive_cap} spp, tested from {args.adaptive_min_samples} spp on.\n")
        adaptive = " adaptive time to 5 % (s) | adaptive ratio |"
    denoised = ""
    if args.converged_spp and args.denoised_spp:
        print(f"Denoised (OIDN): ladder {', '.join(map(str, args.denoised_spp))} spp, each image "
              f"against the converged one; Cycles+OIDN "
              f"{'measured here' if cycles_denoised else 'not given (--cycles-json)'}; "
              "≤: the first rung is below 5 % already.\n")
        denoised = " denoised time to 5 % (s) | Cycles+OIDN (s) | denoised ratio |"
    print("| scene | spp at 5 % | Cycles spp at 5 % | time to 5 % (s) | Cycles (s) | ratio |"
          + adaptive + denoised + " 64-spp rRMSE | converged mean lum vs Cycles (%) "
          "| converged rRMSE vs Cycles |")
    print("|---|" + "---:|" * (8 + (2 if args.adaptive else 0) + (3 if denoised else 0)))
    for name in args.scenes:
        try:
            print(shared_scene_row(name, args, cycles, cycles_denoised), flush=True)
        except penumbra.SceneError as error:
            print(f"| {name} | failed: {error} |", flush=True)


# Where the many-light scene's lights hang, and the rRMSE its time is measured to: in view, the
# camera sees the emitters, a few pixels across (bench/camera_noise.py measures how much of the
# noise is theirs); above the view, light selection and shadows make the noise, and the target is
# the 1 %.
MANY_LIGHT_PLACEMENTS = (("in view", False, TARGET_RRMSE), ("above the view", True, 0.01))
# Ten lights in view reached 5 % near 3 spp, below a ladder starting at 4: rungs at 1 and 2 spp made
# that a crossing, not an extrapolation. Since their draws land on the lights they see (README,
# "Lights small in the image") they are below 5 % at 1 spp: their time is extrapolated below the
# first rung (*), and so is the ratio to them.
MANY_LIGHT_LOW_RUNGS = (1, 2)


def many_light_ladder(args: argparse.Namespace) -> list[Setting]:
    return [Setting(samples) for samples in sorted({*MANY_LIGHT_LOW_RUNGS, *args.spp})]


def many_lights_table(args: argparse.Namespace) -> None:
    ladder = ", ".join(setting.describe() for setting in many_light_ladder(args))
    print(f"\nMany lights (bench/many_lights.py), {args.width} px wide, ladder {ladder}; "
          "* extrapolated.\n")
    print("| lights | sphere lights | target rRMSE | spp at target | time to target (s) "
          "| 64-spp rRMSE | of luminance | time vs 10 lights |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory(prefix="penumbra-many-lights-") as directory:
        for placement, above_view, target in MANY_LIGHT_PLACEMENTS:
            first_seconds: float | None = None
            for count in MANY_LIGHT_COUNTS:
                path = write_stage(Path(directory) / f"lights_{count}_{above_view}.usda", count,
                                   above_view=above_view)
                stage = Usd.Stage.Open(str(path))
                rungs = measure_ladder(stage, f"{count} lights {placement}",
                                       many_light_ladder(args), args, None)
                quality = crossing(rungs, target)
                first_seconds = first_seconds or quality.seconds
                print(
                    f"| {placement} | {count} | {target * 100:g} % "
                    f"| {format_number(quality.samples, marked=quality.extrapolated)} "
                    f"| {format_number(quality.seconds, marked=quality.extrapolated)} "
                    f"| {format_number(rrmse_at(rungs, 64), 2)} "
                    f"| {format_number(rrmse_at(rungs, 64, luminance=True), 2)} "
                    f"| {format_number(quality.seconds / first_seconds, 2)} |",
                    flush=True,
                )
    print("\nTargets: time to 5 % at 1000 lights in view, and to 1 % above the view, ≤ 2 × at "
          "10 lights.")


def threads_table() -> None:
    """Tracing time of one renderer (synced and BVH built by a first render) per thread count;
    CPU seconds over render seconds shows how many cores the render really had (the machine may
    be shared)."""
    stage = Usd.Stage.Open(str(SCENES / f"{THREADS_SCENE}.usda"))
    print(f"\nThreads: {THREADS_SCENE}, {THREADS_WIDTH} px, {THREADS_SAMPLES} spp "
          "(render call after a warm-up render: tracing only).\n")
    print("| threads | render (s) | CPU (s) | speed-up |")
    print("|---:|---:|---:|---:|")
    images: list[np.ndarray] = []
    with penumbra.Renderer(stage) as renderer:
        renderer.render(time=TIME_CODE, width=THREADS_WIDTH, samples=1)
        single: float | None = None
        for threads in (1, 2):
            started, cpu_started = time.perf_counter(), time.process_time()
            image = renderer.render(
                time=TIME_CODE, width=THREADS_WIDTH, samples=THREADS_SAMPLES, threads=threads
            )
            seconds = time.perf_counter() - started
            cpu_seconds = time.process_time() - cpu_started
            progress(f"threads {threads}: {seconds:.2f} s")
            images.append(image["color"])
            single = single or seconds
            print(f"| {threads} | {seconds:.2f} | {cpu_seconds:.2f} | {single / seconds:.2f} |",
                  flush=True)
    identical = np.array_equal(images[0], images[1])
    print(f"\nImages bit-identical across thread counts: {'yes' if identical else 'NO'}.")


def ray_cost_table(args: argparse.Namespace) -> None:
    """Path tracing's rays per second against Embree's alone on the same scene and camera: on
    the rays one sample per pixel of the path tracer traces (each intersected or tested for
    occlusion as it was traced), and on made-up rays of three kinds (camera rays, cosine
    bounces from their hits, intersected and as shadow rays; the table's ratio before the
    path's own rays were logged).

    Both are timed in turn ``args.ray_cost_rounds`` times and the medians compared: on a shared
    machine one pass of either moves by a third within minutes, which one pair cannot tell from
    a change."""
    width, samples, rounds = args.ray_cost_width, 16, args.ray_cost_rounds
    print(f"\nRay cost: {width} px, {samples} spp after a warm-up render (tracing only); Embree "
          "alone, single rays: on the rays sample 0 of every pixel traces (the path's rays and "
          "their shadow rays, each as traced), and on made-up rays (one camera ray per pixel, "
          "cosine bounce rays from their hits, intersect and occluded). Medians of "
          f"{rounds} rounds, each timing both in turn; the range is that of the rounds' own "
          "ratios against the path's rays.\n")
    print("| scene | path tracing Mrays/s | Embree, the path's rays | cost per ray vs Embree "
          "| rounds' range | Embree camera | Embree bounce | Embree occluded "
          "| vs Embree's made-up rays |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    kinds = ("path", "primary", "bounce_intersect", "bounce_occluded")
    for name in args.scenes:
        stage = Usd.Stage.Open(str(SCENES / f"{name}.usda"))
        traced, raw_rates, ratios = [], {kind: [] for kind in kinds}, []
        with penumbra.Renderer(stage) as renderer:
            warm = renderer.render(time=TIME_CODE, width=width, samples=1)
            height = warm["color"].shape[0]
            render_pass = renderer._render_pass((warm.metadata["camera"], width, height, None, 0))
            for _ in range(rounds):
                started = time.perf_counter()
                renderer.render(time=TIME_CODE, width=width, samples=samples)
                traced.append(render_pass.rays_traced / (time.perf_counter() - started))
                raw = render_pass.measure_raw_throughput()
                for kind in kinds:
                    raw_rates[kind].append(raw[kind])
                ratios.append(raw["path"] / traced[-1])
        rays_per_second = float(np.median(traced))
        medians = {kind: float(np.median(raw_rates[kind])) for kind in kinds}
        made_up = [medians[kind] for kind in kinds[1:]]
        progress(f"{name}: {rays_per_second / 1e6:.2f} Mrays/s, Embree {medians}, "
                 f"ratios {[round(r, 2) for r in ratios]}")
        print(f"| {name} | {rays_per_second / 1e6:.2f} | {medians['path'] / 1e6:.1f} "
              f"| {medians['path'] / rays_per_second:.1f} "
              f"| {min(ratios):.1f}–{max(ratios):.1f} | "
              + " | ".join(f"{rate / 1e6:.1f}" for rate in made_up)
              + f" | {raw_cost_ratio(rays_per_second, made_up):.1f} |", flush=True)
    print("\nTarget: path tracing cost per ray against Embree's on the same rays ≤ 1.5 × on "
          "instances, ≤ 3 × on the small scenes.")


def raw_cost_ratio(rays_per_second: float, raw_rates: Sequence[float]) -> float:
    """Path tracing's cost per ray over Embree's mean cost per ray of the three kinds."""
    raw_cost = sum(1 / rate for rate in raw_rates) / len(raw_rates)
    return 1 / rays_per_second / raw_cost


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--scenes", nargs="+", default=list(SHARED_SCENES),
                        help="shared scene names (files NAME.usda in ../shared/scenes)")
    parser.add_argument("--spp", type=int, nargs="+", default=[4, 16, 64, 256],
                        help="the ladder of samples per pixel, ascending")
    parser.add_argument("--seeds", type=int, nargs=2, default=(1, 2))
    parser.add_argument("--converged-spp", type=int, default=1024,
                        help="samples per pixel of the converged image (0: skip it)")
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--denoised-spp", type=int, nargs="*", default=[1, 2, 4, 8, 16, 32],
                        help="the ladder of denoised renders, ascending (needs --converged-spp; "
                        "none: skip denoising)")
    parser.add_argument("--adaptive", type=float, nargs="*", default=[0.2, 0.1, 0.05, 0.025],
                        help="adaptive sampling thresholds, descending (none: skip adaptive)")
    parser.add_argument("--adaptive-cap", type=int, default=1024,
                        help="samples per pixel at most with adaptive sampling")
    parser.add_argument("--adaptive-min-samples", type=int, default=8)
    parser.add_argument("--indirect-clamp", type=float, default=0.0,
                        help="render everything with this indirect clamp (Cycles' numbers use 10)")
    parser.add_argument("--glossy-filter", type=float, default=0.0,
                        help="render everything with this glossy filter (Cycles' numbers use 1)")
    parser.add_argument("--guiding-training-samples", type=int, default=0,
                        help="render everything with path guiding trained on this many spp "
                        "(docs/path-guiding.md; 0: off, the default)")
    parser.add_argument("--indirect-samples", type=int, default=0,
                        help="render everything with this many paths from each camera ray's "
                        "first surface (docs/branching.md; 1: no branching; 0, the default: "
                        "as a pilot chooses per render)")
    parser.add_argument("--light-samples", type=int, default=0,
                        help="render everything with this many estimates of the direct light "
                        "at each camera ray's first surface (docs/branching.md; 0, the default: "
                        "as the same pilot chooses per render)")
    parser.add_argument("--dome-sampling", choices=("auto", "mis", "bsdf"), default="auto",
                        help="how a constant dome is found at the first surface "
                        "(docs/dome-sampling.md; auto, the default, chooses per render)")
    parser.add_argument("--caustics", choices=("path", "light"), default="light",
                        help="how caustics through smooth glass and metal, or off smooth "
                        "plastic, are found "
                        "(docs/caustics.md; light, the default, traces them from the lamps too; "
                        "path leaves them to the path tracer)")
    parser.add_argument("--cycles-json", type=Path,
                        help="Cycles' numbers measured on this machine by "
                        "bench/cycles_scenes.py --json, instead of ../shared/cycles/README.md's")
    parser.add_argument("--cycles-python", type=Path,
                        help="a Python with bpy (bench/cycles_scenes.py's docstring): time "
                        "Cycles on the same scenes first, in this run, and compare with that")
    parser.add_argument("--converged-cache", type=Path,
                        help="a folder for converged images: one rendered with the same settings "
                        "is read from it instead of rendered again (so a long reference can be "
                        "rendered while the machine is busy and the timed runs made later)")
    parser.add_argument("--ray-cost-width", type=int, default=320)
    parser.add_argument("--ray-cost-rounds", type=int, default=5,
                        help="rounds of the ray-cost table, each timing path tracing and Embree "
                        "alone in turn (medians reported)")
    parser.add_argument("--skip-many-lights", action="store_true")
    parser.add_argument("--quick", action="store_true",
                        help=f"smoke test: ladder {', '.join(map(str, QUICK_LADDER))}, "
                        "no converged image")
    args = parser.parse_args()
    if args.quick:
        args.spp, args.converged_spp = list(QUICK_LADDER), 0
        args.adaptive, args.adaptive_cap = [0.2, 0.1], 64
    if len(args.spp) < 2 or sorted(args.spp) != args.spp:
        parser.error("--spp needs at least two ascending sample counts")
    if args.ray_cost_rounds < 1:
        parser.error("--ray-cost-rounds needs at least one round")
    if args.cycles_python and args.cycles_json:
        parser.error("--cycles-python measures Cycles itself: give it or --cycles-json, not both")
    args.seeds = tuple(args.seeds)
    args.render_options = {"guiding_training_samples": args.guiding_training_samples,
                           "indirect_samples": args.indirect_samples,
                           "light_samples": args.light_samples,
                           "dome_sampling": args.dome_sampling,
                           "caustics": args.caustics}
    return args


def time_cycles(python: Path, scenes: Sequence[str], json_path: Path) -> None:
    """Cycles' time to 5 % on `scenes`, by bench/cycles_scenes.py under `python` (which has
    bpy), written to `json_path`; its tables go to stdout before Penumbra's, so that both
    renderers are timed in one sitting (seconds move with the machine between sittings)."""
    script = Path(__file__).resolve().parent / "cycles_scenes.py"
    command = [str(python), str(script), "--scenes", *scenes, "--json", str(json_path)]
    print(f"Cycles first: `{' '.join(command[1:])}` under {python}.\n", flush=True)
    try:
        subprocess.run(command, check=True)
    except (OSError, subprocess.CalledProcessError) as error:
        sys.exit(f"quality.py: Cycles could not be timed with {python}: {error}")
    print(flush=True)


def main() -> None:
    args = parse_args()
    print_provenance()
    shared = SCENES.is_dir()
    with tempfile.TemporaryDirectory(prefix="quality-") as directory:
        if shared and args.cycles_python:
            args.cycles_json = Path(directory) / "cycles.json"
            time_cycles(args.cycles_python, args.scenes, args.cycles_json)
        tables(args, shared)


def tables(args: argparse.Namespace, shared: bool) -> None:
    """The benchmark's tables, in order; the shared scenes' only where they are found."""
    if shared:
        shared_scenes_table(args)
    if not args.skip_many_lights:
        many_lights_table(args)  # its scenes are written here
    if shared:
        ray_cost_table(args)
        threads_table()
    else:
        print(f"\nquality.py: the shared-scene, ray-cost and threads tables are skipped: they "
              f"need the shared scenes, and {SCENES} is missing.")


if __name__ == "__main__":
    main()
