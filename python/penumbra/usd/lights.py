"""UsdLux lights → the render delegate's light sprims.

Every input the delegate knows is sent, authored or not, so that its schema fallback is used
(``Get`` returns the fallback of an unauthored UsdLux input).
"""

from __future__ import annotations

from collections.abc import Callable

from pxr import Usd, UsdLux

from .sampling import SampleReader

# Sprim type, schema class and the shape inputs of each supported light.
_LIGHTS: tuple[tuple[str, type, tuple[str, ...]], ...] = (
    ("rectLight", UsdLux.RectLight, ("width", "height")),
    ("diskLight", UsdLux.DiskLight, ("radius",)),
    ("sphereLight", UsdLux.SphereLight, ("radius", "treatAsPoint")),
    ("distantLight", UsdLux.DistantLight, ("angle",)),
    ("domeLight", UsdLux.DomeLight, ()),
)
_COMMON_INPUTS = (
    "color",
    "intensity",
    "exposure",
    "normalize",
    "enableColorTemperature",
    "colorTemperature",
)


def light_type(prim: Usd.Prim) -> str | None:
    """The delegate's sprim type for a supported UsdLux light, else ``None``."""
    for sprim_type, schema, _ in _LIGHTS:
        if prim.IsA(schema):
            return sprim_type
    return None


def is_light(prim: Usd.Prim) -> bool:
    """Whether ``prim`` is a UsdLux light of any kind (supported or not)."""
    return prim.HasAPI(UsdLux.LightAPI)


def _getter(schema, name: str) -> Usd.Attribute:
    """The attribute of input ``name`` through the schema's ``Get<Name>Attr`` accessor."""
    return getattr(schema, f"Get{name[0].upper()}{name[1:]}Attr")()


def sync_light(core, prim: Usd.Prim, reader: SampleReader, warn: Callable[[str], None]) -> None:
    """Push the inputs of light ``prim`` (of a type :func:`light_type` accepts) to ``core``."""
    path = str(prim.GetPath())
    sprim_type = light_type(prim)
    _, schema_class, shape_inputs = next(entry for entry in _LIGHTS if entry[0] == sprim_type)
    schema = schema_class(prim)
    light_api = UsdLux.LightAPI(prim)
    params = {name: reader.get(_getter(light_api, name)) for name in _COMMON_INPUTS}
    params.update({name: reader.get(_getter(schema, name)) for name in shape_inputs})
    params["color"] = tuple(float(c) for c in params["color"])
    core.set_light(path, **params)
    texture_attr = getattr(schema, "GetTextureFileAttr", None)
    texture = texture_attr().Get(reader.time) if texture_attr is not None else None
    if texture is not None and texture.path:
        warn(
            f"{path}: inputs:texture:file is not supported yet; the light emits its constant color"
        )
