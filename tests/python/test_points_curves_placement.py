"""Points and curves placed like meshes: as the prototypes of instancer rprims (the copies
follow the prototype's geometry, go when it is removed and come back with it), under a render
pass's cameraVisibility and matte collections, and framed by default with unauthored widths."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdRender

import penumbra
from penumbra import _core
from stages import add_camera, add_distant_light, add_instance, add_quad, new_stage

CAMERA = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 5, 1]], float)
SIZE = 16  # pixels across the camera's [-2, 2]² at z = 0
# Two copies, one nearer and one farther than z = 0, and where the camera sees their centres
# on the z = 0 plane: the centres of pixels.
LEFT, RIGHT = (-1.1, 0.1, 1.0), (1.05, 0.15, -1.0)
LEFT_SEEN, RIGHT_SEEN = (-1.375, 0.125), (0.875, 0.125)


def _translation(x: float, y: float, z: float) -> np.ndarray:
    matrix = np.eye(4)
    matrix[3, :3] = x, y, z
    return matrix


def _pixel(x: float, y: float) -> tuple[int, int]:
    """The (row, column) of the pixel seeing point (x, y) of the z = 0 plane."""
    return int((2 - y) / 4 * SIZE), int((x + 2) / 4 * SIZE)


def _depth_at(delegate, points) -> list[float]:
    """The camera depth (Z AOV: the nearest sample's) at the pixels seeing points (x, y) of the
    z = 0 plane."""
    render_pass = _core.RenderPass(delegate, "/cam", SIZE, SIZE)
    render_pass.execute(64)
    depth = render_pass.aov("Z")[:, :, 0]
    return [float(depth[_pixel(x, y)]) for x, y in points]


def _scene_with_prototype(kind: str):
    delegate = _core.RenderDelegate()
    delegate.insert_sprim("camera", "/cam")
    delegate.set_camera("/cam", focal_length=5, horizontal_aperture=4, vertical_aperture=4)
    delegate.set_transform("/cam", CAMERA)
    delegate.insert_sprim("domeLight", "/sky")
    _insert_prototype(delegate, kind)
    delegate.insert_rprim("instancer", "/copies")
    copies = np.stack([_translation(*LEFT), _translation(*RIGHT)])
    delegate.set_instances("/copies", "/proto", copies)
    return delegate


def _insert_prototype(delegate, kind: str) -> None:
    if kind == "points":
        delegate.insert_rprim("points", "/proto")
        delegate.set_points("/proto", np.zeros((1, 3), np.float32), np.float32([0.5]))
    else:
        delegate.insert_rprim("basisCurves", "/proto")
        delegate.set_curves(
            "/proto", "linear", "bezier", "nonperiodic", np.int32([2]),
            np.float32([(0, -0.5, 0), (0, 0.5, 0)]), np.float32([0.5]), "constant",
        )
    delegate.set_visible("/proto", False)  # only its copies render


@pytest.mark.parametrize("kind", ["points", "curves"])
def test_points_and_curves_are_instancer_prototypes(kind):
    delegate = _scene_with_prototype(kind)
    # Each copy's nearest surface (a radius of 0.25 in front of its centre) in its pixel.
    left, middle, right = _depth_at(delegate, [LEFT_SEEN, (0, 0), RIGHT_SEEN])
    assert left == pytest.approx(5 - LEFT[2] - 0.25, abs=0.01)
    assert right == pytest.approx(5 - RIGHT[2] - 0.25, abs=0.01)
    assert not np.isfinite(middle) or middle > 1e6 or middle == 0  # the hidden prototype
    delegate.remove_prim("/proto")  # the copies go with it
    gone = _depth_at(delegate, [LEFT_SEEN, RIGHT_SEEN])
    assert all(not np.isfinite(d) or d > 1e6 or d == 0 for d in gone)
    _insert_prototype(delegate, kind)  # and come back with a prototype of its id
    assert _depth_at(delegate, [LEFT_SEEN])[0] == left


def _pass_stage(kind: str) -> Usd.Stage:
    """A grey wall at z = −1 behind a camera-hidden and a matte sphere point (or a curve) at
    z = 0, lit along −Z (cf. test_render_pass)."""
    stage = new_stage()
    add_camera(stage)
    add_quad(stage, "/World/back", center=(0, 0, -1), half_size=3, color=(0.5,) * 3)
    for name, x in (("cameraHidden", -1.0), ("matte", 1.0)):
        if kind == "points":
            gprim = UsdGeom.Points.Define(stage, f"/World/{name}")
            gprim.CreatePointsAttr([Gf.Vec3f(x, 0, 0)])
        else:
            gprim = UsdGeom.BasisCurves.Define(stage, f"/World/{name}")
            gprim.CreatePointsAttr([Gf.Vec3f(x, -0.8, 0), Gf.Vec3f(x, 0.8, 0)])
            gprim.CreateCurveVertexCountsAttr([2])
            gprim.CreateTypeAttr(UsdGeom.Tokens.linear)
        gprim.CreateWidthsAttr([0.8])
        gprim.SetWidthsInterpolation(UsdGeom.Tokens.constant)
    add_distant_light(stage)
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets(["/cam"])
    render_pass = UsdRender.Pass.Define(stage, "/Render/Pass")
    render_pass.GetRenderSourceRel().SetTargets(["/Render/Settings"])
    prim = render_pass.GetPrim()
    Usd.CollectionAPI(prim, "cameraVisibility").GetExcludesRel().SetTargets(["/World/cameraHidden"])
    Usd.CollectionAPI(prim, "matte").GetIncludesRel().SetTargets(["/World/matte"])
    return stage


@pytest.mark.parametrize("kind", ["points", "curves"])
def test_render_pass_visibility_reaches_points_and_curves(kind):
    image = penumbra.Renderer(_pass_stage(kind), render_pass="/Render/Pass").render(
        camera="/cam", width=80, samples=16, max_path_depth=1
    )["color"]

    def at(x: float, y: float) -> np.ndarray:
        return image[int((2 - y) / 4 * 80), int((x + 2) / 4 * 80)]

    # Hidden from the camera, it still shadows the wall right behind it (seen at 5/6 of its x).
    assert list(at(-1 * 5 / 6, 0)) == [0, 0, 0, 1]
    assert list(at(1, 0)) == [0, 0, 0, 0]  # the matte one: a holdout
    assert at(0, 1.5)[0] > 0.3  # the lit wall elsewhere


@pytest.mark.parametrize("kind", ["points", "curves"])
def test_unauthored_widths_are_framed(kind):
    stage = new_stage()
    if kind == "points":
        UsdGeom.Points.Define(stage, "/World/dot").CreatePointsAttr([Gf.Vec3f(0, 0, 0)])
    else:
        # Lying across the view: usdrecord's framing fits the horizontal field of view, so a
        # scene taller than the film's 1.37:1 would be cut at the top and bottom.
        hair = UsdGeom.BasisCurves.Define(stage, "/World/hair")
        hair.CreatePointsAttr([Gf.Vec3f(-1, 0, 0), Gf.Vec3f(1, 0, 0)])
        hair.CreateCurveVertexCountsAttr([2])
        hair.CreateTypeAttr(UsdGeom.Tokens.linear)
    image = penumbra.render(stage, width=32, samples=4, dome_light_visibility=False)
    covered = image["color"][:, :, 3] > 0.5
    assert covered.sum() > 20  # the unit width seen whole, not from inside it
    border = np.concatenate([covered[0], covered[-1], covered[:, 0], covered[:, -1]])
    assert not border.any()




def _add_gprim(stage: Usd.Stage, path: str, kind: str) -> None:
    """A sphere point, or a vertical curve, of width 0.5 at the origin of ``path``."""
    if kind == "points":
        gprim = UsdGeom.Points.Define(stage, path)
        gprim.CreatePointsAttr([Gf.Vec3f(0, 0, 0)])
    else:
        gprim = UsdGeom.BasisCurves.Define(stage, path)
        gprim.CreatePointsAttr([Gf.Vec3f(0, -0.3, 0), Gf.Vec3f(0, 0.3, 0)])
        gprim.CreateCurveVertexCountsAttr([2])
        gprim.CreateTypeAttr(UsdGeom.Tokens.linear)
    gprim.CreateWidthsAttr([0.5])
    gprim.SetWidthsInterpolation(UsdGeom.Tokens.constant)


COPIES = [(-1.0, 1.0), (1.0, 1.0), (0.0, -1.0)]


def _covered_at(image, centres) -> list[bool]:
    alpha = image["color"][:, :, 3]
    size = alpha.shape[0]
    return [bool(alpha[int((2 - y) / 4 * size), int((x + 2) / 4 * size)] > 0.5) for x, y in centres]


@pytest.mark.parametrize("kind", ["points", "curves"])
def test_points_and_curves_are_point_instancer_prototypes(kind):
    stage = new_stage()
    add_camera(stage)
    instancer = UsdGeom.PointInstancer.Define(stage, "/World/scatter")
    _add_gprim(stage, "/World/scatter/prototypes/one", kind)
    instancer.CreatePrototypesRel().SetTargets(["/World/scatter/prototypes/one"])
    instancer.CreateProtoIndicesAttr([0] * len(COPIES))
    instancer.CreatePositionsAttr([Gf.Vec3f(x, y, 0) for x, y in COPIES])
    renderer = penumbra.Renderer(stage)
    image = renderer.render(camera="/cam", width=32, samples=4, dome_light_visibility=False)
    assert all(_covered_at(image, COPIES))
    assert not _covered_at(image, [(0, 0)])[0]  # the prototype itself is not rendered


@pytest.mark.parametrize("kind", ["points", "curves"])
def test_native_instances_of_points_and_curves_share_one_prototype(kind):
    stage = new_stage()
    add_camera(stage)
    stage.CreateClassPrim("/Prototypes")
    UsdGeom.Xform.Define(stage, "/Prototypes/tuft")
    _add_gprim(stage, "/Prototypes/tuft/gprim", kind)
    for n, (x, y) in enumerate(COPIES):
        add_instance(stage, f"/World/tuft{n}", "/Prototypes/tuft", translate=(x, y, 0))
    renderer = penumbra.Renderer(stage)
    image = renderer.render(camera="/cam", width=32, samples=4, dome_light_visibility=False)
    assert all(_covered_at(image, COPIES))
    # One hidden prototype rprim and one instancer, not one rprim per instance.
    ids = renderer.delegate.prim_ids()
    assert not any(i.startswith("/World/tuft") for i in ids), ids
    assert sum("/prototypes" in i for i in ids) == 1, ids


@pytest.mark.parametrize("kind", ["points", "curves"])
def test_a_rejected_setter_call_changes_nothing(kind):
    """set_points / set_curves convert every argument before they set any: a bad primvar (its
    last argument) raises and leaves the prim as it was, instead of half updated."""
    delegate = _scene_with_prototype(kind)
    before = _depth_at(delegate, [LEFT_SEEN, RIGHT_SEEN])
    moved = np.float32([(0, 0, 1.0)]) if kind == "points" else np.float32([(0, -0.5, 1), (0, 0.5, 1)])
    bad_primvars = {"rough": (np.float32([0.5]), "sideways")}  # no such interpolation
    with pytest.raises(ValueError):
        if kind == "points":
            delegate.set_points("/proto", moved, np.float32([0.5]), primvars=bad_primvars)
        else:
            delegate.set_curves("/proto", "linear", "bezier", "nonperiodic", np.int32([2]), moved,
                                np.float32([0.5]), "constant", primvars=bad_primvars)
    assert _depth_at(delegate, [LEFT_SEEN, RIGHT_SEEN]) == before  # not moved towards the camera


def test_invisible_curves_do_not_grow_the_frame():
    """The default width is added to the bounds of visible curves only: an invisible curve far
    away leaves the visible one framed as if it were alone."""
    stage = new_stage()
    for path, x in (("/World/hair", 0.0), ("/World/hidden", 60.0)):
        hair = UsdGeom.BasisCurves.Define(stage, path)
        hair.CreatePointsAttr([Gf.Vec3f(x, -1, 0), Gf.Vec3f(x, 1, 0)])
        hair.CreateCurveVertexCountsAttr([2])
        hair.CreateTypeAttr(UsdGeom.Tokens.linear)
    UsdGeom.Imageable(stage.GetPrimAtPath("/World/hidden")).MakeInvisible()
    image = penumbra.render(stage, width=32, samples=4, dome_light_visibility=False)
    assert (image["color"][:, :, 3] > 0.5).sum() > 20  # framed whole, not a speck far off
