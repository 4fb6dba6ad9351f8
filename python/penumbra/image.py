"""Rendered images: AOV arrays plus metadata, written by the same writer as the CLI."""

from __future__ import annotations

import base64
import html
import os
import re
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

import numpy as np

from . import _core, cryptomatte

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
"""Files name Penumbra's metadata ``penumbra:<key>``; the camera matrices keep OIIO's standard
names (:data:`OIIO_METADATA`), and keys already in a namespace (standard attributes such as
``Exif:ImageUniqueID``) keep theirs."""
OIIO_METADATA = ("worldtocamera", "worldtoscreen", "PixelAspectRatio")
DATA_WINDOW = "dataWindow"
"""The metadata key of an image cut from a larger frame (render settings' ``dataWindowNDC``):
``[x, y, frame width, frame height]``, its top-left pixel in the frame and the frame's size;
:meth:`Image.write` makes them an EXR's data and display windows."""
"""Metadata written under OIIO's standard names rather than with :data:`METADATA_PREFIX`."""


def _attribute_name(key: str) -> str:
    """The file attribute of a metadata key (see :data:`METADATA_PREFIX`)."""
    if key.startswith(cryptomatte.METADATA_PREFIX):  # the specification's names
        return key
    return key if ":" in key or key in OIIO_METADATA else METADATA_PREFIX + key


_COLOR_SUFFIXES = "RGBA"
_VECTOR_SUFFIXES = "xyzw"
COLOR_AOVS = ("color", "albedo", "variance", "noisyColor")
"""AOVs whose channels are colours (suffixes R, G, B, A); others are vectors (x, y, z, w)."""


def channel_names(aov: str, channels: int, layer: str | None = None) -> list[str]:
    """EXR channel names of an AOV written as ``layer`` (by default its name): ``color`` is R,
    G, B, A and ``Z`` is Z; a one-channel AOV is the layer's name; others are the layer's
    channels ``layer.R``, ``layer.G``, … for colours, ``layer.x``, ``layer.y``, … for vectors
    (normals, positions, primvars), as OIIO names layered channels; Cryptomatte AOVs are
    ``layer00.R``, ``layer00.G``, … as the specification names them."""
    layer = layer or aov
    if aov in cryptomatte.LAYERS:
        return cryptomatte.channel_names(layer, channels)
    if aov == "color" and layer == "color":
        return list(_COLOR_SUFFIXES[:channels])
    if aov == "Z" and layer == "Z" and channels == 1:
        return ["Z"]
    if channels == 1:
        return [layer]
    suffixes = _COLOR_SUFFIXES if aov in COLOR_AOVS else _VECTOR_SUFFIXES
    return [f"{layer}.{suffixes[i] if i < len(suffixes) else i}" for i in range(channels)]


