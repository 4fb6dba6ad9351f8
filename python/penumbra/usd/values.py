"""What kind of value an attribute holds. USD hands a number attribute's value to Python as an
``int`` or a ``float`` (half, float and double alike), a bool as a ``bool`` (which Python counts
as an ``int``), a color3f as a ``Gf.Vec3f``; an attribute authored with a wrong or an unknown
type holds anything else, which the readers reject with a warning naming it."""

from __future__ import annotations

from numbers import Real
from typing import Any

from pxr import Gf, Sdf

# The types USD hands most values as, answered without the checks below (which cost some
# microseconds each: a stage with thousands of lights reads tens of thousands of inputs).
_NUMBER_TYPES = (float, int)
_VECTOR3_TYPES = (Gf.Vec3f, Gf.Vec3d, Gf.Vec3h)


FLOAT32_MAX = 3.4028234663852886e38
"""The largest finite single-precision number: the render delegate takes numbers as such."""


def is_finite_float32(x: float) -> bool:
    """Whether the number ``x`` stays finite in single precision (NaN does not)."""
    return abs(x) <= FLOAT32_MAX


def is_number_value(value: Any) -> bool:
    """Whether an attribute's value is a number (a float, double, half or integer), not a bool."""
    if type(value) in _NUMBER_TYPES:
        return True
    return isinstance(value, Real) and not isinstance(value, bool)


def is_vector3_value(value: Any) -> bool:
    """Whether an attribute's value is one Gf 3-vector (a color3f, float3, vector3d…), not an
    array nor another sequence of three numbers."""
    return type(value) in _VECTOR3_TYPES


def is_color_value(value: Any) -> bool:
    """Whether an attribute's value is three numbers (a color3f, float3, vector3f…)."""
    if type(value) in _VECTOR3_TYPES:
        return True
    return not isinstance(value, (str, bytes)) and hasattr(value, "__len__") and \
        len(value) == 3 and all(is_number_value(v) for v in value)


def as_floats(value: Any) -> tuple[float, ...]:
    """A vector's components (a Gf vector's, a tuple's, a list's) as a tuple of floats. Read by
    index: iterating a Gf vector ends by an IndexError, which costs some 25 µs a vector."""
    return tuple(float(value[i]) for i in range(len(value)))


def as_asset_path(value: Any) -> Sdf.AssetPath | None:
    """An attribute's value as an asset path: an asset as it is, a string (a path authored as
    a string) made one; ``None`` for anything else (no value, or a wrong or unknown type)."""
    if isinstance(value, Sdf.AssetPath):
        return value
    if isinstance(value, str):
        return Sdf.AssetPath(value)
    return None
