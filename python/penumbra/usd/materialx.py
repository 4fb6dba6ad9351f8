"""MaterialX materials authored as UsdShade prims → the delegate's material (docs/materialx.md).

A material whose ``outputs:mtlx:surface`` (else ``outputs:surface``) is a shader with a MaterialX
node definition as ``info:id`` (``ND_standard_surface_surfaceshader``,
``ND_open_pbr_surface_surfaceshader``, ``ND_UsdPreviewSurface_surfaceshader``) is mapped onto the
UsdPreviewSurface parameters the renderer's BSDF takes. Its pattern network is reduced to what
the renderer evaluates per shading point (see ``materialx_values``). What cannot be translated
is reported in one warning per material and node, and the input falls back to its node
definition's default.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache
from typing import Any

from pxr import Sdf, Usd, UsdShade

from . import materialx_values as mv
from .color_spaces import authored_color_space, constant_to_scene_linear, texture_color_space
from .material_data import CONNECTABLE, INPUTS, MaterialData, texture_file
from .sampling import SampleReader

RENDER_CONTEXT = "mtlx"
STANDARD_SURFACE = "ND_standard_surface_surfaceshader"
OPEN_PBR_SURFACE = "ND_open_pbr_surface_surfaceshader"
PREVIEW_SURFACE = "ND_UsdPreviewSurface_surfaceshader"
SURFACES = (STANDARD_SURFACE, OPEN_PBR_SURFACE, PREVIEW_SURFACE)

_SIZES = {"float": 1, "integer": 1, "boolean": 1, "vector2": 2, "color3": 3, "vector3": 3,
          "color4": 4, "vector4": 4}
_VECTOR_PARAMS = frozenset({"diffuseColor", "emissiveColor", "specularColor", "normal",
                            "penumbra:clearcoatColor", "penumbra:sheenColor"})
# The sheen and coat colour are Penumbra's extensions of the delegate's inputs; they may vary
# like the others.
_SHEEN_PARAMS = ("penumbra:sheen", "penumbra:sheenColor", "penumbra:sheenRoughness")
_ANISOTROPY_PARAMS = ("penumbra:anisotropy", "penumbra:clearcoatAnisotropy",
                      "penumbra:anisotropyRotation")
_CONNECTABLE = CONNECTABLE | frozenset(_SHEEN_PARAMS) | frozenset(_ANISOTROPY_PARAMS) | {
    "penumbra:clearcoatColor"}
# MaterialX address modes → UsdUVTexture wrap modes.
_ADDRESS_MODES = {"periodic": "repeat", "clamp": "clamp", "mirror": "mirror", "constant": "black"}
# MaterialX's conversions to the working space (cmlib): <colour space>_to_lin_rec709.
_TO_WORKING_SPACE = "_to_lin_rec709"


@cache
def library() -> Any:
    """The MaterialX standard libraries (node definitions and their defaults)."""
    import MaterialX as mx

    document = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), document)
    return document


def mx_value(value: Any) -> Any:
    """A MaterialX value as Python: tuples of floats for vectors and colours."""
    if hasattr(value, "asTuple"):
        return tuple(float(c) for c in value.asTuple())
    return value


def definition_default(shader_id: str, name: str) -> mv.Constant | None:
    """The default of input ``name`` in node definition ``shader_id`` (``None`` for strings and
    geometric properties such as the texture coordinates)."""
    node_def = library().getNodeDef(shader_id)
    definition = node_def.getActiveInput(name) if node_def else None
    if definition is None or definition.hasDefaultGeomPropString():
        return None
    value = mx_value(definition.getValue())
    return None if value is None or isinstance(value, str) else _constant(value)


def surface_shader(material: Usd.Prim) -> UsdShade.Shader | None:
    """The MaterialX surface shader of ``material``: its ``mtlx`` surface, else its universal
    one, whichever is a surface Penumbra maps; ``None`` when it has none (or a UsdPreviewSurface
    beside an unsupported MaterialX surface)."""
    shaders = [UsdShade.Material(material).ComputeSurfaceSource(context)[0]
               for context in (RENDER_CONTEXT, UsdShade.Tokens.universalRenderContext)]
    ids = [(shader.GetShaderId() or "") if shader else "" for shader in shaders]
    for shader, shader_id in zip(shaders, ids):
        if shader_id in SURFACES:
            return shader
    if ids[1] == "UsdPreviewSurface":
        return None  # an unsupported MaterialX surface beside a UsdPreviewSurface: use that
    for shader, shader_id in zip(shaders, ids):
        if shader_id.startswith("ND_"):
            return shader  # unsupported: read_materialx_material warns and renders defaults
    return None


def _constant(value: Any) -> mv.Constant:
    if isinstance(value, (bool, int, float)):
        return mv.Constant((float(value),))
    return mv.Constant(tuple(float(c) for c in value))


class _Network:
    """Reduces the pattern network behind a surface's inputs, warning once per failing node."""

    def __init__(self, material: Sdf.Path, reader: SampleReader, data: MaterialData,
                 warn: Callable[[str], None]):
        self.material = material
        self.reader = reader
        self.data = data
        self.warn = warn
        self._memo: dict[tuple[Sdf.Path, str], mv.Value] = {}

    def report(self, node: Sdf.Path, message: str) -> None:
        self.warn(f"{self.material}: MaterialX node {node}: {message}")

    # Inputs.
    def input(self, shader: UsdShade.Shader, name: str) -> mv.Value | None:
        """Input ``name`` of ``shader``: its value or network, else its node definition's default
        (``None`` when that is a geometric property such as the texture coordinates)."""
        shader_input = shader.GetInput(name)
        if shader_input:
            producers = shader_input.GetValueProducingAttributes()
            if producers and not UsdShade.Input.IsInput(producers[0]):
                output = producers[0]
                return self.node(UsdShade.Shader(output.GetPrim()),
                                 UsdShade.Output(output).GetBaseName())
            attr = producers[0] if producers else shader_input.GetAttr()
            self.data.sources.add(attr.GetPrim().GetPath())
            value = self.reader.get(attr)
            if value is not None and not isinstance(value, (str, Sdf.AssetPath)):
                return self._decode(_constant(value), attr, shader)
        return self.default(shader, name)

    def default(self, shader: UsdShade.Shader, name: str) -> mv.Value | None:
        return definition_default(shader.GetShaderId() or "", name)

    def string(self, shader: UsdShade.Shader, name: str, default: str = "") -> str:
        shader_input = shader.GetInput(name)
        if shader_input:
            producers = shader_input.GetValueProducingAttributes()
            if producers and UsdShade.Input.IsInput(producers[0]):
                value = self.reader.get(producers[0])
                if value:
                    return str(value)
        node_def = library().getNodeDef(shader.GetShaderId() or "")
        definition = node_def.getActiveInput(name) if node_def else None
        return definition.getValueString() if definition is not None and \
            definition.getValueString() else default

    def _decode(self, value: mv.Constant, attr: Usd.Attribute,
                shader: UsdShade.Shader) -> mv.Constant:
        """A constant colour authored in a colour space other than the working (scene-linear)
        one, converted to it."""
        if value.size not in (3, 4):
            return value
        return mv.Constant(constant_to_scene_linear(
            value.values, authored_color_space(attr),
            lambda message: self.report(shader.GetPath(), f"{attr.GetName()}: {message}")))

    # Nodes.
    def node(self, shader: UsdShade.Shader, output: str) -> mv.Value:
        key = (shader.GetPath(), output)
        if key not in self._memo:
            self.data.sources.add(shader.GetPath())
            try:
                if not shader.GetPrim().IsA(UsdShade.Shader):
                    raise mv.Untranslatable(f"output {output} is not connected to a node")
                self._memo[key] = self._evaluate(shader, output)
            except mv.Untranslatable as error:
                if error.node is None:
                    error.node = shader.GetPath()
                raise
        return self._memo[key]

    def _evaluate(self, shader: UsdShade.Shader, output: str) -> mv.Value:
        shader_id = shader.GetShaderId() or ""
        node_def = library().getNodeDef(shader_id)
        if node_def is None:
            raise mv.Untranslatable(f"{shader_id or 'no info:id'} is not a MaterialX node "
                                    "definition Penumbra knows")
        category = node_def.getNodeString()
        out_def = node_def.getActiveOutput(output) or node_def.getActiveOutputs()[0]
        size = _SIZES.get(out_def.getType(), 0)

        def value(name: str) -> mv.Value:
            result = self.input(shader, name)
            if result is None:
                raise mv.Untranslatable(f"input {name} has no value")
            return result

        if category == "constant":
            return value("value")
        if category in ("image", "tiledimage"):
            return self._image(shader, category, size)
        if category == "texcoord":
            index = int(self.input(shader, "index").values[0])  # type: ignore[union-attr]
            return mv.identity(size, primvar="st" if index == 0 else f"st{index}",
                               fallback=(0.0,) * size)
        if category == "geompropvalue":
            name = self.string(shader, "geomprop")
            default = self.input(shader, "default")
            fallback = default.values if isinstance(default, mv.Constant) else (0.0,) * size
            return mv.identity(size, primvar=name, fallback=fallback)
        if category == "extract":
            return mv.extract(value("in"), int(value("index").values[0]))  # type: ignore
        if category in ("combine2", "combine3", "combine4"):
            return mv.combine([value(f"in{i}") for i in range(1, int(category[-1]) + 1)])
        if category in ("convert", "dot"):
            return mv.resize(value("in"), size) if size else value("in")
        if category == "add":
            return mv.add(value("in1"), value("in2"))
        if category == "subtract":
            return mv.subtract(value("in1"), value("in2"))
        if category == "multiply":
            return mv.multiply(value("in1"), value("in2"))
        if category == "divide":
            return mv.divide(value("in1"), value("in2"))
        if category == "mix":
            return mv.mix(value("fg"), value("bg"), value("mix"))
        if category == "clamp":
            return mv.clamp(value("in"), value("low"), value("high"))
        if category == "normalmap":
            return self._normal_map(value("in"), value("scale"))
        if category.endswith(_TO_WORKING_SPACE):
            return self._to_working_space(shader, value("in"),
                                          category[:-len(_TO_WORKING_SPACE)])
        raise mv.Untranslatable(f"{category} nodes ({shader_id}) are not supported")

    def _image(self, shader: UsdShade.Shader, category: str, size: int) -> mv.Value:
        file = texture_file(shader.GetInput("file"), self.reader)
        default = self.input(shader, "default")
        fallback = list(default.values) if isinstance(default, mv.Constant) else [0.0] * size
        if not file:
            self.report(shader.GetPath(), "image has no file; its default is used")
            return mv.Constant(tuple(fallback))
        texture: dict[str, Any] = {"file": file}
        if len(fallback) == 1:
            fallback = fallback * 3
        texture["fallback"] = tuple((fallback + [0.0, 0.0, 0.0, 1.0][len(fallback):])[:4])
        for axis, wrap in (("u", "wrapS"), ("v", "wrapT")):
            mode = "periodic" if category == "tiledimage" else self.string(
                shader, f"{axis}addressmode", "periodic")
            texture[wrap] = _ADDRESS_MODES.get(mode, "repeat")
        # The file input's colour space (usdMtlx authors the one it inherits in the document),
        # else that of the interface input it is connected to. MaterialX: no colour space is the
        # working space (linear), for every type.
        file_input = shader.GetInput("file")
        space = authored_color_space(file_input.GetAttr(),
                                     *file_input.GetValueProducingAttributes()[:1])
        texture.update(texture_color_space(
            space, lambda message: self.report(shader.GetPath(), message)))
        coordinates = self.input(shader, "texcoord")
        if coordinates is None:
            coordinates = mv.identity(2, primvar="st", fallback=(0.0, 0.0))
        if category == "tiledimage":
            tiling = _constant_or(self.input(shader, "uvtiling"), (1.0, 1.0))
            offset = _constant_or(self.input(shader, "uvoffset"), (0.0, 0.0))
            image_size = _constant_or(self.input(shader, "realworldimagesize"), (1.0, 1.0))
            tile_size = _constant_or(self.input(shader, "realworldtilesize"), (1.0, 1.0))
            ratio = tuple(t / i if i else 1.0 for t, i in zip(tile_size, image_size))
            coordinates = mv.affine(
                coordinates,
                mv.Constant(tuple(a * r for a, r in zip(tiling, ratio))),
                mv.Constant(tuple(-o * r for o, r in zip(offset, ratio))),
            )
        if isinstance(coordinates, mv.Constant):
            texture["st"] = {"fallback": tuple(mv.resize(coordinates, 2).values)}  # type: ignore
        elif isinstance(coordinates, mv.Affine) and coordinates.texture is None and \
                coordinates.channels[:2] == (0, 1):
            texture["st"] = {"primvar": coordinates.primvar,
                             "fallback": tuple((coordinates.fallback + (0.0, 0.0))[:2])}
            if coordinates.scale[:2] != (1.0, 1.0) or coordinates.bias[:2] != (0.0, 0.0):
                texture["transform"] = {"scale": coordinates.scale[:2],
                                        "translation": coordinates.bias[:2]}
        else:
            raise mv.Untranslatable("texture coordinates other than a primvar with scale and "
                                    "offset")
        return mv.identity(size, texture=texture)

    def _normal_map(self, value: mv.Value, scale: mv.Value) -> mv.Value:
        """A tangent-space normal map: the texture's [0, 1] values mapped to [−1, 1], x and y
        scaled by ``scale`` (UsdPreviewSurface's ``normal`` takes the tangent-space vector)."""
        if not isinstance(scale, mv.Constant):
            raise mv.Untranslatable("a varying normal map scale")
        sx, sy = mv.resize(scale, 2).values  # type: ignore[union-attr]
        return mv.affine(value, mv.Constant((2 * sx, 2 * sy, 2.0)), mv.Constant((-sx, -sy, -1.0)))

    def _to_working_space(self, shader: UsdShade.Shader, value: mv.Value,
                          space: str) -> mv.Value:
        """``value`` converted from colour space ``space`` (a ``<space>_to_lin_rec709`` node)."""
        if isinstance(value, mv.Constant):
            return mv.Constant(constant_to_scene_linear(
                value.values, space, lambda message: self.report(shader.GetPath(), message)))
        if not isinstance(value, mv.Affine):
            raise mv.Untranslatable(f"{space} decoding of anything but a texture")
        identity = all(s == 1.0 for s in value.scale) and all(b == 0.0 for b in value.bias)
        raw = value.texture is not None and value.texture.get("sourceColorSpace") == "raw" \
            and "colorSpace" not in value.texture
        if not (raw and identity):
            raise mv.Untranslatable(f"{space} decoding of anything but an unscaled texture "
                                    "without a colour space")
        texture = dict(value.texture, **texture_color_space(  # type: ignore[arg-type]
            space, lambda message: self.report(shader.GetPath(), message)))
        return mv.Affine(value.channels, value.scale, value.bias, texture)


