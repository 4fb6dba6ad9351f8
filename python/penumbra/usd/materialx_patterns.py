"""MaterialX pattern networks → the values the renderer evaluates per shading point.

The network behind a surface input is traversed node by node and each node folded into a
``materialx_values`` value: constants, texture lookups (image and tiledimage nodes with their
coordinates, address modes and colour spaces), primvars, and the arithmetic between them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pxr import Sdf, Usd, UsdShade

from . import materialx_hair as hair
from . import materialx_values as mv
from .color_spaces import authored_color_space, constant_to_scene_linear, texture_color_space
from .material_data import MaterialData, texture_file
from .materialx_library import definition_default, library, to_constant
from .sampling import SampleReader

_SIZES = {"float": 1, "integer": 1, "boolean": 1, "vector2": 2, "color3": 3, "vector3": 3,
          "color4": 4, "vector4": 4}
# MaterialX address modes → UsdUVTexture wrap modes.
_ADDRESS_MODES = {"periodic": "repeat", "clamp": "clamp", "mirror": "mirror", "constant": "black"}
# MaterialX's conversions to the working space (cmlib): <colour space>_to_lin_rec709.
_TO_WORKING_SPACE = "_to_lin_rec709"


class Network:
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
                return self._decode(to_constant(value), attr, shader)
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
        if category == "chiang_hair_absorption_from_color":
            color = _constant(value("color"), "color")
            return mv.Constant(hair.absorption_from_color(
                color, _constant(value("azimuthal_roughness"), "azimuthal_roughness")[0]))
        if category == "deon_hair_absorption_from_melanin":
            concentration, redness, eumelanin, pheomelanin = (
                _constant(value(name), name) for name in (
                    "melanin_concentration", "melanin_redness", "eumelanin_color",
                    "pheomelanin_color"))
            return mv.Constant(hair.absorption_from_melanin(concentration[0], redness[0],
                                                            eumelanin, pheomelanin))
        if category == "chiang_hair_roughness":
            inputs = (_constant(value(name), name)[0]
                      for name in ("longitudinal", "azimuthal", "scale_TT", "scale_TRT"))
            return mv.Constant(hair.roughness(*inputs)[out_def.getName()])
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


def _constant(value: mv.Value, name: str) -> tuple[float, ...]:
    """The values of a hair node's input, which must not vary: the nodes are not affine in
    them (an absorption node feeding chiang_hair_bsdf directly is converted per shading point
    instead, materialx_surfaces._map_hair_absorption)."""
    if not isinstance(value, mv.Constant):
        raise mv.Untranslatable(f"a varying {name} (hair nodes are evaluated on constants, "
                                "except an absorption node feeding absorption_coefficient)")
    return value.values
