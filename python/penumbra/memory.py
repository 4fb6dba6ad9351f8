"""Memory budget of a render (``penumbra-record --maxMemory``), checked before the film and the
scene's acceleration structures are allocated, so that an impossible render fails at once with
a clear message instead of ``std::bad_alloc`` or the kernel's OOM killer."""

from __future__ import annotations

import os
import re

from .errors import SceneError

DEFAULT_BUDGET_FRACTION = 0.8
"""Without ``--maxMemory``, a render may use this fraction of the machine's physical memory."""

FILM_BYTES_PER_PIXEL = 184
"""Bytes per pixel of a render pass's film (73: sums in double precision, depth, sample and ray
counts, activity; 64 more where light paths add caustics: their sums and counts) plus the
resolved AOVs and the copies made on their way to the image writer (about 47 at the render's
peak, as measured when the film was 65; writing adds one more copy)."""

AOV_BYTES_PER_PIXEL = 64
"""Bytes per pixel that each AOV beyond colour adds: up to four channels, each summed in double
precision (or kept nearest as a float) and resolved to a float copy on the way out."""
MIN_TEXTURE_CACHE = 16 * 2**20
"""The texture cache is never smaller: below that, lookups thrash."""
MAX_TEXTURE_CACHE = 512 * 2**20
"""Without ``--textureCacheSize``, the texture cache takes 1/8 of the budget, at most this."""

_UNITS = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}
_SIZE = re.compile(r"\s*(?P<number>\d+(?:\.\d*)?|\.\d+)\s*(?P<unit>[KMGT]?)(?:i?B)?\s*", re.I)


def parse_size(text: str) -> int:
    """Bytes in a size such as ``8G``, ``512M``, ``1.5GiB`` or ``1000000`` (powers of 1024);
    ``ValueError`` if malformed or zero."""
    match = _SIZE.fullmatch(text)
    if not match:
        raise ValueError(f"invalid memory size {text!r} (examples: 8G, 512M, 1.5GiB)")
    size = int(float(match["number"]) * _UNITS[match["unit"].upper()])
    if size < 1:
        raise ValueError(f"memory size {text!r} must be positive")
    return size


def physical_memory() -> int:
    """Bytes of physical memory of the machine."""
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def default_budget() -> int:
    """The budget when none is given: :data:`DEFAULT_BUDGET_FRACTION` of physical memory."""
    return int(DEFAULT_BUDGET_FRACTION * physical_memory())


def resident_memory() -> int:
    """Bytes the process holds in memory now (its resident set)."""
    with open("/proc/self/statm", encoding="ascii") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def format_size(size: float) -> str:
    """``size`` bytes in the largest binary unit that keeps it at least 1, e.g. ``1.5 GiB``."""
    for unit in ("TiB", "GiB", "MiB", "KiB"):
        scale = _UNITS[unit[0]]
        if size >= scale:
            return f"{size / scale:.1f} {unit}"
    return f"{size:.0f} B"


def texture_cache_size(budget: int) -> int:
    """The texture cache's share of ``budget`` when none is given: 1/8 of it, at most
    :data:`MAX_TEXTURE_CACHE` and at least :data:`MIN_TEXTURE_CACHE`."""
    return max(MIN_TEXTURE_CACHE, min(MAX_TEXTURE_CACHE, budget // 8))


def check_film(
    width: int, height: int, budget: int, what: str, extra_aovs: int = 0, reserved: int = 0
) -> None:
    """:class:`SceneError` naming ``what`` when a ``width`` × ``height`` film, with
    ``extra_aovs`` AOVs beyond colour, would not fit in ``budget`` bytes together with what the
    process holds already and ``reserved`` bytes promised elsewhere (the texture cache)."""
    film = width * height * (FILM_BYTES_PER_PIXEL + extra_aovs * AOV_BYTES_PER_PIXEL)
    held = resident_memory() + reserved
    if held + film > budget:
        raise SceneError(
            f"{what}: a {width}x{height} image needs about {format_size(film)} for its film "
            f"and AOVs; with the {format_size(held)} the scene holds (texture cache included), "
            f"that is more than the memory budget of {format_size(budget)} (--maxMemory)"
        )


def check_scene_build(estimate: int, budget: int, what: str, reserved: int = 0) -> None:
    """:class:`SceneError` naming ``what`` when building the scene's geometry and acceleration
    structures (``estimate`` bytes, from the render delegate) would not fit in ``budget``
    bytes together with what the process holds and ``reserved`` bytes promised elsewhere."""
    held = resident_memory() + reserved
    if held + estimate > budget:
        raise SceneError(
            f"{what}: building the scene's geometry and acceleration structures needs about "
            f"{format_size(estimate)}; with the {format_size(held)} the process holds (texture "
            f"cache included), that is more than the memory budget of {format_size(budget)} "
            "(--maxMemory)"
        )
