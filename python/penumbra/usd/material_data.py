"""What the UsdPreviewSurface and MaterialX material readers share: the inputs the delegate's
``material`` takes, the data a material sends, and how a texture's file is resolved."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from pxr import Sdf, UsdShade

from .. import _core
from .packaged_files import local_path
from .sampling import SampleReader
from .values import as_asset_path

MATERIAL_INPUTS: tuple[_core.MaterialInput, ...] = tuple(
    _core.material_inputs()
)
"""Every input the render delegate's ``set_material`` takes (renderer/material_inputs.h)."""

PREVIEW_SURFACE_INPUTS = tuple(i for i in MATERIAL_INPUTS if i.origin != "extension")
"""The inputs read from a UsdPreviewSurface shader: the schema's own and Penumbra's extensions
authored on it (``inputs:penumbra:abbeNumber``)."""

# The inputs with a constant value, in the table's order (docs/core-api.md, set_material).
INPUTS = tuple(i.name for i in PREVIEW_SURFACE_INPUTS if i.constant)


@dataclass
class MaterialData:
    """What a material sends to the delegate, and the prims its values were read from."""

    params: dict[str, Any] = field(default_factory=dict)
    sources: set[Sdf.Path] = field(default_factory=set)


# Inputs a shader network may drive, as the delegate takes them (docs/core-api.md,
# set_material); others take their constant value.
CONNECTABLE = frozenset(i.name for i in PREVIEW_SURFACE_INPUTS if i.connectable)


def texture_file(file_input: UsdShade.Input | None, reader: SampleReader) -> str:
    """The texture's path, resolved (``<UDIM>`` patterns anchored to the layer that authored
    them, as USD's resolver leaves them alone; a file inside a USDZ package copied out,
    :mod:`.packaged_files`); "" when no file is given."""
    if not file_input:
        return ""
    producers = file_input.GetValueProducingAttributes()
    attr = producers[0] if producers else file_input.GetAttr()
    asset = as_asset_path(reader.get(attr))  # of a wrong type: no file, and the caller warns
    if asset is None or not asset.path:
        return ""
    if asset.resolvedPath:
        return local_path(asset.resolvedPath)
    for spec in attr.GetPropertyStack(reader.time):
        if spec.HasDefaultValue() or spec.layer.ListTimeSamplesForPath(spec.path):
            # A search path (no "./") is resolved against the layer by its tiles: the literal
            # pattern is no file, which the layer's own anchoring would leave unresolved.
            if UsdShade.UdimUtils.IsUdimIdentifier(asset.path):
                if resolved := UsdShade.UdimUtils.ResolveUdimPath(asset.path, spec.layer):
                    return resolved
            return spec.layer.ComputeAbsolutePath(asset.path)
    return asset.path  # unresolvable: the delegate reports it missing
