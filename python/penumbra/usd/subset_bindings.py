"""Per-face material bindings: the GeomSubsets of family "materialBind" under a mesh, each of
which UsdShade lets bind a material of its own to the mesh's faces it lists."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdShade

from .material import bound_materials


@dataclass(frozen=True)
class SubsetBinding:
    """A subset's material and the faces it binds (indices not negative; those past the mesh's
    faces bind nothing while it has not that many)."""

    material: Sdf.Path
    faces: np.ndarray  # int32


@dataclass(frozen=True)
class SubsetBindings:
    """A mesh's subset bindings in the subsets' order (the first binds a face where two list
    it), and whether their faces might change with time."""

    bindings: list[SubsetBinding]
    varying: bool = False


def material_subsets(prim: Usd.Prim) -> list[UsdGeom.Subset]:
    """The subsets of ``prim`` that bind materials (family "materialBind"); subsets are
    children, so a prim without children has none and costs no query."""
    if not prim.GetChildrenNames():
        return []
    return UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets()


def subset_materials(subsets: list[Usd.Prim]) -> tuple[Sdf.Path | None, ...]:
    """The materials bound to the prims of ``subsets`` (subsets, or their instance proxies), in
    one batch; ``None`` where a subset resolves none (its faces keep the mesh's binding)."""
    return tuple(bound_materials(subsets))


def read_subset_faces(
    prim: Usd.Prim, time: Usd.TimeCode, warn: Callable[[str], None]
) -> tuple[list[np.ndarray | None], bool]:
    """The faces each material subset of mesh ``prim`` binds at ``time`` (as
    :func:`material_subsets` orders them; ``None`` for a subset of another element type than
    faces), and whether they might change with time. Such subsets, and negative indices, are
    left out with a warning naming the subset; indices past the mesh's faces at ``time`` are
    named too, and kept: they bind the faces the mesh may gain at other times."""
    subsets = material_subsets(prim)
    if not subsets:
        return [], False
    face_count = len(UsdGeom.Mesh(prim).GetFaceVertexCountsAttr().Get(time) or ())
    faces: list[np.ndarray | None] = []
    varying = False
    for subset in subsets:
        element_type = subset.GetElementTypeAttr().Get()
        if element_type != UsdGeom.Tokens.face:
            warn(
                f"{subset.GetPath()}: a material subset of elementType {element_type!r} is not "
                "supported (only 'face'); its faces use the mesh's own material"
            )
            faces.append(None)
            continue
        attribute = subset.GetIndicesAttr()
        varying = varying or attribute.ValueMightBeTimeVarying()
        indices = np.asarray(attribute.Get(time) or (), dtype=np.int64).reshape(-1)
        negative = indices < 0
        if negative.any():
            warn(
                f"{attribute.GetPath()}: {int(negative.sum())} of {indices.size} indices are "
                "negative; they are left out"
            )
        beyond = indices >= face_count
        if beyond.any():
            warn(
                f"{attribute.GetPath()}: {int(beyond.sum())} of {indices.size} indices are not "
                f"faces of the mesh (it has {face_count} at time {time}); they bind no face while "
                "it has not"
            )
        kept = indices[~negative & (indices <= np.iinfo(np.int32).max)]
        faces.append(kept.astype(np.int32))
    return faces, varying


def bound_faces(
    materials: tuple[Sdf.Path | None, ...], faces: list[np.ndarray | None]
) -> list[tuple[Sdf.Path, np.ndarray]]:
    """(material, faces) of each subset that binds both (its material resolved, its faces
    read), in the subsets' order."""
    return [
        (material, indices)
        for material, indices in zip(materials, faces)
        if material is not None and indices is not None
    ]


def read_subset_bindings(
    prim: Usd.Prim, time: Usd.TimeCode, warn: Callable[[str], None]
) -> SubsetBindings:
    """The subset bindings of mesh ``prim`` at ``time`` (see :func:`read_subset_faces`)."""
    subsets = material_subsets(prim)
    if not subsets:
        return SubsetBindings([])
    faces, varying = read_subset_faces(prim, time, warn)
    materials = subset_materials([subset.GetPrim() for subset in subsets])
    return SubsetBindings(
        [SubsetBinding(material, indices) for material, indices in bound_faces(materials, faces)],
        varying,
    )


def copies_subset_materials(
    meshes: list[Usd.Prim], copies: list[Usd.Prim]
) -> list[tuple[Sdf.Path | None, ...]]:
    """For each copy of an instanced mesh (the mesh's prim, and the prim the copy is rendered as:
    an instance proxy, or the mesh itself), the materials the mesh's material subsets bind,
    resolved on the copy's own subset prims as its mesh's binding is on it; ``()`` for meshes
    without such subsets. One batch for all copies."""
    # The subsets' names, None for those whose faces are not read (another element type).
    names: dict[Sdf.Path, list[str | None]] = {}
    for mesh in meshes:
        if mesh.GetPath() not in names:
            names[mesh.GetPath()] = (
                [
                    subset.GetPrim().GetName()
                    if subset.GetElementTypeAttr().Get() == UsdGeom.Tokens.face
                    else None
                    for subset in material_subsets(mesh)
                ]
                if mesh.GetTypeName() == "Mesh"
                else []
            )
    subsets = [
        copy.GetChild(name)
        for mesh, copy in zip(meshes, copies)
        for name in names[mesh.GetPath()]
        if name is not None
    ]
    if not subsets:
        return [(None,) * len(names[mesh.GetPath()]) for mesh in meshes]
    materials = iter(subset_materials(subsets))
    return [
        tuple(None if name is None else next(materials) for name in names[mesh.GetPath()])
        for mesh in meshes
    ]


def warn_subset_bindings(
    prim: Usd.Prim, name: Sdf.Path | str, warn: Callable[[str], None]
) -> None:
    """Warn (naming the prim ``name``, as users know it) that ``prim``'s GeomSubset bindings
    are ignored: a gprim other than a mesh has no authored faces to bind."""
    if material_subsets(prim):
        warn(
            f"{name}: per-face material bindings (GeomSubsets) are read on Mesh prims only; "
            f"this {prim.GetTypeName()}'s own binding is used"
        )
