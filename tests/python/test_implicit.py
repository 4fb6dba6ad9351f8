"""Implicit surfaces (UsdGeomSphere, Cube, Cylinder(_1), Cone, Capsule(_1), Plane) tessellated
into meshes: the geometry of the generators, and their path through the scene delegate."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom

import penumbra
from penumbra.usd import implicit
from penumbra.usd.mesh import sync_mesh_data
from penumbra.usd.sampling import SampleReader, Shutter
from stages import (
    add_camera,
    add_distant_light,
    add_instance,
    add_preview_material,
    bind,
    new_stage,
    pixel,
)

AXES = ("X", "Y", "Z")
FROM_Z = {"X": [2, 0, 1], "Y": [1, 2, 0], "Z": [0, 1, 2]}  # axis coords = z-spine coords[perm]


def to_z_spine(points: np.ndarray, axis: str) -> np.ndarray:
    """Inverse of the generators' axis mapping: coordinates with the spine on Z."""
    out = np.empty_like(points)
    out[:, FROM_Z[axis]] = points
    return out


def radial_z(points: np.ndarray, axis: str) -> tuple[np.ndarray, np.ndarray]:
    p = to_z_spine(points.astype(np.float64), axis)
    return np.hypot(p[:, 0], p[:, 1]), p[:, 2]


def faces(mesh: implicit.GeneratedMesh) -> list[np.ndarray]:
    return np.split(mesh.indices, np.cumsum(mesh.counts)[:-1])


def directed_edges(mesh: implicit.GeneratedMesh) -> list[tuple[int, int]]:
    edges = []
    for face in faces(mesh):
        face = [int(i) for i in face]
        edges += list(zip(face, face[1:] + face[:1]))
    return edges


def signed_volume(mesh: implicit.GeneratedMesh) -> float:
    """Σ over fan triangles of p0·(p1×p2)/6: positive when faces wind counter-clockwise seen
    from outside (right-handed, outward normals)."""
    p = mesh.points.astype(np.float64)
    total = 0.0
    for face in faces(mesh):
        a = p[face[0]]
        for b, c in zip(p[face[1:-1]], p[face[2:]]):
            total += np.dot(a, np.cross(b, c)) / 6.0
    return total


def capsule_volume(rb: float, rt: float, h: float) -> float:
    """Two spherical caps joined by the frustum tangent to both spheres."""
    s = (rb - rt) / h
    c = math.sqrt(1.0 - s * s)
    cap_b, cap_t = rb * (1 + s), rt * (1 - s)  # cap heights
    length = h + (rt - rb) * s  # frustum length along the spine
    r1, r2 = rb * c, rt * c
    frustum = math.pi * length * (r1 * r1 + r1 * r2 + r2 * r2) / 3
    return (
        math.pi * cap_b**2 * (3 * rb - cap_b) / 3
        + frustum
        + math.pi * cap_t**2 * (3 * rt - cap_t) / 3
    )


# (name, generator, analytic volume or None for open surfaces)
SHAPES = [
    ("sphere", lambda axis: implicit.sphere(1.5), 4 / 3 * math.pi * 1.5**3),
    ("cube", lambda axis: implicit.cube(3.0), 27.0),
    ("cylinder", lambda axis: implicit.cylinder(0.7, 0.7, 2.5, axis), math.pi * 0.49 * 2.5),
    (
        "cylinder_1",
        lambda axis: implicit.cylinder(1.0, 0.4, 2.0, axis),
        math.pi * 2.0 * (1.0 + 0.4 + 0.16) / 3,
    ),
    ("cone", lambda axis: implicit.cone(0.8, 3.0, axis), math.pi * 0.64 * 3.0 / 3),
    ("capsule", lambda axis: implicit.capsule(0.5, 0.5, 2.0, axis), capsule_volume(0.5, 0.5, 2)),
    ("capsule_1", lambda axis: implicit.capsule(1.0, 0.3, 2.5, axis), capsule_volume(1, 0.3, 2.5)),
]


