"""Checkpoints of a frame being rendered (docs/checkpoints.md): the image rendered so far,
written to the output path, and beside it the exact state of the render pass
(``<output>.penumbra-checkpoint``) from which a resumed render continues the same sample
sequence, so that it ends bit-identical to an uninterrupted render.

A state file is :data:`_MAGIC`, the length of a JSON header (4 bytes, little-endian), the
header (format version, render key, image size, crop, AOVs, samples done, seconds spent, and
the length and SHA-256 of the state) and the render pass's state
(``penumbra._core.RenderPass.save_state``). Files are written to a temporary file, synced and
renamed, so that a kill leaves the previous checkpoint or the new one, never half of one.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import struct
from dataclasses import dataclass
from pathlib import Path

from .image import remove_stale_temporaries

RENDER_KEY = "Exif:ImageUniqueID"
"""The metadata attribute holding a render's key (``penumbra-record``'s
:meth:`penumbra.jobs.RenderJob.frame_key`): Exif's unique image id (128 bits as 32 hexadecimal
digits), which every output format keeps (EXR, PNG, JPEG and TIFF)."""
PARTIAL = "penumbra:partial"
"""The file attribute saying an image is a checkpoint of a frame still being rendered."""
STATE_SUFFIX = ".penumbra-checkpoint"
FORMAT_VERSION = 1
_MAGIC = b"penumbra checkpoint\n"
_HEADER_LENGTH = struct.Struct("<I")


def check_seconds(value: float | None, name: str) -> float | None:
    """``value`` as a float of seconds (None stays None); ``ValueError`` naming ``name`` unless
    it is a finite number >= 0."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"{name} must be a number of seconds, not {type(value).__name__}")
    if not (math.isfinite(value) and value >= 0):
        raise ValueError(f"{name} must be a finite number of seconds >= 0, not {value!r}")
    return float(value)


@dataclass(frozen=True)
class Checkpoint:
    """Where and how often a render saves its progress (``Renderer.render(checkpoint=...)``).

    ``path``: the image file; every ``interval`` seconds of rendering (checked between passes
    of samples; 0: after every pass; None: never, only resume) the image rendered so far is
    written there atomically, its metadata saying ``partial`` 1 and ``samplesDone``, with the
    render pass's exact state in ``path`` + :data:`STATE_SUFFIX`. When the frame is finished,
    the final image is written to ``path`` and the state file removed. ``resume``: continue
    from the state file when it was saved by the same render (same ``key``); else render from
    scratch (a corrupt state file is reported with a warning naming it). ``key``: what
    identifies the render (``penumbra-record`` gives its frame key); by default a hash of the
    render's arguments and options, Penumbra's version and the layers the stage composes (the
    text of anonymous or edited layers; the identifier, size and modification time of saved
    ones), so that a stage edited in memory or on disk renders from scratch. ``color_mode``: as
    :meth:`Image.write`'s.
    """

    path: str
    interval: float | None = None
    resume: bool = False
    key: str | None = None
    color_mode: str = "openColorIO"

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", os.fspath(self.path))
        object.__setattr__(self, "interval", check_seconds(self.interval, "checkpoint interval"))

    @property
    def state_path(self) -> str:
        """The file holding the render pass's state beside the image."""
        return state_file(self.path)


def state_file(output: str) -> str:
    """The checkpoint state file beside image ``output`` (there while its frame is unfinished)."""
    return output + STATE_SUFFIX


class CorruptCheckpoint(ValueError):
    """A state file that is truncated, of another format, or damaged."""


@dataclass(frozen=True)
class SavedState:
    """A render pass's state as a state file holds it."""

    key: str
    samples_done: int
    render_seconds: float
    """Seconds spent rendering the samples saved (a time limit counts them)."""
    state: bytes


def write_state(
    path: str, key: str, samples_done: int, render_seconds: float, about: dict, state: bytes
) -> None:
    """Write a state file atomically; ``about`` (size, crop, AOVs) goes in its header."""
    header = {
        "formatVersion": FORMAT_VERSION,
        "key": key,
        "samplesDone": samples_done,
        "renderSeconds": render_seconds,
        **about,
        "stateBytes": len(state),
        "stateSha256": hashlib.sha256(state).hexdigest(),
    }
    encoded = json.dumps(header, sort_keys=True).encode()
    remove_stale_temporaries(path)
    target = Path(path)
    # Named as the image writer names its temporaries, so that the same clean-up finds them.
    temporary = target.parent / f".{target.stem}.tmp{os.getpid()}-0{target.suffix}"
    try:
        with open(temporary, "wb") as file:
            file.write(_MAGIC + _HEADER_LENGTH.pack(len(encoded)) + encoded)
            file.write(state)
            file.flush()
            os.fsync(file.fileno())
        os.replace(temporary, path)
    finally:
        if os.path.exists(temporary):
            os.remove(temporary)


def read_state(path: str) -> SavedState | None:
    """The state saved in ``path``; None if there is no such file. Raises
    :class:`CorruptCheckpoint` saying what is wrong with a file that is not a whole state file
    of this format."""
    try:
        with open(path, "rb") as file:
            data = file.read()
    except FileNotFoundError:
        return None
    except OSError as error:
        raise CorruptCheckpoint(f"cannot be read ({error.strerror})") from None
    if not data.startswith(_MAGIC):
        raise CorruptCheckpoint("is not a Penumbra checkpoint")
    start = len(_MAGIC) + _HEADER_LENGTH.size
    if len(data) < start:
        raise CorruptCheckpoint("is truncated")
    (header_length,) = _HEADER_LENGTH.unpack_from(data, len(_MAGIC))
    try:
        header = json.loads(data[start : start + header_length])
        version = header["formatVersion"]
        state = data[start + header_length :]
        if version != FORMAT_VERSION:
            raise CorruptCheckpoint(f"has format version {version}, not {FORMAT_VERSION}")
        if len(state) != header["stateBytes"]:
            raise CorruptCheckpoint("is truncated")
        if hashlib.sha256(state).hexdigest() != header["stateSha256"]:
            raise CorruptCheckpoint("is damaged (checksum mismatch)")
        return SavedState(
            str(header["key"]),
            int(header["samplesDone"]),
            float(header["renderSeconds"]),
            state,
        )
    except (ValueError, KeyError, TypeError) as error:
        if isinstance(error, CorruptCheckpoint):
            raise
        raise CorruptCheckpoint("has a damaged or truncated header") from None


def remove_state(path: str) -> None:
    """Remove a state file if there is one."""
    try:
        os.remove(path)
    except FileNotFoundError:
        pass
