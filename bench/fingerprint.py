"""Fingerprints of every image Penumbra makes of the bundled and benchmark stages.

Renders each stage of ``examples/``, ``tests/assets/`` and (when it is beside the repository)
``../shared/scenes/`` small and with few samples, with every AOV, and prints one SHA-256 per
stage over all the AOVs' float bytes. Two builds whose listings are equal render those stages
bit for bit alike: run it before and after a change that must not change a pixel (a refactor),
then ``diff`` the two listings::

    .venv/bin/python bench/fingerprint.py > before.txt
    # ... change, rebuild ...
    .venv/bin/python bench/fingerprint.py > after.txt && diff before.txt after.txt

``--option KEYWORD=VALUE`` (repeatable) passes a render option to every render, for comparing a
change under the setting that keeps the old behaviour (``--option dome_sampling=mis``).

The edited-stage entries also cover the scene-sync path: the stage is rendered, one prim is
moved, hidden and shown again, and each re-render is fingerprinted.
"""

from __future__ import annotations

import argparse
import hashlib
import sys
from pathlib import Path

import numpy as np
from pxr import Gf, Usd, UsdGeom

import penumbra
from penumbra.cryptomatte import LAYERS
from penumbra.denoise import NOISY_COLOR
from penumbra.usd.products import AOV_NAMES

REPO = Path(__file__).resolve().parents[1]
SHARED_SCENES = REPO.parent / "shared" / "scenes"
# Every AOV a render makes without the denoiser and without names (Cryptomatte's ids come from
# the names of prims, which tests/python/test_cryptomatte.py checks).
AOVS = tuple(name for name in AOV_NAMES if name != NOISY_COLOR and name not in LAYERS)


def digest(image: penumbra.Image) -> str:
    hasher = hashlib.sha256()
    for name in AOVS:
        hasher.update(name.encode())
        hasher.update(np.ascontiguousarray(image[name], dtype=np.float32).tobytes())
    return hasher.hexdigest()[:16]


def stages(include_shared: bool) -> list[Path]:
    found = sorted((REPO / "examples").glob("**/*.usda"))
    found += sorted((REPO / "tests" / "assets").glob("*.usda"))
    found += sorted((REPO / "tests" / "assets" / "materialx").glob("*.usda"))
    found += sorted((REPO / "tests" / "assets" / "usd-wg").glob("**/*.usd*"))
    if include_shared:
        if SHARED_SCENES.is_dir():
            found += sorted(SHARED_SCENES.glob("*.usda"))
        else:
            print(f"# {SHARED_SCENES} is absent: the benchmark scenes are not fingerprinted")
    return found


def first_movable(stage: Usd.Stage) -> UsdGeom.Xformable | None:
    for prim in stage.Traverse():
        if prim.IsA(UsdGeom.Mesh):
            return UsdGeom.Xformable(prim)
    return None


def parse_option(text: str) -> tuple[str, str | float]:
    """``keyword=value``: a number where it reads as one, else a level's name."""
    keyword, separator, value = text.partition("=")
    if not separator or not keyword:
        raise argparse.ArgumentTypeError(f"expected KEYWORD=VALUE, got {text!r}")
    try:
        return keyword, float(value)
    except ValueError:
        return keyword, value


def fingerprint_edits(
    path: Path, width: int, samples: int, extra: dict[str, str | float]
) -> list[str]:
    """Renders after moving, hiding and showing the first mesh: the incremental sync path."""
    stage = Usd.Stage.Open(str(path))
    mesh = first_movable(stage)
    if mesh is None:
        return []
    lines = []
    with penumbra.Renderer(stage) as renderer:
        options = dict(width=width, samples=samples, aovs=AOVS, threads=2, **extra)
        renderer.render(**options)
        mesh.AddTranslateOp(opSuffix="fingerprint").Set(Gf.Vec3d(0.05, 0.02, 0.0))
        lines.append(f"{path.name}:moved {digest(renderer.render(**options))}")
        mesh.MakeInvisible()
        lines.append(f"{path.name}:hidden {digest(renderer.render(**options))}")
        mesh.MakeVisible()
        lines.append(f"{path.name}:shown {digest(renderer.render(**options))}")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=48)
    parser.add_argument("--samples", type=int, default=4)
    parser.add_argument("--no-shared", action="store_true", help="skip ../shared/scenes")
    parser.add_argument(
        "--option",
        type=parse_option,
        action="append",
        default=[],
        metavar="KEYWORD=VALUE",
        help="a render option for every render (repeatable)",
    )
    args = parser.parse_args()
    extra = dict(args.option)
    for path in stages(not args.no_shared):
        name = path.relative_to(REPO.parent if SHARED_SCENES in path.parents else REPO)
        try:
            image = penumbra.render(
                str(path), width=args.width, samples=args.samples, aovs=AOVS, threads=2, **extra
            )
            print(f"{name} {digest(image)}", flush=True)
        except Exception as error:  # noqa: BLE001 - a stage that fails is part of the listing
            print(f"{name} error {type(error).__name__}", flush=True)
    for path in (REPO / "examples" / "cornell.usda", REPO / "examples" / "showcase.usda"):
        for line in fingerprint_edits(path, args.width, args.samples, extra):
            print(line, flush=True)


if __name__ == "__main__":
    sys.exit(main())
