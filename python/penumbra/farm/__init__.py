"""Rendering on a Dask cluster: ``penumbra-record --scheduler tcp://HOST:PORT`` or
``--workers N`` (docs/farm.md).

Tasks are frames, or bands of rows of a frame when there are fewer frames than workers; the
client merges the bands (bit-identical to a local render with the same seed) and writes each
frame once, atomically.
"""

from .client import FarmError, FarmSummary, connect, record_on_farm, tiles_per_frame
from .tiles import Tile, band_rows, merge_tiles
from .worker import FrameFailed

__all__ = [
    "FarmError",
    "FarmSummary",
    "FrameFailed",
    "Tile",
    "band_rows",
    "connect",
    "merge_tiles",
    "record_on_farm",
    "tiles_per_frame",
]
