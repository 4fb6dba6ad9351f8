"""UsdLux lights → the render delegate's light sprims.

Every input the delegate knows is sent, authored or not, so that its schema fallback is used
(``Get`` returns the fallback of an unauthored UsdLux input). Inputs authored to change the
light that the delegate does not render (shadow colour, distance and falloff, light filters, an
IES profile on a distant or dome light) are named in one warning per light. Asset inputs
(``texture:file``, ``shaping:ies:file``) are sent resolved.
"""

from __future__ import annotations

import math

from collections.abc import Callable

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdLux

from .. import _core
from .packaged_files import local_path
from .sampling import SampleReader, schema_fallback
from .values import as_asset_path, as_floats, is_color_value, is_finite_float32, is_number_value


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
# delegate's tables give them; and UsdLux's DomeLight_1, a DomeLight with a poleAxis (the same
# inputs, texture and format), which the delegate renders as a domeLight.
_LIGHTS: tuple[tuple[str, type, tuple[str, ...]], ...] = tuple(
    (light.sprim_type, getattr(UsdLux, light.schema), _inputs("light schema", light.sprim_type))
    for light in _core.light_types()
) + (("domeLight", UsdLux.DomeLight_1, _inputs("light schema", "domeLight")),)
"""The delegate's sprim types for lights."""

_DOME_SCHEMAS = (UsdLux.DomeLight, UsdLux.DomeLight_1)
_INFINITE_LIGHTS = UsdLux.NonboundableLightBase  # distant and dome lights

_POLE_Z = np.asarray(Gf.Matrix4d().SetRotate(Gf.Rotation(Gf.Vec3d(1, 0, 0), 90.0)))
"""Turns the light's +Y, the pole of the delegate's dome texture, to +Z, and the texture's
centre (latitude and longitude 0, +Z) to -Y: a DomeLight_1's orientation when its pole is Z."""

_COMMON_INPUTS = _inputs("LightAPI")
# Inputs of the applied schemas that shape the emission or cast shadows.
_SHAPING_INPUTS = _inputs("ShapingAPI")
_SHADOW_INPUTS = _inputs("ShadowAPI")
_COLOR_INPUTS = tuple(
    light_input.name for light_input in _core.light_inputs() if light_input.kind == "color"
)
_KINDS = {light_input.name: light_input.kind for light_input in _core.light_inputs()}

MAX_EMISSION = 1e20
"""The most a light may emit before normalisation, color * intensity * 2^exposure: 6e10 times
the sun's luminance (1.6e9 nits), yet 3e18 below single precision's largest number, so that
the path tracer's products of it (throughputs, 1/pdf, sums over samples) stay finite (3e38 gave
inf pixels)."""

# The ranges of the inputs UsdLux bounds: sizes are lengths; a distant light's angle is the
# angular diameter of its disc in degrees, 360 (the whole sky) at most, where the delegate's
# cone stops; exposure is a power of two, which alone must not pass MAX_EMISSION. The diffuse
# and specular multipliers scale light, which a negative one would make negative. A cone angle
# limits the angle off the light's axis, which lies in [0, 180] degrees. Not here: a cone
# softness outside [0, 1] and a negative focus, which UsdLux defines (clamped; ignored) and the
# delegate applies so.
_RANGES = {
    "width": (0.0, math.inf),
    "height": (0.0, math.inf),
    "radius": (0.0, math.inf),
    "length": (0.0, math.inf),
    "angle": (0.0, 360.0),
    "exposure": (-math.inf, math.log2(MAX_EMISSION)),
    "diffuse": (0.0, math.inf),
    "specular": (0.0, math.inf),
    "shaping:cone:angle": (0.0, 180.0),
}

# The angles UsdLux clips to the top of their range rather than refusing beyond it: a distant
# light wider than the whole sky is the whole sky (the schema clips its angle), and a cone of
# 180 degrees or more, which no direction lies outside, is no cone.
_CLIPPED = ("angle", "shaping:cone:angle")


def _clipped(name: str, value):
    """``value`` of input ``name``, a finite angle above the top of its range clipped to it
    (other values as they are, for :func:`_input_problem` to judge)."""
    if name in _CLIPPED and is_number_value(value) and is_finite_float32(value):
        return min(value, _RANGES[name][1])
    return value


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