def _constant_or(value: mv.Value | None, default: tuple[float, ...]) -> tuple[float, ...]:
    if value is None:
        return default
    if not isinstance(value, mv.Constant):
        raise mv.Untranslatable("a varying tiling parameter")
    return tuple(mv.resize(value, len(default)).values)  # type: ignore[union-attr]


class _Surface:
    """The surface shader's inputs, each falling back to its default when its network cannot be
    translated."""

    def __init__(self, network: _Network, shader: UsdShade.Shader, defaults_of: str = ""):
        self.network = network
        self.shader = shader
        self.defaults_of = defaults_of  # non-empty: every input is this definition's default
        self.unsupported: list[str] = []

    def __call__(self, name: str) -> mv.Value | None:
        if self.defaults_of:
            return definition_default(self.defaults_of, name)
        try:
            return self.network.input(self.shader, name)
        except mv.Untranslatable as error:
            node = error.node or self.shader.GetPath()
            self.network.report(node, f"{error}; {self.shader.GetPath().name}.{name} uses its "
                                "default value")
            return self.network.default(self.shader, name)

    def constant(self, name: str) -> tuple[float, ...] | None:
        value = self(name)
        return value.values if isinstance(value, mv.Constant) else None

    def connected(self, name: str) -> bool:
        if self.defaults_of:
            return False
        shader_input = self.shader.GetInput(name)
        return bool(shader_input) and shader_input.HasConnectedSource()

    def combine(self, how: Callable[..., mv.Value], *operands: tuple[str, mv.Value | None],
                keep: int) -> mv.Value | None:
        """``how`` applied to the named operands' values, else (after a warning naming them)
        the value of ``operands[keep]``."""
        values = [value for _, value in operands]
        if any(v is None for v in values):
            return values[keep]
        try:
            return how(*values)
        except mv.Untranslatable as error:
            names = ", ".join(name for name, _ in operands)
            self.network.report(self.shader.GetPath(), f"combining {names}: {error}; "
                                f"{operands[keep][0]} alone is used")
            return values[keep]

    def ignore(self, name: str, neutral: tuple[float, ...], weight: str | None = None,
               tolerance: float = 1e-6) -> None:
        """Note ``name`` as unsupported when it is set away from ``neutral`` (and its lobe's
        ``weight`` is not zero)."""
        if weight is not None and self.constant(weight) == (0.0,):
            return
        if not self.connected(name):
            value = self.constant(name)
            if value is None or all(abs(v - n) <= tolerance
                                    for v, n in zip(value, neutral * len(value))):
                return
        self.unsupported.append(name)


