"""The values a MaterialX pattern network reduces to, and the arithmetic Penumbra can fold.

The renderer evaluates per shading point only what UsdPreviewSurface networks give it: one
texture lookup (with a per-channel scale and bias) or one primvar per input. A MaterialX network
is therefore reduced, node by node, to one of three values:

- :class:`Constant`: the network does not vary (constant folding of all arithmetic);
- :class:`Affine` over a texture: ``texture[channels] * scale + bias``;
- :class:`Affine` over a primvar: ``primvar[channels] * scale + bias`` (scale 1 and bias 0 when it
  drives a material input; any scale and bias when it gives a texture's coordinates).

Arithmetic between a varying value and a constant folds into the scale and bias; arithmetic
between two varying values cannot be represented and raises :class:`Untranslatable`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any


class Untranslatable(Exception):
    """A node or combination the renderer cannot evaluate; the message says why, ``node`` (set
    by the network reader) where."""

    def __init__(self, reason: str, node: Any = None):
        super().__init__(reason)
        self.node = node


@dataclass(frozen=True)
class Constant:
    values: tuple[float, ...]

    @property
    def size(self) -> int:
        return len(self.values)


@dataclass(frozen=True)
class Affine:
    """``source[channels] * scale + bias``, ``source`` being a texture description (the dict the
    delegate takes, without scale and bias) or a primvar name."""

    channels: tuple[int, ...]
    scale: tuple[float, ...]
    bias: tuple[float, ...]
    texture: dict[str, Any] | None = None
    primvar: str = ""
    fallback: tuple[float, ...] = ()  # primvars: the value where the mesh lacks the primvar

    @property
    def size(self) -> int:
        return len(self.channels)

    def __hash__(self) -> int:  # textures are dicts; identity is enough for this small algebra
        return id(self)


Value = Constant | Affine


def identity(size: int, *, texture: dict[str, Any] | None = None, primvar: str = "",
             fallback: tuple[float, ...] = ()) -> Affine:
    """The channels ``0..size-1`` of a texture or primvar, unscaled."""
    return Affine(tuple(range(size)), (1.0,) * size, (0.0,) * size, texture, primvar, fallback)


def resize(value: Value, size: int) -> Value:
    """``value`` with ``size`` components: a single component is broadcast, longer values are
    truncated (MaterialX's convert and the FA variants of arithmetic nodes), shorter ones padded
    with zeros (constants) — a varying value cannot be padded."""
    if value.size == size:
        return value
    if isinstance(value, Constant):
        if value.size == 1:
            return Constant(value.values * size)
        return Constant((value.values + (0.0,) * size)[:size])
    if value.size == 1:
        return replace(value, channels=value.channels * size, scale=value.scale * size,
                       bias=value.bias * size)
    if value.size > size:
        return replace(value, channels=value.channels[:size], scale=value.scale[:size],
                       bias=value.bias[:size])
    raise Untranslatable(f"cannot widen a {value.size}-channel input to {size} channels")


def _broadcast(a: Value, b: Value) -> tuple[Value, Value]:
    size = max(a.size, b.size)
    return resize(a, size), resize(b, size)


def affine(value: Value, scale: Constant, bias: Constant) -> Value:
    """``value * scale + bias``, component-wise."""
    size = max(value.size, scale.size, bias.size)
    value, scale, bias = resize(value, size), resize(scale, size), resize(bias, size)
    if isinstance(value, Constant):
        return Constant(tuple(v * s + b for v, s, b in zip(value.values, scale.values,
                                                             bias.values)))
    return replace(
        value,
        scale=tuple(v * s for v, s in zip(value.scale, scale.values)),
        bias=tuple(v * s + b for v, s, b in zip(value.bias, scale.values, bias.values)),
    )


def multiply(a: Value, b: Value) -> Value:
    a, b = _broadcast(a, b)
    if isinstance(b, Constant):
        return affine(a, b, Constant((0.0,) * b.size))
    if isinstance(a, Constant):
        return affine(b, a, Constant((0.0,) * a.size))
    raise Untranslatable("the product of two varying values")


def add(a: Value, b: Value) -> Value:
    a, b = _broadcast(a, b)
    if isinstance(b, Constant):
        return affine(a, Constant((1.0,) * b.size), b)
    if isinstance(a, Constant):
        return affine(b, Constant((1.0,) * a.size), a)
    raise Untranslatable("the sum of two varying values")


def negate(value: Value) -> Value:
    return affine(value, Constant((-1.0,)), Constant((0.0,)))


def reciprocal(value: Value) -> Value:
    if not isinstance(value, Constant):
        raise Untranslatable("division by a varying value")
    return Constant(tuple(1.0 / v if v != 0 else 0.0 for v in value.values))


def mix(foreground: Value, background: Value, amount: Value) -> Value:
    """MaterialX mix: ``background + (foreground − background) · amount``."""
    if foreground == background:
        return foreground
    if isinstance(amount, Constant) and set(amount.values) <= {0.0, 1.0} and len(
        set(amount.values)
    ) == 1:
        return foreground if amount.values[0] == 1.0 else background
    if isinstance(amount, Constant):
        one_minus = affine(amount, Constant((-1.0,)), Constant((1.0,)))
        return add(multiply(foreground, amount), multiply(background, one_minus))
    return add(multiply(amount, add(foreground, negate(background))), background)


def clamp(value: Value, low: Value, high: Value) -> Value:
    """Clamping folds on constants; on a texture it is exact only when the texture's range
    (assumed [0, 1] after scale and bias, as for 8- and 16-bit images) lies inside the bounds."""
    size = value.size
    low, high = resize(low, size), resize(high, size)
    if not isinstance(low, Constant) or not isinstance(high, Constant):
        raise Untranslatable("clamp with varying bounds")
    if isinstance(value, Constant):
        return Constant(tuple(min(max(v, lo), hi)
                              for v, lo, hi in zip(value.values, low.values, high.values)))
    for s, b, lo, hi in zip(value.scale, value.bias, low.values, high.values):
        if min(b, s + b) < lo or max(b, s + b) > hi:
            raise Untranslatable("clamp of a texture or primvar whose range exceeds the bounds")
    return value


def extract(value: Value, index: int) -> Value:
    if not 0 <= index < value.size:
        raise Untranslatable(f"channel {index} of a {value.size}-channel value")
    if isinstance(value, Constant):
        return Constant((value.values[index],))
    return replace(value, channels=(value.channels[index],), scale=(value.scale[index],),
                   bias=(value.bias[index],))


def combine(parts: list[Value]) -> Value:
    """MaterialX combineN: constants, or the channels of one texture or primvar in order."""
    if all(isinstance(p, Constant) for p in parts):
        return Constant(tuple(v for p in parts for v in p.values))  # type: ignore[union-attr]
    varying = [p for p in parts if isinstance(p, Affine)]
    first = varying[0]
    if len(varying) != len(parts) or any(
        p.texture is not first.texture or p.primvar != first.primvar for p in varying
    ):
        raise Untranslatable("combining channels of different sources")
    return replace(
        first,
        channels=tuple(c for p in varying for c in p.channels),
        scale=tuple(s for p in varying for s in p.scale),
        bias=tuple(b for p in varying for b in p.bias),
    )


def _rgba(value: Affine) -> tuple[str, list[float], list[float]]:
    """The delegate's texture output name and 4-channel scale and bias for ``value``."""
    scale, bias = [1.0] * 4, [0.0] * 4
    channels = value.channels
    if len(set(channels)) == 1 and len(set(value.scale)) == 1 and len(set(value.bias)) == 1:
        channels, value = channels[:1], extract(value, 0)  # a broadcast channel: grey
    if channels == (0, 1, 2):
        output = "rgb"
    elif len(channels) == 1:
        output = "rgba"[channels[0]]
    else:
        raise Untranslatable(f"texture channels {channels} in that order")
    for channel, s, b in zip(value.channels, value.scale, value.bias):
        scale[channel], bias[channel] = s, b
    return output, scale, bias


def to_parameter(value: Value, vector: bool) -> Any:
    """``value`` as the delegate takes a material input: a 3-tuple or float for constants (a
    colour read as a number is its first channel), a connection dict otherwise."""
    if isinstance(value, Constant):
        if vector:
            return tuple(resize(value, 3).values)  # type: ignore[union-attr]
        return value.values[0]
    if value.texture is not None:
        output, scale, bias = _rgba(value)
        if not vector and output == "rgb":
            output, scale, bias = _rgba(extract(value, 0))
        texture = dict(value.texture)
        if scale != [1.0] * 4:
            texture["scale"] = tuple(scale)
        if bias != [0.0] * 4:
            texture["bias"] = tuple(bias)
        return {"texture": texture, "output": output}
    if any(s != 1.0 for s in value.scale) or any(b != 0.0 for b in value.bias):
        raise Untranslatable(f"arithmetic on primvar {value.primvar!r}")
    fallback = value.fallback or (0.0,)
    if vector:
        padded = (fallback * 3)[:3] if len(fallback) == 1 else (fallback + (0.0,) * 3)[:3]
        return {"primvar": value.primvar, "fallback": tuple(padded)}
    return {"primvar": value.primvar, "fallback": fallback[0]}
