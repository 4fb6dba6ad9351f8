"""Attributes authored with another type or shape than the schema's, or with values no render
could follow: no exception, one warning naming the prim and the attribute, and the prim
rendered without what was wrong (or skipped); render settings that make the frame impossible
fail cleanly, naming the prim and the attribute.

The camera of :func:`stages.add_camera` sees the square [-2, 2]² of the z = 0 plane."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdRender, Vt

import penumbra
from penumbra.cli import main
from stages import (
    add_camera,
    add_distant_light,
    add_quad,
    covers,
    new_stage,
    render_with_warnings,
)

NAN, INF = math.nan, math.inf
WIDTH = 40


def render(stage: Usd.Stage) -> tuple[np.ndarray, list[str]]:
    return render_with_warnings(stage, WIDTH)



def author(
    stage: Usd.Stage, path: str, name: str, type_name: Sdf.ValueTypeName, value: Any,
    interpolation: str | None = None,
) -> None:
    """Author attribute ``name`` of ``path`` with ``type_name`` in the layer itself: through
    Usd, a schema attribute takes only the schema's type, which files need not keep."""
    spec = stage.GetRootLayer().GetPrimAtPath(path)
    attribute = Sdf.AttributeSpec(spec, name, type_name)
    attribute.default = value
    if interpolation:
        attribute.SetInfo("interpolation", interpolation)


def scene() -> Usd.Stage:
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    return stage


def with_blur(stage: Usd.Stage) -> Usd.Stage:
    # Shutter [-0.25, 0.25] around frame 1: velocities move and spin the copies.
    camera = UsdGeom.Camera.Get(stage, "/cam")
    camera.CreateShutterOpenAttr(-0.25)
    camera.CreateShutterCloseAttr(0.25)
    return stage


# --------------------------------------------------------------------------------------------
# displayColor and displayOpacity


def quad(stage: Usd.Stage) -> str:
    add_quad(stage, "/World/quad")
    return "/World/quad"


def quad_with_primvar(stage: Usd.Stage) -> str:
    """A quad that the scene delegate reads through its general path (another primvar)."""
    mesh = add_quad(stage, "/World/quad")
    mesh.GetPrim().CreateAttribute("primvars:tag", Sdf.ValueTypeNames.FloatArray).Set([1.0])
    return "/World/quad"


def sphere(stage: Usd.Stage) -> str:
    UsdGeom.Sphere.Define(stage, "/World/ball")
    return "/World/ball"


def points(stage: Usd.Stage) -> str:
    cloud = UsdGeom.Points.Define(stage, "/World/cloud")
    cloud.CreatePointsAttr([(-1, 0, 0), (0, 0, 0), (1, 0, 0), (0, 1, 0)])
    cloud.CreateWidthsAttr([0.6] * 4)
    return "/World/cloud"


def curves(stage: Usd.Stage) -> str:
    strand = UsdGeom.BasisCurves.Define(stage, "/World/strand")
    strand.CreateTypeAttr(UsdGeom.Tokens.linear)
    strand.CreateCurveVertexCountsAttr([4])
    strand.CreatePointsAttr([(-1.5, 0, 0), (-0.5, 0.5, 0), (0.5, -0.5, 0), (1.5, 0, 0)])
    strand.CreateWidthsAttr([0.4])
    strand.SetWidthsInterpolation(UsdGeom.Tokens.constant)
    return "/World/strand"


def instancer(stage: Usd.Stage) -> str:
    """Two copies of a cube; the instancer's constant primvars are inherited by the cube."""
    copies = UsdGeom.PointInstancer.Define(stage, "/World/copies")
    UsdGeom.Cube.Define(stage, "/World/copies/cube").CreateSizeAttr(0.8)
    copies.CreatePrototypesRel().SetTargets(["/World/copies/cube"])
    copies.CreatePositionsAttr([(-1, 0, 0), (1, 0, 0)])
    copies.CreateProtoIndicesAttr([0, 0])
    return "/World/copies"


