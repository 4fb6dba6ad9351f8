"""``penumbra-record``: renders a USD file to images, with usdrecord's command line.

Exit status: 0 success; 1 the scene or a file could not be rendered (the message names the file
or prim); 2 usage error (including flags Penumbra does not support yet); 130 Ctrl-C (SIGINT) and
143 SIGTERM, nothing written for the frame in progress. A signal that comes while the stage is
read takes effect as the reads end (``_interrupts``: USD's bindings would lose it), one during a
render pass within 50 ms.

The command line is defined in ``cli_arguments``, the renders in ``cli_record``, what is printed
in ``cli_output``; here: running them, and the exit status of each outcome.
"""

from __future__ import annotations

import logging
import sys
import traceback
import warnings
from collections.abc import Sequence

from ._interrupts import Terminated, TerminateAsInterrupt
from .cli_arguments import (
    EXIT_INTERRUPTED,
    EXIT_SCENE,
    EXIT_TERMINATED,
    EXIT_USAGE,
    PROG,
    UsageError,
    build_parser,
    check_usage,
)
from .cli_output import peak_memory_bytes, report_information, show_warning
from .cli_record import record
from .errors import PenumbraWarning, SceneError
from .trace import Tracer


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``penumbra-record``; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:  # argparse reports usage errors (2), --help and --version (0)
        return int(exit_.code or 0)
    try:
        frames = check_usage(args)
    except UsageError as error:
        sys.stderr.write(f"{PROG}: error: {error}\n")
        return EXIT_USAGE
    if args.quiet:
        logging.getLogger("penumbra").setLevel(logging.WARNING)
    else:
        report_information()

    tracer = Tracer(enabled=bool(args.traceToFile) or args.verbose)
    with warnings.catch_warnings(), TerminateAsInterrupt():
        warnings.simplefilter("always", PenumbraWarning)
        warnings.showwarning = show_warning
        try:
            status = record(args, frames, tracer)
        except (SceneError, RuntimeError, OSError) as error:  # RuntimeError: the image writer's
            sys.stderr.write(f"{PROG}: error: {error}\n")
            status = EXIT_SCENE
        except KeyboardInterrupt:
            sys.stderr.write(f"\n{PROG}: interrupted, nothing written for the frame in progress\n")
            return EXIT_INTERRUPTED
        except Terminated:
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
            sys.stderr.write(
                f"{PROG}: error: {args.traceToFile}: cannot write the trace: {error.strerror}\n"
            )
            return EXIT_SCENE
    return status


if __name__ == "__main__":
    sys.exit(main())
