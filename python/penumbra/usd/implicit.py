"""Implicit surfaces (UsdGeomSphere, Cube, Cylinder, Cylinder_1, Cone, Capsule, Capsule_1,
Plane) tessellated into polygon meshes, as Hydra's mesh generators (``GeomUtil*MeshGenerator``,
used by ``HdsiImplicitSurfaceSceneIndex``) do.

Same construction as Hydra: a shape is built about the Z spine and mapped to its ``axis`` by the
cyclic basis Hydra uses (X: (x, y, z) → (z, x, y); Y: (x, y, z) → (y, z, x)), so orientation
is preserved; every mesh is right-handed with faces wound counter-clockwise seen from outside
(outward normals). Round surfaces carry smooth normals (Penumbra shades polygons flat
otherwise), indexed per face-vertex ("faceVarying") so that creases (cylinder and cone rims,
the cone's apex) are sharp while every point is shared: solids are closed by their indices,
which the renderer relies on to treat a refractive mesh as a solid. (Hydra instead duplicates
the rim rings, which leaves its cylinders and cones topologically open.) The cube and the
plane are flat-shaded (no normals).

Hydra's counts (sphere 10 × 10, cylinder/cone/capsule 10 around, capsule caps 4 rings) are
meant for interactive preview; Penumbra renders final frames, so the counts are higher:

* sphere: ``SPHERE_SEGMENTS`` = 64 around × ``SPHERE_RINGS`` = 32 from pole to pole
  (triangle fans at the poles, quads between);
* cylinder and cone: ``RADIAL_SEGMENTS`` = 64 around (flat caps as triangle fans);
* capsule: 64 around, ``CAPSULE_CAP_RINGS`` = 16 latitude steps per hemispherical cap;
* cube: 6 quads; plane: 1 quad.

Attribute semantics follow the UsdGeom schemas: ``radius``, ``height`` (the spine length; for
capsules without the caps), ``size`` (cube edge), ``radiusTop``/``radiusBottom`` (Cylinder_1,
Capsule_1; Capsule_1's caps are sphere sections tangent to the side, as Hydra computes them),
``width``/``length`` (Plane: width along X for axis Z and Y, along Z for axis X; length along Y
for axis Z and X, along Z for axis Y — as the schema documents and ``ComputeExtent`` does;
Hydra's own plane generator maps them by its cyclic basis instead). A plane faces +axis.
``extent`` is ignored. ``doubleSided`` is read as authored (fallback false, true for Plane).

Nothing here reads attribute values: the caller reads the attributes :func:`shape_attributes`
lists once per time code it needs, and :func:`shape_problem` and :func:`tessellate` take those
values by name; the generators are pure functions of them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np
from pxr import Usd, UsdGeom

from .values import is_number_value

SPHERE_SEGMENTS = 64
SPHERE_RINGS = 32
RADIAL_SEGMENTS = 64
CAPSULE_CAP_RINGS = 16


class GeneratedMesh(NamedTuple):
    """A tessellated implicit surface in the prim's object space."""

    counts: np.ndarray  # int32 [F]: vertices per face
    indices: np.ndarray  # int32 [I]: face-vertex indices
    points: np.ndarray  # float32 [N, 3]
    normals: np.ndarray  # float32 [I, 3] unit normals per face-vertex, or [0, 3]: flat shading


# ----------------------------------------------------------------------------------------------
# Which prims are implicit surfaces, and the attributes that shape them

_SCHEMAS: dict[str, tuple[type, tuple[str, ...]]] = {
    "Sphere": (UsdGeom.Sphere, ("radius",)),
    "Cube": (UsdGeom.Cube, ("size",)),
    "Cylinder": (UsdGeom.Cylinder, ("radius", "height", "axis")),
    "Cone": (UsdGeom.Cone, ("radius", "height", "axis")),
    "Capsule": (UsdGeom.Capsule, ("radius", "height", "axis")),
    "Plane": (UsdGeom.Plane, ("width", "length", "axis")),
}
for _name, _attrs in (
    ("Cylinder_1", ("radiusBottom", "radiusTop", "height", "axis")),
    ("Capsule_1", ("radiusBottom", "radiusTop", "height", "axis")),
):
    if hasattr(UsdGeom, _name):  # usd-core ≥ 24.x
        _SCHEMAS[_name] = (getattr(UsdGeom, _name), _attrs)


def _schema_of(prim: Usd.Prim) -> str | None:
    for name, (schema, _) in _SCHEMAS.items():
        if prim.IsA(schema):
            return name
    return None


def is_implicit(prim: Usd.Prim) -> bool:
    """Whether ``prim`` is an implicit surface Penumbra tessellates."""
    return _schema_of(prim) is not None


