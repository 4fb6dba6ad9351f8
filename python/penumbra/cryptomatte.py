"""Cryptomatte layers in images: channel names, the EXR header entries and their manifests
(Psyop's Cryptomatte specification 1.2; docs/aovs.md, "Cryptomatte").

A layer ``CryptoObject`` of depth 6 is three RGBA channel sets ``CryptoObject00`` …
``CryptoObject02``, each (id, coverage, id, coverage) of two ranks. Its header entries sit under
``cryptomatte/<key>/``, the key being the first 7 hex digits of the layer name's MurmurHash3:
``name``, ``hash`` (``MurmurHash3_32``), ``conversion`` (``uint32_to_float32``) and
``manifest``, a JSON object of the names whose ids the pixels hold → their ids' bits in 8 hex
digits.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping

import numpy as np

from . import _core

LAYERS = ("CryptoObject", "CryptoMaterial", "CryptoAsset")
"""The Cryptomatte AOVs, named as the specification's examples and Blender's Cycles name them."""
METADATA_PREFIX = "cryptomatte/"
_RANK_CHANNELS = "RGBA"


def channel_names(layer: str, channels: int) -> list[str]:
    """``layer00.R``, ``layer00.G``, … ``layer01.R``, …: 4 channels per two ranks."""
    return [f"{layer}{i // 4:02d}.{_RANK_CHANNELS[i % 4]}" for i in range(channels)]


def layer_key(layer: str) -> str:
    """The layer's key in the header: 7 hex digits of its name's hash, the same every frame."""
    return f"{_core.murmur_hash3(layer):08x}"[:7]


def id_hex(name: str) -> str:
    """A name's id as a manifest writes it: the bits of its float in 8 hex digits."""
    return f"{_core.cryptomatte_bits(_core.murmur_hash3(name)):08x}"


def manifest(pixels: np.ndarray, names: Iterable[str]) -> dict[str, str]:
    """The entries of ``names`` whose ids some pixel of the layer ``pixels`` (H, W, 4 per two
    ranks) holds with a coverage above 0, name → id hex, sorted by name."""
    ranks = pixels.reshape(-1, 2)
    present = np.unique(ranks[ranks[:, 1] > 0, 0].astype(np.float32).view(np.uint32))
    wanted = {int(bits) for bits in present}
    entries = {}
    for name in set(names):
        hex_id = id_hex(name)
        if int(hex_id, 16) in wanted:
            entries[name] = hex_id
    return dict(sorted(entries.items()))


def metadata(layer: str, entries: Mapping[str, str]) -> dict[str, str]:
    """The header entries of a layer with manifest ``entries``."""
    prefix = f"{METADATA_PREFIX}{layer_key(layer)}/"
    return {
        prefix + "name": layer,
        prefix + "hash": "MurmurHash3_32",
        prefix + "conversion": "uint32_to_float32",
        prefix + "manifest": json.dumps(dict(sorted(entries.items())), separators=(",", ":")),
    }


def renamed(image_metadata: Mapping[str, object], layers: Mapping[str, str]) -> dict[str, object]:
    """``image_metadata`` with the Cryptomatte entries of the layers written, ``layers`` mapping each
    channel set's name to its AOV (a render product's var named ``objects`` holding
    ``CryptoObject``): the entries of each under its own name, no others."""
    result = {k: v for k, v in image_metadata.items() if not k.startswith(METADATA_PREFIX)}
    for layer, aov in layers.items():
        if aov in LAYERS:
            key = f"{METADATA_PREFIX}{layer_key(aov)}/manifest"
            result.update(metadata(layer, json.loads(str(image_metadata[key]))))
    return result


def merge_manifests(metadatas: Iterable[Mapping[str, object]]) -> dict[str, str]:
    """The manifests of several images of one frame (farm tiles), each layer's the union of
    theirs: ``cryptomatte/<key>/manifest`` → JSON."""
    merged: dict[str, dict[str, str]] = {}
    for entries in metadatas:
        for key, value in entries.items():
            if key.startswith(METADATA_PREFIX) and key.endswith("/manifest"):
                merged.setdefault(key, {}).update(json.loads(str(value)))
    return {
        key: json.dumps(dict(sorted(names.items())), separators=(",", ":"))
        for key, names in merged.items()
    }


def check_output(path: str, aovs: Iterable[str]) -> None:
    """``ValueError`` naming ``path`` when Cryptomatte ``aovs`` would go to a file other than
    OpenEXR (the only format that holds them and their manifest)."""
    crypto = [aov for aov in aovs if aov in LAYERS]
    if crypto and not str(path).lower().endswith(".exr"):
        raise ValueError(
            f"{path}: Cryptomatte AOVs ({', '.join(crypto)}) are written to OpenEXR (.exr) only"
        )
