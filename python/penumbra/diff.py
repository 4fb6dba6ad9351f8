"""``penumbra-diff``: compares two images with the semantics, output and exit codes of OIIO
2.4's idiff (checked against the installed ``idiff`` by ``tests/python/test_diff_vs_idiff.py``).

Pixels are compared over the union of the two images' sizes and channels, a missing value
counting as 0 (so images of different sizes or channel counts fail by their differences, exit
2, as in idiff). For each value the error is the absolute difference. Values that are both
non-finite (NaN and NaN, or infinities of any sign) are equal; a value that is NaN or infinite
in one image only is a difference of "inf" for the maximum error but is not counted over a
threshold nor in the mean or RMS error (idiff counts such values inconsistently when an image
holds several; see the test). A pixel *fails* when one of its values differs by more than
``-fail`` and by more than ``-failrelative`` times the mean of their magnitudes; *warns*
likewise with ``-warn`` and ``-warnrelative``. The result is

* FAILURE (exit 2) if more than ``-failpercent`` % of the pixels fail, the largest error
  exceeds ``-hardfail``, or (``-p``) more than ``-failpercent`` % fail Yee's perceptual test;
* else WARNING (exit 1) if more than ``-warnpercent`` % of the pixels warn or the largest
  error exceeds ``-hardwarn``;
* else PASS (exit 0);
* and PASS whatever the above when at most ``-allowfailures`` pixels fail (0 by default: a
  comparison in which no pixel fails passes, as idiff 2.4 decides).

Percentages are of the first image's pixels. Unreadable or missing files exit 4; a command
line that cannot be parsed exits 1, as idiff's does (the code of WARNING: check the output).
``-o FILE`` writes the difference (first minus second; ``-abs`` its magnitude, times
``-scale``), ``-od`` only when the images differ.
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
EXIT_PASS, EXIT_WARN, EXIT_FAIL, EXIT_FILE = 0, 1, 2, 4
EXIT_USAGE = 1  # idiff's (EXIT_FAILURE from its argument parser)
DEFAULT_THRESHOLD = 1e-6  # idiff's default -fail and -warn


@dataclass(frozen=True)
class Comparison:
    """Error statistics of two images."""

    mean_error: float
    rms_error: float
    max_error: float
    max_location: tuple[int, int, str]  # (x, y, channel name)
    pixels: int  # of the first image (the denominator of idiff's percentages)
    warn_pixels: int  # pixels over the warn thresholds (failing ones included)
    fail_pixels: int


def _union(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both images padded with zeros to the union of their sizes and channel counts."""
    shape = tuple(max(x, y) for x, y in zip(a.shape, b.shape))

    def pad(image: np.ndarray) -> np.ndarray:
        if image.shape == shape:
            return image
        padded = np.zeros(shape, dtype=image.dtype)
        padded[: image.shape[0], : image.shape[1], : image.shape[2]] = image
        return padded

    return pad(a), pad(b)


def compare(
    baseline: np.ndarray,
    test: np.ndarray,
    channel_names: Sequence[str],
    warn: float = DEFAULT_THRESHOLD,
    fail: float = DEFAULT_THRESHOLD,
    warn_relative: float = 0.0,
    fail_relative: float = 0.0,
) -> Comparison:
    """Compare two float (H, W, C) images (of any sizes) as idiff does."""
    pixels = baseline.shape[0] * baseline.shape[1] or 1
    a, b = (image.astype(np.float64) for image in _union(baseline, test))
    finite_a, finite_b = np.isfinite(a), np.isfinite(b)
    both_finite = finite_a & finite_b
    with np.errstate(invalid="ignore", over="ignore"):
        error = np.where(both_finite, np.abs(a - b), 0.0)
        magnitude = np.where(both_finite, (np.abs(a) + np.abs(b)) / 2, 0.0)
    one_nonfinite = finite_a != finite_b
    shown = np.where(one_nonfinite, np.inf, error)  # for the maximum only
    y, x, c = np.unravel_index(int(np.argmax(shown)), shown.shape)
    warns = ((error > warn) & (error > warn_relative * magnitude)).any(axis=2)
    fails = ((error > fail) & (error > fail_relative * magnitude)).any(axis=2)
    values = max(error.size, 1)
    return Comparison(
        mean_error=float(error.sum() / values),
        rms_error=float(np.sqrt((error**2).sum() / values)),
        max_error=float(shown[y, x, c]),
        max_location=(int(x), int(y), channel_names[c] if c < len(channel_names) else str(c)),
        pixels=pixels,
        warn_pixels=int(np.count_nonzero(warns)),
        fail_pixels=int(np.count_nonzero(fails)),
    )


