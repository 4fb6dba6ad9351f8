"""Which prims the scene delegate renders, and as what kind of delegate prim.

Like UsdImaging's prim adapters, found by type name: cameras, lights (their sprim type), meshes
(meshes, implicit surfaces, NURBS patches and tet meshes), points, curves (BasisCurves,
NurbsCurves and HermiteCurves, the delegate's "basisCurves"), volumes (UsdVolVolume; those in
native instances and point-instancer prototypes are skipped with a warning by
:mod:`.flattening`), and what is not supported yet (other gprims, e.g. particle fields),
reported once per update naming a prim.
"""

from __future__ import annotations

from collections.abc import Iterator

from pxr import Sdf, Usd, UsdGeom, UsdVol

from ..errors import warn
from .mesh import reads_as_mesh
from .inherited import Inherited, InheritedState
from .lights import is_light, light_type

CURVES = "basisCurves"
"""The delegate's rprim type of every UsdGeomCurves (NURBS and Hermite curves converted)."""
VOLUME = "volume"
"""The delegate's rprim type of UsdVolVolumes."""


class Classifier:
    """Decides the kind of each prim: ``purposes`` are those rendered; ``inherited`` the stage's
    inherited state (purpose, bindings), shared with the delegate."""

    def __init__(self, purposes: frozenset[str], inherited: InheritedState):
        self.purposes = purposes
        self._inherited = inherited
        self._roles: dict[str, str | None] = {}
        self._unsupported: dict[str, list[Sdf.Path]] = {}

    def classify(self, prim: Usd.Prim, path: Sdf.Path) -> tuple[str | None, Inherited | None]:
        """The delegate prim type for ``prim`` (at ``path``), or ``None`` when it is not
        rendered; with its inherited state when it is a mesh, points, curves or a volume."""
        role = self._role_of_type(prim)
        if role in ("mesh", "points", CURVES, VOLUME, "unsupported"):
            if role != "unsupported" and prim.IsInstanceProxy():
                return None, None  # natively instanced: NativeInstancing
            state = self._inherited.state(prim, path)
            if state.purpose not in self.purposes:
                return None, None
            if role != "unsupported":
                return role, state
        elif role is not None:
            return role, None  # a camera or a light
        if role == "unsupported" or is_light(prim):
            if role is not None or self._inherited.purpose(prim, path) in self.purposes:
                type_name = prim.GetTypeName() or "untyped"
                self._unsupported.setdefault(type_name, []).append(path)
        return None, None

    def traverse(
        self, root: Usd.Prim
    ) -> Iterator[tuple[Sdf.Path, str, Usd.Prim, Inherited | None]]:
        """``(path, kind, prim, inherited state of a gprim)`` of the prims to render under
        ``root`` (instance proxies included; prototypes below a PointInstancer are not rendered
        on their own)."""
        if not root or any(p.IsA(UsdGeom.PointInstancer) for p in _ancestors(root)):
            return
        it = iter(Usd.PrimRange(root, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
        for prim in it:
            path = prim.GetPath()
            kind, state = self.classify(prim, path)
            if kind is not None:
                yield path, kind, prim, state
            elif prim.IsA(UsdGeom.PointInstancer):  # not a rendered kind itself
                it.PruneChildren()

    def report_unsupported(self) -> None:
        """Warn of the prims found unsupported since the last report, one warning a type."""
        for type_name, paths in sorted(self._unsupported.items()):
            count = len(paths)
            noun = "prim" if count == 1 else "prims"
            warn(f"{count} {type_name} {noun} not supported yet, skipped (first: {min(paths)})")
        self._unsupported.clear()

    def _role_of_type(self, prim: Usd.Prim) -> str | None:
        """What prims of ``prim``'s type are (as UsdImaging finds its prim adapters by type
        name): "camera", a light type, "mesh" (meshes, implicit surfaces, NURBS patches and tet
        meshes), "points", "basisCurves" (every UsdGeomCurves), "volume", "unsupported" (other
        gprims) or ``None``; decided once per type name by its schema."""
        type_name = prim.GetTypeName()
        if type_name in self._roles:
            return self._roles[type_name]
        role: str | None = None
        if prim.IsA(UsdGeom.Camera):
            role = "camera"
        elif (sprim_type := light_type(prim)) is not None:
            role = sprim_type
        elif reads_as_mesh(prim):  # meshes, implicit surfaces, NURBS patches, tet meshes
            role = "mesh"
        elif prim.IsA(UsdGeom.Points):
            role = "points"
        elif prim.IsA(UsdGeom.Curves):
            role = CURVES
        elif prim.IsA(UsdVol.Volume):
            role = VOLUME
        elif prim.IsA(UsdGeom.Gprim):
            role = "unsupported"  # point instancers: PointInstancerDelegate
        self._roles[type_name] = role
        return role


def _ancestors(prim: Usd.Prim) -> Iterator[Usd.Prim]:
    prim = prim.GetParent()
    while prim and not prim.IsPseudoRoot():
        yield prim
        prim = prim.GetParent()
