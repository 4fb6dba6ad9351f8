"""Writes a furry ball: 120,000 clumped, drooping, curling BasisCurves strands on a sphere, on a
floor, under a sky dome, a key and a rim light — and renders it with penumbra-record.

Run with the project's Python; the stage (about 20 MB as .usdc) is written to
build/examples/groom.usdc, not committed:

    .venv/bin/python examples/groom.py            # writes the stage, prints the render command
    .venv/bin/python examples/groom.py --render   # and renders examples/images/groom.png

The fur is cubic B-spline curves (nonperiodic, 6 control points each; the first one below the
skin, so the curve starts inside it), tapered by widths per vertex, one displayColor per strand
read by a UsdPreviewSurface through a UsdPrimvarReader_float3.
"""

from __future__ import annotations

import argparse
import math
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt

HERE = Path(__file__).resolve().parent
STAGE = HERE.parent / "build" / "examples" / "groom.usdc"
IMAGE = HERE / "images" / "groom.png"

RADIUS = 1.0  # of the ball
LENGTH = 0.32  # of a strand, on average
CONTROL_POINTS = 6
CLUMPS = 2500
ROOT_WIDTH, TIP_WIDTH = 0.0055, 0.0006


def fibonacci_sphere(count: int) -> np.ndarray:
    """``count`` unit vectors spread evenly over the sphere."""
    k = np.arange(count) + 0.5
    y = 1 - 2 * k / count
    ring = np.sqrt(1 - y * y)
    azimuth = k * math.pi * (3 - math.sqrt(5))
    return np.column_stack([ring * np.cos(azimuth), y, ring * np.sin(azimuth)])


def fur(count: int, seed: int = 7) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Control points (float32 [count·6, 3]), widths per vertex and one colour per strand.

    Each strand grows along its root's normal, bends down under gravity more towards its tip,
    is drawn towards its clump's centre line (clumps of about count/CLUMPS strands) and curls
    about it by a few degrees."""
    rng = np.random.default_rng(seed)
    roots = fibonacci_sphere(count) + rng.normal(scale=0.004, size=(count, 3))
    roots /= np.linalg.norm(roots, axis=1, keepdims=True)
    centres = fibonacci_sphere(CLUMPS)
    clump = np.argmax(roots @ centres.T, axis=1) if count <= 200_000 else _nearest(roots, centres)
    length = LENGTH * rng.uniform(0.75, 1.25, size=(count, 1))
    s = np.linspace(-0.05, 1.0, CONTROL_POINTS)  # the first point lies under the skin
    gravity = np.array([0.0, -1.0, 0.0])
    phase = rng.uniform(0, 2 * math.pi, size=(count, 1))
    aside = np.cross(roots, rng.normal(size=(count, 3)))
    aside /= np.linalg.norm(aside, axis=1, keepdims=True)
    across = np.cross(roots, aside)
    points = np.empty((count, CONTROL_POINTS, 3))
    for k, t in enumerate(s):
        along = roots * (RADIUS + t * length)
        droop = gravity * (0.45 * max(t, 0.0) ** 2) * length
        # Towards the clump's own strand (its centre's normal at this height), tips most.
        pull = 0.55 * max(t, 0.0) ** 1.5
        target = centres[clump] * (RADIUS + t * length)
        curl = 0.05 * length * max(t, 0.0) * (
            np.cos(phase + 5 * t) * aside + np.sin(phase + 5 * t) * across
        )
        points[:, k] = (1 - pull) * along + pull * target + droop + curl
    taper = np.interp(s, [-0.05, 0.0, 1.0], [ROOT_WIDTH, ROOT_WIDTH, TIP_WIDTH])
    widths = taper[None, :] * rng.uniform(0.8, 1.2, size=(count, 1))
    # Warm brown with lighter and darker strands, clumps tinted alike.
    base = np.array([0.50, 0.33, 0.19])
    tint = rng.uniform(0.85, 1.15, size=(CLUMPS, 1))[clump] * rng.uniform(0.8, 1.2, size=(count, 1))
    colors = np.clip(base * tint, 0, 1)
    return (
        points.reshape(-1, 3).astype(np.float32),
        widths.reshape(-1).astype(np.float32),
        colors.astype(np.float32),
    )


def _nearest(points: np.ndarray, centres: np.ndarray, chunk: int = 100_000) -> np.ndarray:
    """The index of the nearest of ``centres`` (unit vectors) to each of ``points``, in chunks."""
    return np.concatenate(
        [np.argmax(points[n : n + chunk] @ centres.T, axis=1) for n in range(0, len(points), chunk)]
    )


def preview_material(stage: Usd.Stage, path: str, **inputs) -> UsdShade.Material:
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/PreviewSurface")
    shader.CreateIdAttr("UsdPreviewSurface")
    for name, value in inputs.items():
        value_type = Sdf.ValueTypeNames.Color3f if isinstance(value, tuple) else Sdf.ValueTypeNames.Float
        shader.CreateInput(name, value_type).Set(value)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def fur_material(stage: Usd.Stage, path: str) -> UsdShade.Material:
    """A glossy UsdPreviewSurface whose diffuse colour is each strand's displayColor."""
    material = preview_material(stage, path, roughness=0.45, specular=0.35)
    reader = UsdShade.Shader.Define(stage, f"{path}/StrandColor")
    reader.CreateIdAttr("UsdPrimvarReader_float3")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("displayColor")
    reader.CreateInput("fallback", Sdf.ValueTypeNames.Float3).Set(Gf.Vec3f(0.5, 0.33, 0.19))
    reader.CreateOutput("result", Sdf.ValueTypeNames.Float3)
    surface = UsdShade.Shader(stage.GetPrimAtPath(f"{path}/PreviewSurface"))
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        reader.ConnectableAPI(), "result"
    )
    return material


