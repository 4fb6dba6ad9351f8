"""atheris (libFuzzer) over the scene delegate: mutated .usda stages, seeded with the
malformed-input corpus, rendered by ``penumbra-record`` at 16 px, 1 spp. A finding is a crash,
a hang (libFuzzer's -timeout) or an error only the CLI's catch-all reports (an exception nothing
checked: ``cannot render: <ExceptionType>``).

    python tests/fuzz/fuzz_scene.py -runs=300 -seed=1     # make test (short)
    python tests/fuzz/fuzz_scene.py -max_total_time=600   # make fuzz

libFuzzer ends the process with C's exit(), which skips Python's clean-up, so the fuzzer runs in a
child process and this one removes the child's scratch directory whatever way it ended.
"""

from __future__ import annotations

import contextlib
import io
import os
import sys
import tempfile
from pathlib import Path
from typing import NoReturn

WORK_VARIABLE = "PENUMBRA_FUZZ_WORK"
CATCH_ALL = ": cannot render: "


def fuzz(work: Path) -> NoReturn:
    """Runs libFuzzer in this process, writing stages and images into `work`."""
    import atheris

    with atheris.instrument_imports():
        from penumbra.cli import main

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))
    from malformed_corpus import CASES

    def render(data: bytes) -> None:
        stage = work / "stage.usda"
        stage.write_bytes(data)
        stderr = io.StringIO()
        with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(io.StringIO()):
            status = main([str(stage), str(work / "out.png"), "-w", "16", "-spp", "1", "-q"])
        if status not in (0, 1, 2) or CATCH_ALL in stderr.getvalue():
            raise AssertionError(f"exit {status}: {stderr.getvalue()}")

    seeds = work / "seeds"  # the corpus's stages as libFuzzer seeds
    seeds.mkdir()
    for index, case in enumerate(CASES):
        (seeds / f"{index:03d}.usda").write_text(case.usda())
    atheris.Setup([*sys.argv, str(seeds)], render)
    atheris.Fuzz()


def main() -> int:
    if WORK_VARIABLE in os.environ:
        fuzz(Path(os.environ[WORK_VARIABLE]))
    import subprocess  # here, so that the fuzzing child instruments what penumbra imports of it

    with tempfile.TemporaryDirectory(prefix="penumbra-fuzz-") as work:
        child = subprocess.run(
            [sys.executable, __file__, *sys.argv[1:]], env={**os.environ, WORK_VARIABLE: work}
        )
    return child.returncode


if __name__ == "__main__":
    sys.exit(main())
