"""Light and shadow linking (UsdLux ``collection:lightLink`` / ``collection:shadowLink``).

The stage: a grey back wall at z = -1 and small grey quads at z = 0 in front of it, seen by a
camera at z = 5, lit by two distant lights 30° off the view axis on either side: ``/key``
casts each quad's shadow on the wall tan 30° to its right, ``/side`` tan 30° to its left.
Direct light only (``max_path_depth=1``), so that a pixel's value depends only on the surface it
shows, the lights and what shadows them: changing how one quad is linked changes no other pixel,
bit for bit.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, Vt

import penumbra
from penumbra.errors import PenumbraWarning

from stages import (
    add_camera,
    add_distant_light,
    add_instance,
    add_preview_material,
    add_quad,
    bind,
    new_stage,
)

SIZE = 64
QUAD = 0.3  # half size
CENTRES = {"target": (-1.0, 0.8), "other": (1.0, 0.8)}
INSTANCES = {"/World/inst0": (-1.0, -0.8), "/World/inst1": (1.0, -0.8)}
POINTS = ((-0.4, 0.0), (0.4, 0.0))  # the point instancer's copies: prototypes a and b
GREY = 0.5
OFFSET = np.tan(np.radians(30))  # how far right (/key) or left (/side) a shadow falls


def linking_stage() -> Usd.Stage:
    stage = new_stage()
    add_camera(stage)
    add_quad(stage, "/World/wall", center=(0, 0, -1), half_size=4, color=(GREY,) * 3)
    for name, (x, y) in CENTRES.items():
        add_quad(stage, f"/World/{name}", center=(x, y, 0), half_size=QUAD, color=(GREY,) * 3)
    stage.CreateClassPrim("/Prototypes")
    UsdGeom.Xform.Define(stage, "/Prototypes/small")
    add_quad(stage, "/Prototypes/small/quad", half_size=QUAD, color=(GREY,) * 3)
    for path, (x, y) in INSTANCES.items():
        add_instance(stage, path, "/Prototypes/small", translate=(x, y, 0))
    points = UsdGeom.PointInstancer.Define(stage, "/World/points")
    for name in ("a", "b"):
        add_quad(stage, f"/World/points/prototypes/{name}", half_size=0.15, color=(GREY,) * 3)
    points.CreatePrototypesRel().SetTargets(
        ["/World/points/prototypes/a", "/World/points/prototypes/b"]
    )
    points.CreateProtoIndicesAttr([0, 1])
    points.CreatePositionsAttr(Vt.Vec3fArray([Gf.Vec3f(x, y, 0) for x, y in POINTS]))
    key = add_distant_light(stage, "/key")
    UsdGeom.Xformable(key).AddRotateYOp().Set(-30.0)  # light travelling towards +X and -Z
    side = add_distant_light(stage, "/side", intensity=2.0)
    UsdGeom.Xformable(side).AddRotateYOp().Set(30.0)  # towards -X and -Z
    return stage


def render(stage: Usd.Stage, samples: int = 8) -> np.ndarray:
    image = penumbra.Renderer(stage).render(
        camera="/cam", width=SIZE, samples=samples, max_path_depth=1
    )
    return image["color"]


def region(centre, half_size: float = QUAD, margin: float = 0.15) -> np.ndarray:
    """Mask of the pixels showing the square of ``half_size`` around ``centre`` of the z = 0
    plane (the camera sees [-2, 2]² there), grown by ``margin``."""
    coordinates = (np.arange(SIZE) + 0.5) / SIZE * 4 - 2
    x = coordinates[None, :]
    y = -coordinates[:, None]
    reach = half_size + margin
    return (np.abs(x - centre[0]) <= reach) & (np.abs(y - centre[1]) <= reach)


def inner(centre, half_size: float = QUAD) -> np.ndarray:
    """Pixels well inside the square."""
    return region(centre, half_size * 0.7, 0.0)


def on_wall(x: float, y: float) -> tuple[float, float]:
    """Where the camera sees the wall point (x, y, -1), as a point of the z = 0 plane."""
    return x * 5 / 6, y * 5 / 6


def shadows(centre, half_size: float = QUAD) -> np.ndarray:
    """Where a quad's shadows on the wall (from /key to its right, from /side to its left) can
    be seen."""
    return region(on_wall(*centre), (half_size + OFFSET) * 5 / 6)


def exclude(stage: Usd.Stage, light: str, collection: str, paths: list[str]) -> None:
    api = UsdLux.LightAPI(stage.GetPrimAtPath(light))
    link = (
        api.GetLightLinkCollectionAPI()
        if collection == "lightLink"
        else api.GetShadowLinkCollectionAPI()
    )
    link.GetExcludesRel().SetTargets(paths)


def without(stage: Usd.Stage, light: str) -> Usd.Stage:
    UsdGeom.Imageable(stage.GetPrimAtPath(light)).MakeInvisible()
    return stage


def assert_only_changed(linked: np.ndarray, reference: np.ndarray, changed: np.ndarray) -> None:
    """Every pixel outside ``changed`` is bit-identical; some inside differ."""
    np.testing.assert_array_equal(linked[~changed], reference[~changed])
    assert not np.array_equal(linked[changed], reference[changed])


def test_an_excluded_quad_receives_none_of_the_light_and_nothing_else_changes():
    reference = render(linking_stage())
    stage = linking_stage()
    exclude(stage, "/key", "lightLink", ["/World/target"])
    linked = render(stage)
    target = region(CENTRES["target"])
    assert_only_changed(linked, reference, target)
    # The quad gets only what /side gives it: as in a render without /key.
    side_only = render(without(linking_stage(), "/key"))
    inside = inner(CENTRES["target"])
    assert linked[inside, :3].mean() == pytest.approx(side_only[inside, :3].mean(), rel=0.02)
    assert reference[inside, :3].mean() > 2 * side_only[inside, :3].mean()


def test_a_shadow_link_lets_its_light_through_the_excluded_blocker_only():
    reference = render(linking_stage())
    stage = linking_stage()
    exclude(stage, "/key", "shadowLink", ["/World/target"])
    linked = render(stage)
    centre = CENTRES["target"]
    assert_only_changed(linked, reference, shadows(centre))
    # Where /key's shadow was, /key now lights the wall as where nothing blocks it; the quad
    # still shadows /side (the wall to its left stays darker than the open wall).
    key_shadow = region(on_wall(centre[0] + OFFSET, centre[1]), 0.05, 0)
    open_wall = region((0.0, 1.6), 0.05, 0)
    assert linked[key_shadow, 0].mean() == pytest.approx(linked[open_wall, 0].mean(), rel=0.03)
    assert reference[key_shadow, 0].mean() < 0.7 * linked[open_wall, 0].mean()
    side_shadow = region(on_wall(centre[0] - OFFSET - 0.12, centre[1]), 0.05, 0)
    assert linked[side_shadow, 0].mean() < 0.8 * linked[open_wall, 0].mean()
    np.testing.assert_array_equal(linked[side_shadow], reference[side_shadow])
    # The quad itself is seen and lit as before.
    quad = inner(centre)
    np.testing.assert_array_equal(linked[quad], reference[quad])


def test_a_light_link_with_only_include_root_false_authored_lights_nothing():
    # The only opinion is includeRoot: the collection must still be evaluated (the fallback,
    # nothing authored, is what is known to include everything without a query).
    stage = linking_stage()
    link = UsdLux.LightAPI(stage.GetPrimAtPath("/key")).GetLightLinkCollectionAPI()
    link.CreateIncludeRootAttr(False)
    linked = render(stage)
    side_only = render(without(linking_stage(), "/key"))
    reference = render(linking_stage())
    assert linked[..., :3].mean() == pytest.approx(side_only[..., :3].mean(), rel=0.02)
    assert reference[..., :3].mean() > 1.2 * side_only[..., :3].mean()


def test_a_membership_expression_links_as_the_equivalent_excludes():
    by_excludes = linking_stage()
    exclude(by_excludes, "/key", "lightLink", ["/World/target"])
    by_expression = linking_stage()
    link = UsdLux.LightAPI(by_expression.GetPrimAtPath("/key")).GetLightLinkCollectionAPI()
    link.CreateIncludeRootAttr(False)
    link.CreateMembershipExpressionAttr(Sdf.PathExpression("//* - /World/target"))
    by_includes = linking_stage()
    link = UsdLux.LightAPI(by_includes.GetPrimAtPath("/key")).GetLightLinkCollectionAPI()
    link.CreateIncludeRootAttr(False)
    link.GetIncludesRel().SetTargets(
        ["/World/wall", "/World/other", "/World/inst0", "/World/inst1", "/World/points"]
    )
    expected = render(by_excludes)
    np.testing.assert_array_equal(render(by_expression), expected)
    np.testing.assert_array_equal(render(by_includes), expected)


def test_native_instances_and_point_instancer_copies_are_linked_one_by_one():
    reference = render(linking_stage())
    stage = linking_stage()
    exclude(stage, "/key", "lightLink", ["/World/inst1", "/World/points/prototypes/b"])
    linked = render(stage)
    changed = region(INSTANCES["/World/inst1"]) | region(POINTS[1], 0.15)
    assert_only_changed(linked, reference, changed)
    # Excluding the instancer excludes all its copies.
    stage = linking_stage()
    exclude(stage, "/key", "lightLink", ["/World/points"])
    everything = render(stage)
    assert_only_changed(everything, reference, region(POINTS[0], 0.15) | region(POINTS[1], 0.15))
    for centre in POINTS:
        inside = inner(centre, 0.15)
        assert everything[inside, 0].mean() < 0.6 * reference[inside, 0].mean()


def test_linking_follows_live_edits():
    stage = linking_stage()
    renderer = penumbra.Renderer(stage)

    def again() -> np.ndarray:
        return renderer.render(camera="/cam", width=SIZE, samples=8, max_path_depth=1)["color"]

    reference = again()
    exclude(stage, "/key", "lightLink", ["/World/target", "/World/inst0"])
    edited = again()
    fresh = linking_stage()
    exclude(fresh, "/key", "lightLink", ["/World/target", "/World/inst0"])
    np.testing.assert_array_equal(edited, render(fresh))
    assert not np.array_equal(edited, reference)
    key = UsdLux.LightAPI(stage.GetPrimAtPath("/key"))
    key.GetLightLinkCollectionAPI().GetExcludesRel().ClearTargets(True)
    np.testing.assert_array_equal(again(), reference)


def test_a_collection_naming_a_missing_prim_warns_once_naming_the_light():
    stage = linking_stage()
    exclude(stage, "/key", "lightLink", ["/World/target", "/World/missing"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        linked = render(stage)
    messages = [str(w.message) for w in caught if issubclass(w.category, PenumbraWarning)]
    naming = [m for m in messages if "/World/missing" in m]
    assert len(naming) == 1 and "/key" in naming[0] and "excludes" in naming[0]
    # The rest of the collection still applies.
    reference = linking_stage()
    exclude(reference, "/key", "lightLink", ["/World/target"])
    np.testing.assert_array_equal(linked, render(reference))


def test_a_mesh_light_lights_only_what_its_link_includes():
    def with_lamp(excluded: bool, lamp: bool = True) -> Usd.Stage:
        stage = linking_stage()
        # Out of view, in front of the quads and to their right, facing them.
        emitter = add_quad(stage, "/World/lamp", center=(2.5, 0.8, 2.5), half_size=0.5)
        emitter.AddRotateYOp().Set(-135.0)
        UsdLux.MeshLightAPI.Apply(emitter.GetPrim())
        UsdLux.LightAPI(emitter.GetPrim()).CreateIntensityAttr(100.0)
        if excluded:
            exclude(stage, "/World/lamp", "lightLink", ["/World/target"])
        if not lamp:
            emitter.MakeInvisible()
        return stage

    lit = render(with_lamp(False), samples=64)
    linked = render(with_lamp(True), samples=64)
    dark = render(with_lamp(False, lamp=False), samples=64)
    inside = inner(CENTRES["target"])
    assert lit[inside, 0].mean() > 1.2 * dark[inside, 0].mean()
    assert linked[inside, 0].mean() == pytest.approx(dark[inside, 0].mean(), rel=0.03)
    elsewhere = ~region(CENTRES["target"])
    np.testing.assert_array_equal(linked[elsewhere], lit[elsewhere])


def test_points_are_linked_like_meshes():
    def with_points(excluded: bool) -> Usd.Stage:
        stage = linking_stage()
        points = UsdGeom.Points.Define(stage, "/World/dots")
        points.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(0, -1.6, 0)]))
        points.CreateWidthsAttr(Vt.FloatArray([0.5]))
        points.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(GREY)])
        if excluded:
            exclude(stage, "/key", "lightLink", ["/World/dots"])
        return stage

    reference = render(with_points(False))
    linked = render(with_points(True))
    assert_only_changed(linked, reference, region((0, -1.6), 0.25))
    inside = inner((0, -1.6), 0.1)
    assert linked[inside, 0].mean() < 0.6 * reference[inside, 0].mean()


def test_light_through_a_blocker_its_shadow_link_excludes_is_the_same_to_every_strategy():
    """BSDF rays stop at a blocker the light's shadow rays pass through: where next-event
    estimation can draw the light, it takes all of it (MIS gave the glossy floor under the
    blocker 5 % less than light sampling did: what BSDF rays were weighed by was lost)."""
    stage = new_stage()
    add_camera(stage)
    floor = add_quad(stage, "/World/floor", half_size=2.0)
    bind(floor, add_preview_material(stage, "/World/glossy", diffuseColor=(0.5, 0.5, 0.5),
                                     roughness=0.2))
    blocker = add_quad(stage, "/World/blocker", center=(0, 0, 0.5), half_size=1.0)
    blocker.GetOrientationAttr().Set(UsdGeom.Tokens.leftHanded)  # unseen from above
    light = UsdLux.RectLight.Define(stage, "/key")
    light.CreateWidthAttr(3.0)
    light.CreateHeightAttr(3.0)
    light.CreateIntensityAttr(3.0)
    light.AddTranslateOp().Set(Gf.Vec3d(0, 0, 1))
    exclude(stage, "/key", "shadowLink", ["/World/blocker"])
    under = {}
    for strategy in ("light", "mis"):
        image = penumbra.Renderer(stage).render(camera="/cam", width=32, samples=64, seed=1,
                                                max_path_depth=1, direct_lighting=strategy)
        under[strategy] = float(image["color"][12:20, 12:20, :3].mean())
    assert under["light"] > 0.05
    assert under["mis"] == pytest.approx(under["light"], rel=0.02)