def verdict(result: Comparison, args: argparse.Namespace, perceptual_fails: int = 0) -> int:
    """idiff 2.4's decision: FAIL, WARN or PASS exit status."""
    allowed_failures = args.failpercent / 100.0 * result.pixels
    if result.fail_pixels <= args.allowfailures:
        return EXIT_PASS
    if (
        result.fail_pixels > allowed_failures
        or result.max_error > args.hardfail
        or perceptual_fails > allowed_failures
    ):
        return EXIT_FAIL
    if result.warn_pixels > args.warnpercent / 100.0 * result.pixels:
        return EXIT_WARN
    if result.max_error > args.hardwarn:
        return EXIT_WARN
    return EXIT_PASS


class _ArgumentParser(argparse.ArgumentParser):
    """Usage errors exit with idiff's status 1 instead of argparse's 2."""

    def error(self, message: str):  # type: ignore[override]
        self.print_usage(sys.stderr)
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _ArgumentParser(
        prog=PROG,
        allow_abbrev=False,
        description="Compare two images (OIIO idiff 2.4 semantics, flags and exit codes).",
        epilog="Exit status: 0 pass, 1 warning (or a usage error, as idiff), 2 failure "
        "(images of different sizes or channel counts included), 4 file error.",
    )
    parser.add_argument("baseline", help="reference image")
    parser.add_argument("test", help="image to check")
    parser.add_argument("--version", action="version", version=f"{PROG} {_core.version()}")
    parser.add_argument("-v", action="store_true", help="verbose: always print the statistics")
    parser.add_argument("-q", action="store_true", help="quiet: print only FAILURE (on stderr)")
    parser.add_argument(
        "-a", action="store_true", help="compare all subimages (Penumbra's images have one)"
    )
    thresholds = (
        ("--fail", "-fail", DEFAULT_THRESHOLD, "a pixel fails when an error exceeds A"),
        ("--failrelative", "-failrelative", 0.0, "... and exceeds R times the values' mean"),
        ("--failpercent", "-failpercent", 0.0, "allow up to P%% of the pixels to fail"),
        ("--hardfail", "-hardfail", math.inf, "fail if any pixel's error exceeds H"),
        ("--warn", "-warn", DEFAULT_THRESHOLD, "a pixel warns when an error exceeds A"),
        ("--warnrelative", "-warnrelative", 0.0, "... and exceeds R times the values' mean"),
        ("--warnpercent", "-warnpercent", 0.0, "allow up to P%% of the pixels to warn"),
        ("--hardwarn", "-hardwarn", math.inf, "warn if any pixel's error exceeds H"),
    )
    for long, short, default, text in thresholds:
        parser.add_argument(
            long, short, type=float, default=default, help=f"{text} (default: %(default)g)"
        )
    parser.add_argument(
        "--allowfailures",
        "-allowfailures",
        type=int,
        default=0,
        metavar="N",
        help="pass when at most N pixels fail, by any amount (default: %(default)s)",
    )
    parser.add_argument(
        "--perceptual",
        "-p",
        action="store_true",
        help="also fail on Yee's perceptual metric (as idiff -p)",
    )
    output = parser.add_argument_group("difference image")
    output.add_argument("-o", metavar="FILENAME", help="write the difference image")
    output.add_argument("-od", action="store_true", help="only if the images differ")
    output.add_argument("-abs", action="store_true", help="absolute difference, not signed")
    output.add_argument(
        "-scale", type=float, default=1.0, metavar="FACTOR", help="scale the difference image"
    )
    return parser