@pytest.mark.parametrize("name, generate, volume", SHAPES, ids=[s[0] for s in SHAPES])
def test_solids_are_closed_outward_and_hold_their_volume(name, generate, volume):
    for axis in AXES:
        mesh = generate(axis)
        assert mesh.counts.dtype == np.int32 and mesh.points.dtype == np.float32
        assert mesh.counts.sum() == len(mesh.indices) and mesh.indices.max() < len(mesh.points)
        edges = directed_edges(mesh)
        # Closed by its indices (the renderer's test for a solid) and consistently wound:
        # each edge once in each direction, no point repeated.
        assert len(np.unique(mesh.points, axis=0)) == len(mesh.points)
        assert len(set(edges)) == len(edges)
        assert set(edges) == {(b, a) for a, b in edges}
        assert signed_volume(mesh) == pytest.approx(volume, rel=0.02)
        assert signed_volume(mesh) <= volume * (1 + 1e-6)  # inscribed polygons


def test_sphere_points_lie_on_the_sphere():
    mesh = implicit.sphere(2.5)
    assert np.abs(np.linalg.norm(mesh.points.astype(np.float64), axis=1) - 2.5).max() < 1e-6
    assert len(mesh.counts) == implicit.SPHERE_SEGMENTS * implicit.SPHERE_RINGS


@pytest.mark.parametrize("axis", AXES)
def test_round_solids_lie_on_their_analytic_surfaces(axis):
    rho, z = radial_z(implicit.cylinder(1.0, 0.4, 2.0, axis).points, axis)
    assert np.abs(np.abs(z) - 1.0).max() < 1e-6  # rims and cap centres only
    rim = rho > 1e-9
    assert np.abs(rho[rim] - np.where(z[rim] < 0, 1.0, 0.4)).max() < 1e-6

    rho, z = radial_z(implicit.cone(0.8, 3.0, axis).points, axis)
    base = np.isclose(z, -1.5, atol=1e-6)
    assert np.all(rho[base] <= 0.8 + 1e-6)
    assert np.abs(rho[~base] - 0.8 * (1.5 - z[~base]) / 3.0).max() < 1e-6  # the side, apex

    rb, rt, h = 1.0, 0.3, 2.5
    p = to_z_spine(implicit.capsule(rb, rt, h, axis).points.astype(np.float64), axis)
    tangent_sin = (rb - rt) / h
    d_bottom = np.linalg.norm(p - (0, 0, -h / 2), axis=1)
    d_top = np.linalg.norm(p - (0, 0, h / 2), axis=1)
    on_bottom = np.isclose(d_bottom, rb, atol=1e-6)
    on_top = np.isclose(d_top, rt, atol=1e-6)
    assert np.all(on_bottom | on_top)
    # Each cap ends at the latitude where the side is tangent to both spheres.
    assert np.all(p[on_bottom & ~on_top, 2] <= -h / 2 + rb * tangent_sin + 1e-6)
    assert np.all(p[on_top & ~on_bottom, 2] >= h / 2 + rt * tangent_sin - 1e-6)


def test_cube_points_are_its_corners():
    points = implicit.cube(3.0).points
    assert sorted(map(tuple, points.tolist())) == sorted(
        (x, y, z) for x in (-1.5, 1.5) for y in (-1.5, 1.5) for z in (-1.5, 1.5)
    )


@pytest.mark.parametrize("name, generate, volume", SHAPES[2:], ids=[s[0] for s in SHAPES[2:]])
def test_axis_rotates_the_spine(name, generate, volume):
    along_z = generate("Z").points
    extent_z = along_z.max(axis=0) - along_z.min(axis=0)
    for axis in ("X", "Y"):
        points = generate(axis).points
        np.testing.assert_array_equal(points, along_z[:, FROM_Z[axis]])
        extent = points.max(axis=0) - points.min(axis=0)
        spine = "XYZ".index(axis)
        assert extent[spine] == pytest.approx(extent_z[2])
        assert np.delete(extent, spine) == pytest.approx(extent_z[:2], abs=1e-6)


