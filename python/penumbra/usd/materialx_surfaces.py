"""MaterialX surface models → UsdPreviewSurface parameters: standard_surface, open_pbr_surface
and UsdPreviewSurface as MaterialX node definitions, each mapped onto the lobes of the
renderer's BSDF, and a surface node over a chiang_hair_bsdf onto its hair BSDF; what a model
sets that the BSDF lacks is collected for one warning.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pxr import UsdShade

from . import materialx_hair as hair
from . import materialx_values as mv
from .material_data import INPUTS
from .materialx_library import definition_default
from .materialx_patterns import Network

STANDARD_SURFACE = "ND_standard_surface_surfaceshader"
OPEN_PBR_SURFACE = "ND_open_pbr_surface_surfaceshader"
PREVIEW_SURFACE = "ND_UsdPreviewSurface_surfaceshader"
SURFACE = "ND_surface"  # the surfaceshader constructor over a BSDF
CHIANG_HAIR = "ND_chiang_hair_bsdf"
CHIANG_HAIR_ROUGHNESS = "ND_chiang_hair_roughness"
ABSORPTION_FROM_COLOR = "ND_chiang_hair_absorption_from_color"
ABSORPTION_FROM_MELANIN = "ND_deon_hair_absorption_from_melanin"
# The inputs of the absorption nodes that become the renderer's when one of them varies.
_ABSORPTION_INPUTS = {
    ABSORPTION_FROM_COLOR: {"color": "penumbra:hairColor",
                            "azimuthal_roughness": "penumbra:hairColorAzimuthalRoughness"},
    ABSORPTION_FROM_MELANIN: {"melanin_concentration": "penumbra:hairMelanin",
                              "melanin_redness": "penumbra:hairMelaninRedness"},
}
SHEEN_PARAMS = ("penumbra:sheen", "penumbra:sheenColor", "penumbra:sheenRoughness")
ANISOTROPY_PARAMS = ("penumbra:anisotropy", "penumbra:clearcoatAnisotropy",
                     "penumbra:anisotropyRotation")


class Surface:
    """The surface shader's inputs, each falling back to its default when its network cannot be
    translated."""

    def __init__(self, network: Network, shader: UsdShade.Shader, defaults_of: str = ""):
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


class Mapping:
    """The model-independent part: the MaterialX lobes onto UsdPreviewSurface parameters."""

    def __init__(self, surface: Surface):
        self.surface = surface
        self.values: dict[str, mv.Value | None] = {}
        self.params: dict[str, Any] = {}

    def map(self, *, base: mv.Value | None, metalness: mv.Value | None,
            roughness: mv.Value | None, ior: mv.Value | None,
            specular_weight: mv.Value | None, specular_color: mv.Value | None,
            coat: mv.Value | None, coat_roughness: mv.Value | None,
            coat_color: mv.Value | None, coat_ior: mv.Value | None,
            transmission: mv.Value | None,
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
            values.update(zip(SHEEN_PARAMS, sheen))
        # Both models' conductors whiten towards grazing angles (F82 edge tint, white unless
        # tinted), where UsdPreviewSurface's metals keep their albedo.
        if metalness != mv.Constant((0.0,)):
            self.params["penumbra:metalWhiteEdge"] = 1
        # The coat has its own IOR (UsdPreviewSurface's coat takes the base's).
        if coat != mv.Constant((0.0,)):
            if isinstance(coat_ior, mv.Constant):
                self.params["penumbra:clearcoatIor"] = max(coat_ior.values[0], 1.0)
            else:
                self.surface.unsupported.append("coat IOR driven by a network (1.5 is used)")
                self.params["penumbra:clearcoatIor"] = 1.5
        self.specular(specular_weight, specular_color, metalness, ior)
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

    def specular(self, weight: mv.Value | None, color: mv.Value | None,
                 metalness: mv.Value | None, ior: mv.Value | None) -> None:
        """The dielectric specular lobe's weight (it scales the lobe whole, grazing reflection
        included) and colour (a tint of F0 alone, through the specular workflow's specularColor:
        dielectrics with a constant IOR only)."""
        if isinstance(weight, mv.Constant) and weight.values[0] != 1.0:
            if weight.values[0] > 1.0:
                self.surface.unsupported.append("specular weight above 1 (1 is used)")
            self.params["penumbra:specularWeight"] = min(max(weight.values[0], 0.0), 1.0)
        tint = color.values if isinstance(color, mv.Constant) else None
        if tint is not None and any(abs(t - 1.0) > 1e-6 for t in tint):
            if (
                isinstance(metalness, mv.Constant) and metalness.values[0] == 0.0
                and isinstance(ior, mv.Constant)
            ):
                # A tinted dielectric specular: the specular workflow carries F0 directly.
                f0 = _dielectric_f0(ior.values[0])
                self.params["useSpecularWorkflow"] = 1
                self.values["specularColor"] = mv.Constant(tuple(f0 * t for t in mv.resize(
                    color, 3).values))  # type: ignore[union-attr]
            else:
                self.surface.unsupported.append("specular tint on metals")
        elif (color is not None and tint is None) or (
                weight is not None and not isinstance(weight, mv.Constant)):
            self.surface.unsupported.append("varying specular weight or colour")

    def anisotropy(self, model: str, specular: mv.Value | None, coat: mv.Value | None,
                   rotation: mv.Value | None) -> None:
        """Anisotropic specular and coat lobes (``model``: the renderer's name of the surface's
        roughness mapping), stretched along the mesh's tangent turned by ``rotation`` (turns).
        Nothing is sent for isotropic lobes."""
        zero = mv.Constant((0.0,))
        sent = {name: value for name, value in zip(ANISOTROPY_PARAMS[:2], (specular, coat))
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


def _map_standard_surface(s: Surface, mapping: Mapping) -> None:
    base = s.combine(mv.multiply, ("base", s("base")), ("base_color", s("base_color")),
                     keep=1)
    _subsurface(s, mapping, weight="subsurface", radius="subsurface_radius",
                scale="subsurface_scale", anisotropy="subsurface_anisotropy", keep_radius=0)
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
        specular_weight=s("specular"), specular_color=s("specular_color"),
        coat=s("coat"), coat_roughness=s("coat_roughness"), coat_color=s("coat_color"),
        coat_ior=s("coat_IOR"), transmission=s("transmission"),
        transmission_roughness=roughness[0] + extra[0] if roughness and extra else None,
        abbe_number=(s.constant("transmission_dispersion") or (0.0,))[0],
        thin_walled=s("thin_walled"),
        emission=s.combine(mv.multiply, ("emission", s("emission")),
                           ("emission_color", s("emission_color")), keep=1),
        opacity=s("opacity"), normal=s("normal") if s.connected("normal") else None,
        sheen=(sheen, s("sheen_color"), s("sheen_roughness")),
    )
    _standard_surface_anisotropy(s, mapping)
    _transmission_absorption(s, mapping, "transmission")
    for name, neutral, weight in (
        ("diffuse_roughness", (0.0,), None),
        ("transmission_scatter", (0.0,), "transmission"),
        ("thin_film_thickness", (0.0,), None),
    ):
        s.ignore(name, neutral, weight)


def _standard_surface_anisotropy(s: Surface, mapping: Mapping) -> None:
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


def _map_open_pbr(s: Surface, mapping: Mapping) -> None:
    base = s.combine(mv.multiply, ("base_weight", s("base_weight")),
                     ("base_color", s("base_color")), keep=1)
    _subsurface(s, mapping, weight="subsurface_weight", radius="subsurface_radius",
                scale="subsurface_radius_scale", anisotropy="subsurface_scatter_anisotropy",
                keep_radius=1)
    dispersion = (s.constant("transmission_dispersion_scale") or (0.0,))[0]
    abbe = (s.constant("transmission_dispersion_abbe_number") or (0.0,))[0]
    roughness = s.constant("specular_roughness")
    mapping.map(
        base=base, metalness=s("base_metalness"), roughness=s("specular_roughness"),
        ior=s("specular_ior"),
        specular_weight=s("specular_weight"), specular_color=s("specular_color"),
        coat=s("coat_weight"), coat_roughness=s("coat_roughness"),
        coat_color=s("coat_color"), coat_ior=s("coat_ior"),
        transmission=s("transmission_weight"),
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
    _transmission_absorption(s, mapping, "transmission_weight")
    for name, neutral, weight, tolerance in (
        ("base_diffuse_roughness", (0.0,), None, 1e-6),
        ("transmission_scatter", (0.0,), "transmission_weight", 1e-6),
        ("thin_film_weight", (0.0,), None, 1e-6),
    ):
        s.ignore(name, neutral, weight, tolerance)


def _subsurface(s: Surface, mapping: Mapping, *, weight: str, radius: str, scale: str,
                anisotropy: str, keep_radius: int) -> None:
    """Subsurface scattering (a random walk through closed meshes, diffuse reflection of the
    subsurface colour on open ones; renderer/include/penumbra/subsurface.h): its weight, colour,
    anisotropy and mean free path, the radius times its scale (``keep_radius``: which of the two
    is kept, after a warning, when they cannot be multiplied — the colour one). Nothing is sent
    for a weight of 0."""
    if not s.connected(weight) and (s.constant(weight) or (0.0,))[0] <= 0:
        return
    mapping.values.update({
        "penumbra:subsurface": s(weight),
        "penumbra:subsurfaceColor": s("subsurface_color"),
        "penumbra:subsurfaceRadius": s.combine(mv.multiply, (radius, s(radius)),
                                               (scale, s(scale)), keep=keep_radius),
        "penumbra:subsurfaceAnisotropy": s(anisotropy),
    })


def _transmission_absorption(s: Surface, mapping: Mapping, weight: str) -> None:
    """A solid's transmission colour reached at its transmission depth (absorbing glass;
    renderer/include/penumbra/material.h, transmissionDepth). Without a positive constant depth
    the colour would tint the interface itself, which the BSDF's translucent part cannot: it is
    reported then."""
    depth = s.constant("transmission_depth")
    if s.constant(weight) == (0.0,):
        return
    if depth is not None and depth[0] > 0:
        mapping.params["penumbra:transmissionDepth"] = depth[0]
        mapping.values["penumbra:transmissionColor"] = s("transmission_color")
        return
    s.ignore("transmission_color", (1.0,), weight)
    s.ignore("transmission_depth", (0.0,), weight)


def _map_preview_surface(s: Surface, mapping: Mapping) -> None:
    for name in INPUTS:
        if not name.startswith("penumbra:") and name != "useSpecularWorkflow":
            mapping.values[name] = s(name)
    workflow = s.constant("useSpecularWorkflow")
    if workflow is not None:
        mapping.params["useSpecularWorkflow"] = int(workflow[0] != 0)
    if s.connected("normal"):
        mapping.values["normal"] = s("normal")


def _source(shader: UsdShade.Shader, name: str) -> tuple[UsdShade.Shader, str] | None:
    """The node and output name that input ``name`` of ``shader`` is connected to (through
    node graph interfaces); ``None`` when it takes a value."""
    shader_input = shader.GetInput(name)
    if not shader_input:
        return None
    producers = shader_input.GetValueProducingAttributes()
    if not producers or UsdShade.Input.IsInput(producers[0]):
        return None
    return UsdShade.Shader(producers[0].GetPrim()), UsdShade.Output(producers[0]).GetBaseName()


def is_hair_surface(shader: UsdShade.Shader) -> bool:
    """Whether ``shader``, a ``surface`` node, is built over a ``chiang_hair_bsdf`` (so that it
    wins over a UsdPreviewSurface beside it, as the supported surfaces do)."""
    source = _source(shader, "bsdf")
    return source is not None and source[0].GetShaderId() == CHIANG_HAIR


def _map_surface(s: Surface, mapping: Mapping) -> None:
    """MaterialX's ``surface`` constructor: over a ``chiang_hair_bsdf``, the renderer's hair
    BSDF; over any other BSDF, a default standard_surface after a warning."""
    source = _source(s.shader, "bsdf")
    bsdf_id = (source[0].GetShaderId() or "") if source else ""
    if source is None or bsdf_id != CHIANG_HAIR:
        s.network.report(s.shader.GetPath(), f"surface over {bsdf_id or 'no BSDF'} is not "
                         f"supported (Penumbra maps a surface over {CHIANG_HAIR}); a default "
                         "standard_surface is used")
        _map_standard_surface(Surface(s.network, s.shader, defaults_of=STANDARD_SURFACE),
                              mapping)
        return
    s.network.data.sources.add(source[0].GetPath())
    fibre = Surface(s.network, source[0])
    _map_chiang_hair(fibre, mapping)
    s.unsupported.extend(fibre.unsupported)
    if s.connected("edf"):
        s.unsupported.append("edf")
    s.ignore("opacity", (1.0,))


def _map_chiang_hair(h: Surface, mapping: Mapping) -> None:
    """chiang_hair_bsdf onto the renderer's hair parameters (material.h, MaterialParams::hair):
    tints and absorption as they are, the cuticle angle from MaterialX's [0, 1] (α = (c − 0.5)
    π) to degrees, the per-lobe roughness to β_m, β_n and scales."""
    mapping.params["penumbra:hair"] = 1
    values = mapping.values
    for lobe in hair.LOBES:
        values[f"penumbra:hairTint{lobe}"] = h(f"tint_{lobe}")
    values["penumbra:hairIor"] = h("ior")
    cuticle = h("cuticle_angle")
    if cuticle is not None:
        values["penumbra:hairCuticleAngle"] = mv.affine(cuticle, mv.Constant((180.0,)),
                                                        mv.Constant((-90.0,)))
    _map_hair_absorption(h, mapping)
    _map_hair_roughness(h, mapping)
    # The fibre's own direction and normal serve (hair_bsdf.h).
    for name in ("normal", "curve_direction"):
        if h.connected(name):
            h.unsupported.append(name)


def _map_hair_absorption(h: Surface, mapping: Mapping) -> None:
    """absorption_coefficient: folded to a constant where it can be; from a
    chiang_hair_absorption_from_color or deon_hair_absorption_from_melanin node whose colour or
    melanin varies (a per-strand primvar, a texture), those inputs drive the renderer's, which
    derives σa at each shading point (material.h, hairAbsorptionFromColor)."""
    source = _source(h.shader, "absorption_coefficient")
    node = source[0] if source else None
    inputs_of = _ABSORPTION_INPUTS.get(node.GetShaderId() or "") if node else None
    if node is not None and inputs_of is not None:
        try:
            values = {name: h.network.input(node, node_input)
                      for node_input, name in inputs_of.items()}
        except mv.Untranslatable:
            values = {}  # reported once below, by the absorption's own evaluation
        if values and not all(isinstance(value, mv.Constant) for value in values.values()):
            inputs = Surface(h.network, node)
            h.network.data.sources.add(node.GetPath())
            mapping.values.update(values)
            if node.GetShaderId() == ABSORPTION_FROM_COLOR:
                mapping.params["penumbra:hairAbsorptionFromColor"] = 1
            else:
                mapping.params["penumbra:hairAbsorptionFromMelanin"] = 1
                # The renderer holds d'Eon's pigments only.
                for name in ("eumelanin_color", "pheomelanin_color"):
                    inputs.ignore(name, definition_default(  # type: ignore[union-attr]
                        ABSORPTION_FROM_MELANIN, name).values, tolerance=1e-5)
            h.unsupported.extend(f"{node.GetPath().name}.{name}" for name in inputs.unsupported)
            return
    mapping.values["penumbra:hairAbsorption"] = h("absorption_coefficient")


def _map_hair_roughness(h: Surface, mapping: Mapping) -> None:
    """roughness_R, _TT and _TRT: from one chiang_hair_roughness node's inputs (which may vary
    over the surface), else from their constant (v, s) pairs."""
    names = [f"roughness_{lobe}" for lobe in hair.LOBES]
    sources = [_source(h.shader, name) for name in names]
    node = sources[0][0] if sources[0] else None
    if node is not None and node.GetShaderId() == CHIANG_HAIR_ROUGHNESS and all(
            source is not None and source[0].GetPath() == node.GetPath() and source[1] == name
            for source, name in zip(sources, names)):
        h.network.data.sources.add(node.GetPath())
        roughness = Surface(h.network, node)
        mapping.values.update({
            "penumbra:hairLongitudinalRoughness": roughness("longitudinal"),
            "penumbra:hairAzimuthalRoughness": roughness("azimuthal"),
            "penumbra:hairLongitudinalScaleTT": roughness("scale_TT"),
            "penumbra:hairLongitudinalScaleTRT": roughness("scale_TRT"),
        })
        return
    lobes = {}
    for name in names:
        value = h.constant(name)
        if value is None:
            h.unsupported.append(f"{name} varying other than through a chiang_hair_roughness "
                                 "node (its default is used)")
            value = definition_default(CHIANG_HAIR, name).values  # type: ignore[union-attr]
        lobes[name] = tuple(value)
    mapping.params.update(hair.parameters_from_lobes(lobes))


MODELS = {
    STANDARD_SURFACE: _map_standard_surface,
    OPEN_PBR_SURFACE: _map_open_pbr,
    PREVIEW_SURFACE: _map_preview_surface,
    SURFACE: _map_surface,
}
