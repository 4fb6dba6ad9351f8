"""MaterialX materials authored as UsdShade prims → the delegate's material (docs/materialx.md).

A material whose ``outputs:mtlx:surface`` (else ``outputs:surface``) is a shader with a MaterialX
node definition as ``info:id`` (``ND_standard_surface_surfaceshader``,
``ND_open_pbr_surface_surfaceshader``, ``ND_UsdPreviewSurface_surfaceshader``) is mapped onto the
UsdPreviewSurface parameters the renderer's BSDF takes. Its pattern network is reduced to what
the renderer evaluates per shading point (see ``materialx_values``). What cannot be translated
is reported in one warning per material and node, and the input falls back to its node
definition's default.

The surface models' mappings are in ``materialx_surfaces``, the pattern networks' traversal and
folding in ``materialx_patterns``, the node definitions in ``materialx_library``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from pxr import Usd, UsdShade

from . import materialx_values as mv
from .material_data import MATERIAL_INPUTS, MaterialData
from .materialx_patterns import Network
from .materialx_surfaces import (
    MODELS,
    OPEN_PBR_SURFACE,
    PREVIEW_SURFACE,
    STANDARD_SURFACE,
    SURFACE,
    Mapping,
    Surface,
    is_hair_surface,
)
from .sampling import SampleReader

RENDER_CONTEXT = "mtlx"
SURFACES = (STANDARD_SURFACE, OPEN_PBR_SURFACE, PREVIEW_SURFACE)

# What a MaterialX surface may send, by the delegate's table of material inputs (its
# extensions included: sheen, coat colour and anisotropy vary like the others).
_VECTOR_PARAMS = frozenset(i.name for i in MATERIAL_INPUTS if i.kind == "vector")
_CONNECTABLE = frozenset(i.name for i in MATERIAL_INPUTS if i.connectable)


def surface_shader(material: Usd.Prim) -> UsdShade.Shader | None:
    """The MaterialX surface shader of ``material``: its ``mtlx`` surface, else its universal
    one, whichever is a surface Penumbra maps; ``None`` when it has none (or a UsdPreviewSurface
    beside an unsupported MaterialX surface)."""
    shaders = [UsdShade.Material(material).ComputeSurfaceSource(context)[0]
               for context in (RENDER_CONTEXT, UsdShade.Tokens.universalRenderContext)]
    ids = [(shader.GetShaderId() or "") if shader else "" for shader in shaders]
    for shader, shader_id in zip(shaders, ids):
        if shader_id in SURFACES or (shader_id == SURFACE and is_hair_surface(shader)):
            return shader
    if ids[1] == "UsdPreviewSurface":
        return None  # an unsupported MaterialX surface beside a UsdPreviewSurface: use that
    for shader, shader_id in zip(shaders, ids):
        if shader_id.startswith("ND_"):
            return shader  # unsupported: read_materialx_material warns and renders defaults
    return None



def read_materialx_material(
    prim: Usd.Prim, shader: UsdShade.Shader, reader: SampleReader, warn: Callable[[str], None]
) -> MaterialData:
    """The delegate parameters of MaterialX material ``prim`` whose surface is ``shader``.

    An unknown surface shader renders as a default ``standard_surface`` (0.8 grey diffuse),
    after one warning naming it.
    """
    path = prim.GetPath()
    data = MaterialData(sources={p.GetPath() for p in Usd.PrimRange(prim)} | {shader.GetPath()})
    network = Network(path, reader, data, warn)
    shader_id = shader.GetShaderId() or ""
    model = MODELS.get(shader_id)
    if model is None:
        network.report(shader.GetPath(), f"surface {shader_id} is not supported (Penumbra "
                       f"renders {', '.join(SURFACES)}); a default standard_surface is used")
        surface = Surface(network, shader, defaults_of=STANDARD_SURFACE)
        model = MODELS[STANDARD_SURFACE]
    else:
        surface = Surface(network, shader)
    mapping = Mapping(surface)
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
