"""UsdGeomTetMesh → its boundary as a triangle mesh.

Each tetrahedron (i0, i1, i2, i3) of ``tetVertexIndices`` has the four faces the schema orders
counter-clockwise for a right-handed mesh, (i1, i2, i3), (i0, i3, i2), (i0, i1, i3),
(i0, i2, i1): outward when i3 lies on the side of (i0, i1, i2) its right-hand normal points to.
The boundary is the faces that occur once (whatever their winding) among all tetrahedra's, as
``UsdGeomTetMesh::ComputeSurfaceFaces`` finds them; interior faces occur twice. They keep their
tetrahedron's winding, and the mesh the prim's ``orientation``. ``surfaceFaceVertexIndices``
(an authored cache of the same faces) is not read: the tetrahedra are the truth.

The triangles index the prim's own points, so vertex (and varying) primvars and point motion
apply unchanged; uniform primvars (one value per tetrahedron) reach each face from its
tetrahedron (``face_tets``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from pxr import Usd, UsdGeom

from .sampling import SampleReader

# The faces of tetrahedron (0, 1, 2, 3), counter-clockwise seen from outside (right-handed).
_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


class Surface(NamedTuple):
    points: np.ndarray  # float32 [N, 3]: the prim's points
    indices: np.ndarray  # int32 [3F]: the boundary triangles
    face_tets: np.ndarray  # int64 [F]: the tetrahedron of each triangle
    tet_count: int
    left_handed: bool


def boundary_faces(tets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The faces of tetrahedra ``tets`` (int [T, 4]) that belong to one of them only, int32
    [F, 3] in their tetrahedron's winding and order, with the index of that tetrahedron."""
    faces = tets[:, _FACES].reshape(-1, 3)
    keys = np.sort(faces, axis=1)
    _, first, counts = np.unique(keys, axis=0, return_index=True, return_counts=True)
    once = np.sort(first[counts == 1])
    return faces[once].astype(np.int32), once // 4


def read_surface(
    prim: Usd.Prim, reader: SampleReader, warn: Callable[[str], None], path: str
) -> Surface | None:
    """The boundary of TetMesh ``prim`` at the reader's time; ``None`` after one warning naming
    the prim and the attribute when its points or tetrahedra are unusable."""
    tet_mesh = UsdGeom.TetMesh(prim)
    points = reader.get(tet_mesh.GetPointsAttr())
    array = np.asarray(points if points is not None else [], dtype=np.float32)
    if array.ndim != 2 or array.shape[1] != 3 or len(array) == 0:
        warn(f"{path}: points has no 3-vectors; skipped")
        return None
    if not np.isfinite(array).all():
        warn(f"{path}: points has non-finite values; skipped")
        return None
    value = reader.get(tet_mesh.GetTetVertexIndicesAttr())
    tets = np.asarray(value if value is not None else [], dtype=np.int64)
    if tets.ndim != 2 or tets.shape[1] != 4 or len(tets) == 0:
        warn(f"{path}: tetVertexIndices has no tetrahedra; skipped")
        return None
    outside = (tets < 0) | (tets >= len(array))
    if outside.any():
        flat = int(np.flatnonzero(outside.any(axis=1))[0])
        warn(
            f"{path}: tetVertexIndices[{flat}] = {tuple(int(i) for i in tets[flat])} is out of "
            f"range for {len(array)} points; skipped"
        )
        return None
    faces, face_tets = boundary_faces(tets)
    left_handed = reader.get(tet_mesh.GetOrientationAttr()) == UsdGeom.Tokens.leftHanded
    return Surface(array, faces.reshape(-1), face_tets, len(tets), left_handed)
