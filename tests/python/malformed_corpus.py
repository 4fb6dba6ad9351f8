"""A corpus of malformed inputs, each with the outcome ``penumbra-record`` must give (render at
64 px, 4 spp): exit 0 with a warning naming the prim (the prim is skipped or simplified), or
exit 1 (2 for usage errors) with a message naming the prim or file. No case may crash, hang or
print a traceback. ``test_malformed.py`` runs it; ``fuzz_scene.py`` mutates its stages."""

from __future__ import annotations

import os
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path

BASE = """#usda 1.0
(
    startTimeCode = 1
    endTimeCode = 1
)
def Camera "cam"
{{
    float focalLength = 35
    float horizontalAperture = 36
    float verticalAperture = 24
    double3 xformOp:translate = (0, 0, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
{camera}
}}
def Mesh "quad" (
    prepend apiSchemas = ["MaterialBindingAPI"]
)
{{
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
{mesh}
}}
def SphereLight "light"
{{
    float inputs:intensity = 20
    double3 xformOp:translate = (0, 0, 3)
    uniform token[] xformOpOrder = ["xformOp:translate"]
{light}
}}
{extra}
"""


@dataclass(frozen=True)
class Case:
    """One malformed input: ``exit`` status and a text ``expect``ed on stderr (prim or file
    and the problem); ``warns`` whether exit 0 must come with that text as a warning."""

    name: str
    exit: int
    expect: str
    camera: str = ""
    mesh: str = ""
    light: str = ""
    extra: str = ""
    args: tuple[str, ...] = ()
    files: dict[str, bytes] = field(default_factory=dict)  # written beside the stage
    stage_kind: str = "file"  # or "fifo", "directory": what stands at the stage's path

    def usda(self) -> str:
        return BASE.format(camera=self.camera, mesh=self.mesh, light=self.light, extra=self.extra)


