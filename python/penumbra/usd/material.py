"""UsdShade material bindings and UsdPreviewSurface materials → the delegate's ``material``."""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import Any

from pxr import Gf, Sdf, Sdr, Usd, UsdShade

from .color_spaces import texture_color_space
from .material_data import CONNECTABLE, INPUTS, PREVIEW_SURFACE_INPUTS, MaterialData, texture_file
from .materialx import read_materialx_material, surface_shader
from .sampling import SampleReader
from .values import as_floats, is_number_value

PREVIEW_SURFACE = "UsdPreviewSurface"


def bound_material(prim: Usd.Prim) -> Usd.Prim | None:
    """The material bound to ``prim`` for final renders ("full" purpose, then all-purpose)."""
    material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial(UsdShade.Tokens.full)
    return material.GetPrim() if material else None


def bound_materials(prims: list[Usd.Prim]) -> list[Sdf.Path | None]:
    """The paths of the materials bound to ``prims`` for final renders, as
    :func:`bound_material` gives them, computed in one batch (the binding API shares its work
    between prims with common ancestors)."""
    if not prims:
        return []
    materials, _ = UsdShade.MaterialBindingAPI.ComputeBoundMaterials(prims, UsdShade.Tokens.full)
    return [material.GetPath() if material else None for material in materials]


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
    """A constant value as the delegate takes it: 3-tuples of floats for colours, else
    float/int."""
    if isinstance(value, (Gf.Vec3f, Gf.Vec3d, Gf.Vec3h, tuple, list)):
        return as_floats(value)
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, int):
        return value
    return float(value)


_VECTOR_INPUTS = frozenset(i.name for i in PREVIEW_SURFACE_INPUTS if i.kind == "vector")
# UsdUVTexture inputs passed on as they are, when authored (the delegate has the spec's
# defaults for the others).
_TEXTURE_TOKENS = ("wrapS", "wrapT", "sourceColorSpace")
_TEXTURE_VECTORS = ("scale", "bias", "fallback")
_PRIMVARS = "primvars:"  # the namespace of primvar attributes, not part of a primvar's name


