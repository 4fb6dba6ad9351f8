"""``penumbra-record``: renders a USD file to images, with usdrecord's command line.

Exit status: 0 success; 1 the scene or a file could not be rendered (the message names the file
or prim); 2 usage error (including flags Penumbra does not support yet).
"""

from __future__ import annotations

import argparse
import itertools
import logging
import os
import resource
import signal
import sys
import threading
import time
import traceback
import warnings
from collections.abc import Iterator, Sequence

from pxr import Usd

from . import _core, render_options
from .denoise import NOISY_COLOR
from .errors import PenumbraWarning, SceneError
from .frames import (
    FrameRange,
    find_placeholder,
    frame_path,
    frame_spec_precision,
    iter_frames,
    parse_frame_spec,
)
from .memory import DEFAULT_BUDGET_FRACTION, MIN_TEXTURE_CACHE, parse_size
from .image import COLOR_MODES, Image, check_output_directory, check_output_format
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
from .renderer import DEFAULT_WIDTH
from .trace import TRACE_FORMATS, Tracer
from .usd.stage import RESOLVERS

PROG = "penumbra-record"
EXIT_OK, EXIT_SCENE, EXIT_USAGE = 0, 1, 2
EXIT_INTERRUPTED = 128 + signal.SIGINT  # 130, as shells report a process Ctrl-C stopped
EXIT_TERMINATED = 128 + signal.SIGTERM  # 143

RENDERER_NAME = "Penumbra"