def bind(prim: Usd.Prim, material: UsdShade.Material) -> None:
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(material)


def write_stage(path: Path, strands: int) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(1)
    UsdGeom.Xform.Define(stage, "/World")
    ball = UsdGeom.Xform.Define(stage, "/World/ball")
    ball.AddTranslateOp().Set(Gf.Vec3d(0, RADIUS + 0.02, 0))

    skin = UsdGeom.Sphere.Define(stage, "/World/ball/skin")
    skin.CreateRadiusAttr(RADIUS)
    bind(skin.GetPrim(), preview_material(stage, "/World/Looks/skin", diffuseColor=(0.12, 0.07, 0.04), roughness=0.8))

    points, widths, colors = fur(strands)
    curves = UsdGeom.BasisCurves.Define(stage, "/World/ball/fur")
    curves.CreateTypeAttr(UsdGeom.Tokens.cubic)
    curves.CreateBasisAttr(UsdGeom.Tokens.bspline)
    curves.CreateWrapAttr(UsdGeom.Tokens.nonperiodic)
    counts = np.full(strands, CONTROL_POINTS, dtype=np.int32)
    curves.CreateCurveVertexCountsAttr(Vt.IntArray.FromNumpy(counts))
    curves.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    curves.CreateWidthsAttr(Vt.FloatArray.FromNumpy(widths))
    curves.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    curves.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform).Set(Vt.Vec3fArray.FromNumpy(colors))
    low, high = points.min(axis=0) - ROOT_WIDTH, points.max(axis=0) + ROOT_WIDTH
    curves.CreateExtentAttr([Gf.Vec3f(*map(float, low)), Gf.Vec3f(*map(float, high))])
    bind(curves.GetPrim(), fur_material(stage, "/World/Looks/fur"))

    floor = UsdGeom.Plane.Define(stage, "/World/floor")
    floor.CreateAxisAttr(UsdGeom.Tokens.y)
    floor.CreateWidthAttr(40)
    floor.CreateLengthAttr(40)
    bind(floor.GetPrim(), preview_material(stage, "/World/Looks/floor", diffuseColor=(0.42, 0.44, 0.47), roughness=0.6))

    camera = UsdGeom.Camera.Define(stage, "/World/main_cam")
    camera.CreateFocalLengthAttr(40)
    camera.CreateHorizontalApertureAttr(36)
    camera.CreateVerticalApertureAttr(24)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.1, 200))
    eye, centre = Gf.Vec3d(0.6, 3.6, 5.2), Gf.Vec3d(0, 0.95, 0)
    view = Gf.Matrix4d().SetLookAt(eye, centre, Gf.Vec3d(0, 1, 0)).GetInverse()
    camera.AddTransformOp().Set(view)

    sky = UsdLux.DomeLight.Define(stage, "/World/Lights/sky")
    sky.CreateIntensityAttr(0.35)
    sky.CreateColorAttr(Gf.Vec3f(0.75, 0.85, 1.0))
    key = UsdLux.RectLight.Define(stage, "/World/Lights/key")
    key.CreateWidthAttr(2.5)
    key.CreateHeightAttr(2.5)
    key.CreateIntensityAttr(18)
    key.CreateColorAttr(Gf.Vec3f(1.0, 0.93, 0.82))
    _aim(key, Gf.Vec3d(-3.5, 4.5, 3.0), centre)
    rim = UsdLux.RectLight.Define(stage, "/World/Lights/rim")
    rim.CreateWidthAttr(1.5)
    rim.CreateHeightAttr(1.5)
    rim.CreateIntensityAttr(40)
    _aim(rim, Gf.Vec3d(2.5, 3.5, -4.0), centre)
    stage.SetDefaultPrim(stage.GetPrimAtPath("/World"))
    stage.Save()


def _aim(light: UsdGeom.Xformable, position: Gf.Vec3d, target: Gf.Vec3d) -> None:
    """Place ``light`` at ``position`` with its −Z axis (the direction a RectLight emits along)
    towards ``target``."""
    light.AddTransformOp().Set(Gf.Matrix4d().SetLookAt(position, target, Gf.Vec3d(0, 1, 0)).GetInverse())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--strands", type=int, default=120_000)
    parser.add_argument("--render", action="store_true", help=f"render {IMAGE.relative_to(HERE.parent)}")
    parser.add_argument("--width", type=int, default=960)
    parser.add_argument("--samples", type=int, default=64)
    args = parser.parse_args()
    write_stage(STAGE, args.strands)
    record = shutil.which("penumbra-record", path=str(Path(sys.executable).parent)) or "penumbra-record"
    command = [record, str(STAGE), str(IMAGE), "-w", str(args.width), "-spp", str(args.samples)]
    print(f"wrote {STAGE} ({args.strands:,} strands); render with:\n  {' '.join(command)}")
    if args.render:
        started = time.perf_counter()
        subprocess.run(command, check=True)
        print(f"rendered {IMAGE} in {time.perf_counter() - started:.1f} s")


if __name__ == "__main__":
    main()
