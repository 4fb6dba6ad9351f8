"""What a UsdVolVolume is made of: its bound volume material read into the renderer's volume
material (``VolumeMaterial`` in renderer/include/penumbra/volume.h), and which of the volume's
fields feed its density, colour, temperature and emission.

Without a material, the default is close to Cycles' Principled Volume with its defaults: grey
scattering (colour 0.5) of density 1 × the ``density`` field, colour from ``color`` or ``Cd``,
and blackbody emission (intensity 1) from ``temperature`` or ``heat`` × 1000 K when the volume
has such a field. A bound material is read by :func:`read_volume_shading`: a MaterialX
``volume`` node (``materialx_volumes``) or Penumbra's principled volume shader
(``principled_volume``) on its ``outputs:mtlx:volume`` or ``outputs:volume``
(docs/volume-materials.md).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace

from pxr import Usd, UsdShade, UsdVol

from .materialx import RENDER_CONTEXT
from .materialx_volumes import VOLUME, read_materialx_volume
from .principled_volume import PRINCIPLED_VOLUME, read_principled_volume
from .sampling import SampleReader
from .volume_inputs import VolumeWarnings

Color = tuple[float, float, float]


@dataclass(frozen=True)
class VolumeShading:
    """The renderer's VolumeMaterial, and the volume fields (by ``field:NAME`` relationship name)
    that feed each of its four field slots: the first name of each tuple that the volume has
    wins; an empty tuple leaves the slot without a field."""

    density: float = 1.0
    scattering: Color = (0.5, 0.5, 0.5)
    absorption: Color = (0.0, 0.0, 0.0)
    principled_absorption: Color = (1.0, 1.0, 1.0)
    anisotropy: float = 0.0
    emission: Color = (0.0, 0.0, 0.0)
    blackbody_intensity: float = 1.0
    blackbody_tint: Color = (1.0, 1.0, 1.0)
    temperature: float = 1000.0
    density_fields: tuple[str, ...] = ("density",)
    color_fields: tuple[str, ...] = ("color", "Cd")
    temperature_fields: tuple[str, ...] = ("temperature", "heat")
    emission_fields: tuple[str, ...] = field(default=())

    def material(self) -> dict[str, object]:
        """The VolumeMaterial values, as ``set_volume``'s ``material`` argument takes them."""
        values = asdict(self)
        for name in ("density_fields", "color_fields", "temperature_fields", "emission_fields"):
            del values[name]
        return values


def read_volume_shading(
    volume: Usd.Prim, material: Usd.Prim | None, reader: SampleReader,
    warn: Callable[[str], None],
) -> VolumeShading:
    """The shading of ``volume`` with ``material`` bound (``None``: the default), its inputs
    read at ``reader``'s time; ``reader.varying`` becomes true when one of them might vary, so
    that the volume is read again at another frame. What a material asks for that the renderer
    cannot do is approximated by the closest mapping, with one warning naming the volume, the
    material and the node and input; a material without a volume shader Penumbra reads gives
    the default, with one warning."""
    if material is None:
        return default_shading(volume)
    report = VolumeWarnings(volume.GetPath(), warn)
    if not material.IsA(UsdShade.Material):
        report(f"{material.GetPath()} is not a Material; the default volume is used")
        return default_shading(volume)
    shaders = [UsdShade.Material(material).ComputeVolumeSource(context)[0]
               for context in (RENDER_CONTEXT, UsdShade.Tokens.universalRenderContext)]
    shaders = [shader for shader in shaders if shader]
    for shader in shaders:
        shader_id = shader.GetShaderId() or ""
        if shader_id == VOLUME:
            return replace(VolumeShading(), **read_materialx_volume(
                volume, material.GetPath(), shader, reader, report))
        if shader_id == PRINCIPLED_VOLUME:
            return replace(VolumeShading(), **read_principled_volume(
                material.GetPath(), shader, reader, report))
    if shaders:
        report(f"{material.GetPath()}: volume shader {shaders[0].GetPath()} "
               f"({shaders[0].GetShaderId() or 'no info:id'}) is not supported (Penumbra reads "
               f"{VOLUME} and {PRINCIPLED_VOLUME}); the default volume is used")
    else:
        report(f"{material.GetPath()} has no volume shader (outputs:mtlx:volume or "
               "outputs:volume); the default volume is used")
    return default_shading(volume)


def default_shading(volume: Usd.Prim) -> VolumeShading:
    """The shading of ``volume`` without a material: :class:`VolumeShading`'s defaults, without
    blackbody emission when the volume has no temperature field (T would be a uniform
    1000 K)."""
    shading = VolumeShading()
    if any(UsdVol.Volume(volume).HasFieldRelationship(name)
           for name in shading.temperature_fields):
        return shading
    return replace(shading, blackbody_intensity=0.0, temperature_fields=())