def _memory_size(text: str) -> int:
    """argparse type of ``--maxMemory``."""
    try:
        return parse_size(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _texture_cache_size(text: str) -> int:
    """argparse type of ``--textureCacheSize``."""
    size = _memory_size(text)
    if size < MIN_TEXTURE_CACHE:
        raise argparse.ArgumentTypeError(f"texture cache size {text!r} is below 16M")
    return size


def _add_render_options(group: argparse._ArgumentGroup, usdrecord: bool) -> None:
    """A flag per render option that usdrecord has too (``usdrecord``) or not. Its default is
    None, so that a flag not given leaves the option to the render settings prim."""
    for option in render_options.OPTIONS:
        if option.usdrecord_flag != usdrecord:
            continue
        default = f"{option.default:g}" if option.type == "float" else str(option.default)
        if option.default_meaning:
            default += f", {option.default_meaning}"
        flags = (option.flag, option.short_flag) if option.short_flag else (option.flag,)
        group.add_argument(
            *flags,
            dest=option.key,
            type=None if option.type == "level" else option.value_type,
            choices=option.levels or None,
            metavar=option.metavar,
            help=f"{option.help} (default: {default})".replace("%", "%%"),
        )


def build_parser() -> argparse.ArgumentParser:
    """The argument parser: usdrecord's flags plus Penumbra's own (no abbreviations)."""
    parser = argparse.ArgumentParser(
        prog=PROG,
        allow_abbrev=False,
        description="Render a USD file with Penumbra (usdrecord-compatible command line).",
        epilog=(
            "Exit status: 0 success, 1 the scene or a file could not be rendered, 2 usage error."
        ),
    )
    parser.add_argument("usdFilePath", help="USD file to render")
    parser.add_argument(
        "outputImagePath",
        help=(
            "output image; the extension picks the format (.exr: scene-linear floats and "
            "metadata; .png/.jpg/.tif: display values). With --frames it holds one frame "
            'placeholder "###" or "###.###" (zero-padded width, decimals)'
        ),
    )
    usd = parser.add_argument_group("usdrecord options")
    usd.add_argument(
        "--camera",
        "-cam",
        metavar="CAMERA",
        help=(
            "camera prim path, or a camera's prim name searched in the stage; a relative path "
            "of several elements is made absolute (default: main_cam, else the render "
            "settings' camera, else the stage's only camera, else one framing the stage)"
        ),
    )
    times = usd.add_mutually_exclusive_group()
    times.add_argument(
        "--defaultTime",
        "-d",
        action="store_true",
        help="render at the Default time code (default: the stage's startTimeCode)",
    )
    times.add_argument(
        "--frames",
        "-f",
        metavar="FRAMESPEC[,FRAMESPEC...]",
        help="time codes to render: 101, 101:110, 101:110x2, 101:104x0.5, comma lists",
    )
    usd.add_argument(
        "--imageWidth",
        "-w",
        type=int,
        metavar="WIDTH",
        help=(
            f"image width in pixels (default: {DEFAULT_WIDTH}, or a render product's "
            "resolution); the height is int(width / aspect) "
            "of the camera's apertures as usdrecord computes it, or follows the render "
            "settings' resolution"
        ),
    )
    _add_render_options(usd, usdrecord=True)
    usd.add_argument(
        "--purposes",
        default="proxy",
        metavar="PURPOSE[,PURPOSE...]",
        help=(
            'purposes rendered besides "default" (always included), comma- or '
            "space-separated (default: %(default)s)"
        ),
    )
    usd.add_argument(
        "--renderSettingsPrimPath",
        "-rs",
        metavar="PRIMPATH",
        help=(
            "UsdRenderSettings prim giving the camera and resolution (default: the stage's "
            "renderSettingsPrimPath metadata)"
        ),
    )
    usd.add_argument(
        "--renderPassPrimPath",
        "-rp",
        metavar="PRIMPATH",
        help="UsdRenderPass prim whose renderSource names the render settings (not with -rs)",
    )
    usd.add_argument(
        "--colorCorrectionMode",
        "-color",
        choices=COLOR_MODES,
        default="sRGB",
        help=(
            "display transform of .png/.jpg/.tif output: sRGB transfer function, "
            "openColorIO ($OCIO, else Penumbra's bundled config: sRGB display, Standard view), "
            "or disabled (default: %(default)s)"
        ),
    )
    usd.add_argument(
        "--mask",
        metavar="PRIMPATH[,PRIMPATH...]",
        help=(
            "populate the stage with only these prims, their ancestors and descendants "
            "(comma- or space-separated)"
        ),
    )
    usd.add_argument(
        "--sessionLayer",
        dest="session_layer",
        metavar="SESSIONLAYER",
        help="open the stage with this layer as its session layer (default: an anonymous one)",
    )
    usd.add_argument(
        "--resolver",
        choices=RESOLVERS,
        default="root",
        help=(
            "asset resolver context: root (made for the USD file) or inherit (the "
            "environment's default) (default: %(default)s)"
        ),
    )
    usd.add_argument(
        "--renderer",
        "-r",
        default=RENDERER_NAME,
        metavar="RENDERER",
        help=f"Hydra renderer: only {RENDERER_NAME} (default: %(default)s)",
    )
    usd.add_argument(
        "--disableGpu",
        action="store_true",
        help="accepted for usdrecord compatibility; Penumbra renders on the CPU",
    )
    usd.add_argument(
        "--disableCameraLight",
        action="store_true",
        help=(
            "a stage without lights is lit only by its emissive surfaces (default: by a "
            "camera light, which is never seen)"
        ),
    )
    usd.add_argument(
        "--enableDomeLightVisibility",
        action="store_true",
        help=(
            "camera rays see dome lights (default: domes light the scene but the background "
            "is transparent, alpha 0)"
        ),
    )
    usd.add_argument(
        "--disableDrawMode",
        action="store_true",
        help=(
            "accepted for usdrecord compatibility: Penumbra ignores UsdGeomModelAPI draw "
            "modes and always renders full geometry, as if this flag were given"
        ),
    )
    usd.add_argument(
        "--traceToFile",
        metavar="PATH",
        help="write a timing trace (stage open, sync, render passes, writes) to PATH",
    )
    usd.add_argument(
        "--traceFormat",
        choices=TRACE_FORMATS,
        default="chrome",
        help="--traceToFile's format: chrome (chrome://tracing JSON) or trace (text) "
        "(default: %(default)s)",
    )
    usd.add_argument(
        "--memstats",
        action="store_true",
        help="print the process's peak memory (resident set) after each frame and at the end",
    )

    own = parser.add_argument_group("Penumbra options")
    _add_render_options(own, usdrecord=False)
    own.add_argument(
        "--maxMemory",
        type=_memory_size,
        metavar="SIZE",
        help=(
            "memory the render may use, e.g. 8G or 512M (default: "
            f"{DEFAULT_BUDGET_FRACTION * 100:.0f}%% of physical memory); a frame whose film, "
            "geometry and acceleration structures would not fit with the scene and the texture "
            "cache fails before rendering (exit status 1)"
        ),
    )
    own.add_argument(
        "--textureCacheSize",
        type=_texture_cache_size,
        metavar="SIZE",
        help=(
            "memory for texture tiles, whatever the textures' resolution, e.g. 256M (default: "
            "1/8 of --maxMemory, at most 512M; at least 16M); part of the --maxMemory budget"
        ),
    )
    own.add_argument(
        "--aov",
        metavar="NAME[,NAME...]",
        help=(
            "AOVs written besides color (.exr only): alpha, depth, Z, normal, Neye, position, "
            "albedo, primId, instanceId, elementId, primvars:NAME, sampleCount, variance, "
            "noisyColor (with --denoise); render products name their own"
        ),
    )
    own.add_argument(
        "--denoise",
        action="store_true",
        help="denoise the colour with Intel Open Image Denoise, guided by albedo and normal",
    )
    own.add_argument(
        "--disableMotionBlur",
        dest="disable_motion_blur",
        action="store_true",
        help=(
            "render each frame at its time code alone (default: over the camera's shutter, "
            "[frame + shutter:open, frame + shutter:close]; also UsdRenderSettings "
            "disableMotionBlur)"
        ),
    )
    own.add_argument(
        "--disableDepthOfField",
        dest="disable_depth_of_field",
        action="store_true",
        help=(
            "render through a pinhole (default: a thin lens from the camera's fStop and "
            "focusDistance, fStop 0 being a pinhole; also UsdRenderSettings disableDepthOfField)"
        ),
    )
    farm = own.add_mutually_exclusive_group()
    farm.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help=(
            "render on the Dask cluster of this scheduler, e.g. tcp://farm:8786 (workers open "
            "the same stage and file paths; the frames are written here)"
        ),
    )
    farm.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="render on a local Dask cluster of N worker processes (loopback only)",
    )
    own.add_argument(
        "--resume",
        action="store_true",
        help=(
            "skip frames whose output exists and was rendered from the same stage, settings "
            "and frame (checked by a key in the image's metadata)"
        ),
    )
    own.add_argument("--version", action="version", version=f"{PROG} {_core.version()}")
    chatter = own.add_mutually_exclusive_group()
    chatter.add_argument(
        "-q", "--quiet", action="store_true", help="print only warnings and errors"
    )
    chatter.add_argument(
        "-v", "--verbose", action="store_true", help="also print the sync and pass timings"
    )
    return parser