def _dielectric_f0(ior: float) -> float:
    return ((ior - 1) / (ior + 1)) ** 2


class _Mapping:
    """The model-independent part: the MaterialX lobes onto UsdPreviewSurface parameters."""

    def __init__(self, surface: _Surface):
        self.surface = surface
        self.values: dict[str, mv.Value | None] = {}
        self.params: dict[str, Any] = {}

    def map(self, *, base: mv.Value | None, metalness: mv.Value | None,
            roughness: mv.Value | None, ior: mv.Value | None, specular_tint: mv.Value | None,
            coat: mv.Value | None, coat_roughness: mv.Value | None,
            coat_color: mv.Value | None, transmission: mv.Value | None,
            transmission_roughness: float | None,
            abbe_number: float, thin_walled: mv.Value | None, emission: mv.Value | None,
            opacity: mv.Value | None, normal: mv.Value | None,
            sheen: tuple[mv.Value | None, mv.Value | None, mv.Value | None]) -> None:
        values = self.values
        values.update(diffuseColor=base, metallic=metalness, roughness=roughness, ior=ior,
                      clearcoat=coat, clearcoatRoughness=coat_roughness, emissiveColor=emission,
                      normal=normal)
        # Nothing is sent for a coat or sheen weight of 0, or a white coat.
        if coat != mv.Constant((0.0,)) and coat_color is not None and \
                coat_color != mv.Constant((1.0, 1.0, 1.0)):
            values["penumbra:clearcoatColor"] = coat_color
        if sheen[0] is not None and sheen[0] != mv.Constant((0.0,)):
            values.update(zip(_SHEEN_PARAMS, sheen))
        tint = specular_tint.values if isinstance(specular_tint, mv.Constant) else None
        if tint is not None and any(abs(t - 1.0) > 1e-6 for t in tint):
            if (
                isinstance(metalness, mv.Constant) and metalness.values[0] == 0.0
                and isinstance(ior, mv.Constant)
            ):
                # A tinted dielectric specular: the specular workflow carries F0 directly.
                f0 = _dielectric_f0(ior.values[0])
                self.params["useSpecularWorkflow"] = 1
                values["specularColor"] = mv.Constant(tuple(f0 * t for t in mv.resize(
                    specular_tint, 3).values))  # type: ignore[union-attr]
            else:
                self.surface.unsupported.append("specular tint on metals")
        elif specular_tint is not None and tint is None:
            self.surface.unsupported.append("varying specular weight or colour")
        transmits = not (isinstance(transmission, mv.Constant) and transmission.values[0] == 0)
        cut_out = opacity is not None and not (
            isinstance(opacity, mv.Constant) and all(v == 1.0 for v in opacity.values)
        )
        if transmits and transmission is not None:
            values["opacity"] = mv.affine(transmission, mv.Constant((-1.0,)),
                                          mv.Constant((1.0,)))
            self.params["opacityThreshold"] = 0.0
            if cut_out:
                self.surface.unsupported.append("geometric opacity with transmission")
            if transmission_roughness is not None:
                self.params["penumbra:transmissionRoughness"] = min(
                    max(transmission_roughness, 0.0), 1.0)
            if abbe_number > 0:
                self.params["penumbra:abbeNumber"] = abbe_number
        elif cut_out and opacity is not None:
            # Geometric opacity is a cut-out at 0.5: Penumbra has no stochastic transparency.
            values["opacity"] = mv.extract(opacity, 0) if opacity.size > 1 and isinstance(
                opacity, mv.Affine) else _mean(opacity)
            self.params["opacityThreshold"] = 0.5
        # thin_walled false leaves the choice to the mesh (closed meshes are solids), as
        # UsdPreviewSurface does: an open mesh cannot be a solid's boundary.
        if isinstance(thin_walled, mv.Constant) and thin_walled.values[0]:
            self.params["penumbra:thinWalled"] = 1

    def anisotropy(self, model: str, specular: mv.Value | None, coat: mv.Value | None,
                   rotation: mv.Value | None) -> None:
        """Anisotropic specular and coat lobes (``model``: the renderer's name of the surface's
        roughness mapping), stretched along the mesh's tangent turned by ``rotation`` (turns).
        Nothing is sent for isotropic lobes."""
        zero = mv.Constant((0.0,))
        sent = {name: value for name, value in zip(_ANISOTROPY_PARAMS[:2], (specular, coat))
                if value is not None and value != zero}
        if not sent:
            return
        self.values.update(sent)
        if rotation is not None and rotation != zero:
            self.values["penumbra:anisotropyRotation"] = rotation
        self.params["penumbra:anisotropyModel"] = model


