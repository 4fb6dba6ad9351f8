"""UsdGeomMesh and implicit surfaces → the delegate's ``mesh`` rprim: topology, points (with
their motion over the shutter), sidedness, displayColor, normals, and the other numeric primvars
(``st``, displayOpacity, ...) for materials to read.

Implicit surfaces (Sphere, Cube, Cylinder, Cone, Capsule, Plane; see :mod:`.implicit`) and
NURBS patches (:mod:`.nurbs_patch`) are tessellated, tetrahedral meshes reduced to their boundary
(:mod:`.tet_mesh`), and then pushed exactly as meshes are (:func:`push_mesh`): the scene
delegate tracks them as ``mesh`` prims (:func:`reads_as_mesh`), so transforms, visibility,
purpose, material bindings, instancing and incremental edits are the meshes' own."""

from __future__ import annotations

from collections.abc import Callable
from functools import cache, lru_cache
from typing import Any, NamedTuple

import numpy as np
from pxr import Usd, UsdGeom, UsdLux

from .._core import MeshRecord
from . import implicit, nurbs_patch, tet_mesh
from .core_batch import CoreBatch
from .lights import sync_mesh_light
from .motion import point_samples
from .sampling import SampleReader, changes_within
from .skinning import SkelCaches, find_skinning, skinned_normals, skinned_points
from .values import is_number_value, is_vector3_value


class Authored(NamedTuple):  # a tuple: built per mesh, faster than a dataclass
    """What the scene delegate already knows of a gprim (docs/architecture.md, "Scene delegate"):
    the names of its properties with an authored opinion and the constant primvars it inherits.
    Attributes not in ``names`` have their schema fallback, so they are not read."""

    names: frozenset[str]
    inherited_primvars: tuple[UsdGeom.Primvar, ...]


def reads_as_mesh(prim: Usd.Prim) -> bool:
    """Whether :func:`sync_mesh_data` reads ``prim``: a UsdGeomMesh, an implicit surface, a
    NurbsPatch or a TetMesh."""
    return (
        prim.IsA(UsdGeom.Mesh)
        or implicit.is_implicit(prim)
        or prim.IsA(UsdGeom.NurbsPatch)
        or prim.IsA(UsdGeom.TetMesh)
    )


def sync_mesh_data(
    core,
    prim: Usd.Prim,
    reader: SampleReader,
    warn: Callable[[str], None],
    prim_id: str | None = None,
    authored: Authored | None = None,
    skel_caches: SkelCaches | None = None,
) -> bool:
    """Push the topology, points, sidedness and displayColor of ``prim`` (a prim that
    :func:`reads_as_mesh`) to ``core`` (as the delegate prim ``prim_id``, by default the prim's
    path); a skinned mesh posed (:mod:`.skinning`).
    ``authored``: what is known of the prim's opinions (without it every attribute is read).
    ``skel_caches``: the UsdSkel caches of the caller's sync (without them, one for this mesh).

    Returns ``False`` (after a warning naming the prim) when the mesh has no points or no
    topology; nothing is pushed then. Index ranges are validated by the delegate at sync.
    """
    path = prim_id or str(prim.GetPath())
    # A prim typed "Mesh" needs no schema lookup; types derived from it still do.
    if prim.GetTypeName() != "Mesh" and not prim.IsA(UsdGeom.Mesh):
        if prim.IsA(UsdGeom.NurbsPatch):
            return _sync_nurbs_patch(core, prim, path, reader, warn, authored)
        if prim.IsA(UsdGeom.TetMesh):
            return _sync_tet_mesh(core, prim, path, reader, warn, authored)
        return _sync_implicit(core, prim, path, reader, warn, authored)
    attributes = _Attributes(prim, reader, authored)
    get = attributes.get
    arrays = []
    for name, valid in _TOPOLOGY:
        value = get(name)
        if value is not None:
            array = valid(value)
            if array is None:
                warn(f"{path}: {name} has type {_value_type(value)}, which a mesh cannot use; skipped")
                return False
            value = array
        arrays.append(value)
    missing = [
        name for (name, _), value in zip(_TOPOLOGY, arrays) if value is None or len(value) == 0
    ]
    if missing:
        warn(f"{path}: mesh has no {' and no '.join(missing)}; skipped")
        return False
    points, counts, indices = arrays

    left_handed = get(UsdGeom.Tokens.orientation) == UsdGeom.Tokens.leftHanded
    scheme = str(get(UsdGeom.Tokens.subdivisionScheme) or UsdGeom.Tokens.catmullClark)
    normals = _normals(prim, scheme, attributes, warn, path)
    names, inherited = (authored.names, authored.inherited_primvars) if authored else (None, ())
    skinning = find_skinning(prim, warn, path, skel_caches, names, inherited)
    if skinning is not None:
        if len(normals[0]):
            normals = (
                skinned_normals(skinning, points, *normals, indices, counts, reader.time),
                normals[1],
            )
        points = skinned_points(skinning, points, reader, warn, path)
    else:
        velocities = attributes.might_have(UsdGeom.Tokens.velocities)
        if velocities or reader.shutter.blurred:  # else the points are those at the frame
            points = point_samples(UsdGeom.Mesh(prim), points, reader, warn, path, velocities)
    push_mesh(
        core,
        prim,
        path,
        reader,
        counts=counts,
        indices=indices,
        points=points,
        normals=normals,
        left_handed=left_handed,
        scheme=scheme,
        primvars=gprim_primvars(prim, reader, warn, path, authored=authored),
        authored=authored,
        attributes=attributes,
        warn=warn,
    )
    if scheme != UsdGeom.Tokens.none:
        _sync_subdivision_tags(core, path, attributes, warn)
    return True


