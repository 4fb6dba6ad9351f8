"""Latencies users feel that the tests do not time: how soon a signal stops a render, and what
the spectral upsampling table costs the first dispersive render.

- Signal: ``penumbra-record`` renders a bundled stage with a billion samples; after it has had
  ``--settle`` seconds to reach the render pass it gets SIGINT (or SIGTERM), and the time until
  it has exited is measured (the target: well under a second).
- Spectral table: ``examples/showcase.usda`` (its glass disperses light) is rendered twice in a
  fresh process at 16x9, one sample; the first render builds the table, the second does not.
  The difference is the table's cost (the target: under 2 s on this 2-core machine).

Medians over ``--runs`` runs; the machines are shared and noisy.
"""

from __future__ import annotations

import argparse
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from provenance import print_provenance

REPO = Path(__file__).resolve().parents[1]
STAGE = REPO / "examples" / "cornell.usda"
DISPERSIVE = REPO / "examples" / "showcase.usda"

SPECTRAL_PROBE = """
import sys, time
import penumbra
with penumbra.Renderer(sys.argv[1]) as renderer:
    seconds = []
    for _ in range(2):
        started = time.perf_counter()
        renderer.render(width=16, samples=1, threads=2)
        seconds.append(time.perf_counter() - started)
print(seconds[0] - seconds[1])
"""


def signal_latency(signal_number: int, settle: float) -> float:
    with tempfile.TemporaryDirectory() as directory:
        process = subprocess.Popen(
            [sys.executable, "-m", "penumbra.cli", str(STAGE), f"{directory}/out.exr"]
            + ["-w", "64", "-spp", "1000000000", "-q"],
            stderr=subprocess.DEVNULL,
            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        )
        try:
            time.sleep(settle)
            sent = time.perf_counter()
            process.send_signal(signal_number)
            process.wait(timeout=60)
            return time.perf_counter() - sent
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()


def spectral_table_seconds() -> float:
    result = subprocess.run(
        [sys.executable, "-c", SPECTRAL_PROBE, str(DISPERSIVE)],
        capture_output=True,
        text=True,
        check=True,
    )
    return float(result.stdout.split()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--settle", type=float, default=3.0, help="seconds before the signal")
    args = parser.parse_args()
    print_provenance()
    print("| what | median (s) | min (s) | max (s) |")
    print("|---|---|---|---|")
    rows = {
        "SIGINT to exit": lambda: signal_latency(signal.SIGINT, args.settle),
        "SIGTERM to exit": lambda: signal_latency(signal.SIGTERM, args.settle),
        "spectral table, first dispersive render": spectral_table_seconds,
    }
    for name, measure in rows.items():
        values = [measure() for _ in range(args.runs)]
        print(
            f"| {name} | {statistics.median(values):.3f} | {min(values):.3f} "
            f"| {max(values):.3f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