class _Network:
    """Reads the shader network behind one material's inputs, noting every prim it reads."""

    def __init__(self, reader: SampleReader, data: MaterialData, warn: Callable[[str], None],
                 material: Sdf.Path):
        self.material = material
        self.reader = reader
        self.data = data
        self.warn = warn

    def value(self, shader: UsdShade.Shader, name: str) -> Any:
        """The value of input ``name`` of ``shader``, through connections to interface inputs;
        ``None`` when unauthored or connected to another shader's output."""
        shader_input = shader.GetInput(name)
        if not shader_input:
            return None
        producers = shader_input.GetValueProducingAttributes()
        if not producers:
            return None
        attr = producers[0]
        if not UsdShade.Input.IsInput(attr):
            return None
        self.data.sources.add(attr.GetPrim().GetPath())
        return self.reader.get(attr)

    def upstream(self, shader_input: UsdShade.Input) -> tuple[UsdShade.Shader, str] | None:
        """The shader and output name ``shader_input`` is connected to, if any."""
        producers = shader_input.GetValueProducingAttributes()
        if not producers or UsdShade.Input.IsInput(producers[0]):
            return None
        output = producers[0]
        self.data.sources.add(output.GetPrim().GetPath())
        return UsdShade.Shader(output.GetPrim()), UsdShade.Output(output).GetBaseName()

    def source(self, shader_input: UsdShade.Input, name: str) -> Any:
        """What drives input ``name``: a connection description, or ``None`` (after a warning
        naming the input) when Penumbra cannot evaluate its network."""
        found = self.upstream(shader_input)
        if found is None:
            return None
        shader, output = found
        shader_id = shader.GetShaderId() or ""
        where = shader_input.GetAttr().GetPath()
        if name not in CONNECTABLE:
            self.warn(f"{where} cannot vary over the surface; the input keeps its default value")
            return None
        if shader_id == "UsdUVTexture":
            try:
                texture = self.texture(shader)
                if texture is None:
                    fallback = self.value(shader, "fallback") or (0.0, 0.0, 0.0, 1.0)
                    return _channels(fallback, output, name in _VECTOR_INPUTS)
            except (TypeError, ValueError, AttributeError) as error:
                self.warn(f"{where}: cannot read the network of {shader.GetPath()} ({error}); "
                          "the input keeps its default value")
                return None
            return {"texture": texture, "output": output}
        if shader_id.startswith("UsdPrimvarReader_"):
            reader = self.primvar_reader(shader)
            if reader["primvar"]:
                return reader
            self.warn(f"{shader.GetPath()}: primvar reader has no varname; its fallback is used")
            fallback = reader.get("fallback", 0.0)
            if name in _VECTOR_INPUTS:
                return fallback if isinstance(fallback, tuple) else (fallback,) * 3
            return fallback[0] if isinstance(fallback, tuple) else fallback
        self.warn(
            f"{where} is connected to {shader.GetPath()} ({shader_id or 'unidentified'}), which "
            "Penumbra cannot evaluate; the input keeps its default value"
        )
        return None

    def primvar_reader(self, shader: UsdShade.Shader) -> dict[str, Any]:
        """A UsdPrimvarReader_*'s primvar name and fallback (padded to 3 values). A varname
        written as the attribute's name, ``primvars:displayColor``, names the primvar
        ``displayColor``, as hdPrman reads it."""
        varname = self.value(shader, "varname")
        fallback = self.value(shader, "fallback")
        result: dict[str, Any] = {"primvar": str(varname or "").removeprefix(_PRIMVARS)}
        if fallback is not None:
            if isinstance(fallback, (int, float)):
                result["fallback"] = float(fallback)
            else:
                values = [float(c) for c in fallback][:3]
                result["fallback"] = tuple(values + [0.0] * (3 - len(values)))
        return result

    def texture(self, shader: UsdShade.Shader) -> dict[str, Any] | None:
        """A UsdUVTexture's description, or ``None`` (after a warning) when it names no file."""
        file = texture_file(shader.GetInput("file"), self.reader)
        if not file:
            self.warn(f"{shader.GetPath()}: UsdUVTexture has no file; its fallback is used")
            return None
        texture: dict[str, Any] = {"file": file}
        for name in _TEXTURE_TOKENS:
            value = self.value(shader, name)
            if value:
                texture[name] = str(value)
        for name in _TEXTURE_VECTORS:
            value = self.value(shader, name)
            if value is not None:
                texture[name] = tuple(float(c) for c in value)
        # colorSpace metadata on the file decides where sourceColorSpace leaves it to the file
        # (auto); it may name any colour space of the OCIO config (docs/materialx.md).
        space = shader.GetInput("file").GetAttr().GetMetadata("colorSpace") or ""
        if space and texture.get("sourceColorSpace", "auto") == "auto":
            texture.update(texture_color_space(space, lambda message: self.warn(
                f"{self.material}: UsdUVTexture {shader.GetPath()}: {message}")))
        st_input = shader.GetInput("st")
        if st_input:
            texture.update(self.coordinates(st_input))
        return texture

    def coordinates(self, st_input: UsdShade.Input) -> dict[str, Any]:
        """Where a texture's ``st`` comes from: ``{"st": ..., "transform": ...}`` entries."""
        result: dict[str, Any] = {}
        found = self.upstream(st_input)
        if found and (found[0].GetShaderId() or "") == "UsdTransform2d":
            transform_shader = found[0]
            transform = {}
            for name in ("scale", "rotation", "translation"):
                value = self.value(transform_shader, name)
                if value is not None:
                    transform[name] = float(value) if name == "rotation" else tuple(value)
            result["transform"] = transform
            in_input = transform_shader.GetInput("in")
            found = self.upstream(in_input) if in_input else None
            st_input = in_input
        if found and (found[0].GetShaderId() or "").startswith("UsdPrimvarReader_"):
            st = {"primvar": self.primvar_reader(found[0])["primvar"]}
            fallback = self.value(found[0], "fallback")
            if fallback is not None and not isinstance(fallback, (int, float)):
                st["fallback"] = tuple(float(c) for c in fallback)[:2]
            result["st"] = st
        elif found:
            self.warn(
                f"{st_input.GetAttr().GetPath()} is connected to {found[0].GetPath()}, which "
                "Penumbra cannot evaluate; texture coordinates (0, 0) are used"
            )
        elif st_input:
            value = self.reader.get(st_input.GetAttr())
            if value is not None:
                result["st"] = {"fallback": tuple(float(c) for c in value)}
        return result


def _channels(values: Any, output: str, vector: bool) -> Any:
    """The channels ``output`` names of a 4-value ``values``, as a constant input value."""
    channels = [float(c) for c in values]
    if output == "rgb":
        return tuple(channels[:3]) if vector else channels[0]
    index = "rgba".find(output)
    value = channels[index] if 0 <= index < len(channels) else 0.0
    return (value, value, value) if vector else value


def push_material(core, material_id: str, data: MaterialData, warn: Callable[[str], None]) -> None:
    """Send ``data`` to the delegate's material ``material_id``. A constant the delegate rejects
    (a value of the wrong type or out of range) is reported and takes its default; a network it
    rejects (a token or value it cannot use) is reported, and the material keeps its constant
    inputs."""
    params = dict(data.params)
    try:
        core.set_material(material_id, params)
        return
    except (TypeError, ValueError):
        pass
    for name, value in data.params.items():  # the error path only: find the rejected constants
        if isinstance(value, dict):
            continue
        try:
            core.set_material(material_id, {name: value})
        except (TypeError, ValueError) as error:
            warn(f"{error}; its default is used")
            del params[name]
    try:
        core.set_material(material_id, params)
    except (TypeError, ValueError) as error:
        warn(f"{error}; the material renders without its shader network")
        core.set_material(material_id, {k: v for k, v in params.items() if not isinstance(v, dict)})