# The fast path for the common mesh (docs/architecture.md, "Scene delegate"): typed Mesh, read
# at one time without noting variability, with none of the properties below and no inherited
# primvars. Such meshes are read attribute by attribute across a whole sync, which costs a
# fraction of the general path's calls per mesh, and are sent as the general path would send
# them (tests/python/test_scene_delegate_reads.py compares the images); any other mesh,
# including every one the general path would warn about, takes the general path.
_NOT_PLAIN = frozenset(
    {
        UsdGeom.Tokens.velocities,
        UsdGeom.Tokens.accelerations,
        UsdGeom.Tokens.normals,
        "primvars:normals",
        "primvars:displayColor:indices",
    }
)


@lru_cache(maxsize=256)  # prims of a kind share one set of names (InheritedState.authored)
def is_plain(names: frozenset[str]) -> bool:
    """Whether a mesh with authored properties ``names`` (and no inherited primvars) can take
    the fast path of :func:`push_plain_meshes`."""
    return names.isdisjoint(_NOT_PLAIN) and not _names_other_primvars(names)


def push_plain_meshes(
    batch: CoreBatch,
    prims: list[Usd.Prim],
    names: list[frozenset[str]],
    ids: list[str],
    time: Usd.TimeCode,
) -> list[bool]:
    """Queue in ``batch`` the plain meshes ``prims`` (authored property names ``names``,
    delegate ids ``ids``; see :func:`is_plain`) at ``time`` as :func:`sync_mesh_data` would
    send them, and say for each whether it was: not when its topology, displayColor or
    subdivision tags need the general path's checks and warnings or when it has
    UsdLuxMeshLightAPI."""
    tokens = UsdGeom.Tokens

    def column(name: str) -> list:
        """Attribute ``name`` of each mesh at ``time`` (``None`` where not authored)."""
        return [
            prim.GetAttribute(name).Get(time) if name in authored else None
            for prim, authored in zip(prims, names)
        ]

    points = [as_vec3_array(prim.GetAttribute("points").Get(time)) for prim in prims]
    counts = [as_int32_array(prim.GetAttribute("faceVertexCounts").Get(time)) for prim in prims]
    indices = [as_int32_array(prim.GetAttribute("faceVertexIndices").Get(time)) for prim in prims]
    lights = [prim.HasAPI(UsdLux.MeshLightAPI) for prim in prims]
    schemes = column(tokens.subdivisionScheme)
    orientations = column(tokens.orientation)
    double_sided = column(tokens.doubleSided)
    color_attributes = [
        prim.GetAttribute(_DISPLAY_COLOR) if _DISPLAY_COLOR in authored else None
        for prim, authored in zip(prims, names)
    ]
    colors = [attr.Get(time) if attr is not None else None for attr in color_attributes]
    pushed = []
    for n, path in enumerate(ids):
        mesh_points, mesh_counts, mesh_indices = points[n], counts[n], indices[n]
        mesh_colors = _color_array(colors[n])
        scheme = str(schemes[n] or tokens.catmullClark)
        tags, tag_problem = None, None
        if scheme != tokens.none:
            attributes = _Attributes(prims[n], SampleReader(time), Authored(names[n], ()))
            tags, tag_problem = _subdivision_tags(attributes)
        usable = (
            mesh_points is not None
            and mesh_counts is not None
            and mesh_indices is not None
            and len(mesh_points) > 0
            and len(mesh_counts) > 0
            and len(mesh_indices) > 0
            and not lights[n]
            and mesh_colors is not None
            and tag_problem is None
        )
        pushed.append(usable)
        if not usable:
            continue
        interpolation = tokens.constant
        if len(mesh_colors):  # what UsdGeomPrimvar::GetInterpolation reads, without a primvar
            interpolation = str(color_attributes[n].GetMetadata(_INTERPOLATION) or interpolation)
        batch.add_mesh(
            MeshRecord(
                path,
                face_vertex_counts=mesh_counts,
                face_vertex_indices=mesh_indices,
                left_handed=orientations[n] == tokens.leftHanded,
                subdivision_scheme=scheme,
                points=mesh_points,
                double_sided=bool(double_sided[n]),
                display_color=mesh_colors,
                display_color_interpolation=interpolation,
                normals=_NO_VECTORS,
                normals_interpolation=tokens.vertex,
                primvars={},
            )
        )
        batch.set_mesh_light(path, False)
        if tags is not None:
            batch.set_mesh_subdivision_tags(path, **tags)
    return pushed


