"""The values a MaterialX pattern network reduces to, and the arithmetic Penumbra folds.

The renderer evaluates per shading point what UsdPreviewSurface networks give it — one texture
lookup (with a per-channel scale and bias) or one primvar per input — and, where a network does
not reduce to that, a small program of component-wise operations over textures, primvars and
constants. A MaterialX network is therefore reduced, node by node, to one of four values:

- :class:`Constant`: the network does not vary (constant folding of all arithmetic);
- :class:`Affine` over a texture: ``texture[channels] * scale + bias``;
- :class:`Affine` over a primvar: ``primvar[channels] * scale + bias``;
- :class:`Expression`: an operation on other values (a product of two textures, a texture mixed
  with a primvar by a mask, …), sent as a program (:func:`program`).

Arithmetic between a varying value and a constant folds into the scale and bias (the fast path,
one lookup); arithmetic between two varying values becomes an :class:`Expression`.
Untranslatable is left for what no program expresses (varying texture coordinates other than a
primvar's affine transform, networks of more than :data:`MAX_PROGRAM_NODES` operations).
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


@dataclass(frozen=True, eq=False)
class Expression:
    """``op`` applied component-wise to ``operands`` (all of ``size`` components), or, for
    ``swizzle``, the components ``channels`` of its operand, for ``concatenate`` its two
    operands' components one after the other. Identity is equality: networks are trees built
    once."""

    op: str  # add, subtract, multiply, divide, mix (foreground, background, amount), clamp,
    # swizzle, concatenate
    operands: tuple[Value, ...]
    size: int
    channels: tuple[int, ...] = ()


Value = Constant | Affine | Expression

# The renderer's bound on a program's length (renderer/include/penumbra/material.h).
MAX_PROGRAM_NODES = 64


def _expression(op: str, *operands: Value) -> Expression:
    return Expression(op, operands, operands[0].size)


def identity(size: int, *, texture: dict[str, Any] | None = None, primvar: str = "",
             fallback: tuple[float, ...] = ()) -> Affine:
    """The channels ``0..size-1`` of a texture or primvar, unscaled."""
    return Affine(tuple(range(size)), (1.0,) * size, (0.0,) * size, texture, primvar, fallback)


def resize(value: Value, size: int) -> Value:
    """``value`` with ``size`` components: a single component is broadcast, longer values are
    truncated (MaterialX's convert and the FA variants of arithmetic nodes), shorter ones padded
    with zeros."""
    if value.size == size:
        return value
    if isinstance(value, Constant):
        if value.size == 1:
            return Constant(value.values * size)
        return Constant((value.values + (0.0,) * size)[:size])
    if isinstance(value, Expression):
        if value.size < size and value.size > 1:
            return Expression("concatenate", (value, Constant((0.0,) * (size - value.size))),
                              size)
        channels = (0,) * size if value.size == 1 else tuple(range(size))
        return Expression("swizzle", (value,), size, channels)
    if value.size == 1:
        return replace(value, channels=value.channels * size, scale=value.scale * size,
                       bias=value.bias * size)
    if value.size > size:
        return replace(value, channels=value.channels[:size], scale=value.scale[:size],
                       bias=value.bias[:size])
    return Expression("concatenate", (value, Constant((0.0,) * (size - value.size))), size)


def _broadcast(a: Value, b: Value) -> tuple[Value, Value]:
    size = max(a.size, b.size)
    return resize(a, size), resize(b, size)


def affine(value: Value, scale: Constant, bias: Constant) -> Value:
    """``value * scale + bias``, component-wise."""
    size = max(value.size, scale.size, bias.size)
    value, scale, bias = resize(value, size), resize(scale, size), resize(bias, size)
    if isinstance(value, Expression):
        if any(v != 1.0 for v in scale.values):  # type: ignore[union-attr]
            value = _expression("multiply", value, scale)
        if any(v != 0.0 for v in bias.values):  # type: ignore[union-attr]
            value = _expression("add", value, bias)
        return value
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
    return _expression("multiply", a, b)


def add(a: Value, b: Value) -> Value:
    a, b = _broadcast(a, b)
    if isinstance(b, Constant):
        return affine(a, Constant((1.0,) * b.size), b)
    if isinstance(a, Constant):
        return affine(b, Constant((1.0,) * a.size), a)
    return _expression("add", a, b)


def subtract(a: Value, b: Value) -> Value:
    a, b = _broadcast(a, b)
    if isinstance(a, Constant) or isinstance(b, Constant):
        return add(a, negate(b))
    return _expression("subtract", a, b)


def negate(value: Value) -> Value:
    return affine(value, Constant((-1.0,)), Constant((0.0,)))


def divide(a: Value, b: Value) -> Value:
    """MaterialX divide; a zero divisor gives 0 (as the renderer's program does)."""
    a, b = _broadcast(a, b)
    if isinstance(b, Constant):
        return multiply(a, Constant(tuple(1.0 / v if v != 0 else 0.0 for v in b.values)))
    return _expression("divide", a, b)


def mix(foreground: Value, background: Value, amount: Value) -> Value:
    """MaterialX mix: ``background + (foreground − background) · amount``."""
    if foreground == background:
        return foreground
    if isinstance(amount, Constant) and set(amount.values) <= {0.0, 1.0} and len(
        set(amount.values)
    ) == 1:
        return foreground if amount.values[0] == 1.0 else background
    size = max(foreground.size, background.size)
    foreground, background = resize(foreground, size), resize(background, size)
    amount = resize(amount, size)
    if isinstance(foreground, Constant) and isinstance(background, Constant):
        # amount · (fg − bg) + bg: an affine function of the amount.
        return affine(amount, add(foreground, negate(background)), background)  # type: ignore
    if isinstance(amount, Constant) and (isinstance(foreground, Constant)
                                         or isinstance(background, Constant)):
        one_minus = affine(amount, Constant((-1.0,)), Constant((1.0,)))
        return add(multiply(foreground, amount), multiply(background, one_minus))
    return Expression("mix", (foreground, background, amount), size)


def clamp(value: Value, low: Value, high: Value) -> Value:
    """Clamping folds on constants; on a texture it is exact only when the texture's range
    (assumed [0, 1] after scale and bias, as for 8- and 16-bit images) lies inside the bounds."""
    size = value.size
    low, high = resize(low, size), resize(high, size)
    if not isinstance(low, Constant) or not isinstance(high, Constant):
        return Expression("clamp", (value, low, high), size)
    if isinstance(value, Constant):
        return Constant(tuple(min(max(v, lo), hi)
                              for v, lo, hi in zip(value.values, low.values, high.values)))
    if isinstance(value, Affine) and value.texture is not None and all(
        lo <= min(b, s + b) and max(b, s + b) <= hi
        for s, b, lo, hi in zip(value.scale, value.bias, low.values, high.values)
    ):
        return value  # within the bounds already
    return Expression("clamp", (value, low, high), size)


def extract(value: Value, index: int) -> Value:
    if not 0 <= index < value.size:
        raise Untranslatable(f"channel {index} of a {value.size}-channel value")
    if isinstance(value, Constant):
        return Constant((value.values[index],))
    if isinstance(value, Expression):
        return Expression("swizzle", (value,), 1, (index,))
    return replace(value, channels=(value.channels[index],), scale=(value.scale[index],),
                   bias=(value.bias[index],))


def combine(parts: list[Value]) -> Value:
    """MaterialX combineN: constants, the channels of one texture or primvar in order, else a
    concatenation."""
    if all(isinstance(p, Constant) for p in parts):
        return Constant(tuple(v for p in parts for v in p.values))  # type: ignore[union-attr]
    affine_parts = [p for p in parts if isinstance(p, Affine)]
    first = affine_parts[0] if affine_parts else None
    if first is None or len(affine_parts) != len(parts) or any(
        p.texture is not first.texture or p.primvar != first.primvar for p in affine_parts
    ):
        result = parts[0]
        for part in parts[1:]:
            result = Expression("concatenate", (result, part), result.size + part.size)
        return result
    varying = affine_parts
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
    colour read as a number is its first channel), a connection dict otherwise — one texture
    lookup or primvar where the value is one, else a program."""
    if isinstance(value, Constant):
        if vector:
            return tuple(resize(value, 3).values)  # type: ignore[union-attr]
        return value.values[0]
    if isinstance(value, Affine):
        try:
            return _lookup(value, vector)
        except Untranslatable:
            pass
    return {"program": program(resize(value, 3) if vector else extract(value, 0))}


def _lookup(value: Affine, vector: bool) -> dict[str, Any]:
    """The connection of one texture lookup or one primvar; Untranslatable where the value is
    not one (channels out of order, arithmetic on a primvar)."""
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
    if any(s != 1.0 for s in value.scale) or any(b != 0.0 for b in value.bias) or \
            value.channels != tuple(range(value.size)):
        raise Untranslatable(f"arithmetic on primvar {value.primvar!r}")
    fallback = value.fallback or (0.0,)
    if vector:
        padded = (fallback * 3)[:3] if len(fallback) == 1 else (fallback + (0.0,) * 3)[:3]
        return {"primvar": value.primvar, "fallback": tuple(padded)}
    return {"primvar": value.primvar, "fallback": fallback[0]}


def _four(values: tuple[float, ...] | tuple[int, ...], filler: Any = 0) -> list[Any]:
    return (list(values) + [filler] * 4)[:4]


def program(value: Value) -> list[dict[str, Any]]:
    """``value`` as the renderer's program (docs/core-api.md, set_material): nodes in evaluation
    order, each naming its operands by index, the last giving the value in its first channels.
    Each texture and primvar is looked up once however often the network reads it."""
    nodes: list[dict[str, Any]] = []
    leaves: dict[Any, int] = {}
    built: dict[int, int] = {}

    def emit(node: dict[str, Any]) -> int:
        nodes.append(node)
        return len(nodes) - 1

    def constant(values: tuple[float, ...]) -> int:
        return emit({"op": "constant", "value": _four(values, 0.0)})

    def leaf(v: Affine) -> int:
        key = ("texture", id(v.texture)) if v.texture is not None else (
            "primvar", v.primvar, v.fallback)
        if key not in leaves:
            leaves[key] = emit(
                {"op": "texture", "texture": v.texture} if v.texture is not None
                else {"op": "primvar", "primvar": v.primvar, "fallback": _four(v.fallback, 0.0)}
            )
        return leaves[key]

    def build(v: Value) -> int:
        if isinstance(v, Constant):
            return constant(v.values)
        if isinstance(v, Affine):
            index = leaf(v)
            if v.channels != tuple(range(v.size)):
                index = emit({"op": "swizzle", "in": [index], "channels": _four(v.channels)})
            if any(s != 1.0 for s in v.scale):
                scale = constant(v.scale)
                index = emit({"op": "multiply", "in": [index, scale]})
            if any(b != 0.0 for b in v.bias):
                bias = constant(v.bias)
                index = emit({"op": "add", "in": [index, bias]})
            return index
        if id(v) not in built:
            operands = [build(o) for o in v.operands]
            node: dict[str, Any] = {"op": v.op, "in": operands}
            if v.op == "swizzle":
                node["channels"] = _four(v.channels)
            elif v.op == "concatenate":
                node["split"] = v.operands[0].size
            built[id(v)] = emit(node)
        return built[id(v)]

    root = build(value)
    if root != len(nodes) - 1:
        emit({"op": "swizzle", "in": [root], "channels": [0, 1, 2, 3]})
    if len(nodes) > MAX_PROGRAM_NODES:
        raise Untranslatable(f"a pattern network of {len(nodes)} operations (at most "
                             f"{MAX_PROGRAM_NODES})")
    return nodes
