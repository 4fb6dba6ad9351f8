"""Ctrl-C while USD's Python modules load.

USD's module loader (Tf's ``_LoadLibModules``) turns any exception raised while it imports the
``pxr`` modules into a warning, :class:`KeyboardInterrupt` included: a Ctrl-C in that second or
so is lost, and the program goes on, into a render that may never end. :func:`deferred` holds
such an interrupt until the imports are done and raises it then.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType


@contextmanager
def deferred() -> Iterator[None]:
    """Within the block, SIGINT is noted instead of raising :class:`KeyboardInterrupt`; one
    noted is raised as the block ends. Only where Python's own handler is in place, in the main
    thread (elsewhere a program's own handling is left alone); the handler is restored after."""
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGINT) is not signal.default_int_handler
    ):
        yield
        return
    noted: list[int] = []

    def note(signum: int, _frame: FrameType | None) -> None:
        noted.append(signum)

    signal.signal(signal.SIGINT, note)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if noted:
        raise KeyboardInterrupt