_PLACEMENT = frozenset({UsdGeom.Tokens.visibility, UsdGeom.Tokens.purpose})


def data_might_vary(prim: Usd.Prim, authored: Authored) -> bool:
    """Whether what :func:`sync_mesh_data` reads of ``prim`` might change with the time or the
    shutter (for a read that did not note it). Conservative: any authored attribute but those
    placing the prim, any inherited primvar, or velocities (points extrapolated over the
    shutter)."""
    names = authored.names
    if UsdGeom.Tokens.velocities in names or UsdGeom.Tokens.accelerations in names:
        return True
    for name in names:
        if name.startswith("xformOp") or name in _PLACEMENT:
            continue
        attr = prim.GetAttribute(name)  # relationships give an invalid attribute
        if attr and attr.ValueMightBeTimeVarying():
            return True
    return any(primvar.ValueMightBeTimeVarying() for primvar in authored.inherited_primvars)


class _Attributes:
    """Reads a gprim's attributes by name at the reader's time; one the prim has no opinion on
    (when ``authored`` says so) gives its schema fallback without a USD call."""

    def __init__(self, prim: Usd.Prim, reader: SampleReader, authored: Authored | None) -> None:
        self.prim = prim
        self.reader = reader
        self.names = authored.names if authored is not None else None

    def might_have(self, name: str) -> bool:
        """Whether the prim may have an opinion on ``name`` (False: certainly none)."""
        return self.names is None or name in self.names

    def get(self, name: str) -> Any:
        if self.names is not None and name not in self.names:
            return _mesh_fallback(name)
        return self.reader.get(self.prim.GetAttribute(name))


