"""Camera-ray noise on the many-light scene (`make bench`): how much of the image's error comes
from the pixels that see the small sphere lights directly, where only the pixel estimator
(which camera samples hit a light about a pixel across) decides the noise.

The scene is bench/many_lights.py's (a floor, a few objects, N sphere lights of radius 5 cm at
0.3–3 m and a dim dome, seen from 5 m up: most lights are in view). A pixel "sees an emitter"
when some light's projected disc, widened by the pixel filter's radius, reaches its centre
(the lights' centres and radii are projected through the USD camera; a light hidden behind an
object still counts, which is rare here). For each sample count, and for adaptive sampling, the
table gives rRMSE (bench/quality.py's: two seeds, weights from a converged image) over all
pixels, and the share of its square that comes from the emitter pixels, beside their share of
the pixels. A share of the error far above the share of the pixels means the pixel estimator,
not light transport, is what more samples are spent on.

    .venv/bin/python bench/camera_noise.py [--lights 1000] [--width 640] [--spp 16 64]
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdLux

import penumbra
from many_lights import write_stage
from provenance import print_provenance
from quality import TIME_CODE, progress, relative_rmse

FILTER_RADIUS_PX = 1.5  # Penumbra's default pixel filter (Gaussian, 1.5 px radius)


def emitter_pixels(stage: Usd.Stage, width: int, height: int) -> np.ndarray:
    """(height, width) bool: pixels whose centre lies within a sphere light's projected disc
    widened by the filter radius."""
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/cam")).GetCamera(TIME_CODE)
    frustum = camera.frustum
    view_projection = frustum.ComputeViewMatrix() * frustum.ComputeProjectionMatrix()
    view = frustum.ComputeViewMatrix()
    # Pixels per unit of tan(angle) off the axis, horizontally.
    half_angle = math.radians(camera.GetFieldOfView(Gf.Camera.FOVHorizontal)) / 2
    pixels_per_tan = width / 2 / math.tan(half_angle)
    ys, xs = np.mgrid[0:height, 0:width] + 0.5
    mask = np.zeros((height, width), dtype=bool)
    cache = UsdGeom.XformCache(TIME_CODE)
    for prim in stage.Traverse():
        if not prim.IsA(UsdLux.SphereLight):
            continue
        centre = cache.GetLocalToWorldTransform(prim).ExtractTranslation()
        depth = -view.Transform(centre)[2]
        if depth <= 0:
            continue
        ndc = view_projection.Transform(centre)
        px, py = (ndc[0] + 1) / 2 * width, (1 - ndc[1]) / 2 * height
        radius = UsdLux.SphereLight(prim).GetRadiusAttr().Get() / depth * pixels_per_tan
        mask |= (xs - px) ** 2 + (ys - py) ** 2 <= (radius + FILTER_RADIUS_PX) ** 2
    return mask


def render(stage: Usd.Stage, width: int, samples: int, seed: int,
           adaptive_threshold: float = 0.0) -> tuple[np.ndarray, float]:
    """RGB (float64) and mean samples per pixel of one render."""
    with penumbra.Renderer(stage) as renderer:
        image = renderer.render(time=TIME_CODE, width=width, samples=samples, seed=seed,
                                adaptive_threshold=adaptive_threshold)
    return image["color"][..., :3].astype(np.float64), image.metadata["meanSamples"]


def row(label: str, images: list[np.ndarray], samples: float, converged: np.ndarray,
        mask: np.ndarray) -> str:
    squared = (images[0] - images[1]) ** 2 / 2 / (converged**2 + 0.01)
    per_pixel = squared.mean(axis=2)
    share = per_pixel[mask].sum() / per_pixel.sum()
    emitter_rrmse = relative_rmse((images[0] - images[1])[mask], converged[mask]) / math.sqrt(2)
    other_rrmse = relative_rmse((images[0] - images[1])[~mask], converged[~mask]) / math.sqrt(2)
    total = math.sqrt(per_pixel.mean())
    return (f"| {label} | {samples:.1f} | {total:.4f} | {100 * share:.1f} % | "
            f"{emitter_rrmse:.4f} | {other_rrmse:.4f} | {total * math.sqrt(1 - share):.4f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--lights", type=int, default=1000)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--spp", type=int, nargs="+", default=[16, 64])
    parser.add_argument("--adaptive", type=float, nargs="*", default=[0.05],
                        help="adaptive thresholds to measure as well (at most 4 × the last spp)")
    parser.add_argument("--converged-spp", type=int, default=1024)
    args = parser.parse_args()
    print_provenance()
    with tempfile.TemporaryDirectory(prefix="penumbra-camera-noise-") as directory:
        stage = Usd.Stage.Open(str(write_stage(Path(directory) / "lights.usda", args.lights)))
        converged, _ = render(stage, args.width, args.converged_spp, 3)
        progress(f"converged: {args.converged_spp} spp")
        height = converged.shape[0]
        mask = emitter_pixels(stage, args.width, height)
        print(f"\nCamera-ray noise: bench/many_lights.py with {args.lights} sphere lights, "
              f"{args.width}x{height}, converged {args.converged_spp} spp; emitter pixels: "
              f"{mask.sum()} ({100 * mask.mean():.2f} % of the image).\n")
        print("| render | spp | rRMSE | emitter pixels' share of the squared error "
              "| rRMSE over emitter pixels | over the others | the others', as if alone |")
        print("|---|---:|---:|---:|---:|---:|---:|")
        settings = [(f"{n} spp", n, 0.0) for n in args.spp]
        settings += [(f"adaptive {t:g}", 4 * args.spp[-1], t) for t in args.adaptive]
        for label, samples, threshold in settings:
            renders = [render(stage, args.width, samples, seed, threshold) for seed in (1, 2)]
            progress(f"{label}: done")
            print(row(label, [image for image, _ in renders],
                      sum(taken for _, taken in renders) / 2, converged, mask), flush=True)
    print("\nThe last column is the rRMSE the image would have if the emitter pixels had none "
          "(their error set to 0, the mean still over every pixel).")


if __name__ == "__main__":
    main()
