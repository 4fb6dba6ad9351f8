"""What tests that interrupt a Penumbra child process share."""

from __future__ import annotations

import signal


def default_sigint() -> None:
    """``preexec_fn`` for ``subprocess.Popen``: the child takes SIGINT as a program run in the
    foreground does (Python raises KeyboardInterrupt), even when the tests run as a background
    job, which ignores SIGINT and passes that on to its children."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