@cache
def _mesh_fallback(name: str) -> Any:
    """The fallback value of UsdGeomMesh's attribute ``name`` (of it or of UsdGeomGprim)."""
    definition = Usd.SchemaRegistry().FindConcretePrimDefinition("Mesh")
    return definition.GetAttributeFallbackValue(name)


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
    authored: Authored | None = None,
    attributes: _Attributes | None = None,
    colors: tuple[np.ndarray, str] | None = None,
    warn: Callable[[str], None],
) -> None:
    """Push a polygon mesh (or subdivision cage) of gprim ``prim`` as delegate prim ``path``
    in one call: the given topology, points (float32 (N, 3) or (K, N, 3) motion samples),
    normals (values, interpolation) and primvars (name → (values, interpolation); by default
    the gprim's constant ones), with what the gprim itself says — sidedness and displayColor;
    then its UsdLuxMeshLightAPI. ``authored``: as for :func:`sync_mesh_data`; ``attributes``:
    the reader of the prim's attributes the caller already made from them; ``colors``: the
    displayColor (values, interpolation) when the caller mapped it to generated topology."""
    if primvars is None:
        primvars = gprim_primvars(prim, reader, warn, path, constant_only=True, authored=authored)
    colors, interpolation = colors or display_color(prim, reader, warn, path, authored)
    if attributes is None:
        attributes = _Attributes(prim, reader, authored)
    core.set_mesh(
        path,
        face_vertex_counts=_int32(counts),
        face_vertex_indices=_int32(indices),
        left_handed=left_handed,
        subdivision_scheme=scheme,
        points=points,
        double_sided=bool(attributes.get(UsdGeom.Tokens.doubleSided)),
        display_color=colors,
        display_color_interpolation=interpolation,
        normals=normals[0],
        normals_interpolation=normals[1],
        primvars=primvars,
    )
    sync_mesh_light(core, prim, path, reader, warn)


def _sync_implicit(
    core,
    prim: Usd.Prim,
    path: str,
    reader: SampleReader,
    warn: Callable[[str], None],
    authored: Authored | None,
) -> bool:
    """Tessellate implicit surface ``prim`` (at the reader's time, and over its shutter when
    a shaping attribute changes within it) and push it as a polygon mesh with smooth normals;
    ``False`` after a warning when a shaping attribute is unusable."""
    attrs = implicit.shape_attributes(prim)
    # Read through the reader, which notes whether the shape might vary with time.
    values = {attr.GetName(): reader.get(attr) for attr in attrs}
    problem = implicit.shape_problem(values)
    if problem:
        warn(f"{path}: {problem}; skipped")
        return False
    generated = implicit.tessellate(prim, values)
    points = generated.points
    shutter = reader.shutter
    if shutter.blurred and any(changes_within(attr, shutter.interval) for attr in attrs):
        keys = [t for attr in attrs for t in attr.GetTimeSamplesInInterval(shutter.interval)]
        times = shutter.times(shutter.segments(keys))
        shapes = [{attr.GetName(): attr.Get(time) for attr in attrs} for time in times]
        problem = next(filter(None, map(implicit.shape_problem, shapes)), None)
        if problem:
            warn(f"{path}: {problem} within the shutter; skipped")
            return False
        samples = np.stack([implicit.tessellate(prim, shape).points for shape in shapes])
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
        authored=authored,
        warn=warn,
    )
    return True