def _input_problem(name: str, attribute: str, value) -> str | None:
    """Why the render delegate cannot take ``value`` for input ``name`` (USD attribute
    ``attribute``): of another kind, not finite in single precision or out of its range; or
    ``None``."""
    kind = _KINDS[name]
    if not _has_kind(value, kind):
        return f"{attribute} has a value of type {type(value).__name__}, not {kind}"
    numbers = as_floats(value) if kind == "color" else (value,) if kind == "float" else ()
    if not all(is_finite_float32(x) for x in numbers):
        return f"{attribute} is not finite in single precision ({value})"
    if name not in _RANGES:
        return None
    low, high = _RANGES[name]
    if low <= value <= high:
        return None
    if high == math.inf:
        return f"{attribute} must be at least {low:g}, not {value:g}"
    if low == -math.inf:
        return f"{attribute} must be at most {high:.4g}, not {value:g}"
    return f"{attribute} must be in [{low:g}, {high:g}], not {value:g}"


def _read_inputs(
    path: str,
    attributes: dict[str, Usd.Attribute],
    reader: SampleReader,
    warn: Callable[[str], None],
) -> dict:
    """The values of the light inputs ``attributes`` (by input name) at the reader's time, as
    the render delegate takes them (colours as tuples of floats); a value blocked there reads
    as the schema's fallback, as USD means. A value the delegate cannot take is replaced by the
    fallback, and the light skipped (intensity 0) with one warning naming it and each such
    input; so is a light whose emission would be negative or above :data:`MAX_EMISSION`."""
    params = {}
    problems = []
    for name, attribute in attributes.items():
        value = _clipped(name, reader.get_or_fallback(attribute))
        problem = _input_problem(name, attribute.GetName(), value)
        if problem is not None:
            problems.append(problem)
            value = schema_fallback(attribute)
        params[name] = as_floats(value) if name in _COLOR_INPUTS else value
    problem = _emission_problem(params)
    if problem is not None:
        problems.append(problem)
    if problems:
        warn(f"{path}: {'; '.join(problems)}; the light is skipped (intensity 0)")
        params["intensity"] = 0.0
    return params


def _emission_problem(params: dict) -> str | None:
    """Why a light's (valid) inputs would give negative, undefined or too bright emission, or
    ``None``."""
    color, intensity = params["color"], params["intensity"]
    if intensity < 0 or min(color) < 0:
        return f"negative emission (intensity {intensity:g}, color {color})"
    # A temperature in kelvin is positive; UsdLux's valid range, [1000, 10000], is where the
    # delegate clamps others. Unused when not enabled, so not refused then.
    temperature = params["colorTemperature"]
    if params["enableColorTemperature"] and not temperature > 0:
        return f"inputs:colorTemperature must be above 0 K, not {temperature:g}"
    emission = max(color) * intensity * 2.0 ** params["exposure"]
    if emission > MAX_EMISSION:
        return (
            f"inputs:color * inputs:intensity * 2^inputs:exposure is {emission:g}, above "
            f"{MAX_EMISSION:g}"
        )
    return None


def _input_attributes(
    prim: Usd.Prim, schema=None, shape_inputs: tuple[str, ...] = ()
) -> dict[str, Usd.Attribute]:
    """The attributes of light ``prim``'s inputs by input name, in the table's order:
    UsdLuxLightAPI's, ``shape_inputs`` of its light ``schema``, then those of the
    UsdLuxShapingAPI (its emission's shape) and UsdLuxShadowAPI applied to it, if they are."""
    light_api = UsdLux.LightAPI(prim)
    attributes = {name: _getter(light_api, name) for name in _COMMON_INPUTS}
    attributes.update({name: _getter(schema, name) for name in shape_inputs})
    if prim.HasAPI(UsdLux.ShapingAPI):
        shaping = UsdLux.ShapingAPI(prim)
        attributes.update({name: _getter(shaping, name) for name in _SHAPING_INPUTS})
    if prim.HasAPI(UsdLux.ShadowAPI):
        shadow = UsdLux.ShadowAPI(prim)
        attributes.update({name: _getter(shadow, name) for name in _SHADOW_INPUTS})
    return attributes


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
    params = _read_inputs(prim_id, _input_attributes(prim), reader, warn)
    _report_ignored_inputs(prim_id, prim, params.get("shadow:enable", True), reader, warn)
    params["shaping:ies:file"] = _ies_path(prim, reader, warn)
    core.set_mesh_light(prim_id, True, **params)


