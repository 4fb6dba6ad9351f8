"""The Python API: :class:`Renderer` keeps a stage synced into one render delegate."""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import time as clock
from collections.abc import Callable, Iterable

import numpy as np
from pxr import Ar, Sdf, Usd

from . import _core, _interrupts, cryptomatte
from .checkpoints import (
    RENDER_KEY,
    Checkpoint,
    CorruptCheckpoint,
    check_seconds,
    read_state,
    remove_state,
    write_state,
)
from .errors import SceneError, warn
from .denoise import GUIDE_AOVS, NOISY_COLOR, denoise_color
from .image import (
    DATA_WINDOW,
    Image,
    check_output_directory,
    check_output_format,
    ocio_config_path,
)
from . import render_options
from .memory import (
    MIN_TEXTURE_CACHE,
    check_film,
    check_scene_build,
    default_budget,
    texture_cache_size,
)
from .trace import Tracer
from .usd.camera import camera_problem, read_shutter
from .usd.camera_metadata import camera_metadata
from .usd.default_light import DefaultLight, DefaultLightManager, check_default_light
from .usd.mtlx_documents import compose_materialx_documents
from .usd.sampling import DEFAULT_MAX_MOTION_SEGMENTS, Shutter
from .usd.render_pass import render_pass_collections
from .usd.settings import FilmWindow, film_window, find_camera
from .usd import (
    DEFAULT_PURPOSES,
    RenderSettings,
    SceneDelegate,
    image_size,
    open_stage,
    read_render_settings,
    resolve_camera,
    stage_name,
)

DEFAULT_WIDTH = 960  # usdrecord's default image width
PassKey = tuple[str, int, int, tuple[int, int, int, int] | None, int]
"""What identifies a render pass: camera, image width and height, crop (or None) and margin."""
PROGRESS_STEPS = 16  # progress is reported about this many times per render

ProgressCallback = Callable[[int, int], None]
"""Called as ``progress(samples_done, samples_total)`` while a render runs."""

TimeLike = float | Usd.TimeCode | None
logger = logging.getLogger("penumbra")


def _time_code(stage: Usd.Stage, time: TimeLike) -> Usd.TimeCode:
    """``time`` as a time code; ``None`` is the stage's startTimeCode (as in usdrecord)."""
    if time is None:
        return Usd.TimeCode(stage.GetStartTimeCode())
    if isinstance(time, Usd.TimeCode):
        return time
    return Usd.TimeCode(float(time))


def as_stage(stage_or_path: Usd.Stage | str | os.PathLike) -> Usd.Stage:
    """A stage, or the stage opened from a file path; ``TypeError`` names the types taken."""
    if isinstance(stage_or_path, Usd.Stage):
        compose_materialx_documents(stage_or_path, warn)
        return stage_or_path
    if isinstance(stage_or_path, (str, os.PathLike)):
        return open_stage(stage_or_path)
    raise TypeError(
        "expected a pxr.Usd.Stage or the path of a USD file (str or os.PathLike), not "
        f"{type(stage_or_path).__module__}.{type(stage_or_path).__qualname__}"
    )


