"""Reading a UsdGeomBasisCurves, NurbsCurves or HermiteCurves prim into the delegate's curves
rprim (``set_curves``).

BasisCurves go as they are: type, basis, wrap, curveVertexCounts, positions over the shutter
(:func:`~.motion.point_samples`: deformation, velocities and accelerations), widths (diameters
of round tubes, or ribbon widths; unauthored: 1.0 constant, as Hydra's Storm draws them, since
the schema has no fallback), normals (ribbons facing them; none: round tubes), displayColor and
the other numeric primvars (displayOpacity among them), each with its interpolation; a single
value is the whole prim's whatever its interpolation (``widths = [w]`` without metadata is vertex),
as Hydra's Storm reads it. NurbsCurves and HermiteCurves are converted to BasisCurves first
(:mod:`.curve_conversions`).

Every array is read in bulk (Vt arrays through numpy's buffer protocol) and passed flat: a groom
of a million strands costs no Python loop per strand. What the renderer's validation rejects
(counts that do not match, too few vertices for the basis, normals of the wrong length) is
warned of by the delegate, naming the prim, and the prim is skipped.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from pxr import Usd, UsdGeom

from .curve_conversions import BasisCurves, hermite_to_bezier, nurbs_to_basis
from .mesh import as_int32_array, as_vec3_array, display_color, gprim_primvars
from .sampling import SampleReader, primvar_over_attribute
from .skinning import SkelCaches, positions_over_shutter

DEFAULT_WIDTH = 1.0
"""The width of curves whose widths are not authored (Hydra's Storm uses it too)."""
WIDTHS = frozenset({"widths"})  # read by _widths, not a primvar for materials

CURVE_TYPES = ("linear", "cubic")
CURVE_BASES = ("bezier", "bspline", "catmullRom")
CURVE_WRAPS = ("nonperiodic", "periodic", "pinned")

_NO_VECTORS = np.zeros((0, 3), dtype=np.float32)
_NO_COUNTS = np.zeros(0, dtype=np.int32)


def sync_curves_data(
    core,
    prim: Usd.Prim,
    reader: SampleReader,
    warn: Callable[[str], None],
    path: str,
    skel_caches: SkelCaches | None = None,
) -> bool:
    """Push the data of curves ``prim`` (BasisCurves, NurbsCurves or HermiteCurves) as delegate
    prim ``path``; ``False`` when it cannot render: without points (silently: empty curves are
    legitimate), or with unusable data (after one warning naming the prim and the attribute).
    Skinned curves are posed (:mod:`.skinning`; ``skel_caches``: those of the caller's sync)."""
    gprim = UsdGeom.Curves(prim)
    positions = as_vec3_array(reader.get(gprim.GetPointsAttr()))
    if positions is None or len(positions) == 0:
        return False
    authored = reader.get(gprim.GetCurveVertexCountsAttr())
    counts = _NO_COUNTS if authored is None else as_int32_array(authored)
    if counts is None:  # larger integers would wrap into plausible small counts
        warn(
            f"{path}: curveVertexCounts ({type(authored).__name__}) is not an array of 32-bit "
            "integers; skipped"
        )
        return False
    if (counts < 0).any():
        warn(f"{path}: curveVertexCounts has negative counts; skipped")
        return False
    if counts.sum() != len(positions):
        warn(
            f"{path}: curveVertexCounts add up to {int(counts.sum())} for {len(positions)} "
            "points; skipped"
        )
        return False
    positions = positions_over_shutter(gprim, positions, reader, warn, path, skel_caches)
    curves = _basis_curves(prim, counts, positions, reader, warn, path)
    if curves is None:
        return False
    widths = _widths(gprim, reader, curves, warn, path)
    if widths is None:
        return False
    normals = _normals(gprim, reader, curves, warn, path)
    if normals is None:
        return False
    colors, color_interpolation = curves.remap(
        *display_color(prim, reader, warn, path), "primvars:displayColor", warn, path
    )
    primvars = {}
    for name, (values, interpolation) in gprim_primvars(
        prim, reader, warn, path, dedicated=WIDTHS
    ).items():
        mapped = curves.remap(values, interpolation, f"primvars:{name}", warn, path)
        if mapped[0] is not None:
            primvars[name] = mapped
    core.set_curves(
        path,
        type=curves.type,
        basis=curves.basis,
        wrap=curves.wrap,
        curve_vertex_counts=curves.counts,
        positions=curves.positions,
        widths=widths[0],
        widths_interpolation=widths[1],
        normals=normals[0],
        normals_interpolation=normals[1],
        display_color=_NO_VECTORS if colors is None else colors,
        display_color_interpolation=color_interpolation,
        primvars=primvars,
    )
    return True


def _basis_curves(
    prim: Usd.Prim,
    counts: np.ndarray,
    positions: np.ndarray,
    reader: SampleReader,
    warn: Callable[[str], None],
    path: str,
) -> BasisCurves | None:
    """``prim``'s curves as BasisCurves (NURBS and Hermite curves converted); ``None`` after a
    warning naming the attribute when they cannot be."""
    if prim.IsA(UsdGeom.NurbsCurves):
        return nurbs_to_basis(UsdGeom.NurbsCurves(prim), counts, positions, reader, warn, path)
    if prim.IsA(UsdGeom.HermiteCurves):
        return hermite_to_bezier(UsdGeom.HermiteCurves(prim), counts, positions, reader, warn, path)
    curves = UsdGeom.BasisCurves(prim)
    curve_type = _token(curves.GetTypeAttr(), CURVE_TYPES, reader, warn, path)
    wrap = curve_type and _token(curves.GetWrapAttr(), CURVE_WRAPS, reader, warn, path)
    if not wrap:
        return None
    if curve_type == "linear":
        return BasisCurves(curve_type, "bezier", wrap, counts, positions)  # no basis
    basis = _token(curves.GetBasisAttr(), CURVE_BASES, reader, warn, path)
    return BasisCurves(curve_type, basis, wrap, counts, positions) if basis else None


def _token(
    attr: Usd.Attribute,
    known: tuple[str, ...],
    reader: SampleReader,
    warn: Callable[[str], None],
    path: str,
) -> str | None:
    """The value of token attribute ``attr``; ``None`` (after a warning naming the prim and the
    attribute) when it is not one of ``known``."""
    value = str(reader.get(attr))
    if value in known:
        return value
    warn(f"{path}: {attr.GetName()} {value!r} is not one of {', '.join(known)}; skipped")
    return None


def _widths(
    gprim: UsdGeom.Curves,
    reader: SampleReader,
    curves: BasisCurves,
    warn: Callable[[str], None],
    path: str,
) -> tuple[np.ndarray, str] | None:
    """The widths (primvars:widths over widths) as float32 (M,) with their interpolation, as
    the converted curves take them; ``None`` (after a warning naming the prim and ``widths``)
    when one is negative or not finite, or they cannot be converted."""
    name, values, interpolation = primvar_over_attribute(
        gprim, reader, UsdGeom.Tokens.widths, gprim.GetWidthsAttr(),
        gprim.GetWidthsInterpolation(),
    )
    if values is None or len(values) == 0:
        if name != UsdGeom.Tokens.widths:  # e.g. indices that do not fit its values
            warn(f"{path}: {name} is authored but has no usable values; skipped")
            return None
        return np.full(1, DEFAULT_WIDTH, dtype=np.float32), UsdGeom.Tokens.constant
    widths = np.asarray(values, dtype=np.float32).reshape(-1)
    if not (np.isfinite(widths) & (widths >= 0)).all():
        warn(f"{path}: {name} must be finite and not negative; skipped")
        return None
    widths, interpolation = curves.remap(widths, interpolation, name, warn, path, "skipped")
    return None if widths is None else (widths, interpolation)


def _normals(
    gprim: UsdGeom.Curves,
    reader: SampleReader,
    curves: BasisCurves,
    warn: Callable[[str], None],
    path: str,
) -> tuple[np.ndarray, str] | None:
    """The normals ribbons face (primvars:normals over normals), float32 (M, 3), with their
    interpolation; none (round tubes) when neither is authored; ``None`` (after a warning) when
    they cannot be converted with the curves."""
    name, values, interpolation = primvar_over_attribute(
        gprim, reader, UsdGeom.Tokens.normals, gprim.GetNormalsAttr(),
        gprim.GetNormalsInterpolation(),
    )
    if values is None:
        return _NO_VECTORS, UsdGeom.Tokens.vertex
    normals = as_vec3_array(values)
    if normals is None or len(normals) == 0:
        return _NO_VECTORS, UsdGeom.Tokens.vertex
    normals, interpolation = curves.remap(normals, interpolation, name, warn, path, "skipped")
    return None if normals is None else (normals, interpolation)