def _displaces(shader: UsdShade.Shader, network: _Network) -> bool:
    """Whether UsdPreviewSurface ``shader``'s ``inputs:displacement`` would move the surface:
    connected to a shader's output, or a value (authored, or reached through interface inputs)
    other than the schema's 0."""
    displacement = shader.GetInput("displacement")
    if not displacement:
        return False
    if displacement.HasConnectedSource():
        value = network.value(shader, "displacement")
        if value is None:  # driven by a shader network
            return True
    else:
        value = network.reader.get(displacement.GetAttr())
    return is_number_value(value) and value != 0


def _check_displacement(material: Usd.Prim, surface: UsdShade.Shader, network: _Network) -> None:
    """Warn once when the material asks for displacement, which Penumbra does not render: on its
    surface shader or the UsdPreviewSurface its ``outputs:displacement`` names."""
    shaders = [surface]
    source, _, _ = UsdShade.Material(material).ComputeDisplacementSource()
    if source and source.GetPrim() != surface.GetPrim() and source.GetShaderId() == PREVIEW_SURFACE:
        network.data.sources.add(source.GetPath())
        shaders.append(source)
    for shader in shaders:
        if _displaces(shader, network):
            network.warn(
                f"{material.GetPath()}: {shader.GetPath()}.inputs:displacement: displacement is "
                "not supported yet; the surface renders undisplaced"
            )
            return


def _check_opacity_mode(surface: UsdShade.Shader, network: _Network) -> None:
    """Warn of ``opacityMode`` "presence" (opacity scaling the whole response, the rest passing
    straight through), which Penumbra does not render: its opacity below 1 is translucency."""
    mode = surface.GetInput("opacityMode")
    if mode and network.value(surface, "opacityMode") == "presence":
        network.warn(
            f"{surface.GetPath()}: inputs:opacityMode 'presence' is not supported yet; opacity "
            "below 1 renders as translucency ('transparent' as Penumbra reads it)"
        )


def read_material(
    prim: Usd.Prim, reader: SampleReader, warn: Callable[[str], None]
) -> MaterialData | None:
    """The UsdPreviewSurface parameters of material ``prim`` at the reader's time.

    Inputs that are authored (or reach a value through connections to interface inputs) are
    read; the others get UsdPreviewSurface's schema defaults. Inputs connected to a shader
    network Penumbra evaluates (UsdUVTexture with UsdPrimvarReader_float2 and UsdTransform2d
    coordinates; UsdPrimvarReader_*) become connection descriptions; other networks leave the
    input at its default, with a warning. MaterialX surfaces (``outputs:mtlx:surface``) are read
    by ``materialx``. Returns ``None`` (after a warning) when the material
    has no UsdPreviewSurface surface.
    """
    path = prim.GetPath()

    mtlx_shader = surface_shader(prim)
    if mtlx_shader:
        return read_materialx_material(prim, mtlx_shader, reader, warn)
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

    # Edits anywhere in the material (its shaders, node graphs, interface inputs) re-read it.
    data = MaterialData(sources={p.GetPath() for p in Usd.PrimRange(prim)} | {shader.GetPath()})
    network = _Network(reader, data, warn, path)
    _check_displacement(prim, shader, network)
    _check_opacity_mode(shader, network)
    defaults = _schema_defaults()
    for name in (*INPUTS, "normal"):
        value = None
        shader_input = shader.GetInput(name)
        if shader_input and shader_input.HasConnectedSource():
            value = network.value(shader, name)
            if value is None:
                value = network.source(shader_input, name)
        elif shader_input:
            value = reader.get(shader_input.GetAttr())
        if name == "normal" and not isinstance(value, dict):
            continue  # a constant tangent-space normal other than +z is not supported
        if value is None:
            value = defaults.get(name)
        if value is not None and not isinstance(value, dict):
            try:
                converted = _to_python(value)
            except (TypeError, ValueError):
                converted = None
            if isinstance(converted, tuple) != (name in _VECTOR_INPUTS):
                kind = "a 3-vector" if name in _VECTOR_INPUTS else "a number"
                warn(f"{shader.GetPath()}: inputs:{name} holds {value!r}, not {kind}; its default is used")
                converted = defaults.get(name)
            value = converted
        if value is not None:
            data.params[name] = value if isinstance(value, dict) else _to_python(value)
    return data