@pytest.mark.parametrize(
    "type_name, attrs",
    [
        ("Cylinder", dict(radius=0.7, height=2.5)),
        ("Cone", dict(radius=0.8, height=3.0)),
        ("Capsule", dict(radius=0.5, height=2.0)),
        ("Cylinder_1", dict(radiusBottom=1.0, radiusTop=0.4, height=2.0)),
        ("Plane", dict(width=2.0, length=6.0)),
        ("Sphere", dict(radius=1.5)),
        ("Cube", dict(size=3.0)),
    ],
)
def test_bounds_match_usd_extents(type_name, attrs):
    """The tessellation reads the schema's attributes as UsdGeom's ComputeExtent does (axis,
    height, radii, Plane's width/length per axis)."""
    if not hasattr(UsdGeom, type_name):
        pytest.skip(f"usd-core has no UsdGeom.{type_name}")
    stage = Usd.Stage.CreateInMemory()
    prim = getattr(UsdGeom, type_name).Define(stage, "/shape").GetPrim()
    for name, value in attrs.items():
        prim.GetAttribute(name).Set(value)
    for axis in AXES if prim.HasAttribute("axis") else ("Z",):
        if prim.HasAttribute("axis"):
            prim.GetAttribute("axis").Set(axis)
        shape = {attr.GetName(): attr.Get() for attr in implicit.shape_attributes(prim)}
        mesh = implicit.tessellate(prim, shape)
        extent = UsdGeom.Boundable.ComputeExtentFromPlugins(
            UsdGeom.Boundable(prim), Usd.TimeCode.Default()
        )
        np.testing.assert_allclose(mesh.points.min(axis=0), extent[0], atol=1e-6)
        np.testing.assert_allclose(mesh.points.max(axis=0), extent[1], atol=1e-6)


@pytest.mark.parametrize("axis", AXES)
def test_plane_faces_its_axis(axis):
    mesh = implicit.plane(2.0, 6.0, axis)
    assert list(mesh.counts) == [4]
    a, b, c = mesh.points[mesh.indices[:3]].astype(np.float64)
    normal = np.cross(b - a, c - a)
    assert normal / np.linalg.norm(normal) == pytest.approx(np.eye(3)["XYZ".index(axis)])


@pytest.mark.parametrize("name, generate, volume", SHAPES, ids=[s[0] for s in SHAPES])
def test_normals_are_unit_and_agree_with_the_winding(name, generate, volume):
    mesh = generate("Y")
    if name == "cube":
        assert mesh.normals.shape == (0, 3)  # flat faces
        return
    assert mesh.normals.shape == (len(mesh.indices), 3)  # one per face-vertex
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-6)
    p = mesh.points.astype(np.float64)
    corner = 0
    for face in faces(mesh):
        a, b, c = p[face[0]], p[face[1]], p[face[2]]
        geometric = np.cross(b - a, c - a)
        geometric /= np.linalg.norm(geometric)
        # Smooth normals stay within a facet's angular size of its geometric normal.
        assert np.all(mesh.normals[corner : corner + len(face)] @ geometric > 0.9)
        corner += len(face)
    caps = {"cylinder": 2, "cylinder_1": 2, "cone": 1}.get(name, 0)
    if caps:  # flat caps (their triangles' corners all face ±axis): the rims are creases
        along_axis = np.isclose(np.abs(mesh.normals @ np.array([0.0, 1.0, 0.0])), 1.0)
        assert along_axis.sum() == caps * 3 * implicit.RADIAL_SEGMENTS


# ----------------------------------------------------------------------------------------------
# Through the scene delegate and the renderer

