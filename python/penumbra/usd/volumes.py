"""Reading a UsdVolVolume into the delegate's volume rprim (``set_volume``).

A Volume's fields are its ``field:NAME`` relationships (``UsdVol.Volume.GetFieldPaths``), each
to an ``OpenVDBAsset`` prim: its ``filePath`` (an asset path resolved against the layer that
authors it; time-sampled paths are read at the frame), ``fieldName`` (the grid's name in the
file; unauthored: NAME), ``fieldIndex`` (which grid of that name, default 0) and
``fieldDataType`` (a vector type on a scalar slot is refused). The volume's shading
(:func:`~.volume_shading.read_volume_shading`, its inputs read at the frame too) gives its
material and, for each of the renderer's four field slots (density, color, temperature,
emission), the candidate NAMEs: the first the volume has feeds the slot. The fields' own
transforms are not applied: a grid is placed by its file's transform and the Volume's.

Bad data never stops a render: a volume without fields, a field whose prim is not an
OpenVDBAsset, whose file is missing, whose fieldIndex is not an int in [0, 2^31 - 1] or whose
data type does not fit its slot each warn once naming the volume, the field and the file; the
slot is then dropped, or the volume skipped when it is the density's. Grids that cannot be read are warned of by the render delegate as it reads
them (at its sync, through its cache of fields).
"""

from __future__ import annotations

from collections.abc import Callable

from pxr import Sdf, Usd, UsdVol

from .sampling import SampleReader
from .volume_shading import VolumeShading, read_volume_shading

INT32_MAX = 2**31 - 1
"""The largest fieldIndex: the render delegate takes it as a 32-bit int."""

SCALAR_SLOTS = ("density", "temperature")
"""The slots that take scalar grids (the others take a scalar or a colour)."""

_VECTOR_TYPES = frozenset(
    ("half2", "float2", "double2", "int2", "half3", "float3", "double3", "int3", "matrix3d",
     "matrix4d", "quatd")
)


def candidate_fields(shading: VolumeShading) -> dict[str, tuple[str, ...]]:
    """The field NAMEs that may feed each slot, first wins."""
    return {
        "density": shading.density_fields,
        "color": shading.color_fields,
        "temperature": shading.temperature_fields,
        "emission": shading.emission_fields,
    }


def volume_dependencies(prim: Usd.Prim, material: Usd.Prim | None) -> set[Sdf.Path]:
    """The prims a volume's data is read from besides its own: its field prims (targets of its
    field relationships, whether or not they exist yet) and its bound material (whose subtree
    holds the shader nodes)."""
    dependencies = set(UsdVol.Volume(prim).GetFieldPaths().values())
    if material is not None:
        dependencies.add(material.GetPath())
    return dependencies


def sync_volume_data(
    core,
    prim: Usd.Prim,
    material: Usd.Prim | None,
    reader: SampleReader,
    warn: Callable[[str], None],
    path: str,
) -> bool:
    """Push the fields and material of Volume ``prim`` (bound to ``material``) as delegate prim
    ``path``; ``False`` when it cannot render (warned)."""
    field_paths = UsdVol.Volume(prim).GetFieldPaths()
    if not field_paths:
        warn(
            f"{path}: a Volume without fields (field:NAME relationships to OpenVDBAsset "
            "prims); skipped"
        )
        return False
    # The volume's reader: the material is read at the frame, and a keyed input marks the
    # volume's data as varying, so that it is read again at the next frame.
    shading = read_volume_shading(prim, material, reader, warn)
    fields: dict[str, tuple[str, str, int]] = {}
    for slot, names in candidate_fields(shading).items():
        name = next((n for n in names if n in field_paths), None)
        if name is None:
            continue
        request = _field_request(prim, name, field_paths[name], slot, reader, warn, path)
        if request is not None:
            fields[slot] = request
        elif slot == "density":
            return False
    if not fields:
        warn(f"{path}: none of the fields {sorted(field_paths)} feeds the volume's density, color, "
             "temperature or emission; skipped")
        return False
    core.set_volume(path, fields, shading.material())
    return True


def _field_request(
    volume: Usd.Prim,
    name: str,
    field_path: Sdf.Path,
    slot: str,
    reader: SampleReader,
    warn: Callable[[str], None],
    path: str,
) -> tuple[str, str, int] | None:
    """(file, grid name, grid index) of field ``name`` for ``slot``; ``None`` after a warning
    naming the volume, the field and the file when it cannot feed the slot."""
    outcome = "the volume is skipped" if slot == "density" else f"its {slot} slot is dropped"
    where = f"{path}: field {name} ({field_path})"
    field_prim = volume.GetStage().GetPrimAtPath(field_path)
    if not field_prim or not field_prim.IsA(UsdVol.OpenVDBAsset):
        type_name = field_prim.GetTypeName() or "typeless" if field_prim else ""
        kind = f"is a {type_name} prim" if field_prim else "does not exist"
        warn(f"{where} {kind}, not an OpenVDBAsset; {outcome}")
        return None
    asset = UsdVol.OpenVDBAsset(field_prim)
    file = reader.get(asset.GetFilePathAttr())
    if not isinstance(file, Sdf.AssetPath) or not file.path:
        warn(f"{where}: no filePath; {outcome}")
        return None
    if not file.resolvedPath:
        warn(f"{where}: file {file.path} not found; {outcome}")
        return None
    grid = reader.get(asset.GetFieldNameAttr()) or name
    index = reader.get(asset.GetFieldIndexAttr())
    index = 0 if index is None else index  # unauthored or blocked: the first of the name
    # The render delegate takes the index as a C++ int: an int of another width (int64, uint)
    # outside its range would not convert, a float or a string is no index.
    if type(index) is not int:
        warn(f"{where}: fieldIndex {index!r} is a {type(index).__name__}, not an int; {outcome} "
             f"(file {file.resolvedPath})")
        return None
    if not 0 <= index <= INT32_MAX:
        warn(f"{where}: fieldIndex {index} is outside [0, {INT32_MAX}]; {outcome} "
             f"(file {file.resolvedPath})")
        return None
    data_type = reader.get(asset.GetFieldDataTypeAttr())
    if slot in SCALAR_SLOTS and data_type in _VECTOR_TYPES:
        warn(f"{where}: fieldDataType {data_type} is not a scalar, as the {slot} slot needs; "
             f"{outcome} (file {file.resolvedPath}, grid {grid})")
        return None
    return file.resolvedPath, str(grid), index
