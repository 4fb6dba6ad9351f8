"""Penumbra's principled volume shader (``info:id`` ``penumbra:PrincipledVolume``), for scenes
coming from Blender: Cycles' Principled Volume, input for input (docs/volume-materials.md).

Inputs are constants (a connection to a node is not evaluated: the input keeps its default,
after a warning). Mapped onto the renderer's volume material as Cycles defines the node:
scattering = color, principledAbsorption = max(1 − √absorptionColor, 0), emission =
emissionStrength · emissionColor, and the three attribute names choose the density, colour and
temperature fields.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from pxr import Sdf, UsdShade

from .color_spaces import authored_color_space, constant_to_scene_linear
from .sampling import SampleReader
from .values import is_color_value, is_number_value
from .volume_inputs import Color, checked_anisotropy, checked_color, checked_number

PRINCIPLED_VOLUME = "penumbra:PrincipledVolume"

# Cycles' defaults, except colorAttribute: Cycles' is empty too, meaning no colour field.
COLOR_DEFAULTS: dict[str, Color] = {
    "color": (0.5, 0.5, 0.5), "absorptionColor": (0.0, 0.0, 0.0),
    "emissionColor": (1.0, 1.0, 1.0), "blackbodyTint": (1.0, 1.0, 1.0),
}
NUMBER_DEFAULTS: dict[str, float] = {
    "density": 1.0, "anisotropy": 0.0, "emissionStrength": 0.0, "blackbodyIntensity": 0.0,
    "temperature": 1000.0,
}
ATTRIBUTE_DEFAULTS: dict[str, str] = {
    "densityAttribute": "density", "colorAttribute": "", "temperatureAttribute": "temperature",
}


def read_principled_volume(material: Sdf.Path, shader: UsdShade.Shader, reader: SampleReader,
                           warn: Callable[[str], None]) -> dict[str, Any]:
    """The ``VolumeShading`` fields given by principled volume ``shader`` of ``material``."""
    inputs = _Inputs(material, shader, reader, warn)
    color = inputs.color("color")
    absorption_color = inputs.color("absorptionColor")
    strength = inputs.number("emissionStrength")
    emission_color = inputs.color("emissionColor")
    return {
        "density": inputs.number("density"),
        "scattering": color,
        "absorption": (0.0, 0.0, 0.0),
        "principled_absorption": tuple(max(1.0 - math.sqrt(a), 0.0) for a in absorption_color),
        "anisotropy": inputs.anisotropy(),
        "emission": tuple(strength * c for c in emission_color),
        "blackbody_intensity": inputs.number("blackbodyIntensity"),
        "blackbody_tint": inputs.color("blackbodyTint"),
        "temperature": inputs.number("temperature"),
        "density_fields": inputs.field("densityAttribute"),
        "color_fields": inputs.field("colorAttribute"),
        "temperature_fields": inputs.field("temperatureAttribute"),
        "emission_fields": (),
    }


class _Inputs:
    """The shader's constant inputs, each checked, warning once per bad input."""

    def __init__(self, material: Sdf.Path, shader: UsdShade.Shader, reader: SampleReader,
                 warn: Callable[[str], None]):
        self.material = material
        self.shader = shader
        self.reader = reader
        self.warn = warn

    def _reporter(self, name: str) -> Callable[[str], None]:
        return lambda message: self.warn(
            f"{self.material}: {PRINCIPLED_VOLUME} {self.shader.GetPath()}: inputs:{name}: "
            f"{message}")

    def _authored(self, name: str) -> tuple[Any, Any]:
        """(value, attribute) of input ``name``; (None, None) when it has no value or is
        connected to a node (reported: networks are not evaluated)."""
        shader_input = self.shader.GetInput(name)
        if not shader_input:
            return None, None
        producers = shader_input.GetValueProducingAttributes()
        if producers and not UsdShade.Input.IsInput(producers[0]):
            self._reporter(name)(f"is connected to {producers[0].GetPath()}, which Penumbra "
                                 "does not evaluate here; its default is used")
            return None, None
        attr = producers[0] if producers else shader_input.GetAttr()
        return self.reader.get(attr), attr

    def color(self, name: str) -> Color:
        default = COLOR_DEFAULTS[name]
        value, attr = self._authored(name)
        if value is None:
            return default
        report = self._reporter(name)
        if not is_color_value(value):
            report(f"is a {attr.GetTypeName()}, not a color3f; its default is used")
            return default
        linear = constant_to_scene_linear(tuple(float(v) for v in value),
                                          authored_color_space(attr), report)
        return checked_color(linear, default, report)

    def number(self, name: str) -> float:
        value = self._number(name)
        default = NUMBER_DEFAULTS[name]
        return default if value is None else checked_number(value, default, self._reporter(name))

    def anisotropy(self) -> float:
        value = self._number("anisotropy")
        if value is None:
            return NUMBER_DEFAULTS["anisotropy"]
        return checked_anisotropy(value, self._reporter("anisotropy"))

    def _number(self, name: str) -> float | None:
        """The authored number ``name``; None when there is none or it is not a number
        (reported)."""
        value, attr = self._authored(name)
        if value is None:
            return None
        if not is_number_value(value):
            self._reporter(name)(f"is a {attr.GetTypeName()}, not a float; its default is used")
            return None
        return float(value)

    def field(self, name: str) -> tuple[str, ...]:
        """The field an attribute-name input names (none for "")."""
        value, attr = self._authored(name)
        if value is None:
            value = ATTRIBUTE_DEFAULTS[name]
        elif not isinstance(value, str):
            self._reporter(name)(f"is a {attr.GetTypeName()}, not a string; its default "
                                 f"{ATTRIBUTE_DEFAULTS[name]!r} is used")
            value = ATTRIBUTE_DEFAULTS[name]
        return (value,) if value else ()
