"""What a prim inherits from its ancestors — purpose, visibility, and whether its transform or
visibility might vary with time — computed once per prim and handed down to its children, so
that one sync walks each ancestor once instead of once per descendant (docs/architecture.md,
"Scene delegate").

The rules are UsdGeomImageable's and UsdGeomXformable's: purpose as
``UsdGeomImageable.ComputePurposeInfo``; a prim is invisible when it or any ancestor is; a
transform might vary when an xformOp of the prim or of an ancestor (up to a
``!resetXformStack!``) is time-sampled.
"""

from __future__ import annotations

from dataclasses import dataclass

from pxr import Sdf, Usd, UsdGeom


@dataclass(frozen=True)
class _Structure:
    """The time-independent part of a prim's inherited state."""

    purpose: UsdGeom.Imageable.PurposeInfo
    transform_might_vary: bool
    visibility_might_vary: bool


_ROOT = _Structure(UsdGeom.Imageable.PurposeInfo(), False, False)


class InheritedState:
    """Memoised inherited state of the prims of one sync; :meth:`forget` after it (the stage
    may be edited before the next), :meth:`at` before reading visibility at a new time."""

    def __init__(self) -> None:
        self._structure: dict[Sdf.Path, _Structure] = {}
        self._invisible: dict[Sdf.Path, bool] = {}
        self._time = Usd.TimeCode.Default()

    def forget(self) -> None:
        self._structure.clear()
        self._invisible.clear()

    def at(self, time: Usd.TimeCode) -> None:
        """Read visibility at ``time`` from now on."""
        if time != self._time:
            self._time = time
            self._invisible.clear()

    def purpose(self, prim: Usd.Prim) -> str:
        """The computed purpose of ``prim``."""
        return self._of(prim).purpose.purpose

    def transform_might_vary(self, prim: Usd.Prim) -> bool:
        """Whether the local-to-world transform of ``prim`` might change with time."""
        return self._of(prim).transform_might_vary

    def visibility_might_vary(self, prim: Usd.Prim) -> bool:
        """Whether the computed visibility of ``prim`` might change with time."""
        return self._of(prim).visibility_might_vary

    def visible(self, prim: Usd.Prim) -> bool:
        """Whether ``prim`` and all its ancestors are visible at the current time."""
        return not self._is_invisible(prim)

    def _is_invisible(self, prim: Usd.Prim) -> bool:
        path = prim.GetPath()
        invisible = self._invisible.get(path)
        if invisible is None:
            parent = prim.GetParent()
            invisible = bool(parent) and not parent.IsPseudoRoot() and self._is_invisible(parent)
            if not invisible:
                attr = prim.GetAttribute(UsdGeom.Tokens.visibility)
                invisible = bool(attr) and attr.Get(self._time) == UsdGeom.Tokens.invisible
            self._invisible[path] = invisible
        return invisible

    def _of(self, prim: Usd.Prim) -> _Structure:
        path = prim.GetPath()
        state = self._structure.get(path)
        if state is not None:
            return state
        parent = prim.GetParent()
        inherited = _ROOT if not parent or parent.IsPseudoRoot() else self._of(parent)
        xformable = UsdGeom.Xformable(prim)
        transform_varies = inherited.transform_might_vary
        if xformable:
            if xformable.TransformMightBeTimeVarying():
                transform_varies = True
            elif xformable.GetResetXformStack():
                transform_varies = False
        visibility = prim.GetAttribute(UsdGeom.Tokens.visibility)
        state = self._structure[path] = _Structure(
            UsdGeom.Imageable(prim).ComputePurposeInfo(inherited.purpose),
            transform_varies,
            inherited.visibility_might_vary
            or (bool(visibility) and visibility.ValueMightBeTimeVarying()),
        )
        return state
