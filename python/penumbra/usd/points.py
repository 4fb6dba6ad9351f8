"""Reading a UsdGeomPoints prim into the delegate's points rprim (``set_points``).

Positions (sampled over the shutter as mesh points are, :func:`~.motion.point_samples`), widths
(diameters; constant or one per point; unauthored: 1.0, as Hydra's Storm draws them, since the
schema has no fallback), normals (discs facing them; none: spheres), displayColor and the other
numeric primvars. A single value of any interpolation is the whole prim's (uniform means one
value for the prim, which is one element, as hdPrman reads it; Hydra's Storm reads one vertex
value so too); one value per point is per point whatever the interpolation says. Counts that fit
neither are warned of naming the authored interpolation: widths then skip the prim, normals
leave spheres, and a colour or primvar is dropped (its fallback used), as a mesh's is.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pxr import Usd, UsdGeom

from .mesh import as_vec3_array, display_color, gprim_primvars
from .sampling import SampleReader, primvar_over_attribute
from .skinning import SkelCaches, positions_over_shutter

DEFAULT_WIDTH = 1.0
"""The diameter of points whose widths are not authored (Hydra's Storm uses it too)."""

_NO_NORMALS = np.zeros((0, 3), dtype=np.float32)


def sync_points_data(
    core,
    prim: Usd.Prim,
    reader: SampleReader,
    warn: Callable[[str], None],
    path: str,
    skel_caches: SkelCaches | None = None,
) -> bool:
    """Push the data of Points ``prim`` as delegate prim ``path``; ``False`` when it cannot
    render: without points (silently: an empty Points is legitimate), or with unusable widths
    (after one warning naming the prim and the attribute). A skinned Points is posed
    (:mod:`.skinning`; ``skel_caches``: those of the caller's sync)."""
    points = UsdGeom.Points(prim)
    positions = as_vec3_array(reader.get(points.GetPointsAttr()))
    if positions is None or len(positions) == 0:
        return False
    count = len(positions)
    widths = _widths(points, reader, count, warn, path)
    if widths is None:
        return False
    # Colours and primvars that fit neither the prim nor its points are dropped, as a mesh's
    # are: the points still render, with the fallbacks.
    colors, color_interpolation = display_color(prim, reader, warn, path)
    if len(colors):  # none: the delegate's fallback colour
        color_interpolation = _per_point(
            colors, color_interpolation, count, "primvars:displayColor", warn, path,
            "the fallback colour is used",
        )
        if color_interpolation is None:
            colors, color_interpolation = colors[:0], UsdGeom.Tokens.constant
    primvars = {}
    for name, (values, interpolation) in gprim_primvars(prim, reader, warn, path).items():
        taken = _per_point(
            values, interpolation, count, f"primvars:{name}", warn, path,
            "materials reading it use their fallback",
        )
        if taken is not None:
            primvars[name] = (values, taken)
    positions = positions_over_shutter(points, positions, reader, warn, path, skel_caches)
    core.set_points(
        path,
        positions=positions,
        widths=widths,
        normals=_normals(points, reader, count, warn, path),
        display_color=colors,
        display_color_interpolation=color_interpolation,
        primvars=primvars,
    )
    return True


def _per_point(
    values: np.ndarray,
    interpolation: str,
    count: int,
    attribute: str,
    warn: Callable[[str], None],
    path: str,
    consequence: str,
) -> str | None:
    """The interpolation with which the delegate takes ``values`` (authored with
    ``interpolation``) on ``count`` points: constant for a single value (of any
    interpolation: uniform is one value for the whole prim, which is one element) and for
    constant arrays (the delegate judges those), else vertex for one value per point (whatever
    the interpolation says: exporters write per-point data as uniform too, and it can only
    mean that); ``None`` after a warning naming the prim, ``attribute``, its authored
    interpolation and the ``consequence`` when their count fits neither."""
    if len(values) == 1 or interpolation == UsdGeom.Tokens.constant:
        return UsdGeom.Tokens.constant
    if len(values) == count:
        return UsdGeom.Tokens.vertex
    warn(_count_problem(path, attribute, interpolation, len(values), count, consequence))
    return None


def _count_problem(
    path: str, attribute: str, interpolation: str, values: int, count: int, consequence: str
) -> str:
    return (f"{path}: {attribute} ({interpolation}) has {values} values, expected 1 or {count} "
            f"(one per point); {consequence}")


def _one_per_point(
    values: np.ndarray,
    interpolation: str,
    count: int,
    attribute: str,
    warn: Callable[[str], None],
    path: str,
    consequence: str,
) -> np.ndarray | None:
    """Widths or normals ``values`` as one per point (a single value repeated); ``None`` after
    a warning (see :func:`_per_point`) when their count fits neither. One per point is read as
    one per point whatever the interpolation says (constant too: a width or a normal is one
    number or vector, so the array cannot be the prim's single value)."""
    if len(values) == count:  # one per point, whatever the interpolation says
        return values
    if len(values) == 1:
        return np.repeat(values, count, axis=0)
    warn(_count_problem(path, attribute, interpolation, len(values), count, consequence))
    return None


def _widths(
    points: UsdGeom.Points,
    reader: SampleReader,
    count: int,
    warn: Callable[[str], None],
    path: str,
) -> np.ndarray | None:
    """One diameter per point (primvars:widths over widths) as float32 (N,); ``None`` (after a
    warning naming the prim and the attribute) when their count fits neither one value for the
    prim nor one per point (see :func:`_per_point`), or one is negative or not finite."""
    name, values, interpolation = primvar_over_attribute(
        points, reader, UsdGeom.Tokens.widths, points.GetWidthsAttr(),
        points.GetWidthsInterpolation(),
    )
    if values is None or len(values) == 0:
        return np.full(count, DEFAULT_WIDTH, dtype=np.float32)
    widths = np.asarray(values, dtype=np.float32).reshape(-1)
    widths = _one_per_point(widths, interpolation, count, name, warn, path, "skipped")
    if widths is None:
        return None
    if not (np.isfinite(widths) & (widths >= 0)).all():
        warn(f"{path}: {name} must be finite and not negative; skipped")
        return None
    return widths


def _normals(
    points: UsdGeom.Points,
    reader: SampleReader,
    count: int,
    warn: Callable[[str], None],
    path: str,
) -> np.ndarray:
    """The normals the points' discs face (primvars:normals over normals), float32 (N, 3);
    none (spheres) when neither is authored, or (after a warning) when their count fits
    neither one value for the prim nor one per point (see :func:`_per_point`)."""
    name, values, interpolation = primvar_over_attribute(
        points, reader, UsdGeom.Tokens.normals, points.GetNormalsAttr(),
        points.GetNormalsInterpolation(),
    )
    if values is None:
        return _NO_NORMALS
    normals = as_vec3_array(values)
    if normals is None or len(normals) == 0:
        return _NO_NORMALS
    normals = _one_per_point(
        normals, interpolation, count, name, warn, path, "rendered as spheres"
    )
    return _NO_NORMALS if normals is None else np.ascontiguousarray(normals)
