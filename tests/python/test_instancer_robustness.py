"""Instance copies hidden by a scale of 0, or with a NaN or infinity in their placement: no
error, nothing rendered from them, the good copies rendered, and one warning per instancer for
what is not finite (a scale of 0 is a way to hide things: no warning, as for a mesh).

The camera of :func:`stages.add_camera` sees the square [-2, 2]² of the z = 0 plane."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

import penumbra
from stages import (
    add_camera,
    add_distant_light,
    add_instance,
    add_quad,
    covers,
    new_stage,
    render_with_warnings,
)

NAN, INF = math.nan, math.inf
WIDTH = 40


def render(stage: Usd.Stage) -> tuple[np.ndarray, list[str]]:
    return render_with_warnings(stage, WIDTH)


def scene() -> Usd.Stage:
    """A lit stage with a marker quad at (0, -1.5), so that no image compared is empty."""
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    add_quad(stage, "/World/marker", center=(0.0, -1.5, 0.0), half_size=0.3)
    return stage


def point_instancer(
    stage: Usd.Stage,
    positions: list[tuple[float, float, float]],
    path: str = "/World/copies",
    prototype: str = "/World/copies/tile",
) -> UsdGeom.PointInstancer:
    """Copies of a quad (half size 0.4) in an Xform ``prototype`` at ``positions``."""
    instancer = UsdGeom.PointInstancer.Define(stage, path)
    UsdGeom.Xform.Define(stage, prototype)
    add_quad(stage, f"{prototype}/quad", half_size=0.4)
    instancer.CreatePrototypesRel().SetTargets([prototype])
    instancer.CreatePositionsAttr(Vt.Vec3fArray(positions))
    instancer.CreateProtoIndicesAttr(Vt.IntArray([0] * len(positions)))
    return instancer


def two_copies() -> tuple[Usd.Stage, UsdGeom.PointInstancer]:
    stage = scene()
    return stage, point_instancer(stage, [(-1, 0.5, 0), (1, 0.5, 0)])


def scale(prim: Usd.Prim, factors: tuple[float, float, float]) -> None:
    UsdGeom.Xformable(prim).AddScaleOp().Set(Gf.Vec3f(*factors))


def instancer_scaled_to_0() -> Usd.Stage:
    stage, instancer = two_copies()
    scale(instancer.GetPrim(), (0, 0, 0))
    return stage


def instancer_scaled_flat() -> Usd.Stage:
    stage, instancer = two_copies()
    scale(instancer.GetPrim(), (1, 0, 1))  # flattens the quads (in the XY plane) to lines
    return stage


def prototype_scaled_to_0() -> Usd.Stage:
    stage, _ = two_copies()
    scale(stage.GetPrimAtPath("/World/copies/tile"), (0, 0, 0))  # part of every copy
    return stage


def instanced_point_instancer(positions: list[tuple[float, float, float]]) -> Usd.Stage:
    """Two instances, at (±1, 0.5), of /Proto holding a point instancer /Proto/copies."""
    stage = scene()
    UsdGeom.Xform.Define(stage, "/Proto").GetPrim().SetSpecifier(Sdf.SpecifierClass)
    point_instancer(stage, positions, "/Proto/copies", "/Proto/copies/tile")
    add_instance(stage, "/Shots/a", "/Proto", (-1.0, 0.5, 0.0))
    add_instance(stage, "/Shots/b", "/Proto", (1.0, 0.5, 0.0))
    return stage


def point_instancer_in_native_prototype_scaled_to_0() -> Usd.Stage:
    stage = instanced_point_instancer([(0, 0, 0)])
    scale(stage.GetPrimAtPath("/Proto/copies"), (0, 0, 0))
    return stage


@pytest.mark.parametrize(
    "hidden",
    [
        instancer_scaled_to_0,
        instancer_scaled_flat,
        prototype_scaled_to_0,
        point_instancer_in_native_prototype_scaled_to_0,
    ],
)
def test_copies_scaled_to_0_render_as_nothing_without_warning(hidden: Callable[[], Usd.Stage]) -> None:
    """As a mesh scaled flat renders as nothing, silently (docs/design.md §3, "Errors")."""
    image, messages = render(hidden())
    assert messages == []
    expected, _ = render(scene())  # the marker alone
    assert covers(expected, 0, -1.5)
    assert np.array_equal(image, expected)


def test_a_prototype_below_a_group_scaled_to_0_still_has_its_copies() -> None:
    """Only the prototype root's own transform is part of a copy, not its ancestors'
    (UsdGeomPointInstancer): a scale of 0 on the group holding the prototypes (hiding them
    where they are defined) leaves the copies as any other scale there does."""

    def stage_with_group(factors: tuple[float, float, float]) -> Usd.Stage:
        stage = scene()
        group = UsdGeom.Xform.Define(stage, "/World/Prototypes")
        group.AddTranslateOp().Set(Gf.Vec3d(0, 10, 0))  # the prototype itself out of view
        scale(group.GetPrim(), factors)
        point_instancer(stage, [(-1, 0.5, 0), (1, 0.5, 0)], prototype="/World/Prototypes/tile")
        return stage

    image, messages = render(stage_with_group((0, 0, 0)))
    assert messages == []
    assert covers(image, -1, 0.5) and covers(image, 1, 0.5)
    expected, _ = render(stage_with_group((1, 1, 1)))
    assert np.array_equal(image, expected)


def with_blur(stage: Usd.Stage) -> Usd.Stage:
    # Shutter [-0.25, 0.25] around frame 1: velocities move the copies.
    camera = UsdGeom.Camera.Get(stage, "/cam")
    camera.CreateShutterOpenAttr(-0.25)
    camera.CreateShutterCloseAttr(0.25)
    return stage


QUARTER = Gf.Quath(0.7071, 0, 0, 0.7071)
NOT_FINITE = {
    # attribute: (type, the first copy's bad value, the second copy's good value)
    "positions": (Sdf.ValueTypeNames.Point3fArray, (NAN, 0.5, 0), (1, 0.5, 0)),
    "orientations": (Sdf.ValueTypeNames.QuathArray, Gf.Quath(NAN, 0, 0, 0), QUARTER),
    "scales": (Sdf.ValueTypeNames.Float3Array, (1, INF, 1), (0.5, 0.5, 1)),
    "velocities": (Sdf.ValueTypeNames.Vector3fArray, (NAN, 0, 0), (12, 0, 0)),
}


@pytest.mark.parametrize("attribute", NOT_FINITE)
def test_point_instancer_copies_not_finite_are_skipped_with_one_warning(attribute: str) -> None:
    """Common in simulation caches: the bad copy is skipped, with one warning naming the
    instancer, the attribute and how many; the good copy renders as if alone."""
    value_type, bad, good = NOT_FINITE[attribute]
    stage, instancer = two_copies()
    with_blur(stage)
    instancer.GetPrim().CreateAttribute(attribute, value_type).Set([bad, good])
    image, messages = render(stage)
    assert messages == [
        f"/World/copies: a NaN or infinity in {attribute} for 1 of 2 instances; those instances "
        "are skipped"
    ]

    alone = with_blur(scene())
    instancer = point_instancer(alone, [(1, 0.5, 0)])
    instancer.GetPrim().CreateAttribute(attribute, value_type).Set([good])
    expected, expected_messages = render(alone)
    assert expected_messages == []
    assert covers(expected, 1, 0.5)
    assert np.array_equal(image, expected)


def test_a_point_instancer_in_a_native_prototype_warns_once_by_its_instance_path() -> None:
    """Two instances share the prototype's point instancer: one warning, by the path users see."""
    image, messages = render(instanced_point_instancer([(NAN, 0, 0), (0, 0, 0)]))
    assert messages == [
        "/Shots/a/copies: a NaN or infinity in positions for 1 of 2 instances; those instances "
        "are skipped"
    ]
    expected, _ = render(instanced_point_instancer([(0, 0, 0)]))
    assert covers(expected, -1, 0.5) and covers(expected, 1, 0.5)
    assert np.array_equal(image, expected)


