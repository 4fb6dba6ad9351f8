"""Rendered images: AOV arrays plus metadata, written by the same writer as the CLI."""

from __future__ import annotations

import os
import re
from collections.abc import Iterator, Mapping
from pathlib import Path

import numpy as np

from . import _core

BUNDLED_OCIO_CONFIG = Path(__file__).resolve().parent / "ocio" / "config.ocio"
"""The OCIO config used (for display output and for linearising textures) when ``$OCIO`` is
unset."""


def ocio_config_path(explicit: str | os.PathLike | None = None) -> str:
    """The OCIO config in effect: ``explicit``, else ``$OCIO``, else the bundled one."""
    return os.fspath(explicit or os.environ.get("OCIO") or BUNDLED_OCIO_CONFIG)

COLOR_MODES = ("disabled", "sRGB", "openColorIO")
OUTPUT_FORMATS = (".exr", ".png", ".jpg", ".jpeg", ".tif", ".tiff")
"""The image formats Penumbra writes (by extension, any case): scene-linear EXR, and display
formats through OCIO."""


def check_output_format(path: str | os.PathLike) -> None:
    """``ValueError`` naming ``path`` unless its extension is one of :data:`OUTPUT_FORMATS`."""
    path = os.fspath(path)
    extension = os.path.splitext(path)[1].lower()
    if extension not in OUTPUT_FORMATS:
        raise ValueError(
            f"{path}: cannot write {extension or 'files without an extension'}; "
            f"the output formats are {', '.join(OUTPUT_FORMATS)}"
        )


def check_output_directory(path: str | os.PathLike) -> None:
    """``OSError`` naming ``path`` unless its directory exists and is writable and ``path``
    itself is not a directory."""
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise OSError(f"{path}: directory {directory} does not exist")
    if not os.access(directory, os.W_OK | os.X_OK):
        raise OSError(f"{path}: directory {directory} is not writable")
    if os.path.isdir(path):
        raise OSError(f"{path}: is a directory, not an image file")


def remove_stale_temporaries(path: str | os.PathLike) -> list[str]:
    """Remove the hidden temporary files that writers of ``path`` killed mid-write (SIGKILL,
    power loss) left beside it; returns their paths. The image writer names them
    ``.<stem>.tmp<pid>-<n><extension>``; those of a live process are kept."""
    target = Path(path)
    pattern = re.compile(
        rf"\.{re.escape(target.stem)}\.tmp(?P<pid>\d+)-\d+{re.escape(target.suffix)}"
    )
    removed = []
    for entry in os.scandir(target.parent):
        match = pattern.fullmatch(entry.name)
        if match and entry.is_file(follow_symlinks=False) and not _alive(int(match["pid"])):
            try:
                os.remove(entry.path)
            except FileNotFoundError:  # another run cleaned it first
                continue
            removed.append(entry.path)
    return removed


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists (possibly another user's)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
METADATA_PREFIX = "penumbra:"
"""Files name Penumbra's metadata ``penumbra:<key>``; keys already in a namespace (standard
attributes such as ``Exif:ImageUniqueID``) keep their name."""


def _attribute_name(key: str) -> str:
    """The file attribute of a metadata key (see :data:`METADATA_PREFIX`)."""
    return key if ":" in key else METADATA_PREFIX + key


_CHANNEL_SUFFIXES = "RGBA"


def channel_names(aov: str, channels: int) -> list[str]:
    """EXR channel names of an AOV: ``color`` is R, G, B, A; ``depth`` is Z; any other AOV is
    a layer ``aov.R``, ``aov.G``, … (or plain ``aov`` when it has one channel)."""
    if aov == "color":
        return list(_CHANNEL_SUFFIXES[:channels])
    if aov == "depth" and channels == 1:
        return ["Z"]
    if channels == 1:
        return [aov]
    return [f"{aov}.{_CHANNEL_SUFFIXES[i] if i < 4 else i}" for i in range(channels)]


class Image(Mapping[str, np.ndarray]):
    """The AOVs of one render (``image["color"]``: float32 (H, W, 4), scene-linear) and its
    metadata (camera, samples, seed, renderTimeSeconds, version, timeCode, stage)."""

    def __init__(self, aovs: Mapping[str, np.ndarray], metadata: Mapping[str, str | int | float]):
        if not aovs:
            raise ValueError("an image needs at least one AOV")
        shapes = {array.shape[:2] for array in aovs.values()}
        if len(shapes) != 1:
            raise ValueError(f"AOVs of one image must have one size, not {sorted(shapes)}")
        self._aovs = {name: np.asarray(array, dtype=np.float32) for name, array in aovs.items()}
        self.metadata: dict[str, str | int | float] = dict(metadata)

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self._aovs[name]
        except KeyError:
            raise KeyError(f"no AOV {name!r} in this image (it has {sorted(self._aovs)})") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._aovs)

    def __len__(self) -> int:
        return len(self._aovs)

    @property
    def width(self) -> int:
        return next(iter(self._aovs.values())).shape[1]

    @property
    def height(self) -> int:
        return next(iter(self._aovs.values())).shape[0]

    def __repr__(self) -> str:
        return f"<penumbra.Image {self.width}x{self.height} aovs={list(self._aovs)}>"

    def write(
        self,
        path: str | os.PathLike,
        color_mode: str = "openColorIO",
        *,
        ocio_config: str | os.PathLike | None = None,
        display: str = "",
        view: str = "",
    ) -> None:
        """Write the image atomically; the extension picks the format.

        ``.exr`` holds every AOV as float channels (see :func:`channel_names`) and the metadata
        as ``penumbra:*`` attributes (keys with a namespace as they are). Other formats hold the ``color`` AOV converted to display
        values: ``color_mode`` ``"openColorIO"`` (default) uses ``ocio_config``, else ``$OCIO``,
        else Penumbra's bundled config (sRGB display, "Standard" view unless ``display``/
        ``view`` say otherwise); ``"sRGB"`` applies the sRGB transfer function;
        ``"disabled"`` writes the linear values. The transform applies to un-premultiplied
        colour; TIFF stores it premultiplied again, PNG as it is (unassociated alpha). An
        extension not in :data:`OUTPUT_FORMATS` raises ``ValueError``, a missing or read-only
        directory ``OSError``, other errors ``RuntimeError``, each naming the file.
        """
        if color_mode not in COLOR_MODES:
            raise ValueError(f"color_mode must be one of {COLOR_MODES}, not {color_mode!r}")
        path = os.fspath(path)
        check_output_format(path)
        check_output_directory(path)
        remove_stale_temporaries(path)
        if path.lower().endswith(".exr"):
            aovs = list(self._aovs.items())
        elif "color" in self._aovs:
            aovs = [("color", self._aovs["color"])]
        else:
            raise ValueError(f"{path}: only .exr can hold an image without a 'color' AOV")
        arrays: list[np.ndarray] = []
        names: list[str] = []
        for aov, array in aovs:
            array = array.reshape(array.shape[0], array.shape[1], -1)
            arrays.append(array)
            names += channel_names(aov, array.shape[2])
        config = ""
        if color_mode == "openColorIO":
            config = ocio_config_path(ocio_config)
        _core.write_image(
            path,
            np.ascontiguousarray(np.concatenate(arrays, axis=2)),
            names,
            {_attribute_name(key): value for key, value in self.metadata.items()},
            color_mode=color_mode,
            ocio_config=config,
            display=display,
            view=view,
        )