def _sync_nurbs_patch(
    core,
    prim: Usd.Prim,
    path: str,
    reader: SampleReader,
    warn: Callable[[str], None],
    authored: Authored | None,
) -> bool:
    """Tessellate NurbsPatch ``prim`` (:mod:`.nurbs_patch`; its control points sampled over the
    shutter as a mesh's points are) and push it as a polygon mesh with the surface's normals.
    Only constant primvars apply to the generated vertices; displayColor of another
    interpolation is left out with a warning."""
    generated = nurbs_patch.mesh(prim, reader, warn, path)
    if generated is None:
        return False
    patch, tessellation = generated.patch, generated.tessellation
    points = tessellation.points
    samples = point_samples(UsdGeom.NurbsPatch(prim), generated.control, reader, warn, path)
    if samples.ndim == 3:
        points = np.stack([generated.points_for(sample) for sample in samples])
    colors = display_color(prim, reader, warn, path, authored)
    if colors[1] != UsdGeom.Tokens.constant and len(colors[0]):
        warn(f"{path}: primvars:displayColor is {colors[1]}; a NurbsPatch takes only constant")
        colors = _NO_VECTORS, UsdGeom.Tokens.constant
    varying = sorted(
        primvar.GetPrimvarName()
        for primvar in UsdGeom.PrimvarsAPI(prim).GetPrimvarsWithAuthoredValues()
        if primvar.GetInterpolation() != UsdGeom.Tokens.constant
        and primvar.GetPrimvarName() not in _DEDICATED_PRIMVARS
    )
    if varying:
        warn(f"{path}: primvars {', '.join(varying)} are not constant; a NurbsPatch takes only "
             "constant primvars, these are left out")
    push_mesh(
        core,
        prim,
        path,
        reader,
        counts=tessellation.counts,
        indices=tessellation.indices,
        points=points,
        normals=(tessellation.normals, UsdGeom.Tokens.vertex),
        left_handed=patch.left_handed,
        authored=authored,
        colors=colors,
        warn=warn,
    )
    return True


def _sync_tet_mesh(
    core,
    prim: Usd.Prim,
    path: str,
    reader: SampleReader,
    warn: Callable[[str], None],
    authored: Authored | None,
) -> bool:
    """Push the boundary triangles of TetMesh ``prim`` (:mod:`.tet_mesh`) over its own points
    (sampled over the shutter as a mesh's), shaded flat; uniform primvars (per tetrahedron)
    pass to the faces, face-varying ones are left out with a warning."""
    surface = tet_mesh.read_surface(prim, reader, warn, path)
    if surface is None:
        return False
    points = point_samples(UsdGeom.TetMesh(prim), surface.points, reader, warn, path)
    primvars = {}
    for name, (values, interpolation) in gprim_primvars(
        prim, reader, warn, path, authored=authored
    ).items():
        per_face = _per_boundary_face(values, interpolation, surface, warn, path, name)
        if per_face is not None:
            primvars[name] = per_face
    colors = _per_boundary_face(
        *display_color(prim, reader, warn, path, authored), surface, warn, path, "displayColor"
    )
    push_mesh(
        core,
        prim,
        path,
        reader,
        counts=np.full(len(surface.face_tets), 3, dtype=np.int32),
        indices=surface.indices,
        points=points,
        normals=(_NO_VECTORS, UsdGeom.Tokens.vertex),
        left_handed=surface.left_handed,
        primvars=primvars,
        authored=authored,
        colors=colors or (_NO_VECTORS, UsdGeom.Tokens.constant),
        warn=warn,
    )
    return True


def _per_boundary_face(
    values: np.ndarray,
    interpolation: str,
    surface: tet_mesh.Surface,
    warn: Callable[[str], None],
    path: str,
    name: str,
) -> tuple[np.ndarray, str] | None:
    """A TetMesh primvar's ``values`` as the boundary mesh takes them: per point and constant
    ones as they are, uniform ones (one per tetrahedron) picked per face; ``None`` (with a
    warning) for face-varying ones or a uniform count that is not the tetrahedra's."""
    if interpolation == UsdGeom.Tokens.uniform and len(values) == surface.tet_count:
        return np.ascontiguousarray(values[surface.face_tets]), interpolation
    if interpolation not in (UsdGeom.Tokens.uniform, UsdGeom.Tokens.faceVarying):
        return values, interpolation
    warn(
        f"{path}: primvars:{name} ({interpolation}, {len(values)} values) does not map to the "
        "faces of a TetMesh's surface; left out"
    )
    return None


# Attributes authored with another type than the schema's keep their authored type: check it.


# np.asarray without a dtype is several times faster on Vt arrays than with one; the usual
# Vec3fArray and IntArray need no conversion after it.


_FLOAT32 = np.dtype(np.float32)
_INT32 = np.dtype(np.int32)
_INT32_RANGE = np.iinfo(np.int32)


