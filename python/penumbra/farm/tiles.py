"""Frames cut into bands of rows, and put back together.

A frame split into ``n`` tiles is cut into ``n`` bands of whole rows. Each worker renders its
band as a crop of the whole image (:meth:`penumbra.Renderer.render`'s ``region``): samples are
seeded by their pixel's position in the image and pixel filters are importance-sampled, not
splatted, so a band's pixels are bit for bit those of the whole image, and pasting the bands
together gives the local render (docs/farm.md).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from .. import cryptomatte
from ..image import Image


@dataclass
class Tile:
    """Rows [first_row, end_row) of a frame's image, as one worker rendered them (no AOVs and
    no metadata for an empty band)."""

    first_row: int
    end_row: int
    width: int
    height: int
    """The whole image's size."""
    aovs: dict[str, np.ndarray]
    metadata: dict[str, str | int | float]
    camera: str
    worker: str
    warnings: list[str] = field(default_factory=list)


def band_rows(height: int, band: int, bands: int) -> tuple[int, int]:
    """Rows [first, end) of band ``band`` of ``bands`` equal bands of an image ``height`` rows
    high (empty when there are more bands than rows)."""
    return height * band // bands, height * (band + 1) // bands


def merge_tiles(tiles: list[Tile]) -> Image:
    """The frame the bands ``tiles`` cover (all of them, any order). Its metadata is the first
    band's, with the counts summed over the bands: ``samplesTaken``, ``rays``, ``meanSamples``
    (as the whole image's) and ``renderTimeSeconds`` (the workers' time, not wall time); the
    passes the last band to stop ran, as the whole image ran them: ``samplesDone`` and
    ``lightPaths`` (each band traces every light path of its passes; with adaptive sampling
    bands stop apart); each Cryptomatte manifest is the union of the bands'."""
    rendered = sorted((tile for tile in tiles if tile.aovs), key=lambda tile: tile.first_row)
    if not rendered:
        raise ValueError("no tile holds pixels")
    first = rendered[0]
    if len(rendered) == 1:
        return Image(first.aovs, first.metadata)
    covered = [(tile.first_row, tile.end_row) for tile in rendered]
    if (
        covered[0][0] != 0
        or covered[-1][1] != first.height
        or any(end != next_first for (_, end), (next_first, _) in itertools.pairwise(covered))
    ):
        raise ValueError(f"tiles {covered} do not cover the {first.height} rows once")
    aovs = {
        name: np.concatenate([tile.aovs[name] for tile in rendered], axis=0) for name in first.aovs
    }
    samples_taken = sum(int(tile.metadata["samplesTaken"]) for tile in rendered)
    metadata = dict(first.metadata)
    metadata.update(
        samplesTaken=samples_taken,
        meanSamples=round(samples_taken / (first.width * first.height), 3),
        rays=sum(int(tile.metadata["rays"]) for tile in rendered),
        renderTimeSeconds=round(
            sum(float(tile.metadata["renderTimeSeconds"]) for tile in rendered), 3
        ),
    )
    for longest in ("samplesDone", "lightPaths"):
        if longest in metadata:
            metadata[longest] = max(int(tile.metadata[longest]) for tile in rendered)
    metadata.update(cryptomatte.merge_manifests(tile.metadata for tile in rendered))
    return Image(aovs, metadata)
