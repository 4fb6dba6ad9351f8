"""What the volume material readers (``principled_volume``, ``materialx_volumes``) share: one
warning per problem naming the volume, and the checks every value passes before it reaches
the renderer's ``VolumeMaterial`` (finite, non-negative, anisotropy inside (−1, 1))."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from pxr import Sdf

Color = tuple[float, float, float]

# Henyey–Greenstein g of ±1 is a delta; the renderer takes (−1, 1), so authored values are
# clamped a little inside.
MAX_ANISOTROPY = 0.99


class VolumeWarnings:
    """``warn`` for one volume: each message is prefixed by the volume's path and said once."""

    def __init__(self, volume: Sdf.Path, warn: Callable[[str], None]):
        self._volume = volume
        self._warn = warn
        self._said: set[str] = set()

    def __call__(self, message: str) -> None:
        text = f"{self._volume}: {message}"
        if text not in self._said:
            self._said.add(text)
            self._warn(text)


def checked_color(values: Sequence[float], default: Color,
                  report: Callable[[str], None]) -> Color:
    """``values`` as a colour of finite, non-negative components; else ``default`` after
    ``report``."""
    if len(values) != 3 or not all(math.isfinite(v) and v >= 0 for v in values):
        report(f"{_shown(values)} is not a colour of finite, non-negative values; "
               f"{_shown(default)} is used")
        return default
    return (float(values[0]), float(values[1]), float(values[2]))


def checked_number(value: float, default: float, report: Callable[[str], None]) -> float:
    """``value`` if finite and non-negative; else ``default`` after ``report``."""
    if not (math.isfinite(value) and value >= 0):
        report(f"{value:g} is not a finite, non-negative number; {default:g} is used")
        return default
    return float(value)


def checked_anisotropy(value: float, report: Callable[[str], None]) -> float:
    """A Henyey–Greenstein g: NaN gives 0, values outside (−0.99, 0.99) are clamped, each
    after ``report``."""
    if math.isnan(value):
        report("is not a number; 0 is used")
        return 0.0
    if abs(value) > MAX_ANISOTROPY:
        clamped = math.copysign(MAX_ANISOTROPY, value)
        report(f"{value:g} is outside (−1, 1) as a phase function needs; clamped to "
               f"{clamped:g}")
        return clamped
    return float(value)


def _shown(values: Sequence[float]) -> str:
    return "(" + ", ".join(f"{v:g}" for v in values) + ")"