class Renderer:
    """Renders a USD stage (a ``Usd.Stage``, or the path of a file to open); edits to the
    stage are picked up incrementally.

    Creating a renderer syncs the stage (at its startTimeCode) into one render delegate. Each
    :meth:`render` then pushes only what changed since the previous one: edited prims (the
    renderer listens to the stage's change notices) and, at a new time code or shutter, the
    prims whose data might vary with time. One render pass is kept per (camera, width, height).

    ``purposes``: the UsdGeomImageable purposes rendered; "default" is always included and the
    default, ``("default", "proxy")``, is usdrecord's. ``max_motion_segments``: at most this many
    uniform steps (that many + 1 motion samples) over a frame's shutter for one prim.
    ``render_pass``: a UsdRenderPass prim whose collections decide what renders
    (``penumbra-record -rp``): ``prune`` and prims outside ``renderVisibility`` are left out,
    prims outside ``cameraVisibility`` are hidden from camera rays only, ``matte`` prims are
    holdouts (no colour, no alpha); read once, when the renderer is created.

    Ctrl-C (Python's own SIGINT handler, in the main thread) stops a render pass within 50 ms;
    while the renderer reads the stage (creating it, :meth:`sync`, the reads before each
    render) it is held until the reads end, since USD's bindings would lose the
    ``KeyboardInterrupt`` (``penumbra/_interrupts.py``). A program's own handler is left alone.
    """

    def __init__(
        self,
        stage: Usd.Stage | str | os.PathLike,
        *,
        purposes: Iterable[str] = DEFAULT_PURPOSES,
        max_motion_segments: int = DEFAULT_MAX_MOTION_SEGMENTS,
        render_pass: str | Sdf.Path | None = None,
    ):
        if max_motion_segments < 1:
            raise ValueError(f"max_motion_segments must be at least 1, not {max_motion_segments}")
        self.max_motion_segments = max_motion_segments
        self.delegate = _core.RenderDelegate(ocio_config=ocio_config_path())
        """The ``penumbra._core.RenderDelegate`` holding the synced scene (for inspection)."""
        self._passes: dict[PassKey, _core.RenderPass] = {}
        self.tracer = Tracer(enabled=False)
        """Records timing spans of each render when enabled (``penumbra-record --traceToFile``)."""
        with _interrupts.deferred():  # USD's bindings would lose a signal (_interrupts.py)
            self.stage = stage = as_stage(stage)
            collections = render_pass_collections(stage, render_pass) if render_pass else None
            self._scene = SceneDelegate(stage, self.delegate, purposes, collections)
            self._default_light = DefaultLightManager(self.delegate, stage_name(stage))
            self._scene.update(self._still(_time_code(stage, None)))

    def sync(self, time: TimeLike = None) -> None:
        """Push the stage (as edited since the last sync) at ``time`` (without motion) into the
        render delegate; :meth:`render` does this itself, over the camera's shutter.
        Acceleration structures are built by the first render."""
        with _interrupts.deferred():
            self._sync(self._still(_time_code(self.stage, time)))

    def _still(self, time_code: Usd.TimeCode) -> Shutter:
        return Shutter(time_code, max_segments=self.max_motion_segments)

    def _sync(
        self,
        shutter: Shutter,
        depth_of_field: bool = True,
        dome_light_visibility: bool = True,
        film_windows: dict[str, FilmWindow] | None = None,
    ) -> None:
        if self._scene.take_prims_resynced():  # variant edits may bring in documents
            compose_materialx_documents(self.stage, warn)
        self._scene.update(shutter, depth_of_field, dome_light_visibility, film_windows)

    def close(self) -> None:
        """Stop tracking stage edits and drop the render passes."""
        self._scene.close()
        self._passes.clear()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *_exc) -> None:
        self.close()

    @render_options.with_option_keywords
    def render(
        self,
        camera: str | Sdf.Path | None = None,
        time: TimeLike = None,
        width: int | None = None,
        height: int | None = None,
        *,
        aovs: str | Iterable[str] = ("color",),
        render_settings: str | RenderSettings | None = None,
        disable_motion_blur: bool = False,
        disable_depth_of_field: bool = False,
        dome_light_visibility: bool = True,
        default_light: DefaultLight = "dome",
        progress: ProgressCallback | None = None,
        max_memory: int | None = None,
        denoise: bool = False,
        region: tuple[int, int, int, int] | None = None,
        dicing_camera: str | Sdf.Path | None = None,
        texture_cache: int | None = None,
        checkpoint: Checkpoint | None = None,
        time_limit: float | None = None,
        **options: render_options.OptionValue,
    ) -> Image:
        """Render the stage and return its AOVs as an :class:`Image`.

        ``camera``: a prim path or bare camera name (``str`` or ``Sdf.Path``); by default
        ``main_cam``, else the render settings' camera (usdrecord's order). ``aovs``: one AOV
        name or several. ``time``: a time code (float or ``Usd.TimeCode``, e.g.
        ``Usd.TimeCode.Default()``); by default the stage's startTimeCode. ``width``: by default
        the render settings' resolution, else 960. ``height``: by default from the aspect ratio
        of the render settings' resolution, else of the camera's apertures. ``render_settings``:
        a UsdRenderSettings prim path (or settings already read, as render products pass them),
        by default the stage's ``renderSettingsPrimPath``; its
        ``aspectRatioConformPolicy`` and ``pixelAspectRatio`` fit the camera's aperture to the
        image, and its ``dataWindowNDC`` crops the image to the pixels whose centres it holds.
        Motion blur samples the camera's shutter, [time + shutter:open, time + shutter:close];
        ``disable_motion_blur`` (or the render settings' ``disableMotionBlur``) renders ``time``
        alone, ``disable_depth_of_field`` (or ``disableDepthOfField``) makes the camera a
        pinhole. ``dome_light_visibility`` False hides dome lights from camera rays (they
        still light the scene; the background is transparent, as usdrecord renders it).
        ``default_light`` lights a stage that has no lights (UsdLux lights or
        UsdLuxMeshLightAPI meshes): ``"dome"`` a uniform white dome of radiance 1,
        ``"camera"`` a light from the camera that is never seen (usdrecord's default), or
        ``"none"`` (only emissive surfaces light the stage).
        ``options``: the render options by keyword (:data:`penumbra.render_options.OPTIONS`
        lists them with their help, range and default: ``samples``, ``seed``, ``threads``,
        ``max_path_depth``, ``complexity``, ``adaptive_threshold``, ...); an option not given
        is the render settings' ``penumbra:KEY`` attribute (``penumbra:maxPathDepth``) when
        authored, else its default. With ``adaptive_threshold`` > 0, ``samples`` is a cap; the
        image stays a pure function of (scene, seed, samples, threshold).
        ``max_memory``: bytes the process may hold (default: 80% of
        physical memory), checked before the scene is synced, before a new size's film is
        allocated and before the scene's geometry and acceleration structures are built.
        ``texture_cache``: bytes of texture tiles kept in memory, whatever the textures'
        resolution (default: 1/8 of ``max_memory``, at most 512 MiB); counted in the budget.
        ``region``: ``(x, y, width, height)`` of the image's pixels (columns from the
        left, rows from the top, as :meth:`image_size` counts them) to render alone, e.g. a farm
        tile: the image returned holds those pixels, bit-identical to the same pixels of the
        whole image (with adaptive sampling, the pixels around them that its convergence tests
        look at are rendered too and dropped; with ``denoise`` the raw ``noisyColor`` is, the
        denoised colour is not: the denoiser sees the region alone). ``dicing_camera``: the
        camera (path or bare name) subdivision surfaces are diced for, from this render on;
        they are re-diced when it moves (an interactive orbit of the view camera then re-dices
        nothing). By default they are diced for each render's own camera and width, so that a
        frame's facets depend on that frame alone.
        ``checkpoint``: a :class:`penumbra.Checkpoint` saying where (the image's path) and how
        often to save the frame rendered so far and the exact state to resume it from
        (``Checkpoint(path, interval=60, resume=True)``); with it, the finished image is also
        written to its path and the state removed; a resumed render ends bit-identical to an
        uninterrupted one. ``time_limit``: seconds after which the render ends with the last
        whole pass of samples that fits (estimated from the previous pass; at least one pass),
        its metadata saying ``samplesDone`` and ``stoppedByTimeLimit``; with adaptive sampling
        the image is the one ``samples=samplesDone`` renders. Seconds must be finite and >= 0.
        Raises :class:`penumbra.SceneError` when the
        stage cannot be rendered (e.g. a camera's shutter:close < shutter:open); warnings about
        skipped prims are :class:`penumbra.PenumbraWarning`.
        """
        render_options.check(options, "render")
        time_limit = check_seconds(time_limit, "time_limit")
        if checkpoint is not None:
            if not isinstance(checkpoint, Checkpoint):
                raise TypeError(f"checkpoint must be a penumbra.Checkpoint, not {checkpoint!r}")
            check_output_format(checkpoint.path)
            check_output_directory(checkpoint.path)
        if texture_cache is not None and texture_cache < MIN_TEXTURE_CACHE:
            raise ValueError(f"texture_cache must be at least 16 MiB, not {texture_cache} bytes")
        check_default_light(default_light)
        # Signals wait for the stage's reads to end (USD's bindings would lose them,
        # _interrupts.py); the render passes below stop at once.
        with _interrupts.deferred():
            if dicing_camera is not None:
                dicing_path = find_camera(self.stage, dicing_camera).GetPath()
                self.delegate.set_dicing_camera(str(dicing_path))
            aovs = (aovs,) if isinstance(aovs, str) else tuple(aovs)
            time_code, settings, camera_prim, (width, height), window = self._framing(
                camera, time, width, height, render_settings
            )
            values = render_options.resolve(options, settings.options if settings else None)
            samples = int(values["samples"])
            camera_id = str(camera_prim.GetPath())
            crop, margin = None, 0
            film_width, film_height = window.width, window.height
            if region is not None:
                crop = _check_region(region, window.width, window.height)
                if values["adaptive_threshold"] > 0:
                    margin = _core.RenderPass.adaptive_sampling_reach(
                        samples, values["adaptive_min_samples"]
                    )
                film_width = min(film_width, crop[2] + 2 * margin)  # at most: margins stop at edges
                film_height = min(film_height, crop[3] + 2 * margin)

            motion_blur = not (disable_motion_blur or (settings and settings.disable_motion_blur))
            depth_of_field = not (
                disable_depth_of_field or (settings and settings.disable_depth_of_field)
            )
            shutter = read_shutter(camera_prim, time_code, motion_blur, self.max_motion_segments)
            budget = default_budget() if max_memory is None else max_memory
            cache = texture_cache_size(budget) if texture_cache is None else texture_cache
            pass_key = (camera_id, window.width, window.height, crop, margin)
            new_pass = pass_key not in self._passes
            extra_aovs = len(set(aovs) - {"color"}) + (len(GUIDE_AOVS) if denoise else 0)
            if new_pass:
                check_film(film_width, film_height, budget, camera_id, extra_aovs, cache)
            with self.tracer.span("sync stage (USD to render delegate)"):
                self._sync(
                    shutter,
                    depth_of_field,
                    dome_light_visibility,
                    {camera_id: window} if settings is not None else None,
                )
                self._default_light.update(
                    default_light,
                    self._scene.has_lights(),
                    camera_prim,
                    time_code,
                    dome_light_visibility,
                )
            stage_label = stage_name(self.stage)
            if self._scene.prim_kind(camera_id) != "camera":
                raise SceneError(f"{stage_label}: camera {camera_id} is not rendered")
            # What the images say of the stage, read once for the image and each checkpoint's.
            crypto_layers = [aov for aov in aovs if aov in cryptomatte.LAYERS]
            crypto_names = self._scene.cryptomatte_names(crypto_layers)
            subset_names = (  # a walk over every tracked prim: only for the layer that asks
                self._scene.cryptomatte_subset_names() if "CryptoMaterial" in crypto_layers else {}
            )
            lens_metadata = camera_metadata(
                camera_prim,
                time_code,
                width,
                height,
                settings.aspect_ratio_conform_policy if settings else "expandAperture",
                settings.pixel_aspect_ratio if settings else 1.0,
            )
        if new_pass:  # the synced scene is in memory now; its BVH and the film are not yet
            check_film(film_width, film_height, budget, camera_id, extra_aovs, cache)
        render_pass = self._render_pass(pass_key)
        if not aovs:
            raise ValueError(f"aovs must name at least one of {render_pass.aov_names()}")
        if NOISY_COLOR in aovs and not denoise:
            raise ValueError(f"the {NOISY_COLOR} AOV needs denoise=True")
        accumulated = {aov for aov in aovs if aov != NOISY_COLOR}
        render_pass.set_aovs(sorted(accumulated | set(GUIDE_AOVS if denoise else ())))

        for option in render_options.OPTIONS:
            value = option.delegate_value(values[option.keyword])
            self.delegate.set_render_setting(option.key, value)
        self.delegate.set_render_setting("textureCacheMB", cache >> 20)
        started = clock.perf_counter()
        render_pass.reset()
        check_scene_build(self.delegate.estimated_sync_bytes(), budget, stage_label, cache)
        with self.tracer.span("render delegate sync (subdivision dicing, BVH builds)"):
            started_us, before = self.tracer.now_us(), self.delegate.sync_statistics()
            render_pass.execute(0)  # syncs what is dirty and renders nothing
            self._trace_sync(started_us, before)

        def make_image() -> Image:
            """The image of the samples taken so far."""
            arrays = {
                name: np.array(render_pass.aov(name))
                for name in (accumulated | {"color"}) - set(crypto_layers)
            }
            crypto_metadata = {}
            for layer, names in crypto_names.items():
                # The material layer names the faces that subsets bind by their material.
                subsets = subset_names if layer == "CryptoMaterial" else {}
                arrays[layer] = render_pass.cryptomatte(names, subsets)
                every_name = {name for placements in names.values() for name in placements}
                every_name |= {name for materials in subsets.values() for name in materials}
                crypto_metadata.update(
                    cryptomatte.metadata(layer, cryptomatte.manifest(arrays[layer], every_name))
                )
            if denoise:
                with self.tracer.span("denoise (OIDN)"):
                    arrays[NOISY_COLOR] = arrays["color"]
                    arrays["color"] = denoise_color(
                        arrays["color"], render_pass.aov("albedo"), render_pass.aov("normal")
                    )
            elapsed = spent_before + clock.perf_counter() - started

            metadata = {
                "camera": camera_id,
                **{
                    option.key: values[option.keyword]
                    for option in render_options.OPTIONS
                    if option.changes_pixels
                },
                "meanSamples": round(render_pass.mean_samples, 3),
                "samplesTaken": render_pass.samples_taken,
                "samplesDone": render_pass.samples_done,
                "rays": render_pass.rays_traced,
                "lightPaths": render_pass.light_paths_traced,
                "constantDomeShare": render_pass.constant_dome_share,
                "indirectSamplesUsed": round(render_pass.indirect_samples, 3),
                "lightSamplesUsed": render_pass.light_samples,
                "renderTimeSeconds": round(elapsed, 3),
                "version": _core.version(),
                "timeCode": "default" if time_code.IsDefault() else time_code.GetValue(),
                "shutterOpen": shutter.open,
                "shutterClose": shutter.close,
                "stage": stage_label,
                "renderSettings": settings.path if settings is not None else "",
                "denoised": int(denoise),
                **lens_metadata,
            }
            metadata.update(crypto_metadata)
            if (data_window := _data_window(window)) is not None:
                metadata[DATA_WINDOW] = data_window
            if "primId" in aovs:
                manifest = self.delegate.prim_id_manifest()
                metadata["primIds"] = json.dumps({str(key): path for key, path in manifest.items()})
            return Image({name: arrays[name] for name in aovs}, metadata)

        key, spent_before = "", 0.0  # seconds spent on the samples of a resumed checkpoint
        if checkpoint is not None:
            pixel_options = {
                name: value
                for name, value in values.items()
                if render_options.BY_KEYWORD[name].changes_pixels
            }
            arguments = (motion_blur, depth_of_field, dome_light_visibility, default_light)
            key = checkpoint.key or _render_key(
                self.stage,
                (camera_id, time_code, window, crop, aovs, denoise, pixel_options),
                (*arguments, time_limit),
            )
            # The render pass checks its options, size, crop and AOVs; these arguments, which
            # change pixels too, go into the key it checks, so that an explicit key does not
            # let a render with depth of field resume one without.
            state_key = f"{key}:{hashlib.sha256(repr(arguments).encode()).hexdigest()[:16]}"
            if checkpoint.resume:
                spent_before = _resume(render_pass, checkpoint, key, state_key)
        step = max(1, math.ceil(samples / PROGRESS_STEPS))
        last_saved = clock.perf_counter()
        pass_seconds: float | None = None  # the last pass's: the next one's estimate
        stopped_by_time_limit = False
        while not render_pass.converged:
            if time_limit is not None and pass_seconds is not None:
                if spent_before + clock.perf_counter() - started + pass_seconds > time_limit:
                    stopped_by_time_limit = True
                    break
            first, count = render_pass.samples_done, min(step, samples - render_pass.samples_done)
            pass_started = clock.perf_counter()
            with self.tracer.span("render pass: samples", first=first + 1, last=first + count):
                render_pass.execute(count)
            pass_seconds = clock.perf_counter() - pass_started
            self._forward_warnings()
            if progress is not None:
                progress(render_pass.samples_done, samples)
            due = checkpoint is not None and checkpoint.interval is not None
            if due and not render_pass.converged:
                if clock.perf_counter() - last_saved >= checkpoint.interval:
                    spent = spent_before + clock.perf_counter() - started
                    about = {"size": [width, height], "crop": crop, "aovs": sorted(accumulated)}
                    self._save_checkpoint(
                        render_pass, checkpoint, (key, state_key), spent, about, make_image
                    )
                    last_saved = clock.perf_counter()
        image = make_image()
        if time_limit is not None:
            image.metadata["timeLimitSeconds"] = time_limit
            image.metadata["stoppedByTimeLimit"] = int(stopped_by_time_limit)
        if checkpoint is not None:
            image.metadata[RENDER_KEY] = key
            with self.tracer.span("write image", file=checkpoint.path):
                image.write(checkpoint.path, color_mode=checkpoint.color_mode)
            remove_state(checkpoint.state_path)
        return image

    def _save_checkpoint(
        self,
        render_pass: _core.RenderPass,
        checkpoint: Checkpoint,
        keys: tuple[str, str],
        spent: float,
        about: dict,
        make_image: Callable[[], Image],
    ) -> None:
        """Write the render pass's state (``about`` the render: size, crop, AOVs; ``keys``: the
        render key and the render pass's state key, as :func:`_resume` takes them), then the
        image rendered so far (metadata ``partial`` 1): an image with the frame's key never
        stands without its state file until the frame is finished, so that a process killed
        between the two writes leaves nothing ``--resume`` takes for finished (PNG, TIFF and
        JPEG drop ``partial``; the state file is what says unfinished)."""
        with self.tracer.span("write checkpoint", file=checkpoint.path):
            image = make_image()
            key, state_key = keys
            image.metadata.update({"partial": 1, RENDER_KEY: key})
            write_state(
                checkpoint.state_path,
                key,
                render_pass.samples_done,
                spent,
                about,
                render_pass.save_state(state_key),
            )
            image.write(checkpoint.path, color_mode=checkpoint.color_mode)
        logger.info("%s: checkpoint at %d samples", checkpoint.path, render_pass.samples_done)

    def image_size(
        self,
        camera: str | Sdf.Path | None = None,
        time: TimeLike = None,
        width: int | None = None,
        height: int | None = None,
        *,
        render_settings: str | None = None,
    ) -> tuple[int, int]:
        """``(width, height)`` of the image :meth:`render` gives for these arguments (after
        the render settings' ``dataWindowNDC``)."""
        with _interrupts.deferred():
            window = self._framing(camera, time, width, height, render_settings)[4]
        return window.width, window.height

    def _framing(
        self,
        camera: str | Sdf.Path | None,
        time: TimeLike,
        width: int | None,
        height: int | None,
        render_settings: str | RenderSettings | None,
    ) -> tuple[Usd.TimeCode, RenderSettings | None, Usd.Prim, tuple[int, int], FilmWindow]:
        """The time code, render settings, camera, image size and film window of a render."""
        time_code = _time_code(self.stage, time)
        settings = (
            render_settings
            if isinstance(render_settings, RenderSettings)
            else read_render_settings(self.stage, render_settings)
        )
        camera_prim = resolve_camera(self.stage, camera, settings, time_code, self._scene.purposes)
        problem = camera_problem(camera_prim, time_code)
        if problem is not None:
            raise SceneError(problem)
        if width is None:
            if settings is not None and settings.resolution is not None and height is None:
                width = settings.resolution[0]
            else:
                width = DEFAULT_WIDTH
        width, height = image_size(camera_prim, time_code, width, height, settings)
        window = film_window(settings, camera_prim, time_code, width, height)
        return time_code, settings, camera_prim, (width, height), window

    def _trace_sync(self, started_us: float, before: dict) -> None:
        """Add the render delegate's time in tessellation (triangulation and subdivision
        dicing) and in acceleration structures (BVHs, light tree) since ``before`` to the trace
        as two spans, one after the other from ``started_us`` (each the total of its kind)."""
        if not self.tracer.enabled:
            return
        after = self.delegate.sync_statistics()
        dicing_us = (after["tessellationSeconds"] - before["tessellationSeconds"]) * 1e6
        bvh_us = (after["bvhBuildSeconds"] - before["bvhBuildSeconds"]) * 1e6
        self.tracer.add(
            "tessellation (triangulation, subdivision dicing)",
            started_us,
            dicing_us,
            meshes=after["meshGeometrySyncs"] - before["meshGeometrySyncs"],
            dicings=after["subdivisionDicings"] - before["subdivisionDicings"],
        )
        self.tracer.add(
            "acceleration structures (BVH builds, light tree)",
            started_us + dicing_us,
            bvh_us,
            meshBvhBuilds=after["meshBvhBuilds"] - before["meshBvhBuilds"],
        )

    def _render_pass(self, key: PassKey):
        """The render pass of (camera, image width, image height, crop, margin)."""
        if key not in self._passes:
            camera_id, width, height, crop, margin = key
            self._passes[key] = _core.RenderPass(
                self.delegate, camera_id, width, height, crop=crop, margin=margin
            )
        return self._passes[key]

    def _forward_warnings(self) -> None:
        for message in self.delegate.take_warnings():
            warn(message)


