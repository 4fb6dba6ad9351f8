"""Colour spaces named by MaterialX ``colorspace`` attributes and USD ``colorSpace`` metadata, for
textures and constant colours (docs/materialx.md, "Colour spaces").

Names are looked up in the OCIO config the renderer uses (``penumbra.image.ocio_config_path``):
Penumbra's bundled config has MaterialX's names and the Color Interop Forum's (``lin_ap1_scene``,
…) as aliases. A name the config does not have is reported once per material and node by the
caller and the values are read as they are (raw).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache

from pxr import Usd

from .. import _core
from ..image import BUNDLED_OCIO_CONFIG, ocio_config_path

# sRGB-encoded Rec.709: UsdUVTexture's sourceColorSpace sRGB (the config's sRGB texture space).
SRGB_NAMES = frozenset({"srgb_texture", "sRGB", "srgb_rec709", "srgb_rec709_scene"})
# Data, and no colour space at all: values as they are.
RAW_NAMES = frozenset({"", "raw", "data"})
# The sRGB texture space's names in studio configs, as the renderer looks for it.
_CONFIG_SRGB_NAMES = ("sRGB - Texture", "srgb_texture", "sRGB", "Utility - sRGB - Texture")


def authored_color_space(*attrs: Usd.Attribute) -> str:
    """The colour space of the first of ``attrs`` that has one: its ``colorSpace`` metadata,
    else the ``UsdColorSpaceAPI`` of its prim or the nearest ancestor; "" when none has one."""
    for attr in attrs:
        if attr:
            name = Usd.ColorSpaceAPI.ComputeColorSpaceName(attr, Usd.ColorSpaceHashCache())
            if name:
                return str(name)
    return ""


@lru_cache(maxsize=256)
def _config_name(name: str, config: str) -> str:
    """The name of colour space ``name`` in the OCIO config at ``config``; "" when it has none."""
    return _core.find_texture_color_space(name, config)


@lru_cache(maxsize=4096)
def _to_scene_linear(rgb: tuple[float, ...], name: str, config: str) -> tuple[float, ...]:
    return tuple(float(c) for c in _core.to_scene_linear(rgb, name, config))


def texture_color_space(name: str, report: Callable[[str], None]) -> dict[str, str]:
    """The texture description's colour-space entry for a file in colour space ``name``
    (non-empty): ``sourceColorSpace`` for sRGB and raw data, else ``colorSpace`` for a colour
    space of the OCIO config, which the renderer converts to scene-linear. A name the config
    lacks is reported through ``report`` and read as raw."""
    if name in SRGB_NAMES:
        return {"sourceColorSpace": "sRGB"}
    if name not in RAW_NAMES:
        config = ocio_config_path()
        if _config_name(name, config):
            return {"colorSpace": name}
        report(f"colour space {name!r} is not in the OCIO config {config}; the texture is read "
               "as raw values")
    return {"sourceColorSpace": "raw"}


def _srgb_to_linear(c: float) -> float:
    """The sRGB transfer function's inverse (IEC 61966-2-1)."""
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def constant_to_scene_linear(rgb: tuple[float, ...], name: str,
                             report: Callable[[str], None]) -> tuple[float, ...]:
    """The first three values of ``rgb`` converted from colour space ``name`` to scene-linear
    (the rest kept), as a texture in that colour space would be. A name the config lacks is
    reported and the values are used as they are."""
    if name in RAW_NAMES or len(rgb) < 3:
        return rgb
    config = ocio_config_path()
    if name in SRGB_NAMES:
        if config == str(BUNDLED_OCIO_CONFIG):  # scene-linear Rec.709: the curve alone
            return tuple(_srgb_to_linear(c) for c in rgb[:3]) + tuple(rgb[3:])
        # Another scene_linear (ACEScg) takes Rec.709's primaries too, as textures do.
        name = next((n for n in _CONFIG_SRGB_NAMES if _config_name(n, config)), name)
    space = _config_name(name, config)
    if not space:
        report(f"colour space {name!r} is not in the OCIO config {config}; the value is used as "
               "it is")
        return rgb
    if space == _config_name("scene_linear", config):
        return rgb  # the working space already: not even rounded to single precision
    return _to_scene_linear(tuple(rgb[:3]), name, config) + tuple(rgb[3:])