class _Progress:
    """Prints ``samples done / total``, the elapsed time and an estimate of the time left of a
    frame on stderr: updated in place on a terminal, else one line per quarter of the frame
    (logs stay short)."""

    def __init__(self, label: str, interactive: bool | None = None) -> None:
        self.label = label
        self.started = time.perf_counter()
        self.interactive = sys.stderr.isatty() if interactive is None else interactive
        self.quarters_reported = 0

    def __call__(self, done: int, total: int) -> None:
        elapsed = time.perf_counter() - self.started
        line = f"{self.label}: {done}/{total} samples, {elapsed:.1f} s"
        if self.interactive:
            if 0 < done < total:
                line += f", about {elapsed * (total - done) / done:.0f} s left"
            end = "\n" if done >= total else ""
            sys.stderr.write(f"\r\033[K{line}{end}")
        elif 4 * done // total > self.quarters_reported:
            self.quarters_reported = 4 * done // total
            sys.stderr.write(f"{line}\n")
        sys.stderr.flush()


def peak_memory_bytes() -> int:
    """The process's peak resident set size so far."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: kilobytes


def frame_summary(label: str, image: Image) -> str:
    """One line about a finished frame: time, samples per pixel (their mean where adaptive
    sampling stopped pixels early), rays per second, peak memory."""
    seconds = max(float(image.metadata["renderTimeSeconds"]), 1e-9)
    samples = int(image.metadata["samples"])
    mean = float(image.metadata["meanSamples"])
    taken = f"{samples}" if mean == samples else f"{mean:.1f} (at most {samples})"
    rays = int(image.metadata["rays"]) / seconds
    return (
        f"{label}: {image.width}x{image.height}, {taken} samples/pixel in {seconds:.2f} s "
        f"({rays / 1e6:.2f} M rays/s), peak memory {peak_memory_bytes() / 2**20:.0f} MB"
    )


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Penumbra warnings as ``penumbra-record: warning: …`` lines on stderr."""
    if issubclass(category, PenumbraWarning):
        sys.stderr.write(f"{PROG}: warning: {message}\n")
    else:
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


_LARGEST_WIDTH = 2**31 - 1  # the render delegate's image sizes are int32


class _UsageError(Exception):
    """A command line that cannot be honoured (exit status 2)."""


