"""MaterialX volume materials → the renderer's volume material (docs/volume-materials.md).

A ``volume`` node (``ND_volume``) takes a VDF — ``anisotropic_vdf`` (absorption, scattering,
anisotropy) or ``absorption_vdf`` — and an EDF — ``uniform_edf`` (colour). Their inputs are
reduced by the surface reader's pattern network (``materialx_patterns.Network``), then each
value is matched to what the renderer evaluates per point: a constant multiplied by at most one
scalar field and one colour field, the fields read by ``geompropvalue`` nodes named like the
volume's ``field:NAME`` relationships. The renderer multiplies one density field into both
scattering and absorption and the colour field into scattering only; a network that asks for
something else gets the closest such mapping, with one warning naming the node and input.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pxr import Sdf, Usd, UsdShade, UsdVol

from . import materialx_values as mv
from .material_data import MaterialData
from .materialx_library import definition_default
from .materialx_patterns import Network
from .sampling import SampleReader
from .values import is_color_value, is_number_value
from .volume_inputs import Color, checked_anisotropy, checked_color

VOLUME = "ND_volume"
ANISOTROPIC_VDF = "ND_anisotropic_vdf"
ABSORPTION_VDF = "ND_absorption_vdf"
UNIFORM_EDF = "ND_uniform_edf"

_BLACK: Color = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class _Factors:
    """A value as the renderer evaluates it: ``constant`` ⊙ the scalar field ``scalar`` ⊙ the
    colour field ``color`` (no field where the name is "")."""

    constant: Color
    scalar: str = ""
    color: str = ""


def read_materialx_volume(volume: Usd.Prim, material: Sdf.Path, shader: UsdShade.Shader,
                          reader: SampleReader, warn: Callable[[str], None]) -> dict[str, Any]:
    """The ``VolumeShading`` fields given by MaterialX ``volume`` node ``shader`` of
    ``material``, bound to ``volume``; ``warn`` is told of each approximation once."""
    volume_node = _VolumeNode(volume, material, reader, warn)
    shading: dict[str, Any] = {"density": 1.0, "blackbody_intensity": 0.0,
                               "temperature_fields": ()}
    shading.update(volume_node.medium(shader))
    shading.update(volume_node.emission(shader))
    return shading


class _VolumeNode:
    """Reads one ``volume`` node's closures through the pattern network of its material."""

    def __init__(self, volume: Usd.Prim, material: Sdf.Path, reader: SampleReader,
                 warn: Callable[[str], None]):
        self.network = Network(material, reader, MaterialData(), warn)
        self.reader = reader
        self.fields = set(UsdVol.Volume(volume).GetFieldPaths())

    def report(self, node: UsdShade.Shader, message: str) -> None:
        self.network.report(node.GetPath(), message)

    def _closure(self, shader: UsdShade.Shader, name: str) -> UsdShade.Shader | None:
        """The node connected to closure input ``name`` (vdf, edf) of the volume node."""
        shader_input = shader.GetInput(name)
        producers = shader_input.GetValueProducingAttributes() if shader_input else []
        if not producers or UsdShade.Input.IsInput(producers[0]):
            return None
        node = UsdShade.Shader(producers[0].GetPrim())
        return node if node.GetPrim().IsA(UsdShade.Shader) else None

    def medium(self, shader: UsdShade.Shader) -> dict[str, Any]:
        """Scattering, absorption, anisotropy and the density and colour fields, from the VDF;
        no VDF is an empty medium."""
        vdf = self._closure(shader, "vdf")
        if vdf is None:
            return {"scattering": _BLACK, "absorption": _BLACK, "principled_absorption": _BLACK,
                    "density_fields": (), "color_fields": ()}
        vdf_id = vdf.GetShaderId() or ""
        if vdf_id not in (ANISOTROPIC_VDF, ABSORPTION_VDF):
            self.report(vdf, f"VDF {vdf_id or 'without info:id'} is not supported (Penumbra "
                        f"reads {ANISOTROPIC_VDF} and {ABSORPTION_VDF}); the default volume "
                        "(grey scattering of the density field) is used")
            return {}  # VolumeShading's defaults
        absorption = self._factors(vdf, "absorption")
        if vdf_id == ABSORPTION_VDF:
            scattering, anisotropy = _Factors(_BLACK), 0.0
        else:
            scattering, anisotropy = self._factors(vdf, "scattering"), self._anisotropy(vdf)
        if absorption.color:
            self.report(vdf, f"absorption: colour field {absorption.color!r} can only colour "
                        "scattering; it is ignored")
        density = scattering.scalar or absorption.scalar
        if density and _varies_otherwise(scattering, absorption, density):
            self.report(vdf, f"scattering and absorption: the renderer multiplies one density "
                        f"field into both; field {density!r} is used for both")
        return {"scattering": scattering.constant, "absorption": absorption.constant,
                "principled_absorption": _BLACK, "anisotropy": anisotropy,
                "density_fields": (density,) if density else (),
                "color_fields": (scattering.color,) if scattering.color else ()}

    def emission(self, shader: UsdShade.Shader) -> dict[str, Any]:
        """Emission and its field, from the EDF; none without one."""
        edf = self._closure(shader, "edf")
        if edf is None:
            return {"emission": _BLACK, "emission_fields": ()}
        edf_id = edf.GetShaderId() or ""
        if edf_id != UNIFORM_EDF:
            self.report(edf, f"EDF {edf_id or 'without info:id'} is not supported (Penumbra "
                        f"reads {UNIFORM_EDF}); the volume does not emit")
            return {"emission": _BLACK, "emission_fields": ()}
        color = self._factors(edf, "color")
        if color.scalar and color.color:
            self.report(edf, f"color: the renderer reads one emission field; colour field "
                        f"{color.color!r} is used and scalar field {color.scalar!r} ignored")
        field_name = color.color or color.scalar
        return {"emission": color.constant, "emission_fields": (field_name,) if field_name else ()}

    # Inputs.
    def _value(self, node: UsdShade.Shader, name: str, size: int) -> mv.Value:
        """Input ``name`` of ``node`` reduced by the pattern network; its node definition's
        default (after a warning) when it has the wrong type or cannot be reduced."""
        default = self._default(node, name, size)
        shader_input = node.GetInput(name)
        producers = shader_input.GetValueProducingAttributes() if shader_input else []
        if producers and UsdShade.Input.IsInput(producers[0]):
            raw = self.reader.get(producers[0])
            if raw is not None and not (is_color_value(raw) if size == 3
                                        else is_number_value(raw)):
                self.report(node, f"{name}: a {producers[0].GetTypeName()} where a "
                            f"{'colour' if size == 3 else 'float'} is expected; its default is "
                            "used")
                return default
        try:
            value = self.network.input(node, name)
        except mv.Untranslatable as error:
            self.network.report(error.node, f"{error}; {name} of {node.GetPath()} takes its "
                                "default")
            return default
        if value is None:
            return default
        if value.size != size:
            self.report(node, f"{name}: {value.size} components where {size} are expected; "
                        "its default is used")
            return default
        return value

    def _factors(self, node: UsdShade.Shader, name: str) -> _Factors:
        """Colour input ``name`` of ``node`` as factors; its default (after one warning) when
        it is not a product of constants and fields."""
        default = _Factors(_color(self._default(node, name, 3)))
        factors = self._reduce(node, name, self._value(node, name, 3))
        if factors is None:
            return default
        constant = checked_color(factors.constant, default.constant,
                                 lambda message: self.report(node, f"{name}: {message}"))
        return _Factors(constant, factors.scalar, factors.color)

    def _default(self, node: UsdShade.Shader, name: str, size: int) -> mv.Constant:
        return definition_default(node.GetShaderId() or "", name) or mv.Constant((0.0,) * size)

    def _reduce(self, node: UsdShade.Shader, name: str, value: mv.Value) -> _Factors | None:
        """``value`` as constant ⊙ fields; None (after a warning) when it is not one."""
        if isinstance(value, mv.Constant):
            return _Factors(_color(value))
        if isinstance(value, mv.Affine):
            return self._field(node, name, value)
        if value.op == "swizzle" and value.operands[0].size == 1:
            return self._reduce(node, name, value.operands[0])  # a scalar, broadcast
        if value.op != "multiply":
            self.report(node, f"{name}: a network computing {value.op} cannot vary over a "
                        "volume (products of constants and geompropvalue fields can); its "
                        "default is used")
            return None
        left, right = (self._reduce(node, name, operand) for operand in value.operands)
        if left is None or right is None:
            return None
        scalar, color = left.scalar or right.scalar, left.color or right.color
        for kind, first, second in (("scalar", left.scalar, right.scalar),
                                    ("colour", left.color, right.color)):
            if first and second:
                self.report(node, f"{name}: the renderer multiplies in one {kind} field; "
                            f"{first!r} is used and {second!r} ignored")
        return _Factors(tuple(a * b for a, b in zip(left.constant, right.constant)),  # type: ignore
                        scalar, color)

    def _field(self, node: UsdShade.Shader, name: str, value: mv.Affine) -> _Factors | None:
        """A geompropvalue (scaled): the field it names, or, when the volume has no such
        field, its default value."""
        if value.texture is not None or any(b != 0.0 for b in value.bias):
            what = "a texture" if value.texture is not None else "an offset field"
            self.report(node, f"{name}: {what} cannot vary over a volume (products of "
                        "constants and geompropvalue fields can); its default is used")
            return None
        scale = _color(mv.Constant(value.scale))
        if value.primvar not in self.fields:
            self.report(node, f"{name}: the volume has no field {value.primvar!r}; the "
                        "geompropvalue default is used")
            fallback = mv.Constant(tuple(value.fallback[c] for c in value.channels))
            return _Factors(tuple(s * f for s, f in zip(scale, _color(fallback))))  # type: ignore
        if set(value.channels) == {0}:  # a float geompropvalue, perhaps broadcast
            return _Factors(scale, scalar=value.primvar)
        if value.channels == (0, 1, 2):
            return _Factors(scale, color=value.primvar)
        self.report(node, f"{name}: channels {value.channels} of field {value.primvar!r} in that "
                    "order cannot be read; its default is used")
        return None

    def _anisotropy(self, vdf: UsdShade.Shader) -> float:
        value = self._value(vdf, "anisotropy", 1)
        if not isinstance(value, mv.Constant):
            self.report(vdf, "anisotropy cannot vary over a volume; 0 is used")
            return 0.0
        return checked_anisotropy(value.values[0],
                                  lambda message: self.report(vdf, f"anisotropy: {message}"))


def _color(value: mv.Constant) -> Color:
    values = mv.resize(value, 3).values  # type: ignore[union-attr]
    return (values[0], values[1], values[2])


def _varies_otherwise(scattering: _Factors, absorption: _Factors, density: str) -> bool:
    """Whether scattering or absorption, not black, lacks the density field the other has."""
    return any(part.scalar != density and any(part.constant)
               for part in (scattering, absorption))