def _ignored_inputs(prim: Usd.Prim, shadows: bool, reader: SampleReader) -> list[str]:
    """The names of the UsdLux inputs of light ``prim`` that are authored to change its light
    but that Penumbra does not render: light filters, an IES profile on a distant or dome light
    (which profiles do not shape), and (when it casts
    shadows) a shadow colour other than black, a finite shadow distance (UsdLux's -1, or any
    negative one, is none) and a shadow falloff (none at 0 or less)."""
    ignored = []
    filters = UsdLux.LightAPI(prim).GetFiltersRel()
    if filters.HasAuthoredTargets() and filters.GetTargets():
        ignored.append(filters.GetName())
    if prim.HasAPI(UsdLux.ShapingAPI) and prim.IsA(_INFINITE_LIGHTS):
        ies = UsdLux.ShapingAPI(prim).GetShapingIesFileAttr()
        profile = as_asset_path(reader.get(ies))
        if profile is not None and profile.path:
            ignored.append(ies.GetName())
    if shadows and prim.HasAPI(UsdLux.ShadowAPI):
        shadow = UsdLux.ShadowAPI(prim)
        color = shadow.GetShadowColorAttr()
        value = reader.get(color)
        if is_color_value(value) and any(component != 0 for component in as_floats(value)):
            ignored.append(color.GetName())
        distance = shadow.GetShadowDistanceAttr()
        value = reader.get(distance)
        if is_number_value(value) and 0 <= value < math.inf:
            ignored.append(distance.GetName())
        falloff = shadow.GetShadowFalloffAttr()
        value = reader.get(falloff)
        if is_number_value(value) and value > 0:
            ignored.append(falloff.GetName())
    return ignored


def _report_ignored_inputs(
    path: str, prim: Usd.Prim, shadows: bool, reader: SampleReader, warn: Callable[[str], None]
) -> None:
    """One warning naming the inputs of light ``prim`` (delegate prim ``path``) that
    :func:`_ignored_inputs` finds: the light renders without them, which is not what was asked."""
    ignored = _ignored_inputs(prim, shadows, reader)
    if ignored:
        verb = "is" if len(ignored) == 1 else "are"
        warn(f"{path}: {', '.join(ignored)} {verb} not supported yet; ignored")


def _light_entry(prim: Usd.Prim) -> tuple[str, type, tuple[str, ...]] | None:
    """The entry of :data:`_LIGHTS` whose schema ``prim`` is, or ``None``."""
    for entry in _LIGHTS:
        if prim.IsA(entry[1]):
            return entry
    return None


def light_type(prim: Usd.Prim) -> str | None:
    """The delegate's sprim type for a supported UsdLux light, else ``None``."""
    entry = _light_entry(prim)
    return entry[0] if entry is not None else None


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
    core.set_light(str(prim.GetPath()), **read_light(prim, reader, warn, dome_light_visibility))


def read_light(
    prim: Usd.Prim,
    reader: SampleReader,
    warn: Callable[[str], None],
    dome_light_visibility: bool = True,
) -> dict:
    """The inputs of light ``prim`` as the delegate's ``set_light`` takes them (see
    :func:`sync_light`); what cannot be used is named in warnings."""
    path = str(prim.GetPath())
    sprim_type, schema_class, shape_inputs = _light_entry(prim)
    schema = schema_class(prim)
    params = _read_inputs(path, _input_attributes(prim, schema, shape_inputs), reader, warn)
    _report_ignored_inputs(path, prim, params.get("shadow:enable", True), reader, warn)
    params["texture:file"] = _texture_path(prim, schema, reader, warn)
    params["shaping:ies:file"] = _ies_path(prim, reader, warn)
    if params["texture:file"] and isinstance(schema, UsdLux.DomeLight_1):
        _check_pole_axis(prim, schema, warn)
    params["cameraVisible"] = dome_light_visibility or sprim_type != "domeLight"
    return params


def pole_axis(prim: Usd.Prim) -> str:
    """The axis a dome light's texture has its top pole on, "Y" or "Z": a DomeLight_1's
    ``poleAxis``, whose fallback "scene" (and a token UsdLux does not know) means the stage's up
    axis; "Y" for every other light (a DomeLight's texture is Y-up, as OpenEXR's latlong
    maps)."""
    if not prim.IsA(UsdLux.DomeLight_1):
        return "Y"
    axis = UsdLux.DomeLight_1(prim).GetPoleAxisAttr().Get()
    if axis not in ("Y", "Z"):
        axis = UsdGeom.GetStageUpAxis(prim.GetStage())
    return "Z" if axis == "Z" else "Y"