WIDTH = 64
RENDER = dict(camera="/cam", width=WIDTH, samples=4, aovs=("color", "depth"))
CAMERA_DISTANCE = 5.0
TAN_HALF_FOV = 2.0 / 5.0  # stages.add_camera: sees [-2, 2]² at distance 5


def sphere_stage(radius: float) -> tuple[Usd.Stage, UsdGeom.Sphere]:
    stage = new_stage()
    add_camera(stage, translate=(0.0, 0.0, CAMERA_DISTANCE))
    add_distant_light(stage)
    ball = UsdGeom.Sphere.Define(stage, "/World/ball")
    ball.CreateRadiusAttr(radius)
    return stage, ball


def coverage(image) -> float:
    """The fraction of the image the geometry covers (alpha), counting the central 3/4 × 3/4
    window only (what lies outside it is not counted)."""
    alpha = image["color"][..., 3]
    h, w = alpha.shape
    return float(alpha[h // 8 : h - h // 8, w // 8 : w - w // 8].sum()) / (h * w)


def expected_disk_fraction(radius: float) -> float:
    """The projected area of a sphere at the camera distance, over the image area."""
    half_angle = math.asin(radius / CAMERA_DISTANCE)
    rho = math.tan(half_angle) / TAN_HALF_FOV  # in units of the image's half-width
    return math.pi * rho * rho / 4.0


def centre_depth(image) -> float:
    depth = image["depth"][..., 0]
    h, w = depth.shape
    return float(depth[h // 2 - 1 : h // 2 + 1, w // 2 - 1 : w // 2 + 1].min())


def test_sphere_renders_as_a_disk_and_radius_edits_resync_only_it():
    stage, ball = sphere_stage(1.0)
    ball.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(0.8, 0.1, 0.1)])
    other = UsdGeom.Cube.Define(stage, "/World/box")
    other.CreateSizeAttr(0.3)
    other.AddTranslateOp().Set(Gf.Vec3d(1.7, 1.7, 0.0))
    with penumbra.Renderer(stage) as renderer:
        assert renderer.delegate.has_prim("/World/ball")
        image = renderer.render(**RENDER)
        assert pixel(image, 0.94, 0.06).max() > 0.0  # the small cube, outside coverage()
        assert coverage(image) == pytest.approx(expected_disk_fraction(1.0), rel=0.02)
        assert centre_depth(image) == pytest.approx(CAMERA_DISTANCE - 1.0, rel=0.01)
        red = pixel(image, 0.5, 0.4)
        assert red[0] > 0.05 and red[0] > 4 * red[1]  # displayColor, lit from the front

        counts = {p: renderer.delegate.sync_count(p) for p in renderer.delegate.prim_ids()}
        ball.GetRadiusAttr().Set(0.5)
        image = renderer.render(**RENDER)
        after = {p: renderer.delegate.sync_count(p) for p in renderer.delegate.prim_ids()}
        assert after.pop("/World/ball") == counts.pop("/World/ball") + 1
        assert after == counts
        assert coverage(image) == pytest.approx(expected_disk_fraction(0.5), rel=0.03)
        assert centre_depth(image) == pytest.approx(CAMERA_DISTANCE - 0.5, rel=0.01)


def test_material_binding_and_visibility_work_as_for_meshes():
    stage, ball = sphere_stage(1.0)
    bind(ball, add_preview_material(stage, "/Looks/green", diffuseColor=(0.1, 0.8, 0.1)))
    box = UsdGeom.Cube.Define(stage, "/World/box")
    box.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 2.0))  # in front of the ball, hiding it
    box.CreateVisibilityAttr(UsdGeom.Tokens.invisible)
    with penumbra.Renderer(stage) as renderer:
        image = renderer.render(**RENDER)
        assert coverage(image) == pytest.approx(expected_disk_fraction(1.0), rel=0.02)
        green = pixel(image, 0.5, 0.4)
        assert green[1] > 0.05 and green[1] > 4 * green[0]
        box.GetVisibilityAttr().Set(UsdGeom.Tokens.inherited)
        image = renderer.render(**RENDER)
        assert centre_depth(image) == pytest.approx(CAMERA_DISTANCE - 3.0, rel=0.01)


