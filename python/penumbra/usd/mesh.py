"""UsdGeomMesh and implicit surfaces → the delegate's ``mesh`` rprim: topology, points (with
their motion over the shutter), sidedness, displayColor, normals, and the other numeric primvars
(``st``, displayOpacity, ...) for materials to read.

Implicit surfaces (Sphere, Cube, Cylinder, Cone, Capsule, Plane; see :mod:`.implicit`) are
tessellated and then pushed exactly as meshes are (:func:`push_mesh`): the scene delegate
tracks them as ``mesh`` prims, so transforms, visibility, purpose, material bindings,
instancing and incremental edits are the meshes' own."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pxr import Usd, UsdGeom

from . import implicit
from .lights import sync_mesh_light
from .motion import point_samples
from .sampling import SampleReader, changes_within


def sync_mesh_data(
    core,
    prim: Usd.Prim,
    reader: SampleReader,
    warn: Callable[[str], None],
    prim_id: str | None = None,
) -> bool:
    """Push the topology, points, sidedness and displayColor of ``prim`` (a UsdGeomMesh or an
    implicit surface) to ``core`` (as the delegate prim ``prim_id``, by default the prim's path).

    Returns ``False`` (after a warning naming the prim) when the mesh has no points or no
    topology; nothing is pushed then. Index ranges are validated by the delegate at sync.
    """
    path = prim_id or str(prim.GetPath())
    if not prim.IsA(UsdGeom.Mesh):
        return _sync_implicit(core, prim, path, reader)
    mesh = UsdGeom.Mesh(prim)
    values = {}
    for name, attr, valid in (
        ("points", mesh.GetPointsAttr(), _as_vec3_array),
        ("faceVertexCounts", mesh.GetFaceVertexCountsAttr(), _as_int_array),
        ("faceVertexIndices", mesh.GetFaceVertexIndicesAttr(), _as_int_array),
    ):
        value = reader.get(attr)
        if value is not None:
            array = valid(value)
            if array is None:
                warn(f"{path}: {name} has type {_value_type(value)}, which a mesh cannot use; skipped")
                return False
            value = array
        values[name] = value
    missing = [name for name, value in values.items() if value is None or len(value) == 0]
    if missing:
        warn(f"{path}: mesh has no {' and no '.join(missing)}; skipped")
        return False
    points, counts, indices = values["points"], values["faceVertexCounts"], values["faceVertexIndices"]

    left_handed = reader.get(mesh.GetOrientationAttr()) == UsdGeom.Tokens.leftHanded
    scheme = str(reader.get(mesh.GetSubdivisionSchemeAttr()) or UsdGeom.Tokens.catmullClark)
    push_mesh(
        core,
        prim,
        path,
        reader,
        counts=counts,
        indices=indices,
        points=point_samples(mesh, points, reader, warn, path),
        normals=_normals(mesh, scheme, reader, warn, path),
        left_handed=left_handed,
        scheme=scheme,
        primvars=_primvars(prim, reader, warn, path),
    )
    if scheme != UsdGeom.Tokens.none:
        _sync_subdivision_tags(core, path, mesh, reader)
    return True


def push_mesh(
    core,
    prim: Usd.Prim,
    path: str,
    reader: SampleReader,
    *,
    counts,
    indices,
    points: np.ndarray,
    normals: tuple[np.ndarray, str],
    left_handed: bool = False,
    scheme: str = UsdGeom.Tokens.none,
    primvars: dict[str, tuple[np.ndarray, str]] | None = None,
) -> None:
    """Push a polygon mesh (or subdivision cage) of gprim ``prim`` as delegate prim ``path``
    in one call: the given topology, points (float32 (N, 3) or (K, N, 3) motion samples),
    normals (values, interpolation) and primvars (name → (values, interpolation); by default
    the gprim's constant ones), with what the gprim itself says — sidedness and displayColor;
    then its UsdLuxMeshLightAPI."""
    if primvars is None:
        primvars = _primvars(prim, reader, None, path, constant_only=True)
    colors, interpolation = _display_color(prim, reader)
    core.set_mesh(
        path,
        face_vertex_counts=np.asarray(counts, dtype=np.int32),
        face_vertex_indices=np.asarray(indices, dtype=np.int32),
        left_handed=left_handed,
        subdivision_scheme=scheme,
        points=points,
        double_sided=bool(reader.get(UsdGeom.Gprim(prim).GetDoubleSidedAttr())),
        display_color=colors,
        display_color_interpolation=interpolation,
        normals=normals[0],
        normals_interpolation=normals[1],
        primvars=primvars,
    )
    sync_mesh_light(core, prim, path, reader)


def _sync_implicit(core, prim: Usd.Prim, path: str, reader: SampleReader) -> bool:
    """Tessellate implicit surface ``prim`` (at the reader's time, and over its shutter when
    a shaping attribute changes within it) and push it as a polygon mesh with smooth normals."""
    attrs = implicit.shape_attributes(prim)
    for attr in attrs:
        reader.get(attr)  # notes whether the shape might vary with time
    generated = implicit.tessellate(prim, reader.time)
    points = generated.points
    shutter = reader.shutter
    if shutter.blurred and any(changes_within(attr, shutter.interval) for attr in attrs):
        authored = [t for attr in attrs for t in attr.GetTimeSamplesInInterval(shutter.interval)]
        times = shutter.times(shutter.segments(authored))
        samples = np.stack([implicit.tessellate(prim, time).points for time in times])
        if not all(np.array_equal(sample, samples[0]) for sample in samples):
            points = samples
    push_mesh(
        core,
        prim,
        path,
        reader,
        counts=generated.counts,
        indices=generated.indices,
        points=points,
        normals=(generated.normals, UsdGeom.Tokens.faceVarying),
    )
    return True


# Attributes authored with another type than the schema's keep their authored type: check it.


def _as_vec3_array(value) -> np.ndarray | None:
    """``value`` as float32 (N, 3) if it is an array of 3-vectors (float or double), else
    ``None``."""
    array = np.asarray(value)
    if array.ndim == 2 and array.shape[1] == 3 and array.dtype.kind == "f":
        return array.astype(np.float32, copy=False)
    return None


def _as_int_array(value) -> np.ndarray | None:
    """``value`` as an int32 array if it is an array of integers, else ``None``."""
    array = np.asarray(value)
    if array.ndim == 1 and array.dtype.kind in "iu":
        return array.astype(np.int32, copy=False)
    return None


def _value_type(value) -> str:
    """The authored type of ``value`` as USD's Python bindings name it (Vt.IntArray: IntArray)."""
    return type(value).__name__


def _normals(
    mesh: UsdGeom.Mesh, scheme: str, reader: SampleReader, warn: Callable[[str], None], path: str
) -> tuple[np.ndarray, str]:
    """Authored shading normals (``primvars:normals`` wins over ``normals``, as in USD) and their
    interpolation; no values when none are authored, when they are not an array of 3-vectors
    (with a warning), or when the mesh is subdivided (its limit normals are used then)."""
    none = np.empty((0, 3), dtype=np.float32), UsdGeom.Tokens.vertex
    if scheme != UsdGeom.Tokens.none:
        return none
    primvar = UsdGeom.PrimvarsAPI(mesh.GetPrim()).GetPrimvar(UsdGeom.Tokens.normals)
    if primvar and primvar.HasValue():
        attr, interpolation = primvar.GetAttr(), primvar.GetInterpolation()
        values = reader.flattened_primvar(primvar)
    else:
        attr, interpolation = mesh.GetNormalsAttr(), mesh.GetNormalsInterpolation()
        values = reader.get(attr)
    if values is None or len(np.asarray(values).reshape(-1)) == 0:
        return none
    array = _as_vec3_array(values)
    if array is None:
        warn(f"{path}: normals have type {_value_type(values)}, not 3-vectors; the mesh is shaded flat")
        return none
    return array, str(interpolation)


# Primvars the delegate receives through their own calls.
_DEDICATED_PRIMVARS = frozenset({"displayColor", "normals"})


def _primvars(
    prim: Usd.Prim,
    reader: SampleReader,
    warn: Callable[[str], None] | None,
    path: str,
    constant_only: bool = False,
) -> dict[str, tuple[np.ndarray, str]]:
    """The numeric primvars of ``prim`` (own, and constant ones inherited from ancestors) that
    materials may read, flattened, as float32 (N,) or (N, width) arrays with their interpolation.
    Non-numeric primvars and widths above 4 are left out (with a warning when ``warn`` is given);
    ``constant_only`` keeps just constant ones (for generated topology, which authored
    per-element data cannot match)."""
    result: dict[str, tuple[np.ndarray, str]] = {}
    for primvar in UsdGeom.PrimvarsAPI(prim).FindPrimvarsWithInheritance():
        name = primvar.GetPrimvarName()
        interpolation = str(primvar.GetInterpolation())
        if name in _DEDICATED_PRIMVARS:
            continue
        if constant_only and interpolation != UsdGeom.Tokens.constant:
            continue
        if not UsdGeom.Primvar.IsValidInterpolation(interpolation):
            if warn:
                warn(f"{path}: primvars:{name} has unknown interpolation {interpolation!r}; skipped")
            continue
        values = numeric_primvar(primvar, reader, warn, path)
        if values is not None:
            result[name] = (values, interpolation)
    return result


def numeric_primvar(
    primvar: UsdGeom.Primvar,
    reader: SampleReader,
    warn: Callable[[str], None] | None,
    path: str,
) -> np.ndarray | None:
    """The flattened values of ``primvar`` as float32 (N,) or (N, width) with width 1 to 4 (a
    constant non-array value gives one row); ``None`` when it has no values or is not numeric
    (with a warning when ``warn`` is given and the type could never be read)."""
    name = primvar.GetPrimvarName()
    if not primvar.HasValue():
        return None
    if primvar.GetElementSize() != 1:
        if warn:
            warn(
                f"{path}: primvar {name} has elementSize {primvar.GetElementSize()}; "
                "materials cannot read it"
            )
        return None
    try:
        array = np.asarray(reader.flattened_primvar(primvar), dtype=np.float32)
    except (TypeError, ValueError):
        return None  # strings, tokens, assets: nothing a material reads as a number
    if not primvar.GetTypeName().isArray:
        array = array.reshape(1, -1)
    if array.ndim == 2 and array.shape[1] == 1:
        array = array.reshape(-1)
    if array.size == 0:
        return None  # authored without values: nothing to read
    if array.ndim not in (1, 2) or (array.ndim == 2 and array.shape[1] > 4):
        if warn:
            warn(
                f"{path}: primvar {name} of type {primvar.GetTypeName()} is not 1 to 4 "
                "numbers per element; materials cannot read it"
            )
        return None
    return np.ascontiguousarray(array)


def _display_color(prim: Usd.Prim, reader: SampleReader) -> tuple[np.ndarray, str]:
    """The flattened displayColor of ``prim`` (own or inherited constant primvar) and its
    interpolation; no values when none is authored (the delegate then uses its grey fallback)."""
    primvar = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance(
        UsdGeom.Tokens.primvarsDisplayColor
    )
    if primvar and primvar.HasValue():
        values = reader.flattened_primvar(primvar)
        if values is not None and len(values) > 0:
            colors = np.asarray(values, dtype=np.float32).reshape(-1, 3)
            return colors, str(primvar.GetInterpolation())
    return np.empty((0, 3), dtype=np.float32), UsdGeom.Tokens.constant


def _sync_subdivision_tags(core, path: str, mesh: UsdGeom.Mesh, reader: SampleReader) -> None:
    """Push the subdivision tags (boundary rules, creases, corners, holes) of a subdivided mesh."""

    def array(attr: Usd.Attribute, dtype) -> np.ndarray:
        value = reader.get(attr)
        return np.asarray(value if value is not None else [], dtype=dtype)

    core.set_mesh_subdivision_tags(
        path,
        interpolate_boundary=str(reader.get(mesh.GetInterpolateBoundaryAttr())),
        face_varying_linear_interpolation=str(
            reader.get(mesh.GetFaceVaryingLinearInterpolationAttr())
        ),
        triangle_subdivision_rule=str(reader.get(mesh.GetTriangleSubdivisionRuleAttr())),
        hole_indices=array(mesh.GetHoleIndicesAttr(), np.int32),
        corner_indices=array(mesh.GetCornerIndicesAttr(), np.int32),
        corner_sharpnesses=array(mesh.GetCornerSharpnessesAttr(), np.float32),
        crease_indices=array(mesh.GetCreaseIndicesAttr(), np.int32),
        crease_lengths=array(mesh.GetCreaseLengthsAttr(), np.int32),
        crease_sharpnesses=array(mesh.GetCreaseSharpnessesAttr(), np.float32),
    )
