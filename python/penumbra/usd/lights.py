"""UsdLux lights → the render delegate's light sprims.

Every input the delegate knows is sent, authored or not, so that its schema fallback is used
(``Get`` returns the fallback of an unauthored UsdLux input).
"""

from __future__ import annotations

import math

from collections.abc import Callable

from pxr import Usd, UsdLux

from .. import _core
from .sampling import SampleReader
from .values import as_asset_path, as_floats, is_color_value, is_number_value


def _inputs(origin: str, sprim_type: str | None = None) -> tuple[str, ...]:
    """The names of the delegate's light inputs from ``origin`` (``"LightAPI"``, ...) in the
    table's order, those of ``sprim_type``'s schema for ``"light schema"``; asset inputs
    (texture:file) apart, as :func:`_texture_path` resolves them."""
    return tuple(
        light_input.name
        for light_input in _core.light_inputs()
        if light_input.origin == origin
        and (sprim_type is None or sprim_type in light_input.light_types)
        and light_input.kind != "asset"
    )


# Sprim type, schema class and the shape inputs of each supported light, as the render
# delegate's tables give them.
_LIGHTS: tuple[tuple[str, type, tuple[str, ...]], ...] = tuple(
    (light.sprim_type, getattr(UsdLux, light.schema), _inputs("light schema", light.sprim_type))
    for light in _core.light_types()
)
"""The delegate's sprim types for lights."""

_COMMON_INPUTS = _inputs("LightAPI")
# Inputs of the applied schemas that shape the emission or cast shadows.
_SHAPING_INPUTS = _inputs("ShapingAPI")
_SHADOW_INPUTS = _inputs("ShadowAPI")
_COLOR_INPUTS = tuple(
    light_input.name for light_input in _core.light_inputs() if light_input.kind == "color"
)
_KINDS = {light_input.name: light_input.kind for light_input in _core.light_inputs()}


def _has_kind(value, kind: str) -> bool:
    """Whether an input's value can be sent as an input of ``kind`` ("float", "bool",
    "color")."""
    if kind == "float":
        return is_number_value(value)
    if kind == "bool":
        return isinstance(value, bool)
    if kind == "color":
        return is_color_value(value)
    return True


def _skip_wrong_kinds(
    prim: Usd.Prim, path: str, params: dict, warn: Callable[[str], None]
) -> None:
    """Replace each input in ``params`` whose value is not of its kind (an attribute authored
    with a wrong or unknown type) by the schema's fallback, with a warning naming it, and then
    skip the light: intensity 0."""
    wrong = [name for name, value in params.items()
             if value is not None and not _has_kind(value, _KINDS[name])]
    for name in wrong:
        warn(f"{path}: inputs:{name} has a value of type {type(params[name]).__name__}, not "
             f"{_KINDS[name]}; the light is skipped (intensity 0)")
        params[name] = prim.GetPrimDefinition().GetAttributeFallbackValue(f"inputs:{name}")
    if wrong:
        params["intensity"] = 0.0


def sync_mesh_light(
    core, prim: Usd.Prim, prim_id: str, reader: SampleReader, warn: Callable[[str], None]
) -> None:
    """Make mesh ``prim`` (delegate prim ``prim_id``) an emitter sampled as a light when it has
    UsdLuxMeshLightAPI applied, or not; shaped and shadowed by the ShapingAPI and ShadowAPI
    applied to it, as the other lights are (about the mesh's frame: the delegate's mesh gives
    its light its transform)."""
    if not prim.HasAPI(UsdLux.MeshLightAPI):
        core.set_mesh_light(prim_id, False)
        return
    light_api = UsdLux.LightAPI(prim)
    params = {name: reader.get(_getter(light_api, name)) for name in _COMMON_INPUTS}
    params.update(_applied_schema_inputs(prim, reader))
    _skip_wrong_kinds(prim, prim_id, params, warn)
    _skip_wrong_emission(prim_id, params, warn)
    core.set_mesh_light(prim_id, True, **params)


def light_type(prim: Usd.Prim) -> str | None:
    """The delegate's sprim type for a supported UsdLux light, else ``None``."""
    for sprim_type, schema, _ in _LIGHTS:
        if prim.IsA(schema):
            return sprim_type
    return None


def is_light(prim: Usd.Prim) -> bool:
    """Whether ``prim`` is a UsdLux light of any kind (supported or not)."""
    return prim.HasAPI(UsdLux.LightAPI)