def as_vec3_array(value) -> np.ndarray | None:
    """``value`` as float32 (N, 3) if it is an array of 3-vectors (float or double), else
    ``None``."""
    array = np.asarray(value)
    if array.ndim != 2 or array.shape[1] != 3:
        return None
    if array.dtype == _FLOAT32:
        return array
    return array.astype(np.float32) if array.dtype.kind == "f" else None


def as_int32_array(value) -> np.ndarray | None:
    """``value`` as an int32 array if it is an array of integers that int32 holds, else
    ``None`` (an int64 array's larger values would wrap into plausible small ones)."""
    array = np.asarray(value)
    if array.ndim != 1:
        return None
    if array.dtype == _INT32:
        return array
    if array.dtype.kind not in "iu" or (
        len(array) and (array.min() < _INT32_RANGE.min or array.max() > _INT32_RANGE.max)
    ):
        return None
    return array.astype(np.int32)


def _int32(values) -> np.ndarray:
    """Integer ``values`` as an int32 array (not copied when they are one)."""
    if isinstance(values, np.ndarray) and values.dtype == _INT32:
        return values
    return np.asarray(values, dtype=np.int32)


_TOPOLOGY = (
    ("points", as_vec3_array),
    ("faceVertexCounts", as_int32_array),
    ("faceVertexIndices", as_int32_array),
)


def _value_type(value) -> str:
    """The authored type of ``value`` as USD's Python bindings name it (Vt.IntArray: IntArray)."""
    return type(value).__name__


def _normals(
    prim: Usd.Prim,
    scheme: str,
    attributes: _Attributes,
    warn: Callable[[str], None],
    path: str,
) -> tuple[np.ndarray, str]:
    """Authored shading normals (``primvars:normals`` wins over ``normals``, as in USD) and their
    interpolation; no values when none are authored, when they are not an array of 3-vectors
    (with a warning), or when the mesh is subdivided (its limit normals are used then)."""
    none = _NO_VECTORS, UsdGeom.Tokens.vertex
    if scheme != UsdGeom.Tokens.none:
        return none
    if not (attributes.might_have("primvars:normals") or attributes.might_have("normals")):
        return none
    reader = attributes.reader
    mesh = UsdGeom.Mesh(prim)
    primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar(UsdGeom.Tokens.normals)
    if primvar and primvar.HasValue():
        interpolation = primvar.GetInterpolation()
        values = reader.flattened_primvar(primvar)
    else:
        interpolation = mesh.GetNormalsInterpolation()
        values = reader.get(mesh.GetNormalsAttr())
    if values is None or len(np.asarray(values).reshape(-1)) == 0:
        return none
    array = as_vec3_array(values)
    if array is None:
        warn(f"{path}: normals have type {_value_type(values)}, not 3-vectors; the mesh is shaded flat")
        return none
    return array, str(interpolation)


_NO_VECTORS = np.empty((0, 3), dtype=np.float32)
_NO_VECTORS.flags.writeable = False  # shared by every mesh without normals or displayColor

# Primvars the delegate receives through their own calls.
_DEDICATED_PRIMVARS = frozenset({"displayColor", "normals"})
_SKEL_PRIMVARS = "skel:"  # UsdSkel's namespace: skinning data (joint influences), not shading


