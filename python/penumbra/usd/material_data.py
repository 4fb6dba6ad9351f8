"""What the UsdPreviewSurface and MaterialX material readers share: the inputs the delegate's
``material`` takes, the data a material sends, and how a texture's file is resolved."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from pxr import Sdf, UsdShade

from .sampling import SampleReader

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
    "penumbra:thinWalled",
)


@dataclass
class MaterialData:
    """What a material sends to the delegate, and the prims its values were read from."""

    params: dict[str, Any] = field(default_factory=dict)
    sources: set[Sdf.Path] = field(default_factory=set)


# Inputs a shader network may drive, as the delegate takes them (docs/core-api.md,
# set_material); others take their constant value.
CONNECTABLE = frozenset(
    {
        "diffuseColor",
        "emissiveColor",
        "specularColor",
        "metallic",
        "roughness",
        "clearcoat",
        "clearcoatRoughness",
        "opacity",
        "ior",
        "normal",
    }
)


def texture_file(file_input: UsdShade.Input | None, reader: SampleReader) -> str:
    """The texture's path, resolved (``<UDIM>`` patterns anchored to the layer that authored
    them, as USD's resolver leaves them alone); "" when no file is given."""
    if not file_input:
        return ""
    producers = file_input.GetValueProducingAttributes()
    attr = producers[0] if producers else file_input.GetAttr()
    asset = reader.get(attr)
    if isinstance(asset, str):  # authored as a string rather than an asset path
        asset = Sdf.AssetPath(asset)
    if not asset or not asset.path:
        return ""
    if asset.resolvedPath:
        return asset.resolvedPath
    for spec in attr.GetPropertyStack(reader.time):
        if spec.HasDefaultValue() or spec.layer.ListTimeSamplesForPath(spec.path):
            return spec.layer.ComputeAbsolutePath(asset.path)
    return asset.path  # unresolvable: the delegate reports it missing
