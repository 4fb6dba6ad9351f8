"""Errors and warnings shared by the Python layers of Penumbra.

Policy (docs/design.md §3 "Errors"): a problem that makes the render meaningless (no camera, unreadable
file) raises :class:`SceneError`; a prim that cannot be used is skipped and reported once with a
:class:`PenumbraWarning` whose text names the prim and the problem.
"""

from __future__ import annotations

import warnings


class SceneError(Exception):
    """The stage cannot be rendered; the message names the file or prim and the problem."""


class PenumbraWarning(UserWarning):
    """A recoverable problem in the scene (the named prim is skipped or simplified)."""


def warn(message: str) -> None:
    """Report ``message`` as a :class:`PenumbraWarning` (deterministic text, no location noise)."""
    warnings.warn(message, PenumbraWarning, stacklevel=2)