def shape_attributes(prim: Usd.Prim) -> list[Usd.Attribute]:
    """The attributes the tessellation of implicit ``prim`` depends on."""
    name = _schema_of(prim)
    return [prim.GetAttribute(a) for a in _SCHEMAS[name][1]] if name else []


ShapeValues = Mapping[str, Any]
"""The values of an implicit surface's :func:`shape_attributes` at one time, by attribute name."""


def shape_problem(values: ShapeValues) -> str | None:
    """Why an implicit surface shaped by ``values`` cannot be tessellated (naming the
    attribute), or ``None``: lengths must be finite numbers >= 0, the axis X, Y or Z."""
    for attr_name, value in values.items():
        if attr_name == "axis":
            if str(value) not in ("X", "Y", "Z"):
                return f"axis must be X, Y or Z, not {value!r}"
        elif not is_number_value(value):
            return f"{attr_name} has a value of type {type(value).__name__}, not a number"
        elif not (math.isfinite(value) and value >= 0):
            return f"{attr_name} must be a finite number >= 0, not {value:g}"
    return None


def tessellate(prim: Usd.Prim, values: ShapeValues) -> GeneratedMesh:
    """The mesh of implicit ``prim`` shaped by ``values`` (which :func:`shape_problem` finds
    no problem with)."""
    name = _schema_of(prim)
    if name is None:
        raise TypeError(f"{prim.GetPath()}: not an implicit surface")
    axis = str(values.get("axis") or "Z")
    if name == "Sphere":
        return sphere(values["radius"])
    if name == "Cube":
        return cube(values["size"])
    if name == "Cylinder":
        return cylinder(values["radius"], values["radius"], values["height"], axis)
    if name == "Cylinder_1":
        return cylinder(values["radiusBottom"], values["radiusTop"], values["height"], axis)
    if name == "Cone":
        return cone(values["radius"], values["height"], axis)
    if name == "Capsule":
        return capsule(values["radius"], values["radius"], values["height"], axis)
    if name == "Capsule_1":
        return capsule(values["radiusBottom"], values["radiusTop"], values["height"], axis)
    return plane(values["width"], values["length"], axis)


# ----------------------------------------------------------------------------------------------
# Generators (pure functions)


def _to_axis(vectors: np.ndarray, axis: str) -> np.ndarray:
    """Map Z-spine vectors to ``axis`` with Hydra's basis (a cyclic permutation: handedness
    kept)."""
    x, y, z = vectors[:, 0], vectors[:, 1], vectors[:, 2]
    if axis == "X":
        return np.stack([z, x, y], axis=1)
    if axis == "Y":
        return np.stack([y, z, x], axis=1)
    return vectors


def _mesh(counts, indices, points, normals=None, axis: str = "Z") -> GeneratedMesh:
    points = _to_axis(np.asarray(points, dtype=np.float64).reshape(-1, 3), axis)
    if normals is None:
        normals = np.empty((0, 3))
    else:
        normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        normals = _to_axis(normals / np.where(length > 0, length, 1.0), axis)
    return GeneratedMesh(
        np.ascontiguousarray(counts, dtype=np.int32),
        np.ascontiguousarray(indices, dtype=np.int32),
        np.ascontiguousarray(points, dtype=np.float32),
        np.ascontiguousarray(normals, dtype=np.float32),
    )


def _ring(segments: int) -> tuple[np.ndarray, np.ndarray]:
    """cos and sin of ``segments`` angles uniformly around the circle, from 0 (+X) towards +Y."""
    angles = np.arange(segments) * (2.0 * math.pi / segments)
    return np.cos(angles), np.sin(angles)


