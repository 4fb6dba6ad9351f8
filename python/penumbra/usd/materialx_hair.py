"""MaterialX's hair nodes (pbrlib: chiang_hair_absorption_from_color,
deon_hair_absorption_from_melanin, chiang_hair_roughness) evaluated on constants, and
chiang_hair_bsdf's per-lobe roughness (longitudinal variance v, azimuthal scale s) turned back
into the renderer's β_m, β_n and TT/TRT scales (renderer/include/penumbra/hair_bsdf.h,
docs/materialx.md)."""

from __future__ import annotations

import math
from collections.abc import Callable

LOBES = ("R", "TT", "TRT")
# MaterialX clamps roughness parameters and the (v, s) pairs to this range.
_LOW, _HIGH = 0.001, 1.0


def _clamp(value: float, low: float = _LOW, high: float = _HIGH) -> float:
    return min(max(value, low), high)


def absorption_from_color(color: tuple[float, ...],
                          azimuthal_roughness: float) -> tuple[float, ...]:
    """σa giving the multiply scattered colour ``color`` (Chiang et al. 2016, eq. 9), the colour
    clamped to [0.001, 1] as MaterialX does."""
    b = azimuthal_roughness
    denominator = (5.969 - 0.215 * b + 2.532 * b**2 - 10.73 * b**3 + 5.574 * b**4
                   + 0.245 * b**5)
    return tuple((math.log(_clamp(c)) / denominator) ** 2 for c in color)


def absorption_from_melanin(concentration: float, redness: float,
                            eumelanin_color: tuple[float, ...],
                            pheomelanin_color: tuple[float, ...]) -> tuple[float, ...]:
    """σa of ``concentration`` melanin, the fraction ``redness`` of it pheomelanin (d'Eon et al.
    2011, as MaterialX's deon_hair_absorption_from_melanin)."""
    melanin = -math.log(max(1.0 - concentration, 1e-4))
    eumelanin, pheomelanin = melanin * (1.0 - redness), melanin * redness
    return tuple(max(-eumelanin * math.log(max(e, 1e-30)) - pheomelanin * math.log(max(p, 1e-30)),
                     0.0) for e, p in zip(eumelanin_color, pheomelanin_color))


def longitudinal_variance(beta: float) -> float:
    """v from β_m (eq. 7)."""
    return (0.726 * beta + 0.812 * beta**2 + 3.7 * beta**20) ** 2


def azimuthal_scale(beta: float) -> float:
    """MaterialX's s from β_n (eq. 8 without the √(π/8), which its BSDF applies)."""
    return 0.265 * beta + 1.194 * beta**2 + 5.372 * beta**22


def roughness(longitudinal: float, azimuthal: float, scale_tt: float,
              scale_trt: float) -> dict[str, tuple[float, float]]:
    """chiang_hair_roughness's outputs: (v, s) of each lobe, by output name."""
    v = longitudinal_variance(_clamp(longitudinal))
    s = azimuthal_scale(_clamp(azimuthal))
    return {"roughness_R": (v, s), "roughness_TT": (v * scale_tt**2, s),
            "roughness_TRT": (v * scale_trt**2, s)}


def _inverse(function: Callable[[float], float], value: float) -> float:
    """The β in [0, 1] at which the increasing ``function`` takes ``value`` (bisection)."""
    low, high = 0.0, 1.0
    value = min(max(value, function(low)), function(high))
    for _ in range(60):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if function(middle) < value else (low, middle)
    return 0.5 * (low + high)


def parameters_from_lobes(lobes: dict[str, tuple[float, float]]) -> dict[str, float]:
    """The renderer's parameters for chiang_hair_bsdf's (v, s) per lobe (``lobes``: by input
    name, clamped to [0.001, 1] as MaterialX does): β_m and β_n from R's, the other lobes' as
    scales of R's."""
    (v_r, s_r), (v_tt, s_tt), (v_trt, s_trt) = (
        tuple(_clamp(x) for x in lobes[f"roughness_{lobe}"]) for lobe in LOBES)
    return {
        "penumbra:hairLongitudinalRoughness": _inverse(longitudinal_variance, v_r),
        "penumbra:hairAzimuthalRoughness": _inverse(azimuthal_scale, s_r),
        "penumbra:hairLongitudinalScaleTT": math.sqrt(v_tt / v_r),
        "penumbra:hairLongitudinalScaleTRT": math.sqrt(v_trt / v_r),
        "penumbra:hairAzimuthalScaleTT": s_tt / s_r,
        "penumbra:hairAzimuthalScaleTRT": s_trt / s_r,
    }
