"""UsdGeomPointInstancer: copies of prototypes placed by positions, orientations, scales and
protoIndices, masked by invisibleIds, sharing one BVH per prototype mesh."""

from __future__ import annotations

import json

import pytest
from pxr import Gf, UsdGeom, Vt

import penumbra
from stages import add_camera, add_distant_light, add_preview_material, add_quad, bind, new_stage

SMALL = dict(camera="/cam", width=40, samples=1)


def instancer_stage():
    """Two prototypes (a red and a blue quad, each a quarter unit wide) placed by a point
    instancer; the camera sees the square [-2, 2]² of the z = 0 plane."""
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    instancer = UsdGeom.PointInstancer.Define(stage, "/World/copies")
    UsdGeom.Xform.Define(stage, "/World/copies/Prototypes")
    for name, color in (("red", (1, 0, 0)), ("blue", (0, 0, 1))):
        quad = add_quad(stage, f"/World/copies/Prototypes/{name}/quad", half_size=0.125)
        bind(quad, add_preview_material(stage, f"/World/Looks/{name}", diffuseColor=color))
        instancer.GetPrototypesRel().AddTarget(f"/World/copies/Prototypes/{name}")
    instancer.CreatePositionsAttr(Vt.Vec3fArray([(-1, 1, 0), (1, 1, 0), (-1, -1, 0), (1, -1, 0)]))
    instancer.CreateProtoIndicesAttr(Vt.IntArray([0, 1, 1, 0]))
    return stage, instancer


def color_at(image, x: float, y: float):
    """Pixel colour at plane point (x, y) for the 40x40 view of [-2, 2]²."""
    height, width = image["color"].shape[:2]
    column = int((x + 2) / 4 * width)
    row = int((2 - y) / 4 * height)
    return image["color"][row, column]


def test_copies_follow_positions_and_proto_indices():
    stage, _ = instancer_stage()
    renderer = penumbra.Renderer(stage)
    image = renderer.render(**SMALL)
    # Diffuse red and blue under a white specular layer.
    red, blue = color_at(image, -1, 1), color_at(image, 1, 1)
    assert red[0] > 5 * red[2] and blue[2] > 5 * blue[0]
    assert color_at(image, -1, -1)[2] > 5 * color_at(image, -1, -1)[0]
    assert color_at(image, 0, 0)[3] == 0  # the prototypes themselves do not render
    # Only two meshes in the delegate, however many copies.
    meshes = [p for p in renderer.delegate.prim_ids() if "/prototypes/" in p]
    assert len(meshes) == 2


def test_orientations_scales_and_invisible_ids():
    stage, instancer = instancer_stage()
    # Scale the first copy by 4 and hide the second; turn the third a quarter about Z.
    instancer.CreateScalesAttr(Vt.Vec3fArray([(4, 4, 1), (1, 1, 1), (1, 1, 1), (1, 1, 1)]))
    instancer.CreateInvisibleIdsAttr(Vt.Int64Array([1]))
    instancer.CreateOrientationsAttr(
        Vt.QuathArray([Gf.Quath(1), Gf.Quath(1), Gf.Quath(0.7071, 0, 0, 0.7071), Gf.Quath(1)])
    )
    image = penumbra.Renderer(stage).render(**SMALL)
    assert color_at(image, -1 + 0.4, 1 + 0.4)[3] == 1  # inside the scaled copy (half size 0.5)
    assert color_at(image, 1, 1)[3] == 0  # invisibleIds
    assert color_at(image, -1, -1)[3] == 1


def test_edits_resync_the_instancer_and_bad_indices_warn():
    stage, instancer = instancer_stage()
    renderer = penumbra.Renderer(stage)
    renderer.render(**SMALL)
    instancer.GetPositionsAttr().Set(Vt.Vec3fArray([(0, 0, 0), (1, 1, 0), (-1, -1, 0), (1, -1, 0)]))
    image = renderer.render(**SMALL)
    assert color_at(image, 0, 0)[3] == 1 and color_at(image, -1, 1)[3] == 0
    instancer.GetProtoIndicesAttr().Set(Vt.IntArray([0, 1, 7, 0]))
    with pytest.warns(penumbra.PenumbraWarning, match="/World/copies: 1 protoIndices are out of range"):
        image = renderer.render(**SMALL)
    assert image["color"][..., 3].max() == 0


def test_copies_blur_along_their_velocities():
    stage, instancer = instancer_stage()
    # Shutter [0, 1] at frame 1 (24 time codes per second): 24 units/s moves a copy 1 unit.
    UsdGeom.Camera.Get(stage, "/cam").CreateShutterCloseAttr(1.0)
    instancer.CreateVelocitiesAttr(Vt.Vec3fArray([(24, 0, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0)]))
    renderer = penumbra.Renderer(stage)
    blurred = renderer.render(camera="/cam", width=40, samples=16)
    # The first copy sweeps from x = -1 to x = 0; the others stay sharp.
    for x in (-0.9, -0.5, -0.1):
        assert color_at(blurred, x, 1)[3] > 0.1
    assert color_at(blurred, 0.3, 1)[3] == 0
    sharp = renderer.render(**SMALL, disable_motion_blur=True)
    assert color_at(sharp, -0.5, 1)[3] == 0 and color_at(sharp, -1, 1)[3] == 1


def test_id_aovs_tell_copies_apart():
    stage, _ = instancer_stage()
    # Ids keep the sample nearest each pixel's centre: with 8, one lies well inside the copy.
    image = penumbra.Renderer(stage).render(aovs=("primId", "instanceId"), **{**SMALL, "samples": 8})
    manifest = json.loads(image.metadata["primIds"])

    def ids_at(x: float, y: float) -> tuple[str | None, int]:
        pixel = {name: int(ids[..., 0][int((2 - y) / 4 * 40), int((x + 2) / 4 * 40)])
                 for name, ids in image.items()}  # fmt: skip
        return manifest.get(str(pixel["primId"])), pixel["instanceId"]

    copies = [ids_at(x, y) for x, y in ((-1, 1), (1, 1), (-1, -1), (1, -1))]
    # primId: the prototype mesh (red, blue, blue, red); instanceId: the copy of it.
    assert [path.rsplit("/", 1)[-1] for path, _ in copies] == ["red", "blue", "blue", "red"]
    assert len(set(copies)) == 4 and all(copy >= 0 for _, copy in copies)
    assert ids_at(0, 0) == (None, -1)  # nothing there