def _read(path: str) -> tuple[np.ndarray, list[str]] | None:
    try:
        pixels, names, _ = _core.read_image(path)
    except RuntimeError as error:
        sys.stderr.write(f"{PROG}: error: {error}\n")
        return None
    return np.asarray(pixels, dtype=np.float32), list(names)


def _format(value: float) -> str:
    if math.isnan(value):
        return "nan"
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return f"{value:.6g}"


def write_difference(
    path: str, a: np.ndarray, b: np.ndarray, names: Sequence[str], absolute: bool, scale: float
) -> None:
    """Write ``(a - b) * scale`` (or its magnitude) over the union of the images."""
    a, b = _union(a, b)
    difference = a - b
    if absolute:
        difference = np.abs(difference)
    difference = np.ascontiguousarray(difference * np.float32(scale), dtype=np.float32)
    channels = list(names)[: difference.shape[2]]
    channels += [f"channel{i}" for i in range(len(channels), difference.shape[2])]
    _core.write_image(path, difference, channels, {})


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``penumbra-diff``; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    say = (lambda _text: None) if args.q else print
    say(f'Comparing "{args.baseline}" and "{args.test}"')
    baseline = _read(args.baseline)
    test = _read(args.test)
    if baseline is None or test is None:
        return EXIT_FILE
    (a, names), (b, names_b) = baseline, test
    if len(names_b) > len(names):
        names = names + names_b[len(names) :]

    result = compare(
        a,
        b,
        names,
        warn=args.warn,
        fail=args.fail,
        warn_relative=args.warnrelative,
        fail_relative=args.failrelative,
    )
    perceptual_fails = perceptual_failures(*_union(a, b)) if args.perceptual else 0
    status = verdict(result, args, perceptual_fails)

    if args.v or (status != EXIT_PASS and not args.q):
        if a.shape != b.shape:
            print(
                f"  Sizes differ: {a.shape[1]}x{a.shape[0]}, {a.shape[2]} channels vs "
                f"{b.shape[1]}x{b.shape[0]}, {b.shape[2]} channels"
            )
        if result.rms_error == 0:
            peak_snr = math.inf
        else:
            peak_snr = 20.0 * math.log10(1.0 / result.rms_error)
        print(f"  Mean error = {_format(result.mean_error)}")
        print(f"  RMS error = {_format(result.rms_error)}")
        print(f"  Peak SNR = {_format(peak_snr)}")
        x, y, channel = result.max_location
        location = f" @ ({x}, {y}, {channel})" if result.max_error != 0 else ""
        print(f"  Max error  = {_format(result.max_error)}{location}")
        for count, threshold in ((result.warn_pixels, args.warn), (result.fail_pixels, args.fail)):
            percent = 100.0 * count / result.pixels
            print(f"  {count} pixels ({percent:.3g}%) over {threshold:g}")
        if args.perceptual:
            percent = 100.0 * perceptual_fails / result.pixels
            print(f"  {perceptual_fails} pixels ({percent:.6g}%) failed the perceptual test")
    if args.o and (result.max_error != 0 or not args.od):
        try:
            write_difference(args.o, a, b, names, args.abs, args.scale)
        except RuntimeError as error:
            sys.stderr.write(f"{PROG}: error: {error}\n")
    label = {EXIT_PASS: "PASS", EXIT_WARN: "WARNING", EXIT_FAIL: "FAILURE"}[status]
    if args.q:
        if status == EXIT_FAIL:
            sys.stderr.write("FAILURE\n")
    else:
        print(label)
    return status


if __name__ == "__main__":
    sys.exit(main())