def _mean(value: mv.Value) -> mv.Value:
    if isinstance(value, mv.Constant):
        return mv.Constant((sum(value.values) / value.size,))
    return mv.extract(value, 0)


def _map_standard_surface(s: _Surface, mapping: _Mapping) -> None:
    base = s.combine(mv.multiply, ("base", s("base")), ("base_color", s("base_color")),
                     keep=1)
    if s.connected("subsurface") or (s.constant("subsurface") or (0.0,))[0] > 0:
        base = s.combine(mv.mix, ("subsurface_color", s("subsurface_color")),
                         ("base_color", base), ("subsurface", s("subsurface")), keep=1)
    roughness = s.constant("specular_roughness")
    extra = s.constant("transmission_extra_roughness")
    # standard_surface's sheen lies on the diffuse base only, not on the metal mixed beside it:
    # its weight is the dielectric fraction's.
    sheen = s("sheen")
    metalness = s.constant("metalness")
    if metalness is not None:
        sheen = s.combine(mv.multiply, ("sheen", sheen),
                          ("1 - metalness", mv.Constant((1.0 - metalness[0],))), keep=0)
    elif sheen != mv.Constant((0.0,)):
        s.unsupported.append("sheen over a varying metalness (the sheen covers the metal too)")
    mapping.map(
        base=base, metalness=s("metalness"), roughness=s("specular_roughness"),
        ior=s("specular_IOR"),
        specular_tint=s.combine(mv.multiply, ("specular", s("specular")),
                                ("specular_color", s("specular_color")), keep=1),
        coat=s("coat"), coat_roughness=s("coat_roughness"), coat_color=s("coat_color"),
        transmission=s("transmission"),
        transmission_roughness=roughness[0] + extra[0] if roughness and extra else None,
        abbe_number=(s.constant("transmission_dispersion") or (0.0,))[0],
        thin_walled=s("thin_walled"),
        emission=s.combine(mv.multiply, ("emission", s("emission")),
                           ("emission_color", s("emission_color")), keep=1),
        opacity=s("opacity"), normal=s("normal") if s.connected("normal") else None,
        sheen=(sheen, s("sheen_color"), s("sheen_roughness")),
    )
    _standard_surface_anisotropy(s, mapping)
    for name, neutral, weight in (
        ("diffuse_roughness", (0.0,), None),
        ("coat_IOR", (1.5,), "coat"),
        ("transmission_color", (1.0,), "transmission"),
        ("transmission_depth", (0.0,), "transmission"),
        ("transmission_scatter", (0.0,), "transmission"),
        ("thin_film_thickness", (0.0,), None),
    ):
        s.ignore(name, neutral, weight)


