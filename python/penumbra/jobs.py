"""What ``penumbra-record`` renders, as one value: a :class:`RenderJob` holds the stage (path,
session layer, mask, resolver), the camera and every render setting. The same job renders each
frame on this machine or on a farm worker (:class:`JobRenderer`), so both see the same inputs,
and names each frame with a key (:meth:`RenderJob.frame_key`) that ``--resume`` finds in the
image's metadata.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from pxr import Usd

from . import _core, _interrupts, render_options
from .checkpoints import PARTIAL, RENDER_KEY, Checkpoint, state_file
from .errors import SceneError, warn
from .image import Image
from .products import render_products
from .renderer import DEFAULT_WIDTH, Renderer
from .trace import Tracer
from .usd import DEFAULT_PURPOSES, open_stage, read_render_settings, render_pass_settings
from .usd import resolve_camera
from .usd.framing import FRAMING_CAMERA_PATH, framing_camera
from .usd.products import read_products

FrameTime = float | str
"""A frame to render: a time code, :data:`DEFAULT_TIME` (USD's Default time code) or
:data:`START_TIME` (the stage's startTimeCode, which only the stage knows)."""
DEFAULT_TIME = "default"
START_TIME = "start"


# Settings that change how a frame is computed but not a bit of its pixels (besides the render
# options that say so). camera_time: a named or stage camera does not depend on it and a framing
# camera is placed again at each frame, so a range's first frame decides no pixel (`-f 3:4
# --resume` skips what `-f 1:4` rendered).
_NOT_IN_KEY = ("max_memory", "texture_cache", "camera_time")
_URI_SCHEME = re.compile(r"[A-Za-z][A-Za-z0-9+.-]+:")


def absolute_path(path: str) -> str:
    """A file path made absolute (farm workers do not share the client's working directory);
    asset identifiers with a URI scheme (``scheme:...``) are kept as they are."""
    return path if _URI_SCHEME.match(path) else os.path.abspath(path)


@dataclass(frozen=True)
class RenderJob:
    """Everything a frame's pixels depend on, as ``penumbra-record``'s flags give it (see
    :meth:`penumbra.Renderer.render` for the render settings)."""

    usd_file: str
    session_layer: str | None = None
    mask: tuple[str, ...] = ()
    resolver: str = "root"
    purposes: tuple[str, ...] = DEFAULT_PURPOSES
    camera: str | None = None
    """``--camera`` as given: resolved on the stage (at :attr:`camera_time`)."""
    camera_time: FrameTime = START_TIME
    """The frame at which the camera is looked up: the first one rendered (not in the key: a
    camera framing the stage is placed again at each frame, as usdrecord places it)."""
    render_settings_path: str | None = None
    render_pass_path: str | None = None
    color_mode: str = "sRGB"
    aovs: tuple[str, ...] = ("color",)
    denoise: bool = False
    width: int | None = None
    """``--imageWidth``; None: a render product's resolution, else :data:`DEFAULT_WIDTH`."""
    options: Mapping[str, render_options.OptionValue] = field(default_factory=dict, hash=False)
    """The render options given, by Python keyword (``{"samples": 16}``); the others are the
    render settings prim's or their defaults (:meth:`penumbra.Renderer.render`)."""
    disable_motion_blur: bool = False
    disable_depth_of_field: bool = False
    dome_light_visibility: bool = False
    disable_camera_light: bool = False
    max_memory: int | None = None
    texture_cache: int | None = None
    time_limit: float | None = None
    """``--timeLimit``: seconds per frame (in the key: it decides how many samples are taken)."""

    def frame_key(self, frame: FrameTime) -> str:
        """A hash of everything that decides the pixels of ``frame`` (stage, population,
        camera, render settings, colour mode, Penumbra's version): an output whose metadata
        holds it is that frame, complete (images are written atomically). Not the stage's
        contents, a render settings prim's ``penumbra:KEY`` options among them: edit the stage
        and render without ``--resume``."""
        fields = {
            name: value
            for name, value in dataclasses.asdict(self).items()
            if name not in _NOT_IN_KEY
        }
        # Every option that changes pixels, given or not: `--samples 64` is the default's key.
        fields["options"] = {
            name: value
            for name, value in render_options.resolve(self.options).items()
            if render_options.BY_KEYWORD[name].changes_pixels
        }
        text = json.dumps(
            {"job": fields, "frame": frame, "version": _core.version()}, sort_keys=True
        )
        return hashlib.sha256(text.encode()).hexdigest()[:32]


def time_code(stage: Usd.Stage, frame: FrameTime) -> Usd.TimeCode:
    """The time code of ``frame`` on ``stage``."""
    if frame == DEFAULT_TIME:
        return Usd.TimeCode.Default()
    if frame == START_TIME:
        return Usd.TimeCode(stage.GetStartTimeCode())
    return Usd.TimeCode(float(frame))


def frame_label(frame: FrameTime) -> str:
    """How messages name a frame: its time code, or "default" / "start"."""
    return f"{frame:g}" if isinstance(frame, float) else frame


def output_is_complete(path: str, key: str) -> bool:
    """Whether ``path`` holds the frame whose key is ``key`` (read from its header only); a
    missing, unreadable or different file is not, nor a checkpoint of it: one with a state file
    beside it (PNG, TIFF and JPEG drop ``partial`` but keep the key) or marked ``partial``."""
    if os.path.exists(state_file(path)):  # removed only once the frame is finished
        return False
    try:
        metadata = _core.read_image_header(path)[3]
    except RuntimeError:
        return False
    return metadata.get(RENDER_KEY) == key and not metadata.get(PARTIAL)


class JobRenderer:
    """A job's stage, opened and synced once, rendering its frames or parts of them; edits
    between frames are synced incrementally (see :class:`penumbra.Renderer`)."""

    def __init__(self, job: RenderJob, tracer: Tracer | None = None):
        self.job = job
        tracer = tracer or Tracer(enabled=False)
        with _interrupts.deferred():  # USD's bindings would lose a signal (_interrupts.py)
            with tracer.span("open stage", file=job.usd_file):
                stage = open_stage(
                    job.usd_file,
                    mask=job.mask,
                    session_layer=job.session_layer,
                    resolver=job.resolver,
                )
            settings_path = job.render_settings_path
            if job.render_pass_path:
                settings_path = render_pass_settings(stage, job.render_pass_path)
            settings = read_render_settings(stage, settings_path)
            self.render_settings = settings.path if settings else None
            self.products = read_products(stage, settings) if settings is not None else None
            """The render products of the render settings, if they name any."""
            if self.products is not None and not self.products.products:
                self.products = None
            purposes = job.purposes
            if self.products is not None:
                if job.aovs != ("color",):
                    warn("--aov applies to renders without render products; the products name "
                         "their vars")
                if self.products.included_purposes is not None:
                    purposes = tuple(self.products.included_purposes)
            camera = resolve_camera(
                stage, job.camera, settings, time_code(stage, job.camera_time), purposes
            )
            self.camera = str(camera.GetPath())
            self._purposes = purposes
            self.renderer = Renderer(stage, purposes=purposes, render_pass=job.render_pass_path)
        self.renderer.tracer = tracer

    def _frame_camera(self, frame: FrameTime) -> str:
        """The camera of ``frame``: a camera framing the stage is placed again at each frame
        (as usdrecord's FrameRecorder does), so that moving geometry stays in view."""
        if self.camera == str(FRAMING_CAMERA_PATH):
            stage = self.renderer.stage
            with _interrupts.deferred():  # USD's bindings would lose a signal (_interrupts.py)
                framing_camera(stage, time_code(stage, frame), self._purposes)
        return self.camera

    def close(self) -> None:
        self.renderer.close()

    def __enter__(self) -> JobRenderer:
        return self

    def __exit__(self, *_exc) -> None:
        self.close()

    def image_size(self, frame: FrameTime) -> tuple[int, int]:
        """The size of ``frame``'s image (apertures and render settings may be animated; a
        framing camera's are fixed, wherever it is placed)."""
        return self.renderer.image_size(
            self.camera,
            time_code(self.renderer.stage, frame),
            self.job.width or DEFAULT_WIDTH,
            render_settings=self.render_settings,
        )

    def _options(self) -> dict:
        """The render() arguments every frame shares."""
        job = self.job
        return dict(
            **job.options,
            disable_motion_blur=job.disable_motion_blur,
            disable_depth_of_field=job.disable_depth_of_field,
            dome_light_visibility=job.dome_light_visibility,
            default_light="none" if job.disable_camera_light else "camera",
            max_memory=job.max_memory,
            texture_cache=job.texture_cache,
            denoise=job.denoise,
            time_limit=job.time_limit,
        )

    def render(
        self,
        frame: FrameTime,
        region: tuple[int, int, int, int] | None = None,
        progress: Callable[[int, int], None] | None = None,
        checkpoint: Checkpoint | None = None,
    ) -> Image:
        """Render ``frame`` (only the pixels of ``region``, ``(x, y, width, height)``, if
        given); the image's metadata holds the frame's key. Stages whose render settings have
        products render them with :meth:`render_products` instead. ``checkpoint``: as
        :meth:`penumbra.Renderer.render`'s, its key set to the frame's."""
        if self.products is not None:
            raise SceneError(
                f"{self.render_settings}: render products are rendered on this machine only "
                "(not with --scheduler or --workers) in this version"
            )
        image = self.renderer.render(
            camera=self._frame_camera(frame),
            time=time_code(self.renderer.stage, frame),
            width=self.job.width or DEFAULT_WIDTH,
            aovs=self.job.aovs,
            render_settings=self.render_settings,
            region=region,
            checkpoint=(
                None
                if checkpoint is None
                else dataclasses.replace(checkpoint, key=self.job.frame_key(frame))
            ),
            progress=progress,
            **self._options(),
        )
        image.metadata[RENDER_KEY] = self.job.frame_key(frame)
        return image

    def render_products(
        self,
        frame: FrameTime,
        directory: str,
        progress: Callable[[str], Callable[[int, int], None]] | None = None,
    ) -> list[tuple[str, Image]]:
        """Render and write (atomically) every render product of ``frame``, with paths relative
        to ``directory`` (PNG, JPEG and TIFF ones through the job's ``color_mode``, as the
        output image); returns each product's path and image. ``progress``: as
        :func:`penumbra.products.render_products`' ``progress_for``."""
        assert self.products is not None
        return render_products(
            self.renderer,
            self.products,
            time_code(self.renderer.stage, frame),
            directory,
            camera=self.job.camera,
            width=self.job.width,
            color_mode=self.job.color_mode,
            progress_for=progress,
            **self._options(),
        )
