"""Writes a cumulus cloud over a field at evening — an OpenVDB density grid (a cluster of
noise-eroded puffs, 128 × 80 × 96 voxels) read through a UsdVolVolume with a MaterialX volume
material — and renders it with penumbra-record.

Run with the project's Python; the stage and its .vdb are written to build/examples/, not
committed:

    .venv/bin/python examples/cloud.py            # writes them, prints the render command
    .venv/bin/python examples/cloud.py --render   # and renders examples/images/cloud.png

The material is MaterialX's ``volume`` of an ``anisotropic_vdf`` whose scattering and absorption
are the ``density`` field (a ``geompropvalue``) times constants: 12 and 0.04 per unit of
length at density 1, forward-scattering (g = 0.6) as water droplets are.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, UsdVol

import penumbra
from example_stages import add_ground, add_look_at_camera, record

HERE = Path(__file__).resolve().parent
OUTPUT = HERE.parent / "build" / "examples"
STAGE = OUTPUT / "cloud.usda"
GRID = OUTPUT / "cloud.vdb"
IMAGE = HERE / "images" / "cloud.png"

RESOLUTION = (128, 80, 96)  # voxels along x, y, z
VOXEL = 0.05  # scene units


def value_noise(shape: tuple[int, int, int], cells: int, rng: np.random.Generator) -> np.ndarray:
    """Smooth noise in [0, 1] over a (z, y, x) block: random values on a lattice of ``cells``
    cells along the longest side, interpolated with a smoothstep."""
    nz, ny, nx = shape
    step = max(shape) / cells
    lattice = rng.random((int(nz / step) + 2, int(ny / step) + 2, int(nx / step) + 2))
    axes = [np.arange(n) / step for n in shape]
    index = [np.floor(a).astype(int) for a in axes]
    frac = [a - np.floor(a) for a in axes]
    frac = [f * f * (3 - 2 * f) for f in frac]
    iz, iy, ix = np.ix_(*index)
    fz, fy, fx = np.ix_(*frac)
    result = np.zeros(shape)
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                weight = (fz if dz else 1 - fz) * (fy if dy else 1 - fy) * (fx if dx else 1 - fx)
                result += weight * lattice[iz + dz, iy + dy, ix + dx]
    return result


def cloud_density(seed: int = 3) -> np.ndarray:
    """Density (float32, [z, y, x]): puffs (spheres with soft edges) whose union is eroded by
    three octaves of noise, flat at the base as cumulus clouds are."""
    rng = np.random.default_rng(seed)
    nx, ny, nz = RESOLUTION
    z, y, x = np.meshgrid(
        np.arange(nz) * VOXEL, np.arange(ny) * VOXEL, np.arange(nx) * VOXEL, indexing="ij"
    )
    size = np.array([nx, ny, nz]) * VOXEL
    shape = np.zeros(x.shape)
    for _ in range(24):
        # Puffs towering in the middle, lower and smaller towards the sides.
        across = rng.uniform(0.2, 0.8)
        middle = 1 - abs(across - 0.5) * 2
        height = rng.uniform(0.3, 0.45) + 0.3 * middle * rng.uniform(0.3, 1.0)
        centre = size * [across, height, rng.uniform(0.35, 0.65)]
        radius = rng.uniform(0.45, 0.75) + 0.45 * middle
        d = np.sqrt((x - centre[0]) ** 2 + (y - centre[1]) ** 2 + (z - centre[2]) ** 2)
        shape = np.maximum(shape, 1 - d / radius)
    noise = sum(
        value_noise((nz, ny, nx), cells, rng) / 2**octave
        for octave, cells in enumerate((6, 14, 30))
    )
    density = np.clip(shape * 3 - noise * 1.1, 0, 1)
    density[y < size[1] * 0.3] = 0  # the flat base
    return density.astype(np.float32)


def write_grid(path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    nx, ny, nz = RESOLUTION
    # Voxel (i, j, k) at VOXEL · (i, j, k), the cloud centred over the origin.
    index_to_object = np.diag([VOXEL, VOXEL, VOXEL, 1.0])
    index_to_object[3, :3] = [-nx * VOXEL / 2, 0.0, -nz * VOXEL / 2]
    penumbra.write_vdb(str(path), {"density": cloud_density()}, index_to_object)


def cloud_material(stage: Usd.Stage, path: str) -> UsdShade.Material:
    """MaterialX volume: scattering 12·density, absorption 0.04·density, g = 0.6."""
    material = UsdShade.Material.Define(stage, path)
    density = UsdShade.Shader.Define(stage, f"{path}/density")
    density.CreateIdAttr("ND_geompropvalue_float")
    density.CreateInput("geomprop", Sdf.ValueTypeNames.String).Set("density")
    density_out = density.CreateOutput("out", Sdf.ValueTypeNames.Float)

    def scaled(name: str, value: float) -> UsdShade.Output:
        node = UsdShade.Shader.Define(stage, f"{path}/{name}")
        node.CreateIdAttr("ND_multiply_color3FA")
        node.CreateInput("in1", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(value))
        node.CreateInput("in2", Sdf.ValueTypeNames.Float).ConnectToSource(density_out)
        return node.CreateOutput("out", Sdf.ValueTypeNames.Color3f)

    vdf = UsdShade.Shader.Define(stage, f"{path}/vdf")
    vdf.CreateIdAttr("ND_anisotropic_vdf")
    vdf.CreateInput("scattering", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        scaled("scattering", 12.0)
    )
    vdf.CreateInput("absorption", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        scaled("absorption", 0.04)
    )
    vdf.CreateInput("anisotropy", Sdf.ValueTypeNames.Float).Set(0.6)
    volume = UsdShade.Shader.Define(stage, f"{path}/volume")
    volume.CreateIdAttr("ND_volume")
    volume.CreateInput("vdf", Sdf.ValueTypeNames.Token).ConnectToSource(
        vdf.CreateOutput("out", Sdf.ValueTypeNames.Token)
    )
    material.CreateOutput("mtlx:volume", Sdf.ValueTypeNames.Token).ConnectToSource(
        volume.CreateOutput("out", Sdf.ValueTypeNames.Token)
    )
    return material


def write_stage(path: Path) -> None:
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.Xform.Define(stage, "/World")
    cloud = UsdVol.Volume.Define(stage, "/World/cloud")
    cloud.AddTranslateOp().Set(Gf.Vec3d(0, 1.2, 0))
    asset = UsdVol.OpenVDBAsset.Define(stage, "/World/cloud/density")
    asset.CreateFilePathAttr(Sdf.AssetPath(f"./{GRID.name}"))
    asset.CreateFieldNameAttr("density")
    cloud.CreateFieldRelationship("density", asset.GetPath())
    UsdShade.MaterialBindingAPI.Apply(cloud.GetPrim()).Bind(
        cloud_material(stage, "/World/Looks/cloud")
    )

    add_ground(stage, "/World/ground", 60, (0.16, 0.2, 0.09))
    add_look_at_camera(stage, "/World/camera", Gf.Vec3d(0.5, 1.0, 9.5), Gf.Vec3d(0, 2.6, 0),
                       30, (36, 20.25), far=500)

    sky = UsdLux.DomeLight.Define(stage, "/World/sky")
    sky.CreateColorAttr(Gf.Vec3f(0.35, 0.55, 1.0))
    sky.CreateIntensityAttr(0.6)
    sun = UsdLux.DistantLight.Define(stage, "/World/sun")
    sun.CreateAngleAttr(0.53)
    sun.CreateIntensityAttr(60000)
    sun.CreateColorAttr(Gf.Vec3f(1.0, 0.8, 0.6))
    sun.AddRotateXYZOp().Set(Gf.Vec3f(-18, -60, 0))  # low, from the right
    stage.SetDefaultPrim(stage.GetPrimAtPath("/World"))
    stage.Save()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--render", action="store_true", help="render examples/images/cloud.png")
    parser.add_argument("--width", type=int, default=960)
    parser.add_argument("--samples", type=int, default=256)
    args = parser.parse_args()
    write_grid(GRID)
    write_stage(STAGE)
    flags = ["--maxVolumeDepth", "64", "--maxPathDepth", "64", "--enableDomeLightVisibility"]
    record(STAGE, IMAGE, args.width, args.samples, flags, args.render, f"{STAGE} and {GRID}")


if __name__ == "__main__":
    main()