def test_animated_radius_is_read_at_each_frame():
    stage, ball = sphere_stage(1.0)
    stage.SetEndTimeCode(2)
    ball.GetRadiusAttr().Set(1.0, 1.0)
    ball.GetRadiusAttr().Set(0.5, 2.0)
    with penumbra.Renderer(stage) as renderer:
        assert centre_depth(renderer.render(time=1.0, **RENDER)) == pytest.approx(4.0, rel=0.01)
        assert centre_depth(renderer.render(time=2.0, **RENDER)) == pytest.approx(4.5, rel=0.01)


class RecordingCore:
    """Records the setters the mesh path calls."""

    def __init__(self):
        self.calls = {}

    def __getattr__(self, name):
        return lambda *args, **kwargs: self.calls.setdefault(name, []).append((args, kwargs))


def test_a_radius_keyed_within_the_shutter_gives_deformation_samples():
    stage, ball = sphere_stage(1.0)
    ball.GetRadiusAttr().Set(1.0, 1.0)
    ball.GetRadiusAttr().Set(2.0, 2.0)
    core = RecordingCore()
    reader = SampleReader(Usd.TimeCode(1.0), Shutter(Usd.TimeCode(1.0), -0.5, 0.5))
    assert sync_mesh_data(core, ball.GetPrim(), reader, lambda message: None)
    assert reader.varying
    (_, mesh), = core.calls["set_mesh"]  # one call per mesh
    points = mesh["points"]
    assert points.ndim == 3 and points.shape[0] >= 2
    radii = np.linalg.norm(points[:, 0], axis=-1)  # the bottom pole over the shutter
    assert radii[0] == pytest.approx(1.0) and radii[-1] == pytest.approx(1.5)
    assert (mesh["left_handed"], mesh["subdivision_scheme"]) == (False, "none")
    normals, indices = mesh["normals"], mesh["face_vertex_indices"]
    assert mesh["normals_interpolation"] == "faceVarying" and normals.shape == (len(indices), 3)


def test_purpose_instance_proxies_and_point_instancer_prototypes():
    stage = new_stage()
    add_camera(stage, translate=(0.0, 0.0, CAMERA_DISTANCE))
    add_distant_light(stage)
    UsdGeom.Sphere.Define(stage, "/Proto/ball").CreateRadiusAttr(0.4)
    for name, x in (("left", -1.0), ("right", 1.0)):
        add_instance(stage, f"/World/{name}", "/Proto", (x, 1.0, 0.0))
    stage.GetPrimAtPath("/Proto").SetSpecifier(Sdf.SpecifierClass)
    guide = UsdGeom.Cylinder.Define(stage, "/World/guide")
    guide.CreatePurposeAttr(UsdGeom.Tokens.guide)
    instancer = UsdGeom.PointInstancer.Define(stage, "/World/scatter")
    UsdGeom.Cube.Define(stage, "/World/scatter/protos/box").CreateSizeAttr(0.5)
    instancer.CreatePrototypesRel().SetTargets(["/World/scatter/protos/box"])
    instancer.CreateProtoIndicesAttr([0, 0])
    instancer.CreatePositionsAttr([Gf.Vec3f(-1.0, -1.0, 0.0), Gf.Vec3f(1.0, -1.0, 0.0)])
    with penumbra.Renderer(stage) as renderer:
        image = renderer.render(**RENDER)
        ids = set(renderer.delegate.prim_ids())
        assert "/prototypes/World/left/ball" in ids  # one mesh for both instances
        assert "/World/guide" not in ids
    for u, v in ((0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)):  # ±1 at z = 0
        assert image["color"][int(v * WIDTH), int(u * WIDTH), 3] == 1.0, (u, v)
    assert image["color"][WIDTH // 2, WIDTH // 2, 3] == 0.0