class _Builder:
    """Accumulates rings of points, rings of normals, and the faces joining them (Hydra's
    capped quad topology). Points are shared wherever the surface is continuous, creases
    included, so that solids are closed by their indices; normals are indexed per face-vertex
    separately (a crease is two normal rings on one point ring)."""

    def __init__(self, segments: int) -> None:
        self.segments = segments
        self.cos, self.sin = _ring(segments)
        half = (np.arange(segments) + 0.5) * (2.0 * math.pi / segments)
        self.mid_cos, self.mid_sin = np.cos(half), np.sin(half)
        self.points: list[np.ndarray] = []
        self.normals: list[np.ndarray] = []
        self.counts: list[np.ndarray] = []
        self.indices: list[np.ndarray] = []
        self.normal_indices: list[np.ndarray] = []
        self.point_count = 0
        self.normal_count = 0

    def _add_points(self, values: np.ndarray) -> int:
        self.points.append(values.reshape(-1, 3))
        self.point_count += len(self.points[-1])
        return self.point_count - len(self.points[-1])

    def _add_normals(self, values: np.ndarray) -> int:
        self.normals.append(values.reshape(-1, 3))
        self.normal_count += len(self.normals[-1])
        return self.normal_count - len(self.normals[-1])

    def point(self, z: float) -> int:
        """A point on the spine; returns its index."""
        return self._add_points(np.array([0.0, 0.0, z]))

    def pole(self, z: float) -> tuple[int, int]:
        """A point on the spine and its normal (±Z): (point index, normal index)."""
        return (
            self.point(z),
            self._add_normals(np.array([0.0, 0.0, math.copysign(1.0, z)])),
        )

    def ring(self, radius: float, z: float) -> int:
        """A ring of points at height ``z``; returns its first index."""
        n = self.segments
        return self._add_points(np.stack([radius * self.cos, radius * self.sin, np.full(n, z)], 1))

    def normal_ring(self, radial: float, axial: float, mid: bool = False) -> int:
        """A ring of normals (radial · direction, axial), at the ring's angles or (``mid``) at
        the middle of each segment; returns its first index."""
        c, s = (self.mid_cos, self.mid_sin) if mid else (self.cos, self.sin)
        return self._add_normals(np.stack([radial * c, radial * s, np.full(len(c), axial)], 1))

    def quads(self, lower: tuple[int, int], upper: tuple[int, int]) -> None:
        """Quads between two (point ring, normal ring) pairs, ``upper`` above ``lower`` along
        +Z, outward facing."""
        i = np.arange(self.segments)
        j = (i + 1) % self.segments
        self.counts.append(np.full(self.segments, 4))
        for out, low, up in (
            (self.indices, lower[0], upper[0]),
            (self.normal_indices, lower[1], upper[1]),
        ):
            out.append(np.stack([low + i, low + j, up + j, up + i], 1).ravel())

    def fan(self, ring: tuple[int, int], apex: tuple[int, int | np.ndarray], below: bool) -> None:
        """Triangles from a ring to an apex point (whose normal may be one per segment);
        ``below``: the apex lies below the ring along Z (a bottom cap): winding reversed."""
        i = np.arange(self.segments)
        j = (i + 1) % self.segments
        for out, start, tip in (
            (self.indices, ring[0], apex[0]),
            (self.normal_indices, ring[1], apex[1]),
        ):
            tip = np.broadcast_to(np.asarray(tip), i.shape)
            corners = [start + j, start + i, tip] if below else [start + i, start + j, tip]
            out.append(np.stack(corners, 1).ravel())
        self.counts.append(np.full(self.segments, 3))

    def build(self, axis: str) -> GeneratedMesh:
        normals = np.concatenate(self.normals)[np.concatenate(self.normal_indices)]
        return _mesh(
            np.concatenate(self.counts),
            np.concatenate(self.indices),
            np.concatenate(self.points),
            normals,
            axis,
        )


def sphere(radius: float, segments: int = SPHERE_SEGMENTS, rings: int = SPHERE_RINGS):
    """A sphere of ``radius`` about the origin: poles on ±Z, ``rings`` latitude steps."""
    b = _Builder(segments)
    bottom = b.pole(-radius)
    starts = []
    for k in range(1, rings):
        latitude = -0.5 * math.pi + math.pi * k / rings
        c, s = math.cos(latitude), math.sin(latitude)
        starts.append((b.ring(radius * c, radius * s), b.normal_ring(c, s)))
    top = b.pole(radius)
    b.fan(starts[0], bottom, below=True)
    for lower, upper in zip(starts, starts[1:]):
        b.quads(lower, upper)
    b.fan(starts[-1], top, below=False)
    return b.build("Z")


def cube(size: float) -> GeneratedMesh:
    """An axis-aligned cube of edge ``size`` centred on the origin (flat faces)."""
    h = 0.5 * size
    points = [
        (h, h, h), (-h, h, h), (-h, -h, h), (h, -h, h),
        (-h, -h, -h), (-h, h, -h), (h, h, -h), (h, -h, -h),
    ]  # fmt: skip
    indices = [0, 1, 2, 3, 4, 5, 6, 7, 0, 6, 5, 1, 4, 7, 3, 2, 0, 3, 7, 6, 4, 2, 1, 5]
    return _mesh([4] * 6, indices, points)


