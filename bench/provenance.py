"""The line each benchmark prints first: when, where and how its numbers were measured, so that
a table pasted into the README says so itself."""

from __future__ import annotations

import datetime
import os
import platform
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def commit() -> str:
    """The checkout's commit (`git describe --always --dirty`)."""
    try:
        found = subprocess.run(
            ["git", "-C", str(REPO), "describe", "--always", "--dirty"],
            capture_output=True,
            text=True,
            check=True,
        )
        return found.stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown commit"


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def provenance() -> str:
    """``Measured <UTC time> on <CPU>, <n> cores (load <1-min average>), commit <id>:
    <command line>``."""
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    load = os.getloadavg()[0]
    script = Path(sys.argv[0]).resolve()
    name = script.relative_to(REPO).as_posix() if REPO in script.parents else script.name
    command = " ".join([name] + sys.argv[1:])
    return (
        f"Measured {now} on {_cpu()}, {os.cpu_count()} cores (load average {load:.1f} at the "
        f"start), commit {commit()}: `{command}`"
    )


def print_provenance() -> None:
    print(provenance() + "\n", flush=True)
