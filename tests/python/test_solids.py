"""Glass solids and thin sheets: a mesh is a solid when it is closed once coincident points are
welded; ``inputs:penumbra:thinWalled`` on the UsdPreviewSurface overrides that either way."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdShade

import penumbra

from stages import add_preview_material, bind, new_stage

IOR = 1.5
TILT = math.radians(30)
WIDTH = 200  # pixels over 4 scene units: 0.02 units per pixel
UNITS_PER_PIXEL = 4 / WIDTH
# A slab of thickness 1 seen at incidence TILT shifts what is behind it sideways by
# sin(TILT - refracted) / cos(refracted) (an orthographic camera: rays stay parallel).
REFRACTED = math.asin(math.sin(TILT) / IOR)
SLAB_SHIFT = math.sin(TILT - REFRACTED) / math.cos(REFRACTED)  # 0.194


def split_cube_points_and_faces(drop_top: bool) -> tuple[list, list[int], list[int]]:
    """A unit cube about the origin, turned by TILT about +Y, with 4 points of its own per face
    (as exporters split vertices at hard edges); without its +Y face when ``drop_top``."""
    corners = [
        (x - 0.5, y - 0.5, z - 0.5) for z in (0, 1) for y in (0, 1) for x in (0, 1)
    ]  # index = x + 2y + 4z
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (0, 4, 6, 2), (1, 3, 7, 5), (2, 6, 7, 3)]
    if drop_top:
        faces = faces[:-1]
    c, s = math.cos(TILT), math.sin(TILT)
    points, indices = [], []
    for face in faces:
        for corner in face:
            x, y, z = corners[corner]
            indices.append(len(points))
            points.append(Gf.Vec3f(c * x + s * z, y, -s * x + c * z))
    return points, [4] * len(faces), indices


def glass_stage(drop_top: bool, thin_walled: bool | None):
    """An orthographic camera looking down −Z through the tilted glass cube at an emissive
    panel behind it that is lit for x < 0 and black for x > 0."""
    stage = new_stage()
    camera = UsdGeom.Camera.Define(stage, "/cam")
    camera.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
    camera.CreateHorizontalApertureAttr(40.0)  # tenths of a unit: 4 × 2 units
    camera.CreateVerticalApertureAttr(20.0)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.01, 100.0))
    camera.AddTranslateOp().Set(Gf.Vec3d(0, 0, 5))

    panel = UsdGeom.Mesh.Define(stage, "/panel")
    panel.CreatePointsAttr([(-3, -2, -2), (0, -2, -2), (0, 2, -2), (-3, 2, -2)])
    panel.CreateFaceVertexCountsAttr([4])
    panel.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    panel.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    bind(panel, add_preview_material(stage, "/lit", diffuseColor=(0.0, 0.0, 0.0),
                                     emissiveColor=(1.0, 1.0, 1.0)))

    cube = UsdGeom.Mesh.Define(stage, "/glass")
    points, counts, indices = split_cube_points_and_faces(drop_top)
    cube.CreatePointsAttr(points)
    cube.CreateFaceVertexCountsAttr(counts)
    cube.CreateFaceVertexIndicesAttr(indices)
    cube.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    cube.CreateDoubleSidedAttr(True)
    material = add_preview_material(stage, "/glassMaterial", opacity=0.0, ior=IOR,
                                    roughness=0.0)
    if thin_walled is not None:
        shader = UsdShade.Shader(stage.GetPrimAtPath("/glassMaterial/Surface"))
        shader.CreateInput("penumbra:thinWalled", Sdf.ValueTypeNames.Bool).Set(thin_walled)
    bind(cube, material)
    return stage


def edge_shift(stage) -> float:
    """Where the panel's lit edge appears through the middle of the cube's front face, in scene
    units to the right of where it is (x = 0)."""
    image = penumbra.render(stage, camera="/cam", width=WIDTH, samples=32,
                            default_light="none")
    color = image["color"]
    assert color.shape[:2] == (100, WIDTH)
    rows = color[40:60, :, :3].mean(axis=(0, 2))  # rows through the cube's middle
    # Columns over x in [-0.1, 0.35]: seen through the front face and (solid) the back face;
    # the lit part is on the left.
    first, last = (round((x + 2) / UNITS_PER_PIXEL) for x in (-0.1, 0.35))
    window = rows[first:last]
    lit = window > 0.5 * window.max()
    assert lit[0] and not lit[-1] and np.all(lit[:-1] >= lit[1:]), window
    return (first + int(lit.sum())) * UNITS_PER_PIXEL - 2.0


@pytest.mark.parametrize(
    "drop_top, thin_walled, solid",
    [
        (False, None, True),  # closed once its split points are welded
        (True, None, False),  # a face missing: a sheet
        (False, True, False),  # the override, both ways
        (True, False, True),
    ],
)
def test_glass_refracts_as_a_solid_or_passes_as_a_sheet(drop_top, thin_walled, solid):
    shift = edge_shift(glass_stage(drop_top, thin_walled))
    expected = SLAB_SHIFT if solid else 0.0
    assert shift == pytest.approx(expected, abs=2 * UNITS_PER_PIXEL), (shift, expected)