def _accessor(name: str) -> str:
    """The name of the schema's accessor of input ``name`` (``shaping:cone:angle`` →
    ``GetShapingConeAngleAttr``)."""
    return "Get" + "".join(part[0].upper() + part[1:] for part in name.split(":")) + "Attr"


# Made once: every light reads about ten inputs.
_ACCESSORS = {light_input.name: _accessor(light_input.name) for light_input in _core.light_inputs()}


def _getter(schema, name: str) -> Usd.Attribute:
    """The attribute of input ``name`` through the schema's ``Get<Name>Attr`` accessor."""
    return getattr(schema, _ACCESSORS[name])()


def sync_light(
    core,
    prim: Usd.Prim,
    reader: SampleReader,
    warn: Callable[[str], None],
    dome_light_visibility: bool = True,
) -> None:
    """Push the inputs of light ``prim`` (of a type :func:`light_type` accepts) to ``core``.
    Without ``dome_light_visibility`` a dome light is not seen by camera rays (usdrecord's
    default: the dome lights the scene, the background stays transparent)."""
    path = str(prim.GetPath())
    sprim_type = light_type(prim)
    _, schema_class, shape_inputs = next(entry for entry in _LIGHTS if entry[0] == sprim_type)
    schema = schema_class(prim)
    light_api = UsdLux.LightAPI(prim)
    params = {name: reader.get(_getter(light_api, name)) for name in _COMMON_INPUTS}
    params.update({name: reader.get(_getter(schema, name)) for name in shape_inputs})
    params.update(_applied_schema_inputs(prim, reader))
    _skip_wrong_kinds(prim, path, params, warn)
    _skip_wrong_emission(path, params, warn)
    params["texture:file"] = _texture_path(prim, schema, reader, warn)
    params["cameraVisible"] = dome_light_visibility or sprim_type != "domeLight"
    core.set_light(path, **params)


def _applied_schema_inputs(prim: Usd.Prim, reader: SampleReader) -> dict:
    """The inputs of the schemas applied to light ``prim`` that shape its emission
    (UsdLuxShapingAPI) or its shadows (UsdLuxShadowAPI); none where neither is applied."""
    params = {}
    if prim.HasAPI(UsdLux.ShapingAPI):
        shaping = UsdLux.ShapingAPI(prim)
        params.update({name: reader.get(_getter(shaping, name)) for name in _SHAPING_INPUTS})
    if prim.HasAPI(UsdLux.ShadowAPI):
        shadow = UsdLux.ShadowAPI(prim)
        params.update({name: reader.get(_getter(shadow, name)) for name in _SHADOW_INPUTS})
    return params


def _skip_wrong_emission(path: str, params: dict, warn: Callable[[str], None]) -> None:
    """Send ``params``' colours as floats, and skip the light (intensity 0) with a warning where
    they would give negative or non-finite radiance."""
    for name in _COLOR_INPUTS:
        if name in params:
            params[name] = as_floats(params[name])
    problem = _emission_problem(params)
    if problem:
        warn(f"{path}: {problem}; the light is skipped (intensity 0)")
        params["intensity"] = 0.0


def _emission_problem(params: dict) -> str | None:
    """Why a light's inputs would give negative or non-finite radiance, or ``None``."""
    for name, value in params.items():
        numbers = value if isinstance(value, tuple) else (value,)
        if any(isinstance(x, float) and not math.isfinite(x) for x in numbers):
            return f"inputs:{name} is not finite ({value})"
    if params["intensity"] < 0 or min(params["color"]) < 0:
        return f"negative emission (intensity {params['intensity']:g}, color {params['color']})"
    return None


def _texture_path(prim: Usd.Prim, schema, reader: SampleReader, warn: Callable[[str], None]) -> str:
    """The resolved ``inputs:texture:file`` of a rect or dome light ("" when none).

    An unresolvable path is passed on as authored: the delegate then warns, naming the file.
    """
    texture_attr = getattr(schema, "GetTextureFileAttr", None)
    value = reader.get(texture_attr()) if texture_attr is not None else None
    texture = as_asset_path(value)
    if texture is None and value is not None:
        warn(f"{prim.GetPath()}: inputs:texture:file has a value of type {type(value).__name__}, "
             "not an asset path; the light has no texture")
    if texture is None or not texture.path:
        return ""
    if isinstance(schema, UsdLux.DomeLight):
        layout = reader.get(schema.GetTextureFormatAttr())
        if layout not in (None, UsdLux.Tokens.automatic, UsdLux.Tokens.latlong):
            warn(f"{prim.GetPath()}: texture:format {layout!r} is not supported yet; read as latlong")
    return texture.resolvedPath or texture.path