def gprim_primvars(
    prim: Usd.Prim,
    reader: SampleReader,
    warn: Callable[[str], None],
    path: str,
    constant_only: bool = False,
    authored: Authored | None = None,
    dedicated: frozenset[str] = frozenset(),
) -> dict[str, tuple[np.ndarray, str]]:
    """The numeric primvars of ``prim`` (own, and constant ones inherited from ancestors) that
    materials may read, flattened, as float32 (N,) or (N, width) arrays with their interpolation.
    Non-numeric primvars and widths above 4 are left out (with a warning for those that could
    never be read, and for a displayOpacity that is not numbers); ``constant_only`` keeps just
    constant ones (for generated topology, which authored per-element data cannot match).
    ``authored``: as for :func:`sync_mesh_data`. ``dedicated``: more primvars that the caller
    reads itself (as displayColor and normals always are)."""
    result: dict[str, tuple[np.ndarray, str]] = {}
    if authored is None:
        primvars = UsdGeom.PrimvarsAPI(prim).FindPrimvarsWithInheritance()
    elif _has_other_primvars(authored):
        inherited = list(authored.inherited_primvars)
        primvars = UsdGeom.PrimvarsAPI(prim).FindPrimvarsWithInheritance(inherited)
    else:
        primvars = []
    for primvar in primvars:
        name = primvar.GetPrimvarName()
        interpolation = str(primvar.GetInterpolation())
        if name in _DEDICATED_PRIMVARS or name in dedicated or name.startswith(_SKEL_PRIMVARS):
            continue
        if constant_only and interpolation != UsdGeom.Tokens.constant:
            continue
        if not UsdGeom.Primvar.IsValidInterpolation(interpolation):
            warn(f"{path}: primvars:{name} has unknown interpolation {interpolation!r}; skipped")
            continue
        if name == "displayOpacity" and primvar.HasValue():
            # The delegate reads an opacity from an element's first number: a colour's red.
            opacity = reader.flattened_primvar(primvar)
            if not (is_number_value(opacity) or _as_float_array(opacity) is not None):
                warn(
                    f"{path}: primvars:displayOpacity has type {_value_type(opacity)}, not "
                    "numbers; ignored"
                )
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


def _has_other_primvars(authored: Authored) -> bool:
    """Whether a gprim has (or inherits) primvars besides those with their own calls."""
    return _names_other_primvars(authored.names) or any(
        primvar.GetPrimvarName() not in _DEDICATED_PRIMVARS
        for primvar in authored.inherited_primvars
    )


@lru_cache(maxsize=256)  # prims of a kind share one set of names (InheritedState.authored)
def _names_other_primvars(names: frozenset[str]) -> bool:
    """Whether property ``names`` include primvars besides those with their own calls."""
    own = (name for name in names if name.startswith("primvars:") and not name.endswith(":indices"))
    return any(name[9:] not in _DEDICATED_PRIMVARS for name in own)


_DISPLAY_COLOR = UsdGeom.Tokens.primvarsDisplayColor
_DISPLAY_COLOR_INDICES = f"{_DISPLAY_COLOR}:indices"
_INTERPOLATION = UsdGeom.Tokens.interpolation


def display_color(
    prim: Usd.Prim,
    reader: SampleReader,
    warn: Callable[[str], None],
    path: str,
    authored: Authored | None = None,
) -> tuple[np.ndarray, str]:
    """The flattened displayColor of ``prim`` (own or inherited constant primvar) and its
    interpolation; no values (the delegate then uses its grey fallback) when none is authored,
    or, after a warning naming ``path`` and the primvar, when it is not 3-vectors."""
    attribute = _DISPLAY_COLOR
    if authored is None:
        primvar = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance(attribute)
    elif attribute in authored.names:
        attr = prim.GetAttribute(attribute)
        primvar = UsdGeom.Primvar(attr)
        if _DISPLAY_COLOR_INDICES not in authored.names:  # not indexed: flat as it is
            return _colors(reader.get(attr), primvar, prim, warn, path)
    else:
        inherited = [
            p for p in authored.inherited_primvars if p.GetPrimvarName() == "displayColor"
        ]
        primvar = inherited[0] if inherited else None
    if primvar and primvar.HasValue():
        return _colors(reader.flattened_primvar(primvar), primvar, prim, warn, path)
    return _NO_VECTORS, UsdGeom.Tokens.constant


