"""A many-light benchmark scene: a floor, a few boxes and spheres, N small SphereLights of varied
power and colour and a dim DomeLight, seen by camera ``/cam`` (640x360 render settings).

The lights are placed and coloured by a seeded random generator, so a given (N, seed) always
writes the same stage. Each light's intensity is scaled by 10 / N: the total emitted power, and
so the image's brightness, stays about the same whatever N is, and only the light count varies.

    .venv/bin/python bench/many_lights.py OUT.usda --lights 1000
"""

from __future__ import annotations

import argparse
import colorsys
from pathlib import Path

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdLux, UsdRender

DEFAULT_SEED = 9
REFERENCE_LIGHT_COUNT = 10  # the light count at which intensities are used as drawn
FLOOR_SIZE = 16.0
LIGHT_RADIUS = 0.05
LIGHT_HEIGHTS = (0.3, 3.0)  # metres above the floor
# Above the camera (at 5 m, looking 28° down): no camera ray meets a light, so the noise left is
# light selection and shadows, not sub-pixel emitters seen directly (bench/camera_noise.py).
ABOVE_VIEW_HEIGHTS = (5.5, 7.0)


def add_objects(stage: Usd.Stage) -> None:
    """The floor and a few grey and coloured boxes and spheres around the origin."""
    floor = UsdGeom.Cube.Define(stage, "/World/floor")
    floor.CreateSizeAttr(1.0)
    floor.AddTranslateOp().Set(Gf.Vec3d(0, -0.05, 0))  # top face at y = 0
    floor.AddScaleOp().Set(Gf.Vec3f(FLOOR_SIZE, 0.1, FLOOR_SIZE))
    floor.CreateDisplayColorAttr([Gf.Vec3f(0.6, 0.6, 0.6)])
    shapes = [
        ("box_a", UsdGeom.Cube, (-2.0, 0.5, -1.0), (0.7, 0.3, 0.2)),
        ("box_b", UsdGeom.Cube, (1.5, 0.5, -2.5), (0.5, 0.5, 0.5)),
        ("ball_a", UsdGeom.Sphere, (0.0, 0.6, 0.0), (0.2, 0.4, 0.7)),
        ("ball_b", UsdGeom.Sphere, (2.5, 0.6, 1.0), (0.8, 0.8, 0.75)),
        ("ball_c", UsdGeom.Sphere, (-1.0, 0.6, 2.0), (0.3, 0.6, 0.3)),
    ]
    for name, schema, centre, colour in shapes:
        shape = schema.Define(stage, f"/World/{name}")
        if schema is UsdGeom.Sphere:
            shape.CreateRadiusAttr(0.6)
        else:
            shape.CreateSizeAttr(1.0)
        shape.AddTranslateOp().Set(Gf.Vec3d(*centre))
        shape.CreateDisplayColorAttr([Gf.Vec3f(*colour)])


def add_lights(
    stage: Usd.Stage, count: int, seed: int, heights: tuple[float, float] = LIGHT_HEIGHTS
) -> None:
    """``count`` small SphereLights scattered over the floor at ``heights`` (metres, lowest and
    highest), plus a dim sky dome."""
    rng = np.random.default_rng(seed)
    half = FLOOR_SIZE / 2
    positions = np.column_stack(
        (
            rng.uniform(-half, half, count),
            rng.uniform(*heights, count),
            rng.uniform(-half, half, count),
        )
    )
    # Powers spread over two orders of magnitude; saturated hues of every colour.
    intensities = 10 ** rng.uniform(1.5, 3.5, count) * REFERENCE_LIGHT_COUNT / count
    hues = rng.uniform(0, 1, count)
    for index, (position, intensity, hue) in enumerate(zip(positions, intensities, hues)):
        light = UsdLux.SphereLight.Define(stage, f"/World/lights/light_{index:04d}")
        light.CreateRadiusAttr(LIGHT_RADIUS)
        light.CreateIntensityAttr(float(intensity))
        light.CreateColorAttr(Gf.Vec3f(*colorsys.hsv_to_rgb(hue, 0.6, 1.0)))
        light.AddTranslateOp().Set(Gf.Vec3d(*position))
    dome = UsdLux.DomeLight.Define(stage, "/World/sky")
    dome.CreateColorAttr(Gf.Vec3f(0.6, 0.7, 1.0))
    dome.CreateIntensityAttr(0.05)


def add_camera(stage: Usd.Stage) -> None:
    """Camera ``/cam`` looking down at the objects, and 640x360 render settings."""
    camera = UsdGeom.Camera.Define(stage, "/cam")
    camera.CreateFocalLengthAttr(0.24)
    camera.CreateHorizontalApertureAttr(0.36)
    camera.CreateVerticalApertureAttr(0.2025)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.05, 100))
    camera.AddTranslateOp().Set(Gf.Vec3d(0, 5, 10))
    camera.AddRotateXOp().Set(-28)
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets([camera.GetPath()])
    settings.CreateResolutionAttr(Gf.Vec2i(640, 360))
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")


def write_stage(
    path: Path, count: int, seed: int = DEFAULT_SEED, above_view: bool = False
) -> Path:
    """Write the scene with ``count`` sphere lights to ``path`` and return ``path``;
    ``above_view``: the lights hang above what the camera sees."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(1)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, "/World").GetPrim())
    add_objects(stage)
    add_lights(stage, count, seed, ABOVE_VIEW_HEIGHTS if above_view else LIGHT_HEIGHTS)
    add_camera(stage)
    stage.GetRootLayer().Save()
    return path


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("output", type=Path, help="the .usda file to write")
    parser.add_argument("--lights", type=int, default=1000, help="number of sphere lights")
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED)
    parser.add_argument("--above-view", action="store_true",
                        help="hang the lights 5.5-7 m up, above what the camera sees")
    args = parser.parse_args()
    write_stage(args.output, args.lights, args.seed, args.above_view)


if __name__ == "__main__":
    main()
