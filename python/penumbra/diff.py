"""``penumbra-diff``: compares two images with the semantics and exit codes of OIIO's idiff.

For every pixel the error is the largest absolute difference over its channels (equal
infinities, e.g. the depth of background pixels, differ by 0; a NaN, or infinities that
differ, are an infinite error). A pixel *fails* when its error exceeds ``--fail``, else *warns*
when it exceeds ``--warn``. The result is

* FAILURE (exit 2) if more than ``--failpercent`` % of the pixels fail or the largest error
  exceeds ``--hardfail``;
* else WARNING (exit 1) if more than ``--warnpercent`` % of the pixels warn or fail, or the
  largest error exceeds ``--hardwarn``;
* else PASS (exit 0).

With ``--perceptual``, idiff's perceptual metric (Yee 2004: a pixel fails when the luminance
difference exceeds the visibility threshold, raised by contrast masking, or the colour
difference is too large; observer: 45° field of view, 100 cd/m² white) also fails the images
when more than ``--failpercent`` % of the pixels fail it.

Images of different sizes or channel counts exit 3; unreadable files exit 4; usage errors
exit 2, as argparse does.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from . import _core
from .perceptual import perceptual_failures

PROG = "penumbra-diff"
EXIT_PASS, EXIT_WARN, EXIT_FAIL, EXIT_SIZE, EXIT_FILE = 0, 1, 2, 3, 4
DEFAULT_THRESHOLD = 1e-6  # idiff's default --fail and --warn


@dataclass(frozen=True)
class Comparison:
    """Error statistics of two images of equal shape."""

    mean_error: float
    rms_error: float
    max_error: float
    max_location: tuple[int, int, str]  # (x, y, channel name)
    pixels: int
    warn_pixels: int  # pixels over the warn threshold (failing ones included)
    fail_pixels: int


def compare(
    baseline: np.ndarray,
    test: np.ndarray,
    channel_names: Sequence[str],
    warn: float = DEFAULT_THRESHOLD,
    fail: float = DEFAULT_THRESHOLD,
) -> Comparison:
    """Compare two float (H, W, C) images of equal shape."""
    with np.errstate(invalid="ignore"):
        error = np.where(baseline == test, 0.0, np.abs(baseline.astype(np.float64) - test))
    error = np.where(np.isnan(error), np.inf, error)
    per_pixel = error.max(axis=2)
    y, x, c = np.unravel_index(int(np.argmax(error)), error.shape)
    finite = error[np.isfinite(error)]
    all_finite = finite.size == error.size
    mean = float(finite.mean()) if all_finite else math.inf
    rms = float(np.sqrt(np.mean(finite**2))) if all_finite else math.inf
    return Comparison(
        mean_error=mean,
        rms_error=rms,
        max_error=float(error[y, x, c]),
        max_location=(int(x), int(y), channel_names[c] if c < len(channel_names) else str(c)),
        pixels=per_pixel.size,
        warn_pixels=int(np.count_nonzero(per_pixel > warn)),
        fail_pixels=int(np.count_nonzero(per_pixel > fail)),
    )


def verdict(result: Comparison, args: argparse.Namespace, perceptual_fails: int = 0) -> int:
    """idiff's decision: FAIL, WARN or PASS exit status."""
    allowed_failures = args.failpercent / 100.0 * result.pixels
    if result.fail_pixels > allowed_failures or perceptual_fails > allowed_failures:
        return EXIT_FAIL
    if result.max_error > args.hardfail:
        return EXIT_FAIL
    if result.warn_pixels > args.warnpercent / 100.0 * result.pixels:
        return EXIT_WARN
    if result.max_error > args.hardwarn:
        return EXIT_WARN
    return EXIT_PASS


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Compare two images (OIIO idiff semantics).",
        epilog="Exit status: 0 pass, 1 warning, 2 failure or usage error, 3 size mismatch, "
        "4 file error.",
    )
    parser.add_argument("baseline", help="reference image")
    parser.add_argument("test", help="image to check")
    thresholds = (
        ("--fail", "-fail", DEFAULT_THRESHOLD, "a pixel fails when its error exceeds A"),
        ("--failpercent", "-failpercent", 0.0, "allow up to P%% of the pixels to fail"),
        ("--hardfail", "-hardfail", math.inf, "fail if any pixel's error exceeds H"),
        ("--warn", "-warn", DEFAULT_THRESHOLD, "a pixel warns when its error exceeds A"),
        ("--warnpercent", "-warnpercent", 0.0, "allow up to P%% of the pixels to warn"),
        ("--hardwarn", "-hardwarn", math.inf, "warn if any pixel's error exceeds H"),
    )
    for long, short, default, text in thresholds:
        parser.add_argument(
            long, short, type=float, default=default, help=f"{text} (default: %(default)g)"
        )
    parser.add_argument(
        "--perceptual",
        "-p",
        action="store_true",
        help="also fail on Yee's perceptual metric (as idiff -p)",
    )
    return parser


def _read(path: str) -> tuple[np.ndarray, list[str]] | None:
    try:
        pixels, names, _ = _core.read_image(path)
    except RuntimeError as error:
        sys.stderr.write(f"{PROG}: error: {error}\n")
        return None
    return np.asarray(pixels, dtype=np.float32), list(names)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``penumbra-diff``; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    print(f'Comparing "{args.baseline}" and "{args.test}"')
    baseline = _read(args.baseline)
    test = _read(args.test)
    if baseline is None or test is None:
        return EXIT_FILE
    (a, names), (b, _) = baseline, test
    if a.shape != b.shape:
        height_a, width_a, channels_a = a.shape
        height_b, width_b, channels_b = b.shape
        print(
            f"Images do not match in size: ({width_a}x{height_a}, {channels_a} channels) vs "
            f"({width_b}x{height_b}, {channels_b} channels)"
        )
        print("FAILURE")
        return EXIT_SIZE

    result = compare(a, b, names, warn=args.warn, fail=args.fail)
    x, y, channel = result.max_location
    if result.rms_error == 0:
        peak_snr = math.inf
    elif math.isinf(result.rms_error):
        peak_snr = -math.inf
    else:
        peak_snr = 20.0 * math.log10(1.0 / result.rms_error)
    print(f"  Mean error = {result.mean_error:.6g}")
    print(f"  RMS error = {result.rms_error:.6g}")
    print(f"  Peak SNR = {peak_snr:.6g}")
    print(f"  Max error  = {result.max_error:.6g} @ ({x}, {y}, {channel})")
    for count, threshold in ((result.warn_pixels, args.warn), (result.fail_pixels, args.fail)):
        percent = 100.0 * count / result.pixels
        print(f"  {count} pixels ({percent:.3g}%) over {threshold:g}")
    perceptual_fails = 0
    if args.perceptual:
        perceptual_fails = perceptual_failures(a, b)
        percent = 100.0 * perceptual_fails / result.pixels
        print(f"  {perceptual_fails} pixels ({percent:.3g}%) failed the perceptual test")
    status = verdict(result, args, perceptual_fails)
    print({EXIT_PASS: "PASS", EXIT_WARN: "WARNING", EXIT_FAIL: "FAILURE"}[status])
    return status


if __name__ == "__main__":
    sys.exit(main())