def native_instances(translates: dict[str, tuple[float, float, float]]) -> Usd.Stage:
    """Instances of a quad (half size 0.4) at ``translates`` (instance name → translate)."""
    stage = scene()
    add_quad(stage, "/Tile/quad", half_size=0.4)
    stage.GetPrimAtPath("/Tile").SetSpecifier(Sdf.SpecifierClass)
    for name, translate in translates.items():
        add_instance(stage, f"/World/{name}", "/Tile", translate)
    return stage


@pytest.mark.parametrize("where", ["instance", "point instancer"])
def test_a_non_finite_xform_op_skips_what_it_places_with_one_warning(where: str) -> None:
    """As a mesh with a NaN in an xformOp: "the world transform is not finite"."""
    if where == "instance":
        stage = native_instances({"bad": (NAN, 0.5, 0), "good": (1, 0.5, 0)})
        expected, _ = render(native_instances({"good": (1, 0.5, 0)}))
        path = "/World/bad"
    else:
        stage = scene()
        UsdGeom.Xformable(point_instancer(stage, [(-1, 0.5, 0)])).AddTranslateOp().Set(
            Gf.Vec3d(0, INF, 0)
        )
        expected, _ = render(scene())
        path = "/World/copies"
    image, messages = render(stage)
    assert messages == [
        f"{path}: the world transform is not finite (a NaN or infinity in an xformOp); the prim "
        "is not rendered"
    ]
    assert np.array_equal(image, expected)
