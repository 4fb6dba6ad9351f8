"""Ctrl-C (SIGINT) and SIGTERM while USD's Python bindings run.

Python runs a signal's handler in the main thread at the next moment it runs Python code, which
may be inside a call into USD's bindings (converting a token value to Python does). An exception
the handler raises there does not get through: USD's module loader (Tf's ``_LoadLibModules``)
turns it into a warning while it imports the ``pxr`` modules; reading the stage, the call
prints it and returns ``None`` (an attribute's value), or raises a ``SystemError`` in its place.
The signal is lost: the program goes on, into a render that may never end, or fails on the
value (``/cam: unknown projection 'None'``: exit status 1, not 130 or 143).

:func:`deferred` holds these signals over a block that calls into USD and raises them as the
block ends. Penumbra defers them while it imports ``pxr`` and while it reads the stage (opening
it, the scene sync, the camera and render settings before each render), not while it renders:
a render pass runs Python's signal handlers itself every 50 ms (``RenderPass.execute``), and
stops at once when one raises.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType

Handler = Callable[[int, FrameType | None], None]


class Terminated(BaseException):
    """SIGTERM arrived while :class:`TerminateAsInterrupt` was active: the run stops as on
    Ctrl-C (a BaseException, so that no ``except Exception`` on the way swallows it)."""


def _raise_terminated(_signum: int, _frame: FrameType | None) -> None:
    raise Terminated()


class TerminateAsInterrupt:
    """While active (in the main thread), SIGTERM raises :class:`Terminated` where Python next
    checks for signals (a running render pass checks every 50 ms and stops; :func:`deferred`
    holds it while the stage is read)."""

    def __enter__(self) -> None:
        self.previous = None
        if threading.current_thread() is threading.main_thread():
            self.previous = signal.signal(signal.SIGTERM, _raise_terminated)

    def __exit__(self, *_exc) -> None:
        if self.previous is not None:
            signal.signal(signal.SIGTERM, self.previous)


# The handlers deferred, by signal: Python's own for SIGINT (KeyboardInterrupt) and
# TerminateAsInterrupt's for SIGTERM. Any other handler is a program's own, left alone.
_RAISING: dict[int, Handler] = {
    signal.SIGINT: signal.default_int_handler,
    signal.SIGTERM: _raise_terminated,
}


@contextmanager
def deferred() -> Iterator[None]:
    """Within the block, SIGINT and SIGTERM are noted instead of raising; the first one noted
    is raised as the block ends, by its handler (:class:`KeyboardInterrupt`,
    :class:`Terminated`). Only where one of those handlers is in place, in the main thread:
    elsewhere (a program's own handler, a renderer in another thread) nothing changes. The
    handlers are restored after; a block nested in another changes nothing either."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held = {
        signum: handler
        for signum, handler in _RAISING.items()
        if signal.getsignal(signum) is handler
    }
    noted: list[int] = []

    def note(signum: int, _frame: FrameType | None) -> None:
        noted.append(signum)

    for signum in held:
        signal.signal(signum, note)
    try:
        yield
    finally:
        for signum, handler in held.items():
            signal.signal(signum, handler)
    if noted:
        held[noted[0]](noted[0], None)
