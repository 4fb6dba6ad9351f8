"""``penumbra-record``'s renders: the job its flags describe, and the frame loop (here or on a
Dask cluster) writing each frame's images."""

from __future__ import annotations

import argparse
import itertools
import logging
import os
import sys
from collections.abc import Iterator

from pxr import Usd

from . import render_options
from .cli_arguments import (
    EXIT_OK,
    EXIT_USAGE,
    PROG,
    RENDERER_NAME,
    UsageError,
    check_frame_placeholder,
)
from .checkpoints import Checkpoint, remove_state, state_file
from .cli_output import Progress, RendersProgress, frame_summary
from .frames import FrameRange, frame_path, iter_frames
from .image import Image, check_output_directory
from .jobs import (
    DEFAULT_TIME,
    START_TIME,
    FrameTime,
    JobRenderer,
    RenderJob,
    absolute_path,
    RENDER_KEY,
    output_is_complete,
    time_code,
)
from .errors import warn
from .trace import Tracer
from .usd.products import ProductPlan


def render_job(args: argparse.Namespace, first_frame: FrameTime) -> RenderJob:
    """Everything the flags say about the pixels, with file paths made absolute (farm workers
    do not share this working directory)."""
    return RenderJob(
        usd_file=absolute_path(args.usdFilePath),
        session_layer=absolute_path(args.session_layer) if args.session_layer else None,
        mask=tuple((args.mask or "").replace(",", " ").split()),
        resolver=args.resolver,
        purposes=tuple(args.purposes.replace(",", " ").split()),
        camera=args.camera,
        camera_time=first_frame,
        render_settings_path=args.renderSettingsPrimPath,
        render_pass_path=args.renderPassPrimPath,
        color_mode=args.colorCorrectionMode,
        aovs=tuple(args.aovs),
        denoise=args.denoise,
        width=args.imageWidth,
        options={
            option.keyword: getattr(args, option.key)
            for option in render_options.OPTIONS
            if getattr(args, option.key) is not None
        },
        disable_motion_blur=args.disable_motion_blur,
        disable_depth_of_field=args.disable_depth_of_field,
        dome_light_visibility=args.enableDomeLightVisibility,
        disable_camera_light=args.disableCameraLight,
        max_memory=args.maxMemory,
        texture_cache=args.textureCacheSize,
        time_limit=args.timeLimit,
    )


def _frames(args: argparse.Namespace, frames: list[FrameRange]) -> tuple[Iterator[FrameTime], int]:
    """The frames to render, generated lazily, and how many there are."""
    if args.defaultTime:
        return iter([DEFAULT_TIME]), 1
    if frames:
        return iter_frames(frames), sum(frame_range.count for frame_range in frames)
    return iter([START_TIME]), 1


def _check_product_names(plan: ProductPlan, frames: str) -> None:
    """``UsageError`` unless every productName tells the frames of ``frames`` apart, as the
    output path must (else a product is overwritten frame after frame)."""
    for product in plan.products:
        check_frame_placeholder(product.name, frames, product=product.path)


def record(args: argparse.Namespace, frames: list[FrameRange], tracer: Tracer) -> int:
    say = (lambda _text: None) if args.quiet else print
    times, count = _frames(args, frames)
    first_frame = next(times)

    def output_path(frame: FrameTime) -> str:
        path = frame_path(args.outputImagePath, frame) if frames else args.outputImagePath
        check_output_directory(path)  # each frame's: a placeholder may name a directory
        return path

    output_path(first_frame)  # before the stage is read
    job = render_job(args, first_frame)

    if args.scheduler or args.workers:
        from .farm import record_on_farm  # Dask takes a second to import: farm renders only

        if not args.verbose:  # the farm client reports failures itself, without Dask's logs
            for name in ("distributed", "distributed.client"):  # both have their own level
                logging.getLogger(name).setLevel(logging.CRITICAL)
        say(f"Renderer plugin: {RENDERER_NAME}, on a Dask cluster")
        with tracer.span("render on the farm"):
            record_on_farm(
                job,
                itertools.chain([first_frame], times),
                count,
                output_path,
                scheduler=args.scheduler,
                workers=args.workers,
                resume=args.resume,
                say=say,
                progress=not args.quiet,
            )
        return EXIT_OK
    with JobRenderer(job, tracer) as session:
        if frames and session.products is not None:
            try:
                _check_product_names(session.products, args.frames)
            except UsageError as error:
                sys.stderr.write(f"{PROG}: error: {error}\n")
                return EXIT_USAGE
        say(f"Camera: {session.camera}")
        say(f"Renderer plugin: {RENDERER_NAME}")
        checkpoints = args.checkpoint is not None or args.resume
        if checkpoints and session.products is not None:
            checkpoints = False
            if args.checkpoint is not None:
                warn("--checkpoint applies to renders without render products; ignored")
        for frame in itertools.chain([first_frame], times):
            label = _time_code_label(time_code(session.renderer.stage, frame))
            output = output_path(frame)
            if args.resume and output_is_complete(output, job.frame_key(frame)):
                say(f"Skipped time code {label}: {output} is complete")
                continue
            say(f"Recording time code: {label}")
            products: list[tuple[str, Image]] = []
            with tracer.span(f"time code {label}"):
                if session.products is not None:
                    progress = None if args.quiet else RendersProgress(f"time code {label}")
                    # The output image holds the first product's render (all its AOVs in EXR).
                    products = session.render_products(
                        frame, os.path.dirname(os.path.abspath(output)), progress
                    )
                    image = products[0][1]
                    image.metadata[RENDER_KEY] = job.frame_key(frame)
                else:
                    progress = None if args.quiet else Progress(f"time code {label}")
                    checkpoint = (  # the render then writes the image and its checkpoints
                        Checkpoint(
                            output, args.checkpoint, resume=args.resume, color_mode=job.color_mode
                        )
                        if checkpoints
                        else None
                    )
                    image = session.render(frame, progress=progress, checkpoint=checkpoint)
                if progress is not None:
                    progress.end()
                if not checkpoints:
                    with tracer.span("write image", file=output):
                        image.write(output, color_mode=job.color_mode)
                    # A checkpoint left by an earlier, killed render would mark it unfinished.
                    remove_state(state_file(output))
            say(frame_summary(f"time code {label}", image))
            for path, _ in products:
                say(f"Wrote {os.path.abspath(path)}")
            say(f"Wrote {os.path.abspath(output)}")
    return EXIT_OK


def _time_code_label(code: Usd.TimeCode) -> str:
    return "default" if code.IsDefault() else f"{code.GetValue():g}"
