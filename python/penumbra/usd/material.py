"""UsdShade material bindings and UsdPreviewSurface materials → the delegate's ``material``."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache
from typing import Any

from pxr import Gf, Sdf, Sdr, Usd, UsdShade

from .sampling import SampleReader

PREVIEW_SURFACE = "UsdPreviewSurface"

# The UsdPreviewSurface inputs the render delegate understands (docs/core-api.md, set_material).
INPUTS = (
    "diffuseColor",
    "emissiveColor",
    "specularColor",
    "metallic",
    "roughness",
    "opacity",
    "opacityThreshold",
    "ior",
    "clearcoat",
    "clearcoatRoughness",
    "useSpecularWorkflow",
    "penumbra:transmissionRoughness",
    "penumbra:abbeNumber",
)


@dataclass
class MaterialData:
    """What a material sends to the delegate, and the prims its values were read from."""

    params: dict[str, Any] = field(default_factory=dict)
    sources: set[Sdf.Path] = field(default_factory=set)


def bound_material(prim: Usd.Prim) -> Usd.Prim | None:
    """The material bound to ``prim`` for final renders ("full" purpose, then all-purpose)."""
    material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial(UsdShade.Tokens.full)
    return material.GetPrim() if material else None


def has_subset_bindings(prim: Usd.Prim) -> bool:
    """Whether ``prim`` binds materials per face through GeomSubsets."""
    return bool(UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets())


@cache
def _schema_defaults() -> dict[str, Any]:
    """UsdPreviewSurface's input defaults from the shader registry (empty if unregistered)."""
    node = Sdr.Registry().GetShaderNodeByIdentifier(PREVIEW_SURFACE)
    if not node:
        return {}
    defaults = {}
    for name in INPUTS:
        shader_input = node.GetShaderInput(name)
        if shader_input is not None and shader_input.GetDefaultValue() is not None:
            defaults[name] = shader_input.GetDefaultValue()
    return defaults


def _to_python(value: Any) -> Any:
    """A value as the delegate takes it: 3-tuples of floats for colours, strings as they are
    (primvar bindings), else float/int."""
    if isinstance(value, str):
        return value
    if isinstance(value, (Gf.Vec3f, Gf.Vec3d, Gf.Vec3h)):
        return tuple(float(c) for c in value)
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, int):
        return value
    return float(value)


def _display_color_reader(output: Usd.Attribute, reader: SampleReader, data: MaterialData):
    """``"primvar:displayColor"`` when ``output`` is a UsdPrimvarReader_float3 of displayColor
    (the delegate then takes diffuseColor from each mesh's displayColor), else ``None``."""
    shader = UsdShade.Shader(output.GetPrim())
    if not shader or shader.GetShaderId() != "UsdPrimvarReader_float3":
        return None
    varname = shader.GetInput("varname")
    if not varname or reader.get(varname.GetAttr()) != "displayColor":
        return None
    data.sources.add(shader.GetPath())
    return "primvar:displayColor"


def read_material(
    prim: Usd.Prim, reader: SampleReader, warn: Callable[[str], None]
) -> MaterialData | None:
    """The UsdPreviewSurface parameters of material ``prim`` at the reader's time.

    Inputs that are authored (or reach a value through connections to interface inputs) are
    read; the others get UsdPreviewSurface's schema defaults. An input connected to a shader
    output (a texture, a shader network) has no value Penumbra can evaluate yet: it is left to
    the delegate's default, with a warning. Returns ``None`` (after a warning) when the material
    has no UsdPreviewSurface surface.
    """
    path = prim.GetPath()
    shader, _, _ = UsdShade.Material(prim).ComputeSurfaceSource()
    if not shader:
        warn(f"{path}: material has no surface shader; bound meshes use their displayColor")
        return None
    shader_id = shader.GetShaderId()
    if shader_id != PREVIEW_SURFACE:
        warn(
            f"{path}: surface shader {shader.GetPath()} is {shader_id or 'unidentified'!r}, "
            f"not {PREVIEW_SURFACE}; bound meshes use their displayColor"
        )
        return None

    data = MaterialData(sources={path, shader.GetPath()})
    defaults = _schema_defaults()
    for name in INPUTS:
        value = None
        shader_input = shader.GetInput(name)
        if shader_input and shader_input.HasConnectedSource():
            producers = shader_input.GetValueProducingAttributes()
            if producers and UsdShade.Input.IsInput(producers[0]):
                data.sources.add(producers[0].GetPrim().GetPath())
                value = reader.get(producers[0])
            elif name == "diffuseColor" and producers:
                value = _display_color_reader(producers[0], reader, data)
            if value is None:
                source = producers[0].GetPath() if producers else "nothing"
                warn(
                    f"{shader_input.GetAttr().GetPath()} is connected to {source}, which "
                    "Penumbra cannot evaluate yet; the input keeps its default value"
                )
                continue
        elif shader_input:
            value = reader.get(shader_input.GetAttr())
        if value is None:
            value = defaults.get(name)
        if value is not None:
            data.params[name] = _to_python(value)
    return data