# The prims (with the path their warning names and a plane point they cover), and the
# displayColors they cannot use.
PRIMS: dict[str, tuple[Callable[[Usd.Stage], str], str, tuple[float, float]]] = {
    "plain mesh": (quad, "/World/quad", (0, 0)),
    "mesh": (quad_with_primvar, "/World/quad", (0, 0)),
    "implicit": (sphere, "/World/ball", (0, 0)),
    "points": (points, "/World/cloud", (0, 0)),
    "curves": (curves, "/World/strand", (0, 0)),
    "inherited from an instancer": (instancer, "/World/copies/cube", (1, 0)),
}
BAD_COLORS = {
    "float[]": (Sdf.ValueTypeNames.FloatArray, Vt.FloatArray([1, 0]), "FloatArray"),
    "string": (Sdf.ValueTypeNames.String, "red", "str"),
    "float": (Sdf.ValueTypeNames.Float, 1.0, "float"),
    "color4f[]": (Sdf.ValueTypeNames.Color4fArray, Vt.Vec4fArray([Gf.Vec4f(1, 0, 0, 1)]), "Vec4fArray"),
}


@pytest.mark.parametrize("bad", BAD_COLORS)
@pytest.mark.parametrize("prim", PRIMS)
def test_a_display_color_not_of_3_vectors_is_ignored_with_one_warning(prim: str, bad: str) -> None:
    """A float[], a string, a float or a color4f[] (whose 4 numbers would have been
    reshaped into garbage colours, or failed the render): the prim renders with its
    fallback colour, as without one."""
    build, warned, seen = PRIMS[prim]
    type_name, value, value_type = BAD_COLORS[bad]
    stage = scene()
    path = build(stage)
    author(stage, path, "primvars:displayColor", type_name, value, UsdGeom.Tokens.constant)
    image, messages = render(stage)
    inherited = " (inherited from /World/copies)" if warned != path else ""
    assert messages == [
        f"{warned}: primvars:displayColor{inherited} has type {value_type}, not 3-vectors; "
        "ignored, the fallback colour is used"
    ]

    fallback = scene()
    build(fallback)
    expected, expected_messages = render(fallback)
    assert expected_messages == []
    assert covers(expected, *seen)
    assert np.array_equal(image, expected)


def test_a_display_color_of_4_vectors_per_point_is_not_reshaped_into_colours() -> None:
    """3 colour4s hold 12 numbers: 4 RGB colours for the quad's 4 points, all garbage."""
    stage = scene()
    path = quad(stage)
    colors = Vt.Vec4fArray([Gf.Vec4f(1, 0, 0, 1), Gf.Vec4f(0, 1, 0, 1), Gf.Vec4f(0, 0, 1, 1)])
    author(stage, path, "primvars:displayColor", Sdf.ValueTypeNames.Color4fArray, colors, "vertex")
    image, messages = render(stage)
    assert messages == [
        "/World/quad: primvars:displayColor has type Vec4fArray, not 3-vectors; ignored, the "
        "fallback colour is used"
    ]
    fallback = scene()
    quad(fallback)
    assert np.array_equal(image, render(fallback)[0])


def test_a_display_opacity_not_of_numbers_is_ignored_with_one_warning() -> None:
    """The delegate reads an opacity from an element's first number: a colour's red (0.25)
    made the quad see-through."""
    stage = scene()
    path = quad(stage)
    add_quad(stage, "/World/behind", center=(0, 0, -1), color=(1, 0, 0))
    opacity = Vt.Vec3fArray([Gf.Vec3f(0.25, 1, 1)])
    author(stage, path, "primvars:displayOpacity", Sdf.ValueTypeNames.Color3fArray, opacity,
           UsdGeom.Tokens.constant)
    image, messages = render(stage)
    assert messages == [
        "/World/quad: primvars:displayOpacity has type Vec3fArray, not numbers; ignored"
    ]
    opaque = scene()
    quad(opaque)
    add_quad(opaque, "/World/behind", center=(0, 0, -1), color=(1, 0, 0))
    assert np.array_equal(image, render(opaque)[0])