def _standard_surface_anisotropy(s: _Surface, mapping: _Mapping) -> None:
    """One tangent serves both lobes: the specular rotation where the specular lobe is
    anisotropic, else the coat's."""
    coat = None if s.constant("coat") == (0.0,) else s("coat_anisotropy")
    specular = s("specular_anisotropy")
    isotropic = mv.Constant((0.0,))
    rotation = s("specular_rotation")
    if specular in (None, isotropic):
        rotation = s("coat_rotation")
    elif coat not in (None, isotropic) and s("coat_rotation") != rotation:
        s.unsupported.append("coat_rotation other than specular_rotation")
    if s.connected("tangent") and _anisotropic(specular, coat):
        s.unsupported.append("tangent")
    mapping.anisotropy("standardSurface", specular, coat, rotation)


def _anisotropic(*anisotropies: mv.Value | None) -> bool:
    return any(a not in (None, mv.Constant((0.0,))) for a in anisotropies)


def _map_open_pbr(s: _Surface, mapping: _Mapping) -> None:
    base = s.combine(mv.multiply, ("base_weight", s("base_weight")),
                     ("base_color", s("base_color")), keep=1)
    if s.connected("subsurface_weight") or (s.constant("subsurface_weight") or (0.0,))[0] > 0:
        base = s.combine(mv.mix, ("subsurface_color", s("subsurface_color")),
                         ("base_color", base), ("subsurface_weight", s("subsurface_weight")),
                         keep=1)
    dispersion = (s.constant("transmission_dispersion_scale") or (0.0,))[0]
    abbe = (s.constant("transmission_dispersion_abbe_number") or (0.0,))[0]
    roughness = s.constant("specular_roughness")
    mapping.map(
        base=base, metalness=s("base_metalness"), roughness=s("specular_roughness"),
        ior=s("specular_ior"),
        specular_tint=s.combine(mv.multiply, ("specular_weight", s("specular_weight")),
                                ("specular_color", s("specular_color")), keep=1),
        coat=s("coat_weight"), coat_roughness=s("coat_roughness"),
        coat_color=s("coat_color"), transmission=s("transmission_weight"),
        transmission_roughness=roughness[0] if roughness else None,
        # OpenPBR: the effective Abbe number is the authored one divided by the scale.
        abbe_number=abbe / dispersion if dispersion > 0 and abbe > 0 else 0.0,
        thin_walled=s("geometry_thin_walled"),
        emission=s.combine(mv.multiply, ("emission_luminance", s("emission_luminance")),
                           ("emission_color", s("emission_color")), keep=1),
        opacity=s("geometry_opacity"),
        normal=s("geometry_normal") if s.connected("geometry_normal") else None,
        sheen=(s("fuzz_weight"), s("fuzz_color"), s("fuzz_roughness")),
    )
    specular_anisotropy = s("specular_roughness_anisotropy")
    coat_anisotropy = None if s.constant("coat_weight") == (0.0,) else s(
        "coat_roughness_anisotropy")
    mapping.anisotropy("openPBR", specular_anisotropy, coat_anisotropy, None)
    for tangent, anisotropy in (("geometry_tangent", specular_anisotropy),
                                ("geometry_coat_tangent", coat_anisotropy)):
        if s.connected(tangent) and _anisotropic(anisotropy):
            s.unsupported.append(tangent)
    for name, neutral, weight, tolerance in (
        ("base_diffuse_roughness", (0.0,), None, 1e-6),
        ("coat_ior", (1.5,), "coat_weight", 0.15),  # the BSDF's coat has ior 1.5
        ("transmission_color", (1.0,), "transmission_weight", 1e-6),
        ("transmission_depth", (0.0,), "transmission_weight", 1e-6),
        ("thin_film_weight", (0.0,), None, 1e-6),
    ):
        s.ignore(name, neutral, weight, tolerance)