def _check_usage(args: argparse.Namespace) -> list[FrameRange]:
    """Reject invalid values; return the ``--frames`` ranges (empty without ``--frames``)."""
    if args.renderer.lower() != RENDERER_NAME.lower():
        raise _UsageError(
            f"--renderer {args.renderer}: {PROG} renders with {RENDERER_NAME} only"
        )
    if args.renderSettingsPrimPath and args.renderPassPrimPath:
        raise _UsageError("give --renderSettingsPrimPath or --renderPassPrimPath, not both")
    if args.traceFormat != "chrome" and not args.traceToFile:
        raise _UsageError("--traceFormat needs --traceToFile")
    if args.imageWidth is not None and args.imageWidth < 1:
        raise _UsageError("--imageWidth must be at least 1")
    if args.imageWidth is not None and args.imageWidth > _LARGEST_WIDTH:
        raise _UsageError(f"--imageWidth must be at most {_LARGEST_WIDTH}")
    for option in render_options.OPTIONS:
        value = getattr(args, option.key)
        problem = option.problem(value) if value is not None else None
        if problem is not None:
            raise _UsageError(f"{option.flag} {problem}")
    if args.workers is not None and args.workers < 1:
        raise _UsageError("--workers must be at least 1")
    args.aovs = _aov_list(args.aov or "", args.denoise)
    if len(args.aovs) > 1 and not args.outputImagePath.lower().endswith(".exr"):
        raise _UsageError(f"--aov needs an .exr output; {args.outputImagePath} holds colour only")
    try:
        check_output_format(args.outputImagePath)
        placeholder = find_placeholder(args.outputImagePath)
        frames = parse_frame_spec(args.frames) if args.frames is not None else []
    except ValueError as error:
        raise _UsageError(str(error)) from None
    if args.frames is None:
        if placeholder:
            raise _UsageError(
                f"{args.outputImagePath} holds a frame placeholder, so --frames is needed"
            )
        return frames
    if not placeholder:
        raise _UsageError(
            f'with --frames, {args.outputImagePath} needs a frame placeholder such as "####"'
        )
    decimals = len(placeholder.partition(".")[2])
    needed = frame_spec_precision(args.frames)
    if decimals < needed:
        raise _UsageError(
            f"the frames need {needed} decimals but placeholder {placeholder} has {decimals}"
        )
    return frames


def _aov_list(text: str, denoise: bool) -> list[str]:
    """``--aov``'s names after color; ``_UsageError`` for an unknown one."""
    names = [name for name in text.replace(",", " ").split() if name != "color"]
    known = set(_core.RenderPass.aov_names()) | {NOISY_COLOR}
    for name in names:
        if name not in known and not (name.startswith("primvars:") and len(name) > 9):
            raise _UsageError(f"--aov {name}: unknown AOV (known: {', '.join(sorted(known))})")
    if NOISY_COLOR in names and not denoise:
        raise _UsageError(f"--aov {NOISY_COLOR} needs --denoise")
    return ["color", *names]


class _Terminated(BaseException):
    """SIGTERM arrived: the render stops as on Ctrl-C (a BaseException, so that no ``except
    Exception`` on the way swallows it)."""


class _TerminateAsInterrupt:
    """While active (in the main thread), SIGTERM raises :class:`_Terminated` where Python
    next checks for signals; a running render pass checks every 50 ms and stops."""

    def __enter__(self) -> None:
        self.previous = None
        if threading.current_thread() is threading.main_thread():
            self.previous = signal.signal(signal.SIGTERM, self._raise)

    def __exit__(self, *_exc) -> None:
        if self.previous is not None:
            signal.signal(signal.SIGTERM, self.previous)

    @staticmethod
    def _raise(_signum: int, _frame) -> None:
        raise _Terminated()


def _report_information() -> None:
    """Show the library's informational messages (e.g. default lighting) on stderr."""
    logger = logging.getLogger("penumbra")
    if not any(isinstance(handler, _StderrHandler) for handler in logger.handlers):
        handler = _StderrHandler()
        handler.setFormatter(logging.Formatter(f"{PROG}: note: %(message)s"))
        logger.addHandler(handler)
    logger.setLevel(logging.INFO)


