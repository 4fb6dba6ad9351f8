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
    """A subset's material and the faces it binds (valid indices of the mesh's faces)."""

    subset: Sdf.Path
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


def read_subset_bindings(
    prim: Usd.Prim, time: Usd.TimeCode, warn: Callable[[str], None]
) -> SubsetBindings:
    """The subset bindings of mesh ``prim`` at ``time``. A subset that resolves no material
    leaves its faces to the mesh's own binding; one of another element type than faces, and
    indices outside the mesh's faces, are left out with a warning naming the subset."""
    subsets = material_subsets(prim)
    if not subsets:
        return SubsetBindings([])
    face_count = len(UsdGeom.Mesh(prim).GetFaceVertexCountsAttr().Get(time) or ())
    bindings: list[SubsetBinding] = []
    varying = False
    for subset, material in zip(subsets, bound_materials([s.GetPrim() for s in subsets])):
        if material is None:
            continue
        where = subset.GetPath()
        element_type = subset.GetElementTypeAttr().Get()
        if element_type != UsdGeom.Tokens.face:
            warn(
                f"{where}: a material subset of elementType {element_type!r} is not supported "
                "(only 'face'); its faces use the mesh's own material"
            )
            continue
        attribute = subset.GetIndicesAttr()
        varying = varying or attribute.ValueMightBeTimeVarying()
        indices = np.asarray(attribute.Get(time) or (), dtype=np.int64).reshape(-1)
        outside = (indices < 0) | (indices >= face_count)
        if outside.any():
            warn(
                f"{attribute.GetPath()}: {int(outside.sum())} of {indices.size} indices are not "
                f"faces of the mesh (it has {face_count}); they are left out"
            )
            indices = indices[~outside]
        bindings.append(SubsetBinding(where, material, indices.astype(np.int32)))
    return SubsetBindings(bindings, varying)
