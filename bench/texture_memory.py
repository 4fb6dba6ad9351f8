"""Peak memory and time of renders with one huge texture (a material's and a dome light's).

Writes a ``SIZE``² 8-bit RGB PNG of a simple pattern (a 16k² one is 3.3 MB) and two
stages into a temporary directory, renders each with ``penumbra-record`` (64 px, 4 spp) in a
subprocess and prints its peak resident memory (``getrusage``) and wall time. Needs nothing
outside the repository.

    python bench/texture_memory.py --size 16384
    python bench/texture_memory.py --size 8192 --record /other/checkout/.venv/bin/penumbra-record
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "python"))
from pattern_png import write_pattern_png  # noqa: E402  (the tests' writer, shared)
from provenance import print_provenance  # noqa: E402

CAMERA = """
def Camera "cam"
{
    double3 xformOp:translate = (0, 0, 3)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""

MATERIAL_STAGE = (
    "#usda 1.0\n"
    + CAMERA
    + """
def Mesh "quad"
{
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = "vertex")
    rel material:binding = </mat>
}
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
        asset inputs:file = @pattern.png@
        float2 inputs:st.connect = </mat/st.outputs:result>
        float3 outputs:rgb
    }
    def Shader "st"
    {
        uniform token info:id = "UsdPrimvarReader_float2"
        string inputs:varname = "st"
        float2 outputs:result
    }
}
def DistantLight "sun"
{
    float inputs:intensity = 3
}
"""
)

DOME_STAGE = (
    "#usda 1.0\n"
    + CAMERA
    + """
def Sphere "ball"
{
    double radius = 0.8
}
def DomeLight "dome"
{
    asset inputs:texture:file = @pattern.png@
}
"""
)


def measure(record: str, stage: Path, output: Path, extra: list[str]) -> tuple[float, float, float]:
    """Peak resident MiB, wall seconds and CPU seconds of one ``penumbra-record`` run in a child
    process (CPU time says more than wall time on a shared machine)."""
    started = time.perf_counter()
    subprocess.run(
        [record, "-w", "64", "--samples", "4", "--enableDomeLightVisibility", *extra, str(stage), str(output)],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    seconds = time.perf_counter() - started
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)  # this process's only child
    return usage.ru_maxrss / 1024, seconds, usage.ru_utime + usage.ru_stime


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=16384, help="texture width and height")
    parser.add_argument(
        "--record",
        default=str(Path(sys.executable).with_name("penumbra-record")),
        help="the penumbra-record to measure (default: this environment's)",
    )
    parser.add_argument(
        "--textureCacheSize", metavar="SIZE", help="passed on to penumbra-record (default: its own)"
    )
    args = parser.parse_args()
    print_provenance()
    extra = ["--textureCacheSize", args.textureCacheSize] if args.textureCacheSize else []
    with tempfile.TemporaryDirectory(prefix="penumbra-texture-bench-") as directory:
        root = Path(directory)
        started = time.perf_counter()
        write_pattern_png(root / "pattern.png", args.size)
        megabytes = (root / "pattern.png").stat().st_size / 2**20
        print(
            f"{args.size}² PNG: {megabytes:.1f} MiB, written in {time.perf_counter() - started:.1f} s"
        )
        # RUSAGE_CHILDREN sums and maximises over all children, so each case is measured
        # by a fresh intermediate process with one child.
        for name, text in (("material", MATERIAL_STAGE), ("dome", DOME_STAGE)):
            stage = root / f"{name}.usda"
            stage.write_text(text)
            result = subprocess.run(
                [sys.executable, __file__, "--child", args.record, str(stage), str(root / f"{name}.exr"), *extra],
                check=True,
                capture_output=True,
                text=True,
            )
            peak, seconds, cpu = (float(value) for value in result.stdout.split())
            print(f"{name:8s} peak RSS {peak:8.0f} MiB   {seconds:6.1f} s wall   {cpu:6.1f} s CPU")
    return 0


if __name__ == "__main__":
    if len(sys.argv) >= 5 and sys.argv[1] == "--child":
        print(*measure(sys.argv[2], Path(sys.argv[3]), Path(sys.argv[4]), sys.argv[5:]))
        sys.exit(0)
    sys.exit(main())
