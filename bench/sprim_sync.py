"""Sprim-sync benchmark (`make bench`): what one light edit and one material edit cost through
the render delegate (`penumbra._core`, no USD), beside many materials and mesh lights.

The scene is generated (nothing from ../shared is read): a camera, ``--materials`` constant
materials, ``--mesh-lights`` mesh lights (each a grid of ``--grid`` x ``--grid`` quads, bound
to one of the materials) and a sphere light. Reported, in CPU milliseconds (all threads; the
fastest of ten, since the machine may be shared): the first sync, an unchanged re-render and a
re-render after setting the sphere light's intensity or one material's inputs, each a 4x4
image at one sample per pixel (so the sync dominates), and the render delegate's sync
statistics. Since materials and lights sync themselves (docs/architecture.md), an edit of one
builds that one alone: no other material, light or mesh light is built again.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from penumbra import _core
from provenance import print_provenance


def grid(size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Face vertex counts, indices and points of a size x size grid of quads over [-1, 1]²."""
    xs = np.linspace(-1, 1, size + 1, dtype=np.float32)
    points = np.array([(x, y, 0) for y in xs for x in xs], np.float32)
    row = size + 1
    quads = [
        (j * row + i, j * row + i + 1, (j + 1) * row + i + 1, (j + 1) * row + i)
        for j in range(size)
        for i in range(size)
    ]
    return np.full(len(quads), 4, np.int32), np.array(quads, np.int32).ravel(), points


def build(materials: int, mesh_lights: int, grid_size: int) -> _core.RenderDelegate:
    delegate = _core.RenderDelegate()
    delegate.insert_sprim("camera", "/cam")
    delegate.set_camera("/cam", focal_length=5, horizontal_aperture=4, vertical_aperture=4)
    camera_to_world = np.eye(4)
    camera_to_world[3, 2] = 5
    delegate.set_transform("/cam", camera_to_world)
    for m in range(materials):
        delegate.insert_sprim("material", f"/m{m:05d}")
        delegate.set_material(f"/m{m:05d}", {"diffuseColor": (0.5, 0.5, 0.5), "roughness": 0.5})
    counts, indices, points = grid(grid_size)
    for light in range(mesh_lights):
        prim_id = f"/panel{light:03d}"
        delegate.insert_rprim("mesh", prim_id)
        delegate.set_mesh_topology(prim_id, counts, indices)
        delegate.set_mesh_points(prim_id, points)
        delegate.set_mesh_material(prim_id, f"/m{light % materials:05d}")
        delegate.set_mesh_light(prim_id, True, intensity=1.0)
    delegate.insert_sprim("sphereLight", "/bulb")
    delegate.set_light("/bulb", intensity=1.0)
    return delegate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--materials", type=int, default=2000)
    parser.add_argument("--mesh-lights", type=int, default=40)
    parser.add_argument("--grid", type=int, default=100)
    args = parser.parse_args()
    print_provenance()
    delegate = build(args.materials, args.mesh_lights, args.grid)
    render_pass = _core.RenderPass(delegate, "/cam", 4, 4)

    def execute() -> float:
        started = time.process_time()
        render_pass.execute(1)
        return (time.process_time() - started) * 1000

    first = execute()
    unchanged = min(execute() for _ in range(10))
    light_edits, material_edits = [], []
    for k in range(10):
        delegate.set_light("/bulb", intensity=2.0 + k)
        light_edits.append(execute())
        delegate.set_material("/m00007", {"diffuseColor": (0.1 * k, 0.5, 0.5), "roughness": 0.5})
        material_edits.append(execute())
    print(
        f"\n| {args.materials:,} materials, {args.mesh_lights} mesh lights of "
        f"{2 * args.grid**2:,} triangles | CPU ms |"
    )
    print("|---|---|")
    print(f"| first sync and sample | {first:.0f} |")
    print(f"| unchanged re-render | {unchanged:.2f} |")
    print(f"| after one light's intensity edit | {min(light_edits):.2f} |")
    print(f"| after one material's inputs edit | {min(material_edits):.2f} |")
    print(f"\nsync statistics: {delegate.sync_statistics()}", flush=True)


if __name__ == "__main__":
    main()
