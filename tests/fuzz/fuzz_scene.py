"""atheris (libFuzzer) over the scene delegate: mutated .usda stages, seeded with the
malformed-input corpus, rendered by ``penumbra-record`` at 16 px, 1 spp. A finding is a crash,
a hang (libFuzzer's -timeout) or an error only the CLI's catch-all reports (an exception nothing
checked: ``cannot render: <ExceptionType>``).

    python tests/fuzz/fuzz_scene.py -runs=200          # make test (short)
    python tests/fuzz/fuzz_scene.py -max_total_time=600 # make fuzz
"""

from __future__ import annotations

import contextlib
import io
import sys
import tempfile
from pathlib import Path

import atheris

with atheris.instrument_imports():
    from penumbra.cli import main

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))
from malformed_corpus import CASES  # noqa: E402

WORK = Path(tempfile.mkdtemp(prefix="penumbra-fuzz-"))
CATCH_ALL = ": cannot render: "


def render(data: bytes) -> None:
    stage = WORK / "stage.usda"
    stage.write_bytes(data)
    stderr = io.StringIO()
    with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(io.StringIO()):
        status = main([str(stage), str(WORK / "out.png"), "-w", "16", "-spp", "1", "-q"])
    if status not in (0, 1, 2) or CATCH_ALL in stderr.getvalue():
        raise AssertionError(f"exit {status}: {stderr.getvalue()}")


def seed_corpus() -> Path:
    """The corpus's stages as libFuzzer seeds."""
    directory = WORK / "seeds"
    directory.mkdir()
    for index, case in enumerate(CASES):
        (directory / f"{index:03d}.usda").write_text(case.usda())
    return directory


if __name__ == "__main__":
    atheris.Setup([*sys.argv, str(seed_corpus())], render)
    atheris.Fuzz()
