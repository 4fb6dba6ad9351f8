"""Writes examples/showcase.usda: UsdPreviewSurface materials and UsdLux lights side by side.

Run with the project's Python (`.venv/bin/python examples/showcase.py`); the .usda is committed,
so this is only needed to change the scene. With ``--render`` it also renders the README's
examples/images/showcase.png with penumbra-record (256 samples per pixel, the dome seen, denoised).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade

from example_stages import record

HERE = Path(__file__).resolve().parent


def uv_sphere_cage(stage: Usd.Stage, path: str, centre, radius: float) -> UsdGeom.Mesh:
    """A coarse UV-sphere cage rendered as a Catmull-Clark limit surface."""
    stacks, slices = 6, 8
    points = [Gf.Vec3f(0, radius, 0)]
    for i in range(1, stacks):
        theta = math.pi * i / stacks
        for j in range(slices):
            phi = 2 * math.pi * j / slices
            points.append(
                Gf.Vec3f(
                    radius * math.sin(theta) * math.cos(phi),
                    radius * math.cos(theta),
                    -radius * math.sin(theta) * math.sin(phi),
                )
            )
    points.append(Gf.Vec3f(0, -radius, 0))
    bottom = len(points) - 1

    def ring(i: int, j: int) -> int:
        return 1 + (i - 1) * slices + j % slices

    counts, indices = [], []
    for j in range(slices):
        counts += [3, 3]
        indices += [0, ring(1, j), ring(1, j + 1), bottom, ring(stacks - 1, j + 1), ring(stacks - 1, j)]
    for i in range(1, stacks - 1):
        for j in range(slices):
            counts.append(4)
            indices += [ring(i, j), ring(i + 1, j), ring(i + 1, j + 1), ring(i, j + 1)]
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(points)
    mesh.CreateFaceVertexCountsAttr(counts)
    mesh.CreateFaceVertexIndicesAttr(indices)
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.catmullClark)
    mesh.AddTranslateOp().Set(Gf.Vec3d(*centre))
    return mesh


def preview_material(stage: Usd.Stage, path: str, **inputs) -> UsdShade.Material:
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/PreviewSurface")
    shader.CreateIdAttr("UsdPreviewSurface")
    for name, value in inputs.items():
        value_type = Sdf.ValueTypeNames.Color3f if isinstance(value, tuple) else Sdf.ValueTypeNames.Float
        shader.CreateInput(name, value_type).Set(value)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def bind(prim: Usd.Prim, material: UsdShade.Material) -> None:
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(material)


def new_stage(name: str, end_time: float = 1) -> Usd.Stage:
    """A new metre, Y-up stage ``examples/<name>.usda`` rendering from time code 1, with /World."""
    stage = Usd.Stage.CreateNew(str(HERE / f"{name}.usda"))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(end_time)
    stage.SetTimeCodesPerSecond(24)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    return stage


def add_floor(stage: Usd.Stage, half_size: float, **look) -> None:
    """A square floor at y = 0 with a UsdPreviewSurface of ``look`` inputs."""
    s = half_size
    floor = UsdGeom.Mesh.Define(stage, "/World/floor")
    floor.CreatePointsAttr([(-s, 0, -s), (-s, 0, s), (s, 0, s), (s, 0, -s)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    floor.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    bind(floor.GetPrim(), preview_material(stage, "/World/Looks/floor", **look))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--render", action="store_true",
                        help="render examples/images/showcase.png")
    args = parser.parse_args()
    write_stage()
    # Photons gather the caustics seen through the flint ball (docs/caustics.md). Denoised: the
    # raw 256 spp still shows grain in the frosted ball, light that scatters inside rough glass
    # on its way to the lamps (the README says so under the image).
    record(HERE / "showcase.usda", HERE / "images" / "showcase.png", 640, 256,
           ["--enableDomeLightVisibility", "--caustics", "photons", "--denoise"], args.render,
           "examples/showcase.usda")


def write_stage() -> None:
    stage = new_stage("showcase")
    add_floor(stage, 20, diffuseColor=(0.55, 0.55, 0.5), roughness=0.7)

    looks = [
        ("gold", dict(diffuseColor=(1.0, 0.78, 0.34), metallic=1.0, roughness=0.25)),
        ("lacquer", dict(diffuseColor=(0.7, 0.05, 0.04), roughness=0.5, clearcoat=1.0, clearcoatRoughness=0.05)),
        # A dispersive flint-like glass (Abbe number 25): the scene renders spectrally.
        ("glass", {"diffuseColor": (1.0, 1.0, 1.0), "opacity": 0.0, "ior": 1.6, "roughness": 0.0,
                   "penumbra:abbeNumber": 25.0}),
        ("frosted", dict(diffuseColor=(0.2, 0.35, 0.8), opacity=0.0, ior=1.5, roughness=0.35)),
    ]
    for index, (name, inputs) in enumerate(looks):
        sphere = uv_sphere_cage(stage, f"/World/{name}", (-2.4 + 1.6 * index, 0.7, 0), 0.7)
        bind(sphere.GetPrim(), preview_material(stage, f"/World/Looks/{name}", **inputs))

    key = UsdLux.RectLight.Define(stage, "/World/key")
    key.CreateWidthAttr(2.5)
    key.CreateHeightAttr(1.0)
    key.CreateIntensityAttr(12)
    key.AddTranslateOp().Set(Gf.Vec3d(-1, 3.5, 2))
    key.AddRotateXOp().Set(-70)
    shaping = UsdLux.ShapingAPI.Apply(key.GetPrim())
    shaping.CreateShapingConeAngleAttr(60)
    shaping.CreateShapingConeSoftnessAttr(0.3)

    warm = UsdLux.SphereLight.Define(stage, "/World/warm")
    warm.CreateRadiusAttr(0.15)
    warm.CreateIntensityAttr(60)
    warm.CreateEnableColorTemperatureAttr(True)
    warm.CreateColorTemperatureAttr(3000)
    warm.AddTranslateOp().Set(Gf.Vec3d(2.8, 1.8, 1.5))

    sky = UsdLux.DomeLight.Define(stage, "/World/sky")
    sky.CreateColorAttr(Gf.Vec3f(0.6, 0.7, 1.0))
    sky.CreateIntensityAttr(0.25)

    camera = UsdGeom.Camera.Define(stage, "/cam")
    camera.CreateFocalLengthAttr(0.35)
    camera.CreateHorizontalApertureAttr(0.36)
    camera.CreateVerticalApertureAttr(0.2025)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.05, 1000))
    camera.CreateFStopAttr(4.0)
    camera.CreateFocusDistanceAttr(6.9)
    camera.AddTranslateOp().Set(Gf.Vec3d(0, 2.2, 6.5))
    camera.AddRotateXOp().Set(-12)
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets([camera.GetPath()])
    settings.CreateResolutionAttr(Gf.Vec2i(640, 360))
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    stage.GetRootLayer().Save()


if __name__ == "__main__":
    main()