# --------------------------------------------------------------------------------------------
# Point instancer motion


def two_copies() -> tuple[Usd.Stage, UsdGeom.PointInstancer]:
    """Two copies of a quad (half size 0.4) at (±1, 0.5), under a blurring shutter."""
    stage = with_blur(scene())
    copies = UsdGeom.PointInstancer.Define(stage, "/World/copies")
    UsdGeom.Xform.Define(stage, "/World/copies/tile")
    add_quad(stage, "/World/copies/tile/quad", half_size=0.4)
    copies.CreatePrototypesRel().SetTargets(["/World/copies/tile"])
    copies.CreatePositionsAttr([(-1, 0.5, 0), (1, 0.5, 0)])
    copies.CreateProtoIndicesAttr([0, 0])
    return stage, copies


@pytest.mark.parametrize("bad", [NAN, INF])
def test_copies_spinning_at_a_rate_not_finite_are_skipped_with_one_warning(bad: float) -> None:
    """The rate sets the motion segments (a NaN or infinity failed the render there); the
    copy is skipped, the other spins as if alone."""
    stage, copies = two_copies()
    copies.CreateAngularVelocitiesAttr([(0, 0, bad), (0, 0, 90)])
    image, messages = render(stage)
    assert messages == [
        "/World/copies: a NaN or infinity in angularVelocities for 1 of 2 instances; those "
        "instances are skipped"
    ]
    alone, copies = two_copies()
    copies.CreatePositionsAttr([(1, 0.5, 0)])
    copies.CreateProtoIndicesAttr([0])
    copies.CreateAngularVelocitiesAttr([(0, 0, 90)])
    expected, expected_messages = render(alone)
    assert expected_messages == []
    assert covers(expected, 1, 0.5) and not covers(expected, -1, 0.5)
    assert np.array_equal(image, expected)


@pytest.mark.parametrize("attribute", ["velocities", "accelerations", "angularVelocities"])
def test_copy_motion_of_another_type_is_ignored_with_one_warning(attribute: str) -> None:
    """float[] where the schema has vector3f[]: the copies render without that motion."""
    stage, copies = two_copies()
    author(stage, "/World/copies", attribute, Sdf.ValueTypeNames.FloatArray, Vt.FloatArray([40, 40]))
    image, messages = render(stage)
    assert messages == [f"/World/copies: {attribute} has type FloatArray, not 3-vectors; ignored"]
    still, _ = two_copies()
    expected, _ = render(still)
    assert covers(expected, -1, 0.5) and covers(expected, 1, 0.5)
    assert np.array_equal(image, expected)


# --------------------------------------------------------------------------------------------
# Subdivision tags


TAGS = {
    "creaseSharpnesses": (Sdf.ValueTypeNames.String, "x", "str", "float[]", "creases"),
    "creaseLengths": (Sdf.ValueTypeNames.FloatArray, Vt.FloatArray([2]), "FloatArray", "int[]", "creases"),
    "cornerSharpnesses": (Sdf.ValueTypeNames.Float, 10.0, "float", "float[]", "corners"),
    "cornerIndices": (Sdf.ValueTypeNames.Int64Array, Vt.Int64Array([2**32]), "Int64Array", "int[]", "corners"),
}


@pytest.mark.parametrize("plain", [True, False], ids=["plain mesh", "mesh"])
@pytest.mark.parametrize("attribute", TAGS)
def test_subdivision_tags_of_another_type_are_ignored_with_one_warning(
    attribute: str, plain: bool
) -> None:
    """The group of tags holding the attribute is left out (its arrays only make sense
    together); an int64 index past int32 is not wrapped into a small one (2**32 into 0)."""

    def subdivided_quad() -> Usd.Stage:
        stage = scene()
        build = quad if plain else quad_with_primvar
        UsdGeom.Mesh(stage.GetPrimAtPath(build(stage))).CreateSubdivisionSchemeAttr(
            UsdGeom.Tokens.catmullClark
        )
        return stage

    type_name, value, value_type, expected_type, group = TAGS[attribute]
    stage = subdivided_quad()
    if group == "creases":  # the crease along the bottom edge, but for the bad attribute
        mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/quad"))
        mesh.CreateCreaseIndicesAttr([0, 1])
        if attribute != "creaseLengths":
            mesh.CreateCreaseLengthsAttr([2])
        if attribute != "creaseSharpnesses":
            mesh.CreateCreaseSharpnessesAttr([10.0])
    author(stage, "/World/quad", attribute, type_name, value)
    image, messages = render(stage)
    assert messages == [
        f"/World/quad: {attribute} has type {value_type}, not {expected_type}; the mesh's "
        f"{group} are ignored"
    ]
    expected, _ = render(subdivided_quad())
    assert covers(expected, 0, 0)
    assert np.array_equal(image, expected)


