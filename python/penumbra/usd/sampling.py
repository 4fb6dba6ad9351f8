"""Reading attributes at a time code while noting whether what was read can vary with time.

The scene delegate re-reads, at a new time code, only the aspects of a prim whose inputs might
be time-varying; :class:`SampleReader` collects that fact while a prim is being read.
"""

from __future__ import annotations

from typing import Any

from pxr import Usd, UsdGeom


class SampleReader:
    """Reads attributes at ``time``; ``varying`` becomes true once any attribute read might vary."""

    def __init__(self, time: Usd.TimeCode) -> None:
        self.time = time
        self.varying = False

    def get(self, attr: Usd.Attribute) -> Any:
        """The value of ``attr`` at the reader's time (``None`` if it has none)."""
        if attr.ValueMightBeTimeVarying():
            self.varying = True
        return attr.Get(self.time)

    def flattened_primvar(self, primvar: UsdGeom.Primvar) -> Any:
        """The de-indexed value of ``primvar`` at the reader's time (``None`` if it has none)."""
        if primvar.ValueMightBeTimeVarying():
            self.varying = True
        return primvar.ComputeFlattened(self.time)


def transform_might_vary(prim: Usd.Prim) -> bool:
    """Whether the local-to-world transform of ``prim`` might change with time."""
    while prim and not prim.IsPseudoRoot():
        xformable = UsdGeom.Xformable(prim)
        if xformable and xformable.TransformMightBeTimeVarying():
            return True
        if xformable and xformable.GetResetXformStack():
            return False
        prim = prim.GetParent()
    return False


def visibility_might_vary(prim: Usd.Prim) -> bool:
    """Whether the computed visibility of ``prim`` might change with time."""
    while prim and not prim.IsPseudoRoot():
        imageable = UsdGeom.Imageable(prim)
        if imageable and imageable.GetVisibilityAttr().ValueMightBeTimeVarying():
            return True
        prim = prim.GetParent()
    return False