def _render_key(stage: Usd.Stage, *fields: object) -> str:
    """A hash of a render's arguments (``fields``), the layers the stage composes and Penumbra's
    version: a checkpoint saved under the same key continues the same render. An anonymous
    layer, or one with unsaved edits, counts by its text; a saved one by its identifier and its
    file's size and modification time (not read: it may be a huge crate file). So a stage
    edited in memory or on disk between two renders gets another key, and the second render
    starts from scratch instead of adding its samples to the other scene's."""
    with _interrupts.deferred():
        layers = sorted(
            _layer_entry(layer, stage.GetRootLayer(), stage.GetSessionLayer())
            for layer in stage.GetUsedLayers()
        )
    text = json.dumps([layers, _core.version(), fields], sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _layer_entry(layer: Sdf.Layer, root: Sdf.Layer, session: Sdf.Layer | None) -> list[str]:
    """``[role, identifier, fingerprint]`` of one of a stage's layers for :func:`_render_key`.
    An anonymous root or session layer is named by its role alone (its identifier holds an
    address: the same in-memory scene built again has the same key); other anonymous layers
    keep their identifier, which the layers using them name."""
    role = "root" if layer == root else "session" if layer == session else ""
    identifier = "" if role and layer.anonymous else layer.identifier
    if layer.anonymous or layer.dirty:
        return [role, identifier, hashlib.sha256(layer.ExportToString().encode()).hexdigest()]
    # A layer in a package (``shot.usdz[geo.usdc]``) changes with the package file.
    path = Ar.SplitPackageRelativePathOuter(layer.realPath)[0] if layer.realPath else ""
    try:
        status = os.stat(path) if path else None
    except OSError:
        status = None
    return [role, identifier, f"{status.st_size}:{status.st_mtime_ns}" if status else ""]


def _resume(
    render_pass: _core.RenderPass, checkpoint: Checkpoint, key: str, state_key: str
) -> float:
    """Load the state saved beside ``checkpoint``'s image into ``render_pass`` when it is the
    same render's (``key``; the render pass checks ``state_key``, which holds the render's
    arguments too); returns the seconds spent on its samples (0 when it renders from scratch).
    A corrupt or unusable state file is reported and ignored."""
    path = checkpoint.state_path
    try:
        saved = read_state(path)
    except CorruptCheckpoint as error:
        warn(f"{path}: {error}; rendering from scratch")
        return 0.0
    if saved is None:
        return 0.0
    if saved.key != key:
        logger.info(
            "%s: saved by another render (other stage, settings or frame); rendering from "
            "scratch",
            path,
        )
        return 0.0
    try:
        render_pass.load_state(saved.state, state_key)
    except ValueError as error:
        warn(f"{path}: {error}; rendering from scratch")
        return 0.0
    logger.info("%s: resuming from %d samples", path, render_pass.samples_done)
    return saved.render_seconds


def _data_window(window: FilmWindow) -> list[int] | None:
    """``[x, y, frame width, frame height]``: where the image rendered through ``window`` lies in
    the frame its render settings' ``dataWindowNDC`` cut it from, for an EXR's data and display
    windows; None when it is the whole frame. (A ``region`` is a part of that image, as farm
    bands are: bands merged give it back whole.)"""
    if window.frame is None or (window.x, window.y, window.width, window.height) == (
        0,
        0,
        *window.frame,
    ):
        return None
    return [window.x, window.y, *window.frame]


def _check_region(
    region: tuple[int, int, int, int], width: int, height: int
) -> tuple[int, int, int, int]:
    """``region`` as a tuple of ints; ``ValueError`` unless it is a non-empty part of the
    ``width`` x ``height`` image."""
    x, y, region_width, region_height = (int(value) for value in region)
    if not (
        region_width > 0
        and region_height > 0
        and 0 <= x
        and x + region_width <= width
        and 0 <= y
        and y + region_height <= height
    ):
        raise ValueError(
            f"region {tuple(region)} (x, y, width, height) is not a non-empty part of the "
            f"{width}x{height} image"
        )
    return x, y, region_width, region_height


def render(
    stage_or_path: Usd.Stage | str | os.PathLike,
    *,
    purposes: Iterable[str] = DEFAULT_PURPOSES,
    **kwargs,
) -> Image:
    """Render a stage (or the file at a path) once: ``Renderer(stage).render(**kwargs)``."""
    with Renderer(stage_or_path, purposes=purposes) as renderer:
        return renderer.render(**kwargs)