def light_transform(prim: Usd.Prim, matrices: np.ndarray) -> np.ndarray:
    """The transform the delegate should place light ``prim`` by, from its local-to-world
    ``matrices`` ((4, 4) or (K, 4, 4), as :func:`~.motion.transform_samples` gives them): those
    of a dome whose :func:`pole_axis` is Z after the turn of its texture's pole from the light's
    +Y to +Z (UsdLux turns the dome alone, before its transform, and not its children; row
    vectors, so the turn is the left factor)."""
    if pole_axis(prim) != "Z":
        return matrices
    return np.matmul(_POLE_Z, matrices)


def uneven_scale_problem(prim: Usd.Prim, matrix: np.ndarray) -> str | None:
    """What the delegate approximates of a sphere or cylinder light placed by ``matrix`` (row
    vectors) with a non-uniform scale: a sphere stays a sphere of the scales' geometric mean, a
    cylinder's cross-section a circle of its two scales' mean (UsdLux scales the shape itself,
    an ellipsoid or an elliptic cylinder, and normalises by its area); ``None`` otherwise."""
    if prim.IsA(UsdLux.SphereLight) and not UsdLux.SphereLight(prim).GetTreatAsPointAttr().Get():
        scales = np.linalg.norm(np.asarray(matrix)[:3, :3], axis=1)
        shape = "a sphere of the scales' geometric mean radius, not an ellipsoid"
    elif prim.IsA(UsdLux.CylinderLight):
        scales = np.linalg.norm(np.asarray(matrix)[1:3, :3], axis=1)  # the cross-section's
        shape = "a circular cylinder of the two scales' mean radius, not an elliptic one"
    else:
        return None
    if not np.isfinite(scales).all() or scales.min() <= 0 or scales.max() <= 1.001 * scales.min():
        return None
    shown = ", ".join(f"{v:g}" for v in scales)
    return f"{prim.GetPath()}: scaled unevenly ({shown}); rendered as {shape}"


def _check_pole_axis(
    prim: Usd.Prim, schema: UsdLux.DomeLight_1, warn: Callable[[str], None]
) -> None:
    """Warn of a textured DomeLight_1's ``poleAxis`` that UsdLux does not know (read as
    "scene")."""
    axis = schema.GetPoleAxisAttr().Get()
    if axis not in ("scene", "Y", "Z"):
        warn(f"{prim.GetPath()}: poleAxis {axis!r} is not scene, Y or Z; read as scene")


def _asset_file(
    prim: Usd.Prim, attr: Usd.Attribute, reader: SampleReader, warn: Callable[[str], None],
    without: str,
) -> str:
    """The file asset input ``attr`` names, resolved ("" when none). A path that does not
    resolve is anchored to the layer authoring it (not to the working directory): the delegate
    then warns, naming it, and reads it once it appears. A value that is not an asset path is
    named in a warning (the light renders without ``without``)."""
    value = reader.get(attr)
    asset = as_asset_path(value)
    if asset is None and value is not None:
        warn(f"{prim.GetPath()}: {attr.GetName()} has a value of type {type(value).__name__}, "
             f"not an asset path; the light has no {without}")
    if asset is None or not asset.path:
        return ""
    if asset.resolvedPath:
        return local_path(asset.resolvedPath)
    specs = attr.GetPropertyStack(reader.time)
    if specs and not specs[0].layer.anonymous:
        return specs[0].layer.ComputeAbsolutePath(asset.path)
    return asset.path


def _ies_path(prim: Usd.Prim, reader: SampleReader, warn: Callable[[str], None]) -> str:
    """The ``inputs:shaping:ies:file`` of a local light with ShapingAPI (see :func:`_asset_file`;
    distant and dome lights are not shaped by profiles)."""
    if not prim.HasAPI(UsdLux.ShapingAPI) or prim.IsA(_INFINITE_LIGHTS):
        return ""
    attr = UsdLux.ShapingAPI(prim).GetShapingIesFileAttr()
    return _asset_file(prim, attr, reader, warn, "IES profile")


def _texture_path(prim: Usd.Prim, schema, reader: SampleReader, warn: Callable[[str], None]) -> str:
    """The ``inputs:texture:file`` of a rect or dome light (see :func:`_asset_file`)."""
    texture_attr = getattr(schema, "GetTextureFileAttr", None)
    if texture_attr is None:
        return ""
    texture = _asset_file(prim, texture_attr(), reader, warn, "texture")
    if not texture:
        return ""
    if isinstance(schema, _DOME_SCHEMAS):
        layout = reader.get(schema.GetTextureFormatAttr())
        if layout not in (None, UsdLux.Tokens.automatic, UsdLux.Tokens.latlong):
            warn(f"{prim.GetPath()}: texture:format {layout!r} is not supported yet; read as latlong")
    return texture