class Image(Mapping[str, np.ndarray]):
    """The AOVs of one render (``image["color"]``: float32 (H, W, 4), scene-linear) and its
    metadata (camera, samples, seed, renderTimeSeconds, version, timeCode, stage)."""

    def __init__(
        self,
        aovs: Mapping[str, np.ndarray],
        metadata: Mapping[str, object],
        *,
        sources: Mapping[str, str] | None = None,
    ):
        """``sources``: for entries not named after the AOV they hold (render products' vars),
        that AOV's name (it decides the channel suffixes)."""
        if not aovs:
            raise ValueError("an image needs at least one AOV")
        shapes = {array.shape[:2] for array in aovs.values()}
        if len(shapes) != 1:
            raise ValueError(f"AOVs of one image must have one size, not {sorted(shapes)}")
        self._aovs = {name: np.asarray(array, dtype=np.float32) for name, array in aovs.items()}
        self.metadata: dict[str, object] = dict(metadata)
        self.sources = {name: (sources or {}).get(name, name) for name in self._aovs}

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
        half: Iterable[str] = (),
    ) -> None:
        """Write the image atomically; the extension picks the format.

        ``.exr`` holds every AOV as float channels (see :func:`channel_names`; the AOVs named
        in ``half`` as half floats) and the metadata as ``penumbra:*`` attributes (the camera
        matrices under OIIO's names, :data:`OIIO_METADATA`; keys with a namespace as they
        are); an image cut from a larger frame (metadata ``dataWindow``: x, y, frame width and
        height) keeps the frame as the EXR's display window and its place as the data window.
        Other formats hold the ``color`` AOV converted to display values: ``color_mode``
        ``"openColorIO"`` (default) uses ``ocio_config``, else ``$OCIO``, else Penumbra's
        bundled config (sRGB display, "Standard" view unless ``display``/``view`` say
        otherwise); ``"sRGB"`` applies the sRGB transfer function;
        ``"disabled"`` writes the linear values. The transform applies to un-premultiplied
        colour; TIFF stores it premultiplied again, PNG as it is (unassociated alpha). An
        extension not in :data:`OUTPUT_FORMATS` raises ``ValueError``, a missing or read-only
        directory ``OSError``, other errors ``RuntimeError``, each naming the file.
        """
        if color_mode not in COLOR_MODES:
            raise ValueError(f"color_mode must be one of {COLOR_MODES}, not {color_mode!r}")
        path = os.fspath(path)
        check_output_format(path)
        cryptomatte.check_output(path, self.sources.values())
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
        half_channels: list[bool] = []
        half = set(half)
        for aov, array in aovs:
            array = array.reshape(array.shape[0], array.shape[1], -1)
            arrays.append(array)
            names += channel_names(self.sources[aov], array.shape[2], aov)
            half_channels += [aov in half] * array.shape[2]
        config = ""
        if color_mode == "openColorIO":
            config = ocio_config_path(ocio_config)
        # A crop of a frame (dataWindowNDC): an EXR keeps the frame as its display window.
        data_window = self.metadata.get(DATA_WINDOW) if path.lower().endswith(".exr") else None
        _core.write_image(
            path,
            np.ascontiguousarray(np.concatenate(arrays, axis=2)),
            names,
            {
                _attribute_name(key): value
                for key, value in self.metadata.items()
                if key != DATA_WINDOW  # the file's data and display windows say it
            },
            color_mode=color_mode,
            ocio_config=config,
            display=display,
            view=view,
            half_channels=half_channels,
            data_window=tuple(data_window) if data_window is not None else None,
        )

    def display(
        self,
        view: str = "",
        display: str = "",
        *,
        aov: str = "color",
        ocio_config: str | os.PathLike | None = None,
    ) -> np.ndarray:
        """Display-referred RGB (float32, H x W x 3, unpremultiplied, clipped to [0, 1]) of
        a colour AOV through OCIO: ``ocio_config``, else ``$OCIO``, else the bundled config,
        with its default display and view unless named."""
        pixels = self[aov]
        rgb = pixels[..., :3]
        if pixels.shape[2] > 3:  # the transform applies to colour, not colour times coverage
            alpha = pixels[..., 3:4]
            rgb = np.where(alpha > 0, rgb / np.where(alpha > 0, alpha, 1), 0)
        shown = _core.display_pixels(
            np.ascontiguousarray(rgb, dtype=np.float32),
            "openColorIO",
            ocio_config_path(ocio_config),
            display,
            view,
        )
        return np.clip(shown, 0.0, 1.0)

    def _repr_png_(self) -> bytes:
        """The colour AOV (else the first) as a PNG, for Jupyter."""
        return png_bytes(self._preview("color" if "color" in self._aovs else next(iter(self))))

    def _repr_html_(self) -> str:
        """Every AOV side by side, each under its name, for Jupyter."""
        cells = "".join(
            '<figure style="margin:0 8px 8px 0">'
            f'<img src="data:image/png;base64,{base64.b64encode(png_bytes(self._preview(name))).decode()}"/>'
            f'<figcaption style="text-align:center">{html.escape(name)}</figcaption></figure>'
            for name in self._aovs
        )
        return f'<div style="display:flex;flex-wrap:wrap">{cells}</div>'

    def _preview(self, name: str) -> np.ndarray:
        """An AOV as display RGB in [0, 1]: colours through OCIO, the rest mapped to show
        their structure (see :func:`preview_pixels`)."""
        if self.sources[name] in ("color", "noisyColor"):
            return self.display(aov=name)
        return preview_pixels(self.sources[name], self[name])


def preview_pixels(aov: str, pixels: np.ndarray) -> np.ndarray:
    """A non-colour AOV as RGB in [0, 1] for a glance: ids (Cryptomatte's most covering one)
    as distinct hashed colours (black: nothing), distances and other single channels scaled over their finite range (near
    bright), vectors with 3 channels (normals, positions, albedo) scaled the same way."""
    pixels = pixels.reshape(pixels.shape[0], pixels.shape[1], -1)
    if aov in cryptomatte.LAYERS:  # rank 0's id as a colour, dimmed by its coverage
        bits = np.ascontiguousarray(pixels[..., 0], dtype=np.float32).view(np.uint32)
        rgb = np.stack([(bits >> shift & 0xFF) / 255.0 for shift in (0, 8, 16)], axis=-1)
        return (0.25 + 0.75 * rgb) * pixels[..., 1:2]
    if aov in ("primId", "instanceId", "elementId"):
        ids = pixels[..., 0].astype(np.int64)
        hashed = (ids + 1) * np.array([2654435761, 2246822519, 3266489917], dtype=np.int64)[:, None, None]
        rgb = ((hashed >> 8) % 255 / 255.0).transpose(1, 2, 0)
        return np.where((ids < 0)[..., None], 0.0, 0.25 + 0.75 * rgb)
    finite = np.isfinite(pixels)
    low = float(pixels[finite].min()) if finite.any() else 0.0
    high = float(pixels[finite].max()) if finite.any() else 1.0
    scaled = np.where(finite, (pixels - low) / max(high - low, 1e-12), 0.0)
    if aov in ("depth", "Z"):
        scaled = np.where(finite, 1.0 - scaled, 0.0)
    if scaled.shape[2] >= 3:
        return scaled[..., :3]
    return np.repeat(scaled[..., :1], 3, axis=2)


def png_bytes(rgb: np.ndarray) -> bytes:
    """An 8-bit PNG of display RGB in [0, 1] (H x W x 3)."""
    with tempfile.TemporaryDirectory() as directory:
        path = os.path.join(directory, "preview.png")
        _core.write_image(
            path,
            np.ascontiguousarray(rgb, dtype=np.float32),
            ["R", "G", "B"],
            color_mode="disabled",
        )
        with open(path, "rb") as file:
            return file.read()
