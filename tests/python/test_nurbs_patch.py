"""UsdGeomNurbsPatch tessellated into a quad mesh: exact for bilinear patches, on the analytic
surface for rational ones (cylinder, sphere), through the scene delegate as a mesh, and bad
data warned of (naming prim and attribute) and skipped."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

import penumbra
from penumbra.usd import nurbs_patch
from penumbra.usd.mesh import sync_mesh_data
from penumbra.usd.sampling import SampleReader, Shutter
from stages import add_camera, add_distant_light, new_stage

W = math.sqrt(0.5)  # the weight of a rational quadratic quarter circle's middle point
RENDER = dict(camera="/cam", width=48, samples=4)


class RecordingCore:
    """Records the setters the mesh path calls."""

    def __init__(self):
        self.calls = {}

    def __getattr__(self, name):
        return lambda *args, **kwargs: self.calls.setdefault(name, []).append((args, kwargs))


def define_patch(
    stage: Usd.Stage,
    path: str,
    points,
    u: tuple[int, int, list[float]],
    v: tuple[int, int, list[float]],
    weights=None,
) -> UsdGeom.NurbsPatch:
    """A patch with ``points`` (u fastest); ``u``, ``v``: (vertex count, order, knots)."""
    patch = UsdGeom.NurbsPatch.Define(stage, path)
    patch.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
    patch.CreateUVertexCountAttr(u[0])
    patch.CreateUOrderAttr(u[1])
    patch.CreateUKnotsAttr(Vt.DoubleArray(u[2]))
    patch.CreateVVertexCountAttr(v[0])
    patch.CreateVOrderAttr(v[1])
    patch.CreateVKnotsAttr(Vt.DoubleArray(v[2]))
    if weights is not None:
        patch.CreatePointWeightsAttr(Vt.DoubleArray(list(weights)))
    return patch


def pushed_mesh(prim: Usd.Prim, reader: SampleReader | None = None) -> dict:
    """What the mesh path sends the delegate for ``prim``."""
    core = RecordingCore()
    messages = []
    reader = reader or SampleReader(Usd.TimeCode(1.0))
    assert sync_mesh_data(core, prim, reader, messages.append), messages
    ((_, mesh),) = core.calls["set_mesh"]
    return mesh


QUAD = [(-1.2, -0.9, 0.1), (1.1, -1.0, -0.2), (-0.8, 1.0, 0.0), (1.0, 1.3, 0.3)]  # u fastest
LINEAR = (2, 2, [0.0, 0.0, 1.0, 1.0])


def test_a_bilinear_patch_renders_exactly_as_its_quad():
    images = []
    for kind in ("patch", "mesh"):
        stage = new_stage()
        add_camera(stage)
        add_distant_light(stage)
        if kind == "patch":
            define_patch(stage, "/World/surface", QUAD, LINEAR, LINEAR)
        else:
            mesh = UsdGeom.Mesh.Define(stage, "/World/surface")
            mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in QUAD]))
            mesh.CreateFaceVertexCountsAttr([4])
            mesh.CreateFaceVertexIndicesAttr([0, 1, 3, 2])
            mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        with penumbra.Renderer(stage) as renderer:
            images.append(renderer.render(**RENDER)["color"])
    assert images[0][..., 3].mean() > 0.2  # the quad is seen
    assert np.array_equal(images[0], images[1])


def test_a_degree_one_patch_is_its_control_polygons():
    stage = new_stage()
    grid = [(x + 0.1 * y * y, y, 0.3 * x * y) for y in range(3) for x in range(4)]
    knots_u, knots_v = [0, 0, 1, 2, 3, 3], [0, 0, 0.5, 1, 1]
    patch = define_patch(stage, "/p", grid, (4, 2, knots_u), (3, 2, knots_v))
    mesh = pushed_mesh(patch.GetPrim())
    assert np.array_equal(mesh["points"], np.array(grid, dtype=np.float32))
    assert list(mesh["face_vertex_counts"]) == [4] * 6
    assert list(mesh["face_vertex_indices"][:4]) == [0, 1, 5, 4]
    assert mesh["normals"].shape == (0, 3)  # shaded flat, as the polygons


def quarter_cylinder(stage: Usd.Stage, path: str = "/cylinder") -> UsdGeom.NurbsPatch:
    """A unit-radius quarter cylinder about Z, from (1, 0) to (0, 1), z from 0 to 2: a rational
    quadratic arc in u, linear in v."""
    arc = [(1, 0), (1, 1), (0, 1)]
    points = [(x, y, z) for z in (0.0, 2.0) for x, y in arc]
    weights = [1, W, 1] * 2
    return define_patch(
        stage, path, points, (3, 3, [0, 0, 0, 1, 1, 1]), LINEAR, weights=weights
    )


def test_a_rational_quarter_cylinder_lies_on_its_circle_with_radial_normals():
    stage = new_stage()
    mesh = pushed_mesh(quarter_cylinder(stage).GetPrim())
    points = mesh["points"].astype(np.float64)
    radius = np.hypot(points[:, 0], points[:, 1])
    assert np.abs(radius - 1).max() < 1e-6
    assert len(points) == 2 * 17  # 90° in steps of MAX_TURN_PER_SEGMENT, both ends
    assert set(np.round(points[:, 2], 6)) == {0.0, 2.0}
    # Chords of the circle: each edge's midpoint sags by 1 − cos(half its angle), and the
    # segments, uniform in the parameter, each turn about MAX_TURN_PER_SEGMENT (a rational
    # arc's angular speed varies by a few per cent along it).
    quads = mesh["face_vertex_indices"].reshape(-1, 4)
    a, b = points[quads[:, 0]], points[quads[:, 1]]
    angle = np.arctan2(b[:, 1], b[:, 0]) - np.arctan2(a[:, 1], a[:, 0])
    middles = (a + b) / 2
    sag = 1 - np.hypot(middles[:, 0], middles[:, 1])
    assert np.abs(sag - (1 - np.cos(angle / 2))).max() < 1e-6
    turn = nurbs_patch.MAX_TURN_PER_SEGMENT
    assert angle.sum() == pytest.approx(math.pi / 2) and angle.max() < 1.06 * turn
    # Normals: radial and outward (∂S/∂u × ∂S/∂v for the right-handed default).
    assert mesh["normals_interpolation"] == "vertex"
    radial = np.column_stack([points[:, 0], points[:, 1], np.zeros(len(points))]) / radius[:, None]
    assert np.abs(mesh["normals"] - radial).max() < 1e-5
    # The quads wind counter-clockwise seen from outside.
    a, b, d = points[quads[:, 0]], points[quads[:, 1]], points[quads[:, 3]]
    assert (np.einsum("ij,ij->i", np.cross(b - a, d - a), (a + b) / 2) > 0).all()


def test_left_handed_flips_the_normals_and_the_winding():
    stage = new_stage()
    patch = quarter_cylinder(stage)
    patch.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
    mesh = pushed_mesh(patch.GetPrim())
    points = mesh["points"]
    assert mesh["left_handed"]
    assert (np.einsum("ij,ij->i", mesh["normals"], points * [1, 1, 0]) < 0).all()


def unit_sphere(stage: Usd.Stage, path: str = "/World/ball") -> UsdGeom.NurbsPatch:
    """The classic rational quadratic unit sphere: a 9-point circle in u (closed) swept by a
    5-point half circle in v from the south pole to the north pole."""
    circle = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1), (1, 0)]
    circle_w = [1, W, 1, W, 1, W, 1, W, 1]
    profile = [(0, -1), (1, -1), (1, 0), (1, 1), (0, 1)]  # (radius, z)
    profile_w = [1, W, 1, W, 1]
    points = [(r * x, r * y, z) for r, z in profile for x, y in circle]
    weights = [wp * wc for wp in profile_w for wc in circle_w]
    patch = define_patch(
        stage,
        path,
        points,
        (9, 3, [0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 4]),
        (5, 3, [0, 0, 0, 1, 1, 2, 2, 2]),
        weights=weights,
    )
    patch.CreateUFormAttr(UsdGeom.Tokens.closed)
    return patch


def test_a_rational_sphere_patch_lies_on_the_sphere_and_encloses_its_volume():
    stage = new_stage()
    mesh = pushed_mesh(unit_sphere(stage).GetPrim())
    points = mesh["points"].astype(np.float64)
    assert np.abs(np.linalg.norm(points, axis=1) - 1).max() < 1e-6
    normals = mesh["normals"].astype(np.float64)
    assert np.abs(np.linalg.norm(normals, axis=1) - 1).max() < 1e-5
    poles = np.abs(points[:, 2]) > 1 - 1e-9
    assert poles.any()  # where ∂S/∂u vanishes: the neighbours' mean, ±Z
    assert np.abs(normals - points).max() < 1e-3
    # Signed volume of the quads (two triangles each): inscribed, so a little less than 4π/3.
    # A cell subtending angles a × b sags by (a² + b²)/12 of the radius on average, so the
    # volume lacks about 3(a² + b²)/12; segments turn at most 1.06 × MAX_TURN_PER_SEGMENT.
    quads = mesh["face_vertex_indices"].reshape(-1, 4)
    p0, p1, p2, p3 = (points[quads[:, k]] for k in range(4))
    volume = (
        np.einsum("ij,ij->i", p0, np.cross(p1, p2)).sum()
        + np.einsum("ij,ij->i", p0, np.cross(p2, p3)).sum()
    ) / 6
    exact = 4 / 3 * math.pi
    assert exact * (1 - (1.06 * nurbs_patch.MAX_TURN_PER_SEGMENT) ** 2 / 2) < volume < exact


def test_density_follows_the_control_net():
    flat = [(x, y, 0.0) for y in range(4) for x in range(5)]  # cubic, one row flat
    knots_u, knots_v = [0, 0, 0, 0, 1, 2, 2, 2, 2], [0, 0, 0, 0, 1, 1, 1, 1]
    stage = new_stage()
    patch = define_patch(stage, "/flat", flat, (5, 4, knots_u), (4, 4, knots_v))
    mesh = pushed_mesh(patch.GetPrim())
    # A flat net: the minimum, degree (3) segments per span (u: 2 spans, v: 1 span).
    assert len(mesh["face_vertex_counts"]) == (2 * 3) * 3
    params = nurbs_patch.parameters(
        nurbs_patch.Direction(3, 2, np.array([0.0, 0, 0, 1, 1, 1]), 0.25, 1.0),
        np.array([[[1, 0, 0], [1, 1, 0], [0, 1, 0]]], dtype=float),
    )
    assert params[0] == 0.25 and params[-1] == 1.0  # uRange honoured
    assert len(params) == 16 + 1  # the span's 90° turn in 16 segments of π/32, both ends


def test_a_noisy_net_is_thinned_to_the_vertex_budget_with_a_warning(monkeypatch):
    """Each span of a noisy cubic net turns far: unbounded, a 30 × 30 net alone asks for
    hundreds of thousands of vertices (a 100 × 100 one for 33 million)."""
    monkeypatch.setattr(nurbs_patch, "MAX_VERTICES", 2000)
    rng = np.random.default_rng(4)
    count = 30
    net = [(x + rng.normal(0, 0.4), y + rng.normal(0, 0.4), rng.normal(0, 1.0))
           for y in range(count) for x in range(count)]
    knots = [0.0] * 4 + list(range(1, count - 3)) + [float(count - 3)] * 4
    stage = new_stage()
    patch = define_patch(stage, "/noisy", net, (count, 4, knots), (count, 4, knots))
    messages = []
    generated = nurbs_patch.mesh(patch.GetPrim(), SampleReader(Usd.TimeCode(1.0)),
                                 messages.append, "/noisy")
    assert len(generated.tessellation.points) <= 2000
    assert len(messages) == 1 and messages[0].startswith("/noisy: its tessellation would have ")
    assert messages[0].endswith("(at most 2,000 a patch)")
    first, last = generated.tessellation.points[0], generated.tessellation.points[-1]
    np.testing.assert_allclose(first, net[0], atol=1e-5)  # the corners are kept
    np.testing.assert_allclose(last, net[-1], atol=1e-5)


def test_primvars_that_are_not_constant_are_warned_of_and_left_out():
    stage = new_stage()
    patch = define_patch(stage, "/patch", QUAD, LINEAR, LINEAR)
    api = UsdGeom.PrimvarsAPI(patch)
    api.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        [(0, 0), (1, 0), (0, 1), (1, 1)])
    api.CreatePrimvar("roughness", Sdf.ValueTypeNames.Float, UsdGeom.Tokens.constant).Set(0.3)
    core, messages = RecordingCore(), []
    assert sync_mesh_data(core, patch.GetPrim(), SampleReader(Usd.TimeCode(1.0)), messages.append)
    assert messages == ["/patch: primvars st are not constant; a NurbsPatch takes only constant "
                        "primvars, these are left out"]
    ((_, mesh),) = core.calls["set_mesh"]
    assert set(mesh["primvars"]) == {"roughness"}


def test_a_sphere_patch_renders_through_the_scene_delegate_as_a_disk():
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    unit_sphere(stage)
    with penumbra.Renderer(stage) as renderer:
        image = renderer.render(camera="/cam", width=64, samples=4, aovs=("color", "depth"))
        assert "/World/ball" in set(renderer.delegate.prim_ids())
    alpha = image["color"][..., 3]
    # The camera sees [-2, 2]² at distance 5: a unit sphere covers about π/16 of the image.
    assert alpha.mean() == pytest.approx(math.pi / 16 * (25 / 24), rel=0.05)
    depth = image["depth"][..., 0]
    assert depth[31:33, 31:33].min() == pytest.approx(4.0, abs=0.01)


def test_control_points_moving_within_the_shutter_give_motion_samples():
    stage = new_stage()
    patch = quarter_cylinder(stage)
    points = np.array(patch.GetPointsAttr().Get())
    patch.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(points), 0.5)
    patch.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(points * 2), 1.5)
    reader = SampleReader(Usd.TimeCode(1.0), Shutter(Usd.TimeCode(1.0), -0.5, 0.5))
    samples = pushed_mesh(patch.GetPrim(), reader)["points"]
    assert samples.ndim == 3 and samples.shape[0] >= 2
    radius = np.hypot(samples[..., 0], samples[..., 1])
    assert np.abs(radius[0] - 1).max() < 1e-6 and np.abs(radius[-1] - 2).max() < 1e-5


def test_trim_curves_are_warned_of_once_and_the_patch_still_renders():
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    patch = define_patch(stage, "/World/trimmed", QUAD, LINEAR, LINEAR)
    patch.CreateTrimCurveCountsAttr([1])
    patch.CreateTrimCurveOrdersAttr([2])
    patch.CreateTrimCurveVertexCountsAttr([2])
    patch.CreateTrimCurveKnotsAttr([0, 0, 1, 1])
    patch.CreateTrimCurveRangesAttr([Gf.Vec2d(0, 1)])
    patch.CreateTrimCurvePointsAttr([Gf.Vec3d(0, 0, 1), Gf.Vec3d(1, 1, 1)])
    with pytest.warns(penumbra.PenumbraWarning) as record:
        with penumbra.Renderer(stage) as renderer:
            image = renderer.render(**RENDER)
            renderer.render(**RENDER)
    trims = [str(w.message) for w in record if "trim" in str(w.message)]
    assert len(trims) == 1 and "/World/trimmed" in trims[0] and "trimCurve" in trims[0]
    assert image["color"][..., 3].mean() > 0.2


def sphere_with(edit) -> Usd.Stage:
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    edit(unit_sphere(stage))
    return stage


BAD = [
    ("uKnots", lambda p: p.GetUKnotsAttr().Set(Vt.DoubleArray([0, 0, 0, 1, 1, 1]))),
    ("vOrder", lambda p: p.GetVOrderAttr().Set(6)),
    ("uVertexCount", lambda p: p.GetUVertexCountAttr().Set(1)),
    ("vKnots", lambda p: p.GetVKnotsAttr().Set(Vt.DoubleArray([0, 0, 0, 2, 1, 2, 2, 2]))),
    ("points", lambda p: p.GetPointsAttr().Set(
        Vt.Vec3fArray([Gf.Vec3f(math.nan, 0, 0)] + list(p.GetPointsAttr().Get())[1:]))),
    ("points", lambda p: p.GetPointsAttr().Set(Vt.Vec3fArray(list(p.GetPointsAttr().Get())[1:]))),
    ("pointWeights", lambda p: p.GetPointWeightsAttr().Set(Vt.DoubleArray([-1.0] * 45))),
    ("pointWeights", lambda p: p.GetPointWeightsAttr().Set(Vt.DoubleArray([1.0] * 44))),
    ("uRange", lambda p: p.CreateURangeAttr(Gf.Vec2d(0, 5))),
]


@pytest.mark.parametrize("attribute, edit", BAD, ids=[f"{a}-{n}" for n, (a, _) in enumerate(BAD)])
def test_bad_data_warns_naming_prim_and_attribute_and_skips(attribute, edit):
    stage = sphere_with(edit)
    with pytest.warns(penumbra.PenumbraWarning) as record:
        with penumbra.Renderer(stage) as renderer:
            image = renderer.render(**RENDER)
            assert "/World/ball" not in set(renderer.delegate.prim_ids())
    messages = [str(w.message) for w in record if "/World/ball" in str(w.message)]
    assert len(messages) == 1 and f"/World/ball: {attribute}" in messages[0], messages
    assert image["color"][..., 3].max() == 0.0