class _StderrHandler(logging.StreamHandler):
    """Writes to the current sys.stderr (which tests may capture after import)."""

    def emit(self, record: logging.LogRecord) -> None:
        self.stream = sys.stderr
        super().emit(record)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``penumbra-record``; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:  # argparse reports usage errors (2), --help and --version (0)
        return int(exit_.code or 0)
    try:
        frames = _check_usage(args)
    except _UsageError as error:
        sys.stderr.write(f"{PROG}: error: {error}\n")
        return EXIT_USAGE
    if args.quiet:
        logging.getLogger("penumbra").setLevel(logging.WARNING)
    else:
        _report_information()

    tracer = Tracer(enabled=bool(args.traceToFile) or args.verbose)
    with warnings.catch_warnings(), _TerminateAsInterrupt():
        warnings.simplefilter("always", PenumbraWarning)
        warnings.showwarning = _show_warning
        try:
            status = _record(args, frames, tracer)
        except (SceneError, RuntimeError, OSError) as error:  # RuntimeError: the image writer's
            sys.stderr.write(f"{PROG}: error: {error}\n")
            status = EXIT_SCENE
        except KeyboardInterrupt:
            sys.stderr.write(f"\n{PROG}: interrupted, nothing written for the frame in progress\n")
            return EXIT_INTERRUPTED
        except _Terminated:
            sys.stderr.write(f"\n{PROG}: terminated, nothing written for the frame in progress\n")
            return EXIT_TERMINATED
        except Exception as error:  # anything else: a bug or an input nothing checked yet
            if args.verbose:
                traceback.print_exc()
            sys.stderr.write(
                f"{PROG}: error: {args.usdFilePath}: cannot render: "
                f"{type(error).__name__}: {error}\n"
            )
            status = EXIT_SCENE
    if args.verbose:
        sys.stderr.write(tracer.report())
    if args.memstats:
        print(f"Peak memory (resident set): {peak_memory_bytes() / 2**20:.1f} MB")
    if args.traceToFile:
        try:
            tracer.write(args.traceToFile, args.traceFormat)
        except OSError as error:
            sys.stderr.write(f"{PROG}: error: {args.traceToFile}: cannot write the trace: {error.strerror}\n")
            return EXIT_SCENE
    return status


def _render_job(args: argparse.Namespace, first_frame: FrameTime) -> RenderJob:
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
    )


def _frames(args: argparse.Namespace, frames: list[FrameRange]) -> tuple[Iterator[FrameTime], int]:
    """The frames to render, generated lazily, and how many there are."""
    if args.defaultTime:
        return iter([DEFAULT_TIME]), 1
    if frames:
        return iter_frames(frames), sum(frame_range.count for frame_range in frames)
    return iter([START_TIME]), 1


def _record(args: argparse.Namespace, frames: list[FrameRange], tracer: Tracer) -> int:
    say = (lambda _text: None) if args.quiet else print
    check_output_directory(args.outputImagePath)
    times, count = _frames(args, frames)
    first_frame = next(times)
    job = _render_job(args, first_frame)

    def output_path(frame: FrameTime) -> str:
        return frame_path(args.outputImagePath, frame) if frames else args.outputImagePath

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
        say(f"Camera: {session.camera}")
        say(f"Renderer plugin: {RENDERER_NAME}")
        for frame in itertools.chain([first_frame], times):
            label = _time_code_label(time_code(session.renderer.stage, frame))
            output = output_path(frame)
            if args.resume and output_is_complete(output, job.frame_key(frame)):
                say(f"Skipped time code {label}: {output} is complete")
                continue
            say(f"Recording time code: {label}")
            progress = None if args.quiet else _Progress(f"time code {label}")
            products: list[tuple[str, Image]] = []
            with tracer.span(f"time code {label}"):
                if session.products is not None:
                    # The output image holds the first product's render (all its AOVs in EXR).
                    products = session.render_products(
                        frame, os.path.dirname(os.path.abspath(output)), progress
                    )
                    image = products[0][1]
                    image.metadata[RENDER_KEY] = job.frame_key(frame)
                else:
                    image = session.render(frame, progress=progress)
                with tracer.span("write image", file=output):
                    image.write(output, color_mode=job.color_mode)
            say(frame_summary(f"time code {label}", image))
            for path, _ in products:
                say(f"Wrote {os.path.abspath(path)}")
            say(f"Wrote {os.path.abspath(output)}")
    return EXIT_OK


def _time_code_label(code: Usd.TimeCode) -> str:
    return "default" if code.IsDefault() else f"{code.GetValue():g}"


if __name__ == "__main__":
    sys.exit(main())