def _map_preview_surface(s: _Surface, mapping: _Mapping) -> None:
    for name in INPUTS:
        if not name.startswith("penumbra:") and name != "useSpecularWorkflow":
            mapping.values[name] = s(name)
    workflow = s.constant("useSpecularWorkflow")
    if workflow is not None:
        mapping.params["useSpecularWorkflow"] = int(workflow[0] != 0)
    if s.connected("normal"):
        mapping.values["normal"] = s("normal")


_MODELS = {
    STANDARD_SURFACE: _map_standard_surface,
    OPEN_PBR_SURFACE: _map_open_pbr,
    PREVIEW_SURFACE: _map_preview_surface,
}


def read_materialx_material(
    prim: Usd.Prim, shader: UsdShade.Shader, reader: SampleReader, warn: Callable[[str], None]
) -> MaterialData:
    """The delegate parameters of MaterialX material ``prim`` whose surface is ``shader``.

    An unknown surface shader renders as a default ``standard_surface`` (0.8 grey diffuse),
    after one warning naming it.
    """
    path = prim.GetPath()
    data = MaterialData(sources={p.GetPath() for p in Usd.PrimRange(prim)} | {shader.GetPath()})
    network = _Network(path, reader, data, warn)
    shader_id = shader.GetShaderId() or ""
    model = _MODELS.get(shader_id)
    if model is None:
        network.report(shader.GetPath(), f"surface {shader_id} is not supported (Penumbra "
                       f"renders {', '.join(SURFACES)}); a default standard_surface is used")
        surface = _Surface(network, shader, defaults_of=STANDARD_SURFACE)
        model = _map_standard_surface
    else:
        surface = _Surface(network, shader)
    mapping = _Mapping(surface)
    model(surface, mapping)
    if surface.unsupported:
        network.report(shader.GetPath(), f"{', '.join(surface.unsupported)} "
                       f"{'is' if len(surface.unsupported) == 1 else 'are'} not supported by "
                       "Penumbra's BSDF and ignored (docs/materialx.md)")
    for name, param in mapping.params.items():
        if _finite(param):
            data.params[name] = param
        else:
            network.report(shader.GetPath(), f"{name} is not finite; its default is used")
    for name, value in mapping.values.items():
        if value is None:
            continue
        vector = name in _VECTOR_PARAMS
        if not isinstance(value, mv.Constant) and name not in _CONNECTABLE:
            network.report(shader.GetPath(), f"{name} cannot vary over the surface; its "
                           "default is used")
            continue
        try:
            param = mv.to_parameter(value, vector)
        except mv.Untranslatable as error:
            network.report(shader.GetPath(), f"{name}: {error}; its default is used")
            continue
        if name == "normal" and not isinstance(param, dict):
            continue
        if not _finite(param):
            network.report(shader.GetPath(), f"{name} is not finite; its default is used")
            continue
        data.params[name] = param
    return data


def _finite(param: Any) -> bool:
    """Whether every number of a parameter (a texture's scale, bias and fallback included) is
    finite: nothing else may reach the renderer."""
    if isinstance(param, dict):
        return all(_finite(v) for v in param.values())
    if isinstance(param, (tuple, list)):
        return all(_finite(v) for v in param)
    if isinstance(param, float):
        return math.isfinite(param)
    return True
