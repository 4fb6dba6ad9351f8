"""What a prim inherits from its ancestors and the scene delegate needs at every sync: purpose,
visibility, constant primvars, and whether its transform or visibility might vary with time
(docs/architecture.md, "Scene delegate").

Each is computed once per prim and handed down to its children (as UsdImaging's inherited-value
caches do), so that a sync reads each ancestor once rather than once per descendant. A prim's
own opinions are read only when it has authored them: :meth:`InheritedState.authored` lists the
properties with an authored opinion once per prim (one USD call), and what is not in it has its
schema's fallback, which neither overrides the inherited value nor varies with time.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Callable, NamedTuple

from pxr import Sdf, Usd, UsdGeom

from .ray_visibility import VISIBLE, RayVisibility, own_ray_visibility

_PURPOSE = UsdGeom.Tokens.purpose
_VISIBILITY = UsdGeom.Tokens.visibility


class Inherited(NamedTuple):  # a tuple: made per prim, faster than a dataclass
    """The time-independent inherited state of one prim (cf. UsdGeomImageable::PurposeInfo);
    prims whose state equals their parent's share its record."""

    purpose: str
    purpose_inheritable: bool  # an ancestor or the prim authored it: its descendants take it
    visibility_might_vary: bool
    imageable_opinions: bool  # the prim is imageable and authored purpose or visibility
    bindings: bool  # the prim or an ancestor authored a material binding (of any kind)
    hideable: bool  # the prim or an ancestor authored visibility: it may be invisible


_ROOT = Inherited(UsdGeom.Tokens.default_, False, False, False, False, False)


@lru_cache(maxsize=256)  # prims of a kind share one set of names (InheritedState.authored)
def _binds(names: frozenset[str]) -> bool:
    """Whether properties ``names`` include a material binding (direct or collection-based,
    of any purpose: all are named ``material:binding...``)."""
    return any(name.startswith("material:binding") for name in names)


