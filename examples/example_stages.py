"""What the example scripts (groom.py, cloud.py, subsurface.py) share: a look-at camera, a
ground quad, and rendering the stage they wrote with penumbra-record, timed."""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from pathlib import Path

from pxr import Gf, Usd, UsdGeom


def add_look_at_camera(
    stage: Usd.Stage, path: str, eye: Gf.Vec3d, centre: Gf.Vec3d, focal_length: float,
    aperture: tuple[float, float], far: float = 200.0,
) -> UsdGeom.Camera:
    """A camera at ``eye`` looking at ``centre`` (Y up), ``aperture`` in millimetres."""
    camera = UsdGeom.Camera.Define(stage, path)
    camera.CreateFocalLengthAttr(focal_length)
    camera.CreateHorizontalApertureAttr(aperture[0])
    camera.CreateVerticalApertureAttr(aperture[1])
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.1, far))
    view = Gf.Matrix4d().SetLookAt(eye, centre, Gf.Vec3d(0, 1, 0)).GetInverse()
    camera.AddTransformOp().Set(view)
    return camera


def add_ground(stage: Usd.Stage, path: str, half_size: float, color: tuple[float, float, float]):
    """A square at y = 0 facing up, of side 2 · ``half_size``, coloured by displayColor."""
    ground = UsdGeom.Mesh.Define(stage, path)
    s = half_size
    ground.CreatePointsAttr([(-s, 0, -s), (s, 0, -s), (s, 0, s), (-s, 0, s)])
    ground.CreateFaceVertexCountsAttr([4])
    ground.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    ground.CreateDisplayColorAttr([color])
    return ground


def record(stage: Path, image: Path, width: int, samples: int, flags: list[str], render: bool,
           wrote: str) -> None:
    """Prints the penumbra-record command that renders ``stage`` into ``image`` (the one beside
    this Python, .venv/bin, else the one on PATH) after "wrote ``wrote``", and runs it, timed,
    when ``render``."""
    beside = shutil.which("penumbra-record", path=str(Path(sys.executable).parent))
    command = [beside or "penumbra-record", str(stage), str(image), "-w", str(width),
               "-spp", str(samples), *flags]
    print(f"wrote {wrote}; render with:\n  {' '.join(command)}")
    if render:
        started = time.perf_counter()
        subprocess.run(command, check=True)
        print(f"rendered {image} in {time.perf_counter() - started:.1f} s")
