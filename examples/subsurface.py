"""Writes a row of wax-like spheres whose MaterialX standard_surface differs only in its
subsurface mean free path, beside a block of absorbing green glass, back-lit by a warm light —
and renders it with penumbra-record.

Run with the project's Python; the stage is written to build/examples/subsurface.usda, not
committed:

    .venv/bin/python examples/subsurface.py            # writes the stage, prints the command
    .venv/bin/python examples/subsurface.py --render   # and renders examples/images/subsurface.png

From left to right the spheres' subsurface_scale is 0.02, 0.1 and 0.4 (subsurface_radius
(1, 0.55, 0.3): red travels furthest, as in skin and wax): the longer the mean free path, the
more light crosses the sphere to its shadowed side and the softer and redder it glows. The glass
block's transmission_color is reached at a depth of 0.5 units (Beer–Lambert inside the solid).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from example_stages import add_ground, add_look_at_camera, record

HERE = Path(__file__).resolve().parent
STAGE = HERE.parent / "build" / "examples" / "subsurface.usda"
IMAGE = HERE / "images" / "subsurface.png"
SCALES = (0.02, 0.1, 0.4)


def standard_surface(stage: Usd.Stage, path: str, **inputs) -> UsdShade.Material:
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/surface")
    shader.CreateIdAttr("ND_standard_surface_surfaceshader")
    for name, value in inputs.items():
        kind = (Sdf.ValueTypeNames.Color3f if isinstance(value, tuple)
                else Sdf.ValueTypeNames.Float)
        shader.CreateInput(name, kind).Set(Gf.Vec3f(*value) if isinstance(value, tuple) else value)
    material.CreateSurfaceOutput("mtlx").ConnectToSource(
        shader.CreateOutput("out", Sdf.ValueTypeNames.Token)
    )
    return material


def bind(prim: Usd.Prim, material: UsdShade.Material) -> None:
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(material)


def write_stage(path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.Xform.Define(stage, "/World")
    for n, scale in enumerate(SCALES):
        sphere = UsdGeom.Sphere.Define(stage, f"/World/wax_{n}")
        sphere.CreateRadiusAttr(0.5)
        sphere.AddTranslateOp().Set(Gf.Vec3d(-2.4 + 1.2 * n, 0.5, 0))
        bind(sphere.GetPrim(), standard_surface(
            stage, f"/World/Looks/wax_{n}", base=1.0, base_color=(0.9, 0.75, 0.6),
            subsurface=1.0, subsurface_color=(0.95, 0.75, 0.55),
            subsurface_radius=(1.0, 0.55, 0.3), subsurface_scale=scale,
            specular=1.0, specular_roughness=0.35,
        ))
    glass = UsdGeom.Cube.Define(stage, "/World/glass")
    glass.CreateSizeAttr(0.9)
    glass.AddTranslateOp().Set(Gf.Vec3d(1.5, 0.45, 0))
    glass.AddRotateYOp().Set(30)
    bind(glass.GetPrim(), standard_surface(
        stage, "/World/Looks/glass", base=0.0, specular=1.0, specular_roughness=0.02,
        transmission=1.0, transmission_color=(0.35, 0.8, 0.45), transmission_depth=0.5,
    ))
    add_ground(stage, "/World/floor", 20, (0.3, 0.3, 0.32))
    centre = Gf.Vec3d(0, 0.45, 0)
    add_look_at_camera(stage, "/World/camera", Gf.Vec3d(0, 1.6, 6.5), centre, 40, (36, 20.25))

    back = UsdLux.RectLight.Define(stage, "/World/back")
    back.CreateWidthAttr(3)
    back.CreateHeightAttr(1.5)
    back.CreateIntensityAttr(25)
    back.CreateColorAttr(Gf.Vec3f(1.0, 0.85, 0.65))
    view = Gf.Matrix4d().SetLookAt(Gf.Vec3d(0.5, 3.5, -2.5), centre, Gf.Vec3d(0, 1, 0))
    back.AddTransformOp().Set(view.GetInverse())
    sky = UsdLux.DomeLight.Define(stage, "/World/sky")
    sky.CreateIntensityAttr(0.15)
    sky.CreateColorAttr(Gf.Vec3f(0.7, 0.8, 1.0))
    stage.SetDefaultPrim(stage.GetPrimAtPath("/World"))
    stage.Save()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--render", action="store_true",
                        help="render examples/images/subsurface.png")
    parser.add_argument("--width", type=int, default=960)
    parser.add_argument("--samples", type=int, default=128)
    args = parser.parse_args()
    write_stage(STAGE)
    record(STAGE, IMAGE, args.width, args.samples, ["--enableDomeLightVisibility"], args.render,
           str(STAGE))

if __name__ == "__main__":
    main()