def png_header(width: int, height: int) -> bytes:
    """A PNG whose header claims ``width`` × ``height`` RGB pixels but holds one byte of data."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(b"\0"))


TEXTURED_MATERIAL = """
def Material "mat"
{
    token outputs:surface.connect = </mat/surface.outputs:surface>
    def Shader "surface"
    {
        uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor.connect = </mat/tex.outputs:rgb>
        token outputs:surface
    }
    def Shader "tex"
    {
        uniform token info:id = "UsdUVTexture"
        asset inputs:file = @huge.png@
        float3 outputs:rgb
    }
}
"""

HUGE_SCALE = "(1e30, 1e30, 1e30)"
SCALE_ONLY = 'uniform token[] xformOpOrder = ["xformOp:scale"]'

CASES = [
    # Cameras: the render would be meaningless → exit 1 naming the camera and attribute.
    Case("clipping negative", 1, "/cam: clippingRange", camera="float2 clippingRange = (-1, 10)"),
    Case("clipping infinite", 1, "/cam: clippingRange", camera="float2 clippingRange = (0.1, inf)"),
    Case("clipping inverted", 1, "/cam: clippingRange", camera="float2 clippingRange = (10, 1)"),
    Case("clipping empty", 1, "/cam: clippingRange", camera="float2 clippingRange = (0, 0)"),
    Case("clipping NaN", 1, "/cam: clippingRange", camera="float2 clippingRange = (nan, 10)"),
    Case("camera beyond 1e18", 1, "/cam: the camera's world transform translates it beyond 1e+18", camera='double3 xformOp:translate:far = (0, 1e30, 5)\nuniform token[] xformOpOrder = ["xformOp:translate:far"]'),
    Case(
        "camera zero scale",
        1,
        "/cam: the camera's world transform",
        camera='float3 xformOp:scale = (0, 0, 0)\nuniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]',
    ),
    Case("camera NaN translate", 1, "/cam: the camera's world transform", camera="double3 xformOp:translate = (nan, 0, 5)"),
    Case("aperture offset NaN", 1, "/cam: horizontalApertureOffset", camera="float horizontalApertureOffset = nan"),
    Case("focal length zero", 1, "/cam: focalLength", camera="float focalLength = 0"),
    Case("focal length negative", 1, "/cam: focalLength", camera="float focalLength = -35"),
    Case("focal length NaN", 1, "/cam: focalLength", camera="float focalLength = nan"),
    Case("aperture zero", 1, "/cam: verticalAperture", camera="float verticalAperture = 0"),
    Case("fStop negative", 1, "/cam: fStop", camera="float fStop = -2"),
    Case("fStop of an unknown type", 1, "/cam: fStop must be a number", camera="floau fStop = -2"),
    Case("clipping a scalar", 1, "/cam: clippingRange must be two numbers", camera="float clippingRange = 3"),
    Case("focus distance inf", 1, "/cam: focusDistance", camera="float fStop = 2\nfloat focusDistance = inf"),
    Case("unknown projection", 1, "/cam: unknown projection 'fisheye'", camera='token projection = "fisheye"'),
    Case("exposure fStop zero", 1, "/cam: the exposure scale", camera="float exposure:fStop = 0"),
    Case("exposure NaN", 1, "/cam: the exposure scale", camera="float exposure = nan"),
    Case("exposure overflowing", 1, "/cam: the exposure scale", camera="float exposure = 3000"),
    Case("exposure ISO negative", 1, "/cam: the exposure scale", camera="float exposure:iso = -100"),
    Case("exposure of an unknown type", 1, "/cam: exposure must be a number", camera='string exposure = "2"'),
    # Sizes and memory: exit 1 before anything is allocated.
    Case("huge width", 1, "--maxMemory", args=("-w", "100000")),
    Case("sliver aperture", 1, "--maxMemory", camera="float horizontalAperture = 0.004", args=("--maxMemory", "1G")),
    Case(
        "render settings 1 x 200000",
        1,
        "--maxMemory",
        extra='def RenderSettings "rs"\n{\n    rel camera = </cam>\n    uniform int2 resolution = (1, 200000)\n}',
        args=("-rs", "/rs", "--maxMemory", "1G"),
    ),
    # Command line: usage errors (exit 2).
    Case("samples past int32", 2, "--samples must be at most", args=("--samples", str(2**31))),
    Case("width past int32", 2, "--imageWidth must be at most", args=("-w", str(2**40))),
    Case("seed past uint32", 2, "--seed must be at most", args=("--seed", str(2**32))),
    Case("seed negative", 2, "--seed cannot be negative", args=("--seed", "-1")),
    Case("threads past TBB's arenas", 2, "--threads must be in [0, 1024]", args=("--threads", "100000")),
    Case("max memory malformed", 2, "invalid memory size", args=("--maxMemory", "lots")),
    Case("texture cache too small", 2, "below 16M", args=("--textureCacheSize", "1M")),
    Case("frames not finite", 2, "frames must be finite", args=("-f", "1:" + "9" * 400)),
    # Meshes, primvars, materials, instancers, lights: warning and skip (exit 0).
    Case("unknown primvar interpolation", 0, "/quad", mesh='float[] primvars:foo = [1] (interpolation = "bogus")'),
    Case("faces with fewer than 3 vertices", 0, "/quad", mesh="int[] faceVertexCounts = [2, 2]"),
    Case("ray visibility not a bool", 0, "/quad: primvars:penumbra:visibility:shadow has type float", mesh="float primvars:penumbra:visibility:shadow = 0"),
    Case("holdout per face", 0, "/quad: primvars:penumbra:holdout has uniform interpolation", mesh='bool primvars:penumbra:holdout = 1 (interpolation = "uniform")'),
    Case("face index out of range", 0, "/quad", mesh="int[] faceVertexIndices = [0, 1, 2, 9]"),
    Case("NaN points", 0, "/quad", mesh="point3f[] points = [(nan, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]"),
    Case("mesh NaN transform", 0, "/quad", mesh='double3 xformOp:translate = (nan, 0, 0)\nuniform token[] xformOpOrder = ["xformOp:translate"]'),
    Case("mesh at 1e20", 0, "/quad", mesh='double3 xformOp:translate = (1e20, 0, 0)\nuniform token[] xformOpOrder = ["xformOp:translate"]'),
    # Finite, but hits out there would start rays Embree cannot take (it asserts ray.valid()).
    Case("mesh scaled 1e30", 0, "/quad: its world bounds reach beyond 1e18", mesh=f"float3 xformOp:scale = {HUGE_SCALE}\n{SCALE_ONLY}"),
    Case("points scaled 1e30", 0, "/pts: its world bounds reach beyond 1e18", extra=f'def Points "pts"\n{{\n    point3f[] points = [(0, 0, 0), (1, 1, 1)]\n    float[] widths = [0.1, 0.1]\n    float3 xformOp:scale = {HUGE_SCALE}\n    {SCALE_ONLY}\n}}'),
    Case("instance scaled 1e30", 0, "/inst/instances/inst/proto: 1 of 2 copies: its world bounds reach beyond 1e18", extra=f'def PointInstancer "inst"\n{{\n    rel prototypes = [</inst/proto>]\n    int[] protoIndices = [0, 0]\n    point3f[] positions = [(0, 0, 0), (1, 0, 0)]\n    float3[] scales = [(1, 1, 1), {HUGE_SCALE}]\n    def Cube "proto"\n    {{\n        double size = 0.2\n    }}\n}}'),
    Case("primvar count mismatch", 0, "/quad", mesh='color3f[] primvars:displayColor = [(1, 0, 0), (0, 1, 0)] (interpolation = "vertex")'),
    Case(
        "shader input of the wrong type",
        0,
        "/mat",
        mesh='rel material:binding = </mat>',
        extra='def Material "mat"\n{\n    token outputs:surface.connect = </mat/s.outputs:surface>\n    def Shader "s"\n    {\n        uniform token info:id = "UsdPreviewSurface"\n        string inputs:diffuseColor = "red"\n        float3 inputs:roughness = (1, 1, 1)\n        token outputs:surface\n    }\n}',
    ),
    Case("point instancer without prototypes", 0, "/inst", extra='def PointInstancer "inst"\n{\n    int[] protoIndices = [0, 0]\n    point3f[] positions = [(0, 0, 0), (1, 0, 0)]\n}'),
    Case("point instancer without positions", 0, "/inst: no positions", extra='def PointInstancer "inst"\n{\n    rel prototypes = [</inst/proto>]\n    int[] protoIndices = [0, 0]\n    def Cube "proto"\n    {\n        double size = 0.2\n    }\n}'),
    Case("cube size of an unknown type", 0, "/box: size has a value of type UnregisteredValue", extra='def Cube "box"\n{\n    ououble size = 0.2\n}'),
    Case("sphere radius negative", 0, "/ball: radius must be a finite number >= 0, not -1", extra='def Sphere "ball"\n{\n    double radius = -1\n}'),
    Case("cylinder axis unknown", 0, "/can: axis must be X, Y or Z, not 'W'", extra='def Cylinder "can"\n{\n    uniform token axis = "W"\n}'),
    Case("protoIndices of an unknown type", 0, "/inst: protoIndices has a value of type UnregisteredValue", extra='def PointInstancer "inst"\n{\n    rel prototypes = [</inst/proto>]\n    hnt[] protoIndices = [0, 0]\n    point3f[] positions = [(0, 0, 0), (1, 0, 0)]\n    def Cube "proto"\n    {\n        double size = 0.2\n    }\n}'),
    Case("negative light intensity", 0, "/light", light="float inputs:intensity = -20"),
    Case("light input of an unknown type", 0, "/light: inputs:exposure has a value of type UnregisteredValue", light="floa1 inputs:exposure = 1"),
    Case("light input of the wrong type", 0, "/light: inputs:color has a value of type str", light='string inputs:color = "red"'),
    Case("mesh light input of an unknown type", 0, "/panel: inputs:intensity has a value of type UnregisteredValue", extra='def Mesh "panel" (\n    prepend apiSchemas = ["MeshLightAPI"]\n)\n{\n    int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n    point3f[] points = [(-1, -1, 2), (1, -1, 2), (1, 1, 2), (-1, 1, 2)]\n    floa1 inputs:intensity = 5\n}'),
    Case("negative mesh light intensity", 0, "/panel: negative emission", extra='def Mesh "panel" (\n    prepend apiSchemas = ["MeshLightAPI"]\n)\n{\n    int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n    point3f[] points = [(-1, -1, 2), (1, -1, 2), (1, 1, 2), (-1, 1, 2)]\n    float inputs:intensity = -5\n}'),
    Case("shaped mesh light scaled flat along its -Z", 0, "/panel: the light's transform collapses its -Z axis", extra='def Mesh "panel" (\n    prepend apiSchemas = ["MeshLightAPI", "ShapingAPI"]\n)\n{\n    int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n    point3f[] points = [(-1, -1, 2), (1, -1, 2), (1, 1, 2), (-1, 1, 2)]\n    float inputs:shaping:cone:angle = 30\n    float3 xformOp:scale = (1, 1, 0)\n    uniform token[] xformOpOrder = ["xformOp:scale"]\n}'),
    Case("sun scaled flat along its -Z", 0, "/sun: the light's transform collapses its -Z axis", extra='def DistantLight "sun"\n{\n    float3 xformOp:scale = (1, 1, 0)\n    uniform token[] xformOpOrder = ["xformOp:scale"]\n}'),
    Case("NaN light colour", 0, "/light", light="color3f inputs:color = (nan, 1, 1)"),
    Case("light zero scale", 0, "/light", light='float3 xformOp:scale = (0, 0, 0)\nuniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]'),
    Case(
        "dome texture header 60000 squared",
        0,
        "huge.png",
        extra='def DomeLight "dome"\n{\n    asset inputs:texture:file = @huge.png@\n}',
        files={"huge.png": png_header(60000, 60000)},
    ),
    Case(
        "material texture header 60000 squared",
        0,
        "huge.png",
        mesh='rel material:binding = </mat>\ntexCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = "vertex")',
        extra=TEXTURED_MATERIAL,
        files={"huge.png": png_header(60000, 60000)},
    ),
    Case(
        "dome texture file of an unknown type",
        0,
        "/dome: inputs:texture:file has a value of type UnregisteredValue",
        extra='def DomeLight "dome"\n{\n    Uasset inputs:texture:file = @huge.png@\n}',
    ),
    Case(
        "material texture file of an unknown type",
        0,
        "/mat/tex: UsdUVTexture has no file",
        mesh='rel material:binding = </mat>\ntexCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = "vertex")',
        extra=TEXTURED_MATERIAL.replace("asset inputs:file", "Uasset inputs:file"),
    ),
    # Files and composition: exit 1 naming the file, or a warning.
    Case("reference cycle", 0, "composition error", extra='def "a" (references = </b>) {}\ndef "b" (references = </a>) {}'),
    Case("missing reference", 0, "composition error", extra='def "r" (references = @missing.usda@) {}'),
    Case("stage a FIFO", 1, "stage.usda: cannot read the file: it is a FIFO", stage_kind="fifo"),
    Case("stage a directory", 1, "stage.usda: cannot read the file: it is a directory", stage_kind="directory"),
]


def write_case(case: Case, directory: Path) -> Path:
    """Write the case's stage (and its files) into ``directory``; returns the stage's path."""
    for name, data in case.files.items():
        (directory / name).write_bytes(data)
    stage = directory / "stage.usda"
    if case.stage_kind == "fifo":
        os.mkfifo(stage)  # nothing ever writes to it: reading it would block forever
    elif case.stage_kind == "directory":
        stage.mkdir()
    else:
        stage.write_text(case.usda())
    return stage
