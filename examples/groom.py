"""Writes a furry ball: 120,000 combed, clumped, curling BasisCurves strands on a sphere, on a
floor, under a sky dome, a key and a rim light — and renders it with penumbra-record.

Run with the project's Python; the stage (13 MB as .usdc) is written to
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
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt

from example_stages import add_look_at_camera, record

HERE = Path(__file__).resolve().parent
STAGE = HERE.parent / "build" / "examples" / "groom.usdc"
IMAGE = HERE / "images" / "groom.png"

RADIUS = 1.0  # of the ball
LENGTH = 0.45  # of a strand, on average
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

    Each strand leaves its root along the normal and lies down along a combed flow (a downward
    direction projected onto the skin) and under gravity, more towards its tip; it is drawn
    towards its clump's strand (CLUMPS clumps at random over the ball) and curls a little."""
    rng = np.random.default_rng(seed)
    roots = _unit(fibonacci_sphere(count) + rng.normal(scale=0.004, size=(count, 3)))
    centres = _unit(rng.normal(size=(CLUMPS, 3)))
    clump = _nearest(roots, centres)
    length = LENGTH * rng.uniform(0.75, 1.25, size=(count, 1))
    s = np.linspace(-0.05, 1.0, CONTROL_POINTS)  # the first point lies under the skin

    def combed(normals: np.ndarray) -> np.ndarray:
        flow = np.array([0.35, -1.0, 0.25]) + rng.normal(scale=0.25, size=normals.shape)
        flow -= normals * (flow * normals).sum(axis=1, keepdims=True)
        return flow / np.maximum(np.linalg.norm(flow, axis=1, keepdims=True), 1e-6)

    def offset(normals: np.ndarray, flow: np.ndarray, t: float) -> np.ndarray:
        """Where a strand of unit length rooted at ``normals`` is at ``t`` (0 root, 1 tip),
        from its root."""
        rise, lie = t * (1 - 0.3 * t), 0.45 * t * t
        return normals * rise + flow * lie + np.array([0.0, -0.25, 0.0]) * t**3

    flows, clump_flows = combed(roots), combed(centres)[clump]
    phase = rng.uniform(0, 2 * math.pi, size=(count, 1))
    aside = _unit(np.cross(roots, flows))
    points = np.empty((count, CONTROL_POINTS, 3))
    for k, t in enumerate(s):
        own = roots * RADIUS + offset(roots, flows, t) * length
        guide = centres[clump] * RADIUS + offset(centres[clump], clump_flows, t) * length
        pull = 0.4 * max(t, 0.0) ** 1.5  # tips gather most
        curl = 0.06 * length * max(t, 0.0) * np.sin(phase + 6 * t) * aside
        points[:, k] = (1 - pull) * own + pull * guide + curl
    taper = np.interp(s, [-0.05, 0.0, 1.0], [ROOT_WIDTH, ROOT_WIDTH, TIP_WIDTH])
    widths = taper[None, :] * rng.uniform(0.8, 1.2, size=(count, 1))
    # Warm brown with lighter and darker strands, clumps tinted alike.
    base = np.array([0.46, 0.29, 0.16])
    tint = rng.uniform(0.85, 1.15, size=(CLUMPS, 1))[clump] * rng.uniform(0.8, 1.2, size=(count, 1))
    colors = np.clip(base * tint, 0, 1)
    return (
        points.reshape(-1, 3).astype(np.float32),
        widths.reshape(-1).astype(np.float32),
        colors.astype(np.float32),
    )


def _unit(vectors: np.ndarray) -> np.ndarray:
    return vectors / np.linalg.norm(vectors, axis=1, keepdims=True)


def _nearest(points: np.ndarray, centres: np.ndarray, chunk: int = 4096) -> np.ndarray:
    """The index of the nearest of ``centres`` (unit vectors) to each of ``points``, in chunks
    that keep the products small (penumbra-record, started from this process, would count its
    peak memory as its own)."""
    return np.concatenate(
        [np.argmax(points[n : n + chunk] @ centres.T, axis=1) for n in range(0, len(points), chunk)]
    )


def preview_material(stage: Usd.Stage, path: str, **inputs) -> UsdShade.Material:
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/PreviewSurface")
    shader.CreateIdAttr("UsdPreviewSurface")
    for name, value in inputs.items():
        names = Sdf.ValueTypeNames
        value_type = names.Color3f if isinstance(value, tuple) else names.Float
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
    skin_look = preview_material(
        stage, "/World/Looks/skin", diffuseColor=(0.12, 0.07, 0.04), roughness=0.8
    )
    bind(skin.GetPrim(), skin_look)

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
    floor_look = preview_material(
        stage, "/World/Looks/floor", diffuseColor=(0.42, 0.44, 0.47), roughness=0.6
    )
    bind(floor.GetPrim(), floor_look)

    centre = Gf.Vec3d(0, 0.95, 0)
    add_look_at_camera(stage, "/World/main_cam", Gf.Vec3d(0.6, 3.6, 5.2), centre, 40, (36, 24))

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
    view = Gf.Matrix4d().SetLookAt(position, target, Gf.Vec3d(0, 1, 0))
    light.AddTransformOp().Set(view.GetInverse())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--strands", type=int, default=120_000)
    parser.add_argument("--render", action="store_true", help="render examples/images/groom.png")
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--samples", type=int, default=64)
    args = parser.parse_args()
    write_stage(STAGE, args.strands)
    record(STAGE, IMAGE, args.width, args.samples, [], args.render,
           f"{STAGE} ({args.strands:,} strands)")

if __name__ == "__main__":
    main()