class InheritedState:
    """Inherited state of the prims of one sync; :meth:`forget` it afterwards (the stage may be
    edited before the next sync) and call :meth:`at` before reading visibility at a new time.
    Each kind of state is computed only when asked for (a leaf mesh's primvars for children,
    say, never are)."""

    def __init__(self, warn: Callable[[str], None] | None = None) -> None:
        self._warn = warn or (lambda message: None)  # of ray visibility values ignored
        self._states: dict[Sdf.Path, Inherited] = {}
        self._authored: dict[Sdf.Path, frozenset[str]] = {}
        # Prims of a kind mostly author the same properties: one set serves them all.
        self._name_sets: dict[frozenset[str], frozenset[str]] = {}
        self._visible: dict[Sdf.Path, bool] = {}  # at the current time
        self._transform_varies: dict[Sdf.Path, bool] = {}
        self._primvars: dict[Sdf.Path, tuple[UsdGeom.Primvar, ...]] = {}  # for descendants
        self._ray_visibility: dict[Sdf.Path, RayVisibility] = {}  # at the current time
        self._time = Usd.TimeCode.Default()

    def forget(self) -> None:
        for cache in (self._states, self._authored, self._visible, self._transform_varies):
            cache.clear()
        self._primvars.clear()
        self._ray_visibility.clear()
        self._name_sets.clear()

    def at(self, time: Usd.TimeCode) -> None:
        """Read visibility at ``time`` from now on."""
        if time != self._time:
            self._visible.clear()
            self._ray_visibility.clear()
        self._time = time

    def authored(self, prim: Usd.Prim, path: Sdf.Path) -> frozenset[str]:
        """The names of the properties of ``prim`` (at ``path``) with an authored opinion (in
        any layer)."""
        names = self._authored.get(path)
        if names is None:
            names = frozenset(prim.GetAuthoredPropertyNames())
            names = self._authored[path] = self._name_sets.setdefault(names, names)
        return names

    # Every method takes the prim's path as well: the caller has it, and asking the prim for
    # it again costs more than the rest of a cached answer. A prim's parent is fetched only
    # when nothing is known of it yet (prims are mostly visited parents first).

    def purpose(self, prim: Usd.Prim, path: Sdf.Path) -> str:
        """The computed purpose of ``prim``."""
        return self.state(prim, path).purpose

    def visibility(
        self, prim: Usd.Prim, path: Sdf.Path, state: Inherited | None = None
    ) -> tuple[bool, bool]:
        """Whether ``prim`` is visible (:meth:`visible`), and whether its computed visibility
        might change with time; ``state``: its :meth:`state`, if the caller has it."""
        if state is None:
            state = self.state(prim, path)
        if not state.hideable:  # most prims: no visibility authored above them
            return True, False
        return self.visible(prim, path), state.visibility_might_vary

    def visible(self, prim: Usd.Prim, path: Sdf.Path) -> bool:
        """Whether ``prim`` and all its ancestors are visible at the current time."""
        visible = self._visible.get(path)
        if visible is None:
            if path.pathElementCount <= 1:
                visible = True
            else:
                parent_path = path.GetParentPath()
                visible = self._visible.get(parent_path)
                if visible is None:
                    visible = self.visible(prim.GetParent(), parent_path)
            if visible and self.state(prim, path).imageable_opinions:
                if _VISIBILITY in self.authored(prim, path):
                    value = prim.GetAttribute(_VISIBILITY).Get(self._time)
                    visible = value != UsdGeom.Tokens.invisible
            self._visible[path] = visible
        return visible

    def ray_visibility(self, prim: Usd.Prim, path: Sdf.Path) -> RayVisibility:
        """Which rays see ``prim`` and whether it is a holdout, from its own and its ancestors'
        ``primvars:penumbra:visibility:*`` and ``primvars:penumbra:holdout`` (ray_visibility.py)
        at the current time."""
        found = self._ray_visibility.get(path)
        if found is None:
            found = VISIBLE
            if path.pathElementCount > 1:
                parent_path = path.GetParentPath()
                found = self._ray_visibility.get(parent_path)
                if found is None:
                    found = self.ray_visibility(prim.GetParent(), parent_path)
            found = own_ray_visibility(
                found, prim, self.authored(prim, path), self._time, self._warn
            )
            self._ray_visibility[path] = found
        return found

    def transform_might_vary(self, prim: Usd.Prim, path: Sdf.Path) -> bool:
        """Whether the local-to-world transform of ``prim`` might change with time: an xformOp
        of it or of an ancestor (up to a ``!resetXformStack!``) is time-sampled."""
        varies = self._transform_varies.get(path)
        if varies is None:
            varies = False
            if path.pathElementCount > 1:
                parent_path = path.GetParentPath()
                varies = self._transform_varies.get(parent_path)
                if varies is None:
                    varies = self.transform_might_vary(prim.GetParent(), parent_path)
            if any(name.startswith("xformOp") for name in self.authored(prim, path)):
                xformable = UsdGeom.Xformable(prim)  # and xformOpOrder
                if xformable:
                    if xformable.TransformMightBeTimeVarying():
                        varies = True
                    elif xformable.GetResetXformStack():
                        varies = False
            self._transform_varies[path] = varies
        return varies

    def inherited_primvars(self, prim: Usd.Prim, path: Sdf.Path) -> tuple[UsdGeom.Primvar, ...]:
        """The constant primvars ``prim`` inherits from its ancestors (not its own)."""
        if path.pathElementCount <= 1:
            return ()
        parent_path = path.GetParentPath()
        primvars = self._primvars.get(parent_path)
        if primvars is None:
            parent = prim.GetParent()
            primvars = self.inherited_primvars(parent, parent_path)
            if any(name.startswith("primvars:") for name in self.authored(parent, parent_path)):
                api = UsdGeom.PrimvarsAPI(parent)
                found = api.FindIncrementallyInheritablePrimvars(list(primvars))
                primvars = tuple(found) or primvars  # none: the parent adds nothing
            self._primvars[parent_path] = primvars
        return primvars

    def state(self, prim: Usd.Prim, path: Sdf.Path) -> Inherited:
        """The inherited state of ``prim`` (at ``path``). Its ``bindings`` says whether a
        material may be bound to it: only a binding authored on it or on an ancestor binds one
        (UsdShadeMaterialBindingAPI), so without any it has none."""
        state = self._states.get(path)
        if state is not None:
            return state
        if path.pathElementCount <= 1:
            up = _ROOT
        else:
            parent_path = path.GetParentPath()
            up = self._states.get(parent_path) or self.state(prim.GetParent(), parent_path)
        authored = self.authored(prim, path)
        # Prims that are not imageable pass purpose and visibility down but have none of their own.
        opinions = (_PURPOSE in authored or _VISIBILITY in authored) and prim.IsA(UsdGeom.Imageable)
        purpose, inheritable = up.purpose, up.purpose_inheritable
        if opinions and _PURPOSE in authored:  # its own opinion wins over an ancestor's
            attr = prim.GetAttribute(_PURPOSE)
            if attr.HasAuthoredValue():
                purpose, inheritable = attr.Get(), True
        visibility_varies = up.visibility_might_vary or (
            opinions
            and _VISIBILITY in authored
            and prim.GetAttribute(_VISIBILITY).ValueMightBeTimeVarying()
        )
        bindings = up.bindings or _binds(authored)
        hideable = up.hideable or (opinions and _VISIBILITY in authored)
        if opinions or up.imageable_opinions or bindings != up.bindings:
            state = Inherited(
                purpose, inheritable, visibility_varies, opinions, bindings, hideable
            )
        else:
            state = up  # the same in every field: most prims
        self._states[path] = state
        return state