# --------------------------------------------------------------------------------------------
# Curve vertex counts


@pytest.mark.parametrize(
    "type_name, value, value_type",
    [
        # 2**32 + 4 wrapped to 4: the strand rendered as if its counts were right.
        (Sdf.ValueTypeNames.Int64Array, Vt.Int64Array([2**32 + 4]), "Int64Array"),
        (Sdf.ValueTypeNames.String, "4", "str"),
    ],
    ids=["int64 past int32", "string"],
)
def test_curve_vertex_counts_not_32_bit_integers_skip_the_curves_with_one_warning(
    type_name: Sdf.ValueTypeName, value: Any, value_type: str
) -> None:
    stage = scene()
    path = curves(stage)
    stage.GetRootLayer().GetPrimAtPath(path).RemoveProperty(
        stage.GetRootLayer().GetPropertyAtPath(f"{path}.curveVertexCounts")
    )
    author(stage, path, "curveVertexCounts", type_name, value)
    image, messages = render(stage)
    assert messages == [
        f"{path}: curveVertexCounts ({value_type}) is not an array of 32-bit integers; skipped"
    ]
    expected, _ = render(scene())
    assert not covers(expected, 0, 0)
    assert np.array_equal(image, expected)


# --------------------------------------------------------------------------------------------
# Render settings


@pytest.mark.parametrize(
    "name, type_name, value, expect",
    [
        ("dataWindowNDC", Sdf.ValueTypeNames.Float4, Gf.Vec4f(-INF, 0, INF, 1),
         "/rs: dataWindowNDC must be 4 finite numbers"),
        ("dataWindowNDC", Sdf.ValueTypeNames.Float4, Gf.Vec4f(0, 0, NAN, 1),
         "/rs: dataWindowNDC must be 4 finite numbers"),
        ("dataWindowNDC", Sdf.ValueTypeNames.Float2, Gf.Vec2f(0, 1),
         "/rs: dataWindowNDC must be 4 finite numbers"),
        ("resolution", Sdf.ValueTypeNames.String, "64x48", "/rs: resolution must be 2 finite numbers"),
        ("resolution", Sdf.ValueTypeNames.Float2, Gf.Vec2f(INF, 48),
         "/rs: resolution must be 2 finite numbers"),
    ],
    ids=["dataWindowNDC infinite", "dataWindowNDC NaN", "dataWindowNDC float2", "resolution string",
         "resolution infinite"],
)
def test_render_settings_of_another_type_or_infinite_fail_cleanly(
    name: str, type_name: Sdf.ValueTypeName, value: Any, expect: str, tmp_path: Path, capsys
) -> None:
    path = tmp_path / "stage.usda"
    stage = new_stage(path)
    add_camera(stage)
    add_quad(stage, "/World/quad")
    UsdRender.Settings.Define(stage, "/rs").CreateCameraRel().SetTargets(["/cam"])
    author(stage, "/rs", name, type_name, value)
    stage.Save()
    out = tmp_path / "out.png"
    status = main([str(path), str(out), "-w", "32", "-spp", "1", "-q", "-rs", "/rs"])
    stderr = capsys.readouterr().err
    assert status == 1, stderr
    assert expect in stderr
    assert "Traceback" not in stderr
    assert not out.exists()