def _colors(
    values,
    primvar: UsdGeom.Primvar,
    prim: Usd.Prim,
    warn: Callable[[str], None],
    path: str,
) -> tuple[np.ndarray, str]:
    """Flat displayColor ``values`` of ``primvar`` (of ``prim`` or inherited by it) as float32
    (N, 3) and their interpolation; none (the delegate's grey fallback) when there are no
    values, or after a warning when they are not 3-vectors (reshaping other numbers into
    colours would paint garbage)."""
    colors = _color_array(values)
    if colors is None:
        owner = primvar.GetAttr().GetPrim()
        where = "" if owner == prim else f" (inherited from {owner.GetPath()})"
        warn(
            f"{path}: primvars:displayColor{where} has type {_value_type(values)}, not "
            "3-vectors; ignored, the fallback colour is used"
        )
        colors = _NO_VECTORS
    if len(colors) == 0:
        return _NO_VECTORS, UsdGeom.Tokens.constant
    return colors, str(primvar.GetInterpolation())


def _color_array(values) -> np.ndarray | None:
    """Flat displayColor ``values`` as float32 (N, 3): none for no values, one row for a single
    3-vector (a color3f authored without brackets); ``None`` when they are not 3-vectors."""
    if values is None:
        return _NO_VECTORS
    if is_vector3_value(values):
        values = [values]
    colors = as_vec3_array(values)
    if colors is None and np.size(values) == 0:  # an empty array of any type: nothing authored
        return _NO_VECTORS
    return colors


def _as_float_array(value) -> np.ndarray | None:
    """``value`` as a float32 array if it is an array of numbers, else ``None``."""
    array = np.asarray(value)
    return array.astype(np.float32) if array.ndim == 1 and array.dtype.kind in "iuf" else None


# Subdivision tags in groups whose arrays only make sense together (the delegate checks their
# counts and ranges): a group with an attribute of another type is left out whole.
_TAG_GROUPS = (
    ("holes", (("hole_indices", UsdGeom.Tokens.holeIndices, as_int32_array, "int[]"),)),
    (
        "corners",
        (
            ("corner_indices", UsdGeom.Tokens.cornerIndices, as_int32_array, "int[]"),
            ("corner_sharpnesses", UsdGeom.Tokens.cornerSharpnesses, _as_float_array, "float[]"),
        ),
    ),
    (
        "creases",
        (
            ("crease_indices", UsdGeom.Tokens.creaseIndices, as_int32_array, "int[]"),
            ("crease_lengths", UsdGeom.Tokens.creaseLengths, as_int32_array, "int[]"),
            ("crease_sharpnesses", UsdGeom.Tokens.creaseSharpnesses, _as_float_array, "float[]"),
        ),
    ),
)


def _subdivision_tags(attributes: _Attributes) -> tuple[dict[str, Any], str | None]:
    """The subdivision tags (boundary rules, creases, corners, holes) of a subdivided mesh as
    ``set_mesh_subdivision_tags`` takes them, and what is wrong with them (``None``: nothing):
    tag attributes of another type than the schema's, whose groups are left out."""
    tokens = UsdGeom.Tokens
    tags: dict[str, Any] = {
        "interpolate_boundary": str(attributes.get(tokens.interpolateBoundary)),
        "face_varying_linear_interpolation": str(
            attributes.get(tokens.faceVaryingLinearInterpolation)
        ),
        "triangle_subdivision_rule": str(attributes.get(tokens.triangleSubdivisionRule)),
    }
    problems, dropped = [], []
    for group, members in _TAG_GROUPS:
        arrays, wrong = {}, []
        for keyword, name, convert, expected in members:
            value = attributes.get(name)
            if value is None:
                continue  # the delegate's default: none
            array = convert(value)
            if array is None:
                wrong.append(f"{name} has type {_value_type(value)}, not {expected}")
            arrays[keyword] = array
        if wrong:
            problems.extend(wrong)
            dropped.append(group)
        else:
            tags.update(arrays)
    if not problems:
        return tags, None
    return tags, f"{'; '.join(problems)}; the mesh's {' and '.join(dropped)} are ignored"


def _sync_subdivision_tags(
    core, path: str, attributes: _Attributes, warn: Callable[[str], None]
) -> None:
    """Push the subdivision tags of a subdivided mesh, after a warning naming the attributes
    of a group left out."""
    tags, problem = _subdivision_tags(attributes)
    if problem:
        warn(f"{path}: {problem}")
    core.set_mesh_subdivision_tags(path, **tags)
