"""``penumbra-record``'s command line: usdrecord's flags plus Penumbra's own (those of the render
options derived from ``render_options``), and the checks of the values given.
"""

from __future__ import annotations

import argparse
import math
import signal

from . import _core, render_options
from .denoise import NOISY_COLOR
from .frames import FrameRange, find_placeholder, frame_spec_precision, parse_frame_spec
from .image import COLOR_MODES, check_output_format
from .memory import DEFAULT_BUDGET_FRACTION, MIN_TEXTURE_CACHE, parse_size
from .renderer import DEFAULT_WIDTH
from .trace import TRACE_FORMATS
from .usd.products import HOUDINI_FRAME
from .usd.stage import RESOLVERS

PROG = "penumbra-record"
# The exit statuses (the parser's epilog lists the first three).
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
            "noisyColor (with --denoise), CryptoObject, CryptoMaterial, CryptoAsset "
            "(Cryptomatte); render products name their own"
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
            "and frame (checked by a key in the image's metadata), and continue a partly "
            "rendered frame from its checkpoint (see --checkpoint)"
        ),
    )
    own.add_argument(
        "--checkpoint",
        type=float,
        metavar="SECONDS",
        help=(
            "every SECONDS of rendering (between passes of samples; 0: after every pass) "
            "write the frame rendered so far to its output, and its exact state beside it "
            "(OUTPUT.penumbra-checkpoint), from which --resume continues bit-identically"
        ),
    )
    own.add_argument(
        "--timeLimit",
        type=float,
        metavar="SECONDS",
        help=(
            "end each frame after the last whole pass of samples that fits in SECONDS (at "
            "least one pass); the metadata says the samples reached"
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


_LARGEST_WIDTH = 2**31 - 1  # the render delegate's image sizes are int32


class UsageError(Exception):
    """A command line that cannot be honoured (exit status 2)."""


def check_usage(args: argparse.Namespace) -> list[FrameRange]:
    """Reject invalid values; return the ``--frames`` ranges (empty without ``--frames``)."""
    if args.renderer.lower() != RENDERER_NAME.lower():
        raise UsageError(
            f"--renderer {args.renderer}: {PROG} renders with {RENDERER_NAME} only"
        )
    if args.renderSettingsPrimPath and args.renderPassPrimPath:
        raise UsageError("give --renderSettingsPrimPath or --renderPassPrimPath, not both")
    if args.traceFormat != "chrome" and not args.traceToFile:
        raise UsageError("--traceFormat needs --traceToFile")
    if args.imageWidth is not None and args.imageWidth < 1:
        raise UsageError("--imageWidth must be at least 1")
    if args.imageWidth is not None and args.imageWidth > _LARGEST_WIDTH:
        raise UsageError(f"--imageWidth must be at most {_LARGEST_WIDTH}")
    for option in render_options.OPTIONS:
        value = getattr(args, option.key)
        problem = option.problem(value) if value is not None else None
        if problem is not None:
            raise UsageError(f"{option.flag} {problem}")
    if args.workers is not None and args.workers < 1:
        raise UsageError("--workers must be at least 1")
    for flag, seconds in (("--checkpoint", args.checkpoint), ("--timeLimit", args.timeLimit)):
        if seconds is not None and not (math.isfinite(seconds) and seconds >= 0):
            raise UsageError(f"{flag} must be a finite number of seconds >= 0, not {seconds:g}")
        if seconds is not None and (args.scheduler or args.workers):
            raise UsageError(
                f"{flag} renders on this machine only, not with --scheduler or --workers"
            )
    args.aovs = _aov_list(args.aov or "", args.denoise)
    if len(args.aovs) > 1 and not args.outputImagePath.lower().endswith(".exr"):
        raise UsageError(f"--aov needs an .exr output; {args.outputImagePath} holds colour only")
    try:
        check_output_format(args.outputImagePath)
        placeholder = find_placeholder(args.outputImagePath)
        frames = parse_frame_spec(args.frames) if args.frames is not None else []
    except ValueError as error:
        raise UsageError(str(error)) from None
    if args.frames is None:
        if placeholder:
            raise UsageError(
                f"{args.outputImagePath} holds a frame placeholder, so --frames is needed"
            )
        return frames
    check_frame_placeholder(args.outputImagePath, args.frames)
    return frames


def check_frame_placeholder(path: str, frames: str, *, product: str | None = None) -> None:
    """``UsageError`` unless ``path`` tells apart the frames of ``frames`` (a ``--frames``
    value): one ``#`` placeholder with the decimals their strides need. ``product``: the
    RenderProduct whose productName ``path`` is (named in messages); a ``$F`` placeholder,
    which writes any decimals, may then stand in for the ``#`` run."""
    prefix = f"{product}: productName " if product else ""
    try:
        placeholder = find_placeholder(path)
    except ValueError as error:
        raise UsageError(f"{prefix}{error}") from None
    if placeholder is None:
        if product and HOUDINI_FRAME.search(path):
            return
        raise UsageError(f'{prefix}{path} needs a frame placeholder such as "####" with --frames')
    decimals = len(placeholder.partition(".")[2])
    needed = frame_spec_precision(frames)
    if decimals < needed:
        raise UsageError(
            f"{prefix}{path}: the frames need {needed} decimals but placeholder {placeholder} "
            f"has {decimals}"
        )


def _aov_list(text: str, denoise: bool) -> list[str]:
    """``--aov``'s names after color; ``UsageError`` for an unknown one."""
    names = [name for name in text.replace(",", " ").split() if name != "color"]
    known = set(_core.RenderPass.aov_names()) | {NOISY_COLOR}
    for name in names:
        if name not in known and not (name.startswith("primvars:") and len(name) > 9):
            raise UsageError(f"--aov {name}: unknown AOV (known: {', '.join(sorted(known))})")
    if NOISY_COLOR in names and not denoise:
        raise UsageError(f"--aov {NOISY_COLOR} needs --denoise")
    return ["color", *names]
