"""Per-object ray visibility and holdout (docs/ray-visibility.md).

``primvars:penumbra:visibility:camera``, ``:shadow``, ``:diffuse``, ``:glossy`` and
``:transmission`` say which rays see an object, ``primvars:penumbra:holdout`` makes it a holdout
for camera rays. Each is a constant bool primvar, inherited as constant primvars are: authored
on an ancestor it applies to the descendants, and the nearest authored value wins. A value that
is not a constant bool is ignored with one warning naming the prim and the attribute.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache
from typing import TYPE_CHECKING, Callable

from pxr import Sdf, Usd, UsdGeom

from .render_pass import SHOWN, PassVisibility, RenderPassCollections, set_pass_visibility

if TYPE_CHECKING:
    from .inherited import InheritedState

_PREFIX = "primvars:penumbra:"
_VISIBILITY = _PREFIX + "visibility:"
HOLDOUT = _PREFIX + "holdout"
RAY_KINDS = ("camera", "shadow", "diffuse", "glossy", "transmission")
ATTRIBUTES = tuple(_VISIBILITY + kind for kind in RAY_KINDS) + (HOLDOUT,)
_FIELDS = dict(zip(ATTRIBUTES, RAY_KINDS + ("holdout",)))
PRIMVAR_NAMES = frozenset(name.removeprefix("primvars:") for name in ATTRIBUTES)
"""The primvars' names as UsdGeom.Primvar.GetPrimvarName gives them."""


@dataclass(frozen=True)
class RayVisibility:
    """Which rays see an object (all by default), and whether it is a holdout."""

    camera: bool = True
    shadow: bool = True
    diffuse: bool = True
    glossy: bool = True
    transmission: bool = True
    holdout: bool = False

    def shown(self, passed: PassVisibility) -> PassVisibility:
        """The object as a render pass shows it (``passed``) and as it shows itself: hidden
        from the camera by either, a holdout by either."""
        if self is VISIBLE:
            return passed
        return PassVisibility(
            camera=passed.camera and self.camera,
            matte=passed.matte or self.holdout,
            shadow=self.shadow,
            diffuse=self.diffuse,
            glossy=self.glossy,
            transmission=self.transmission,
        )


VISIBLE = RayVisibility()
"""An object that authors nothing of its ray visibility, nor inherits anything."""


@lru_cache(maxsize=256)  # prims of a kind share one set of names
def _ray_visibility_names(names: frozenset[str]) -> tuple[str, ...]:
    """Those of properties ``names`` that set ray visibility or holdout."""
    return tuple(name for name in ATTRIBUTES if name in names)


def authored_value(prim: Usd.Prim, name: str, time: Usd.TimeCode, warn: Callable[[str], None]):
    """The bool ``prim`` authors in primvar ``name`` at ``time``; None when it authors no value
    or one that is not a constant bool (then with a warning)."""
    primvar = UsdGeom.Primvar(prim.GetAttribute(name))
    if primvar.GetTypeName() != Sdf.ValueTypeNames.Bool:
        warn(f"{prim.GetPath()}: {name} has type {primvar.GetTypeName()}, not bool; it is ignored")
        return None
    if primvar.GetInterpolation() != UsdGeom.Tokens.constant:
        warn(
            f"{prim.GetPath()}: {name} has {primvar.GetInterpolation()} interpolation, not "
            "constant; it is ignored"
        )
        return None
    value = primvar.Get(time)
    return None if value is None else bool(value)


def authored_ray_visibility(
    prim: Usd.Prim, authored_names: frozenset[str], time: Usd.TimeCode, warn: Callable[[str], None]
) -> dict[str, bool]:
    """The fields of :class:`RayVisibility` that ``prim`` (whose authored property names are
    ``authored_names``) sets itself, by name."""
    found = {}
    for name in _ray_visibility_names(authored_names):
        value = authored_value(prim, name, time, warn)
        if value is not None:
            found[_FIELDS[name]] = value
    return found


def own_ray_visibility(
    inherited: RayVisibility,
    prim: Usd.Prim,
    authored_names: frozenset[str],
    time: Usd.TimeCode,
    warn: Callable[[str], None],
) -> RayVisibility:
    """The ray visibility of ``prim`` given what it ``inherited``: its own authored values
    override."""
    if not _ray_visibility_names(authored_names):
        return inherited
    own = authored_ray_visibility(prim, authored_names, time, warn)
    return replace(inherited, **own) if own else inherited


def authored_below(
    stage: Usd.Stage,
    root: Sdf.Path,
    path: Sdf.Path,
    time: Usd.TimeCode,
    warn: Callable[[str], None],
) -> dict[str, bool]:
    """The fields of :class:`RayVisibility` authored on the prims below ``root`` down to
    ``path`` (a USD prototype's mesh, say), the nearest winning: what its copies take over the
    ray visibility of the instance that places them."""
    found: dict[str, bool] = {}
    for prefix in path.GetPrefixes():
        if prefix != root and prefix.HasPrefix(root):
            prim = stage.GetPrimAtPath(prefix)
            found.update(
                authored_ray_visibility(
                    prim, frozenset(prim.GetAuthoredPropertyNames()), time, warn
                )
            )
    return found


class ShownSender:
    """Sends how objects show (their render pass's collections and their ray visibility) to the
    core's meshes, points and curves. What the core has already is not sent again: the default,
    shown to every ray, to an object never sent otherwise."""

    def __init__(
        self, core, render_pass: RenderPassCollections | None, inherited: InheritedState
    ) -> None:
        self._core = core
        self._render_pass = render_pass
        self._inherited = inherited
        self._shown_otherwise: set[Sdf.Path] = set()  # sent something other than SHOWN

    def send(self, prim_id: str, prim: Usd.Prim, path: Sdf.Path) -> None:
        passes = self._render_pass
        shown = passes.visibility(path) if passes is not None else SHOWN
        shown = self._inherited.ray_visibility(prim, path).shown(shown)
        if shown != SHOWN:
            self._shown_otherwise.add(path)
        elif path in self._shown_otherwise:
            self._shown_otherwise.discard(path)
        elif passes is None:
            return
        set_pass_visibility(self._core, prim_id, shown)