def cylinder(
    radius_bottom: float,
    radius_top: float,
    height: float,
    axis: str = "Z",
    segments: int = RADIAL_SEGMENTS,
) -> GeneratedMesh:
    """A (possibly tapered) capped cylinder along ``axis`` from −height/2 (``radius_bottom``)
    to +height/2 (``radius_top``); the rims are creases (flat caps, smooth side)."""
    b = _Builder(segments)
    z = 0.5 * height
    # Side normal of a frustum: (height, r_bottom − r_top) in the (radial, axial) plane.
    nr, nz = height, radius_bottom - radius_top
    length = math.hypot(nr, nz) or 1.0
    side = b.normal_ring(nr / length, nz / length)
    bottom = b.pole(-z)
    bottom_rim = b.ring(radius_bottom, -z)
    top_rim = b.ring(radius_top, z)
    top = b.pole(z)
    b.fan((bottom_rim, b.normal_ring(0.0, -1.0)), bottom, below=True)
    b.quads((bottom_rim, side), (top_rim, side))
    b.fan((top_rim, b.normal_ring(0.0, 1.0)), top, below=False)
    return b.build(axis)


def cone(radius: float, height: float, axis: str = "Z", segments: int = RADIAL_SEGMENTS):
    """A capped cone along ``axis``: base of ``radius`` at −height/2, apex at +height/2. The
    base rim is a crease; at the apex each triangle gets the side normal of its middle."""
    b = _Builder(segments)
    z = 0.5 * height
    length = math.hypot(height, radius) or 1.0
    nr, nz = height / length, radius / length
    bottom = b.pole(-z)
    rim = b.ring(radius, -z)
    apex = b.point(z)
    b.fan((rim, b.normal_ring(0.0, -1.0)), bottom, below=True)
    apex_normals = b.normal_ring(nr, nz, mid=True) + np.arange(segments)
    b.fan((rim, b.normal_ring(nr, nz)), (apex, apex_normals), below=False)
    return b.build(axis)


def capsule(
    radius_bottom: float,
    radius_top: float,
    height: float,
    axis: str = "Z",
    segments: int = RADIAL_SEGMENTS,
    cap_rings: int = CAPSULE_CAP_RINGS,
) -> GeneratedMesh:
    """A capsule along ``axis``: spheres of ``radius_bottom`` at −height/2 and ``radius_top`` at
    +height/2 joined by their tangent cylinder (cone) — ``height`` excludes the caps. As in
    Hydra, the caps meet the side at the latitude φ, sin φ = (r_bottom − r_top) / height."""
    b = _Builder(segments)
    z = 0.5 * height
    ratio = (radius_bottom - radius_top) / height if height > 0 else 0.0
    tangent = math.asin(max(-1.0, min(1.0, ratio)))
    bottom = b.pole(-z - radius_bottom)
    starts = []
    for k in range(1, cap_rings + 1):  # latitudes (−π/2, φ] on the bottom sphere
        latitude = -0.5 * math.pi + (tangent + 0.5 * math.pi) * k / cap_rings
        c, s = math.cos(latitude), math.sin(latitude)
        starts.append((b.ring(radius_bottom * c, -z + radius_bottom * s), b.normal_ring(c, s)))
    for k in range(cap_rings):  # latitudes [φ, π/2) on the top sphere
        latitude = tangent + (0.5 * math.pi - tangent) * k / cap_rings
        c, s = math.cos(latitude), math.sin(latitude)
        starts.append((b.ring(radius_top * c, z + radius_top * s), b.normal_ring(c, s)))
    top = b.pole(z + radius_top)
    b.fan(starts[0], bottom, below=True)
    for lower, upper in zip(starts, starts[1:]):
        b.quads(lower, upper)
    b.fan(starts[-1], top, below=False)
    return b.build(axis)


# Plane: (width direction, length direction) per axis, as the UsdGeomPlane schema defines them.
_PLANE_AXES = {"X": (2, 1), "Y": (0, 2), "Z": (0, 1)}


def plane(width: float, length: float, axis: str = "Z") -> GeneratedMesh:
    """A ``width`` × ``length`` rectangle through the origin facing +``axis`` (flat)."""
    w, l = _PLANE_AXES.get(axis, _PLANE_AXES["Z"])
    corners = np.zeros((4, 3))
    for k, (sw, sl) in enumerate(((1, 1), (-1, 1), (-1, -1), (1, -1))):
        corners[k, w] = 0.5 * width * sw
        corners[k, l] = 0.5 * length * sl
    normal = np.zeros(3)
    normal[{"X": 0, "Y": 1}.get(axis, 2)] = 1.0
    e_w, e_l = np.eye(3)[w], np.eye(3)[l]
    indices = [0, 1, 2, 3] if np.dot(np.cross(e_w, e_l), normal) > 0 else [3, 2, 1, 0]
    return _mesh([4], indices, corners)
