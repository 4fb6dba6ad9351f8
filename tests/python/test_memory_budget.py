"""Memory limits: huge textures cost the texture cache, not their resolution; the scene's
geometry and acceleration structures are checked against ``max_memory`` before they are built."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pxr import Sdf, UsdGeom, UsdLux, UsdShade, Vt

import penumbra
from penumbra.memory import FILM_BYTES_PER_PIXEL, format_size, resident_memory
from pattern_png import write_pattern_png
from stages import add_camera, new_stage

TEXTURE_SIZE = 8192
CACHE = 64 * 2**20
GROWTH_LIMIT = 200 * 2**20
"""Peak memory a render with an 8k² texture on a material and on a dome may add. Before the
texture cache (measured): 2.0 GB for the material (the image as floats and its MIP levels),
3.1 GB for the dome (the image, its texels and their sampling distribution). Now: the cache
(64 MiB here), the dome's sampling distribution (from a 1024² MIP level, about 40 MB) and
the buffers of one band of scanlines while a texture is prepared: 74 MiB in all, measured."""

# The peak is the child's VmHWM, not getrusage's ru_maxrss: Linux carries ru_maxrss over fork
# and exec, so it would start at the RSS of the test process that launched the child.
CHILD = """
import re, sys
from penumbra import Renderer
from penumbra.memory import resident_memory
renderer = Renderer(sys.argv[1])
before = resident_memory()
image = renderer.render("/cam", width=32, samples=1, texture_cache=int(sys.argv[2]))
with open("/proc/self/status", encoding="ascii") as status:
    peak = int(re.search(r"VmHWM:\\s+(\\d+) kB", status.read())[1]) * 1024
print(peak - before, float(image["color"][..., :3].mean()))
"""


def textured_stage(path: Path, texture: Path) -> None:
    """A quad whose diffuse colour reads ``texture`` (auto: an 8-bit PNG is sRGB), lit by a
    dome light showing the same texture (read raw)."""
    stage = new_stage(path)
    add_camera(stage)
    mesh = UsdGeom.Mesh.Define(stage, "/quad")
    mesh.CreatePointsAttr([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(
        "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex
    )
    st.Set([(0, 0), (1, 0), (1, 1), (0, 1)])
    material = UsdShade.Material.Define(stage, "/mat")
    surface = UsdShade.Shader.Define(stage, "/mat/surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    reader = UsdShade.Shader.Define(stage, "/mat/st")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
    image = UsdShade.Shader.Define(stage, "/mat/texture")
    image.CreateIdAttr("UsdUVTexture")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(texture))
    image.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(
        reader.ConnectableAPI(), "result"
    )
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        image.ConnectableAPI(), "rgb"
    )
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    dome = UsdLux.DomeLight.Define(stage, "/dome")
    dome.CreateTextureFileAttr(str(texture))
    stage.Save()


@pytest.mark.skipif(
    "libasan" in os.environ.get("LD_PRELOAD", ""),
    reason="under AddressSanitizer (make sanitize) resident memory holds its shadow and quarantine",
)
def test_a_huge_texture_costs_the_cache_not_its_resolution(tmp_path: Path) -> None:
    texture = tmp_path / "pattern.png"
    write_pattern_png(texture, TEXTURE_SIZE)
    stage = tmp_path / "textured.usda"
    textured_stage(stage, texture)
    result = subprocess.run(
        [sys.executable, "-c", CHILD, str(stage), str(CACHE)],
        capture_output=True,
        text=True,
        check=True,
    )
    growth, mean = (float(value) for value in result.stdout.split())
    assert growth < GROWTH_LIMIT, f"the render's peak grew by {format_size(growth)}"
    assert mean > 0.01  # the textures were read: the quad and the dome are lit and coloured


def grid_stage(quads: int):
    """An in-memory stage: a camera and a polygon grid of ``quads``² quads."""
    stage = new_stage()
    add_camera(stage)
    mesh = UsdGeom.Mesh.Define(stage, "/grid")
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    xs = np.linspace(-2, 2, quads + 1, dtype=np.float32)
    x, y = np.meshgrid(xs, xs)
    points = np.stack([x.ravel(), y.ravel(), np.zeros(x.size, np.float32)], axis=1)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    i, j = np.meshgrid(np.arange(quads), np.arange(quads))
    corner = (j * (quads + 1) + i).ravel()
    indices = np.stack([corner, corner + 1, corner + quads + 2, corner + quads + 1], axis=1)
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(quads * quads, 4, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(indices.ravel().astype(np.int32)))
    UsdLux.DistantLight.Define(stage, "/sun")
    return stage


def test_the_scene_build_is_checked_against_the_budget_before_it_runs() -> None:
    quads = 600
    renderer = penumbra.Renderer(grid_stage(quads))
    estimate = renderer.delegate.estimated_sync_bytes()
    triangles = 2 * quads * quads
    assert 150 * triangles < estimate < 200 * triangles  # 170 B a triangle was measured
    # Room for the film and the texture cache, and half of the scene's build.
    width = 16
    budget = resident_memory() + CACHE + width * width * FILM_BYTES_PER_PIXEL + estimate // 2
    with pytest.raises(penumbra.SceneError) as error:
        renderer.render("/cam", width=width, samples=1, max_memory=budget, texture_cache=CACHE)
    message = str(error.value)
    assert "acceleration structures" in message
    assert format_size(estimate) in message
    assert format_size(budget) in message and "--maxMemory" in message
    # Nothing was built: with room for it, the same renderer renders, and then nothing is left
    # to build.
    image = renderer.render("/cam", width=width, samples=1, texture_cache=CACHE)
    assert image["color"][..., :3].mean() > 0
    assert renderer.delegate.estimated_sync_bytes() == 0


def test_a_texture_cache_below_the_floor_is_refused() -> None:
    renderer = penumbra.Renderer(grid_stage(1))
    with pytest.raises(ValueError, match="16 MiB"):
        renderer.render("/cam", width=8, samples=1, texture_cache=2**20)
