"""UsdGeomTetMesh rendered as its boundary triangles: the faces found once among the
tetrahedra's, wound outward by the schema's orientation rule, through the scene delegate as a
mesh, and bad data warned of (naming prim and attribute) and skipped."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, Vt

import penumbra
from penumbra.usd import tet_mesh
from penumbra.usd.mesh import sync_mesh_data
from penumbra.usd.sampling import SampleReader
from stages import add_camera, add_distant_light, new_stage

RENDER = dict(camera="/cam", width=48, samples=4, aovs=("color", "depth"))

CORNERS = np.array([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)], dtype=np.float64)
ONE = np.array([[0, 1, 2, 3]])  # positively oriented: 3 is on the normal side of (0, 1, 2)
TWO = np.array([[0, 1, 2, 3], [1, 4, 2, 3]])  # sharing face (1, 2, 3)

# The unit cube as six tetrahedra about its diagonal 0–6 (Kuhn), all positively oriented.
CUBE = np.array([(x, y, z) for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=np.float64)
CUBE_TETS = np.array(
    [[0, 1, 3, 7], [0, 3, 2, 7], [0, 2, 6, 7], [0, 6, 4, 7], [0, 4, 5, 7], [0, 5, 1, 7]]
)


def signed_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    a, b, c, d = (points[tets[:, k]] for k in range(4))
    return np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) / 6


def outward(points: np.ndarray, faces: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """Whether each triangle's right-hand normal points away from ``inside`` (one point per
    face)."""
    a, b, c = (points[faces[:, k]] for k in range(3))
    return np.einsum("ij,ij->i", np.cross(b - a, c - a), (a + b + c) / 3 - inside) > 0


def rotated(face) -> tuple[int, ...]:
    """A triangle's indices started at the smallest (the same winding)."""
    k = int(np.argmin(face))
    return tuple(int(i) for i in np.roll(face, -k))


def test_the_analytic_tetrahedra_are_positively_oriented():
    assert (signed_volumes(CORNERS, np.vstack([ONE, TWO])) > 0).all()
    assert signed_volumes(CUBE, CUBE_TETS) == pytest.approx([1 / 6] * 6)


def test_a_tetrahedron_has_four_outward_faces():
    faces, tets = tet_mesh.boundary_faces(ONE)
    assert faces.shape == (4, 3) and list(tets) == [0] * 4
    assert {tuple(sorted(f)) for f in faces} == {(1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2)}
    assert outward(CORNERS, faces, CORNERS[:4].mean(axis=0)).all()


def test_two_tetrahedra_have_six_outward_faces_as_usd_computes_them():
    faces, tets = tet_mesh.boundary_faces(TWO)
    assert len(faces) == 6
    assert (1, 2, 3) not in {tuple(sorted(f)) for f in faces}  # the shared face is inside
    centres = np.array([CORNERS[TWO[t]].mean(axis=0) for t in tets])
    assert outward(CORNERS, faces, centres).all()
    stage = new_stage()
    prim = UsdGeom.TetMesh.Define(stage, "/t")
    prim.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(CORNERS.astype(np.float32)))
    prim.CreateTetVertexIndicesAttr(Vt.Vec4iArray.FromNumpy(TWO.astype(np.int32)))
    usd = UsdGeom.TetMesh.ComputeSurfaceFaces(prim, Usd.TimeCode.Default())
    assert {rotated(f) for f in faces} == {rotated(np.array(f)) for f in usd}


def test_a_cube_of_six_tetrahedra_is_bounded_by_twelve_triangles_enclosing_it():
    faces, _ = tet_mesh.boundary_faces(CUBE_TETS)
    assert len(faces) == 12
    a, b, c = (CUBE[faces[:, k]] for k in range(3))
    assert np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6 == pytest.approx(1.0)
    edges = [(int(f[k]), int(f[(k + 1) % 3])) for f in faces for k in range(3)]
    assert set(edges) == {(b, a) for a, b in edges}  # closed and consistently wound


def define_tet_mesh(stage: Usd.Stage, path: str, points, tets) -> UsdGeom.TetMesh:
    prim = UsdGeom.TetMesh.Define(stage, path)
    prim.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(points, dtype=np.float32)))
    prim.CreateTetVertexIndicesAttr(Vt.Vec4iArray.FromNumpy(np.asarray(tets, dtype=np.int32)))
    return prim


class RecordingCore:
    def __init__(self):
        self.calls = {}

    def __getattr__(self, name):
        return lambda *args, **kwargs: self.calls.setdefault(name, []).append((args, kwargs))


def test_uniform_colours_pass_from_each_tetrahedron_to_its_faces():
    stage = new_stage()
    prim = define_tet_mesh(stage, "/t", CORNERS, TWO)
    colors = [Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 0, 1)]
    prim.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform).Set(colors)
    core = RecordingCore()
    assert sync_mesh_data(core, prim.GetPrim(), SampleReader(Usd.TimeCode(1)), pytest.fail)
    ((_, mesh),) = core.calls["set_mesh"]
    _, tets = tet_mesh.boundary_faces(TWO)
    assert mesh["display_color_interpolation"] == "uniform"
    assert np.array_equal(mesh["display_color"], np.array(colors, dtype=np.float32)[tets])
    assert list(mesh["face_vertex_counts"]) == [3] * 6
    assert mesh["subdivision_scheme"] == "none" and mesh["points"].shape == (5, 3)


def cube_stage(edit=None) -> Usd.Stage:
    """The six-tetrahedron unit cube centred on the origin, seen by the test camera (distance
    5 along +Z)."""
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    prim = define_tet_mesh(stage, "/World/jelly", CUBE - 0.5, CUBE_TETS)
    if edit is not None:
        edit(prim)
    return stage


def test_a_tet_mesh_cube_renders_as_a_solid_square():
    with penumbra.Renderer(cube_stage()) as renderer:
        image = renderer.render(**RENDER)
        assert "/World/jelly" in set(renderer.delegate.prim_ids())
    alpha = image["color"][..., 3]
    # A unit square at distance 4.5 in a view 4 units wide at distance 5: (5 / 4.5 / 4)² of it.
    assert alpha.mean() == pytest.approx((5 / 4.5 / 4) ** 2, rel=0.1)
    assert image["depth"][23:25, 23:25, 0].min() == pytest.approx(4.5, abs=1e-3)


BAD = [
    ("tetVertexIndices", lambda p: p.GetTetVertexIndicesAttr().Set(
        Vt.Vec4iArray([Gf.Vec4i(0, 1, 3, 8)]))),
    ("tetVertexIndices", lambda p: p.GetTetVertexIndicesAttr().Set(Vt.Vec4iArray())),
    ("points", lambda p: p.GetPointsAttr().Set(
        Vt.Vec3fArray([Gf.Vec3f(math.inf, 0, 0)] + list(p.GetPointsAttr().Get())[1:]))),
]


@pytest.mark.parametrize("attribute, edit", BAD, ids=[f"{a}-{n}" for n, (a, _) in enumerate(BAD)])
def test_bad_data_warns_naming_prim_and_attribute_and_skips(attribute, edit):
    with pytest.warns(penumbra.PenumbraWarning) as record:
        with penumbra.Renderer(cube_stage(edit)) as renderer:
            image = renderer.render(**RENDER)
            assert "/World/jelly" not in set(renderer.delegate.prim_ids())
    messages = [str(w.message) for w in record if "/World/jelly" in str(w.message)]
    assert len(messages) == 1 and f"/World/jelly: {attribute}" in messages[0], messages
    assert image["color"][..., 3].max() == 0.0
