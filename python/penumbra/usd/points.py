"""Reading a UsdGeomPoints prim into the delegate's points rprim (``set_points``).

Positions (sampled over the shutter as mesh points are, :func:`~.motion.point_samples`), widths
(diameters; constant or one per point; unauthored: 1.0, as Hydra's Storm draws them, since the
schema has no fallback), normals (discs facing them; none: spheres), displayColor and the other
numeric primvars. Uniform and varying interpolation mean one value per point here, as vertex.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pxr import Usd, UsdGeom

from .mesh import as_vec3_array, display_color, gprim_primvars
from .motion import point_samples
from .sampling import SampleReader, primvar_over_attribute

DEFAULT_WIDTH = 1.0
"""The diameter of points whose widths are not authored (Hydra's Storm uses it too)."""

_NO_NORMALS = np.zeros((0, 3), dtype=np.float32)


def sync_points_data(
    core, prim: Usd.Prim, reader: SampleReader, warn: Callable[[str], None], path: str
) -> bool:
    """Push the data of Points ``prim`` as delegate prim ``path``; ``False`` when it cannot
    render: without points (silently: an empty Points is legitimate), or with unusable widths
    (after one warning naming the prim and the attribute)."""
    points = UsdGeom.Points(prim)
    positions = as_vec3_array(reader.get(points.GetPointsAttr()))
    if positions is None or len(positions) == 0:
        return False
    widths = _widths(points, reader, len(positions), warn, path)
    if widths is None:
        return False
    if reader.shutter.blurred or points.GetVelocitiesAttr().HasAuthoredValue():
        positions = point_samples(points, positions, reader, warn, path)
    colors, color_interpolation = display_color(prim, reader, warn, path)
    core.set_points(
        path,
        positions=positions,
        widths=widths,
        normals=_normals(points, reader, len(positions), warn, path),
        display_color=colors,
        display_color_interpolation=_per_point(color_interpolation),
        primvars={
            name: (values, _per_point(interpolation))
            for name, (values, interpolation) in gprim_primvars(prim, reader, warn, path).items()
        },
    )
    return True


def _per_point(interpolation: str) -> str:
    """A primvar interpolation as points take it: constant, or one value per point."""
    return "constant" if interpolation == UsdGeom.Tokens.constant else "vertex"


def _widths(
    points: UsdGeom.Points,
    reader: SampleReader,
    count: int,
    warn: Callable[[str], None],
    path: str,
) -> np.ndarray | None:
    """One diameter per point (primvars:widths over widths) as float32 (N,); ``None`` (after a
    warning naming the prim and the attribute) when their count fits neither constant nor
    per-point interpolation, or one is not finite or not positive."""
    name, values, interpolation = primvar_over_attribute(
        points, reader, UsdGeom.Tokens.widths, points.GetWidthsAttr(),
        points.GetWidthsInterpolation(),
    )
    if values is None or len(values) == 0:
        return np.full(count, DEFAULT_WIDTH, dtype=np.float32)
    widths = np.asarray(values, dtype=np.float32).reshape(-1)
    constant = interpolation == UsdGeom.Tokens.constant
    if len(widths) == 1 and (constant or count != 1):
        widths = np.full(count, widths[0], dtype=np.float32)
    if len(widths) != count:
        warn(f"{path}: {name} has {len(widths)} values for {count} points; skipped")
        return None
    if not (np.isfinite(widths) & (widths > 0)).all():
        warn(f"{path}: {name} must be finite and greater than 0; skipped")
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
    neither one per point nor a constant."""
    name, values, _ = primvar_over_attribute(
        points, reader, UsdGeom.Tokens.normals, points.GetNormalsAttr(),
        points.GetNormalsInterpolation(),
    )
    if values is None:
        return _NO_NORMALS
    normals = as_vec3_array(values)
    if normals is None or len(normals) == 0:
        return _NO_NORMALS
    if len(normals) == 1 and count != 1:
        normals = np.repeat(normals, count, axis=0)
    if len(normals) != count:
        warn(f"{path}: {name} has {len(normals)} values for {count} points; rendered as spheres")
        return _NO_NORMALS
    return np.ascontiguousarray(normals)
