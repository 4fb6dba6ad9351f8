"""The materials bound to rendered meshes, reference-counted by their users.

One registry serves the scene delegate's meshes and the hidden meshes of native and point
instancing: a material enters the delegate when its first user acquires it and leaves with its
last; edits of the prims it was read from, and new frames when it varies, re-read it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from pxr import Sdf, Usd, UsdShade

from .material import push_material, read_material
from .sampling import SampleReader


@dataclass
class _Material:
    """A material used by at least one mesh."""

    users: set[Sdf.Path]
    sources: set[Sdf.Path]
    in_core: bool = False  # False when the material is unusable (not UsdPreviewSurface)
    varying: bool = False


class MaterialRegistry:
    """The materials of ``stage`` in ``core``, read at the frame set by :meth:`at`; users are
    mesh paths or the delegate ids of hidden meshes."""

    def __init__(self, stage: Usd.Stage, core, warn: Callable[[str], None]):
        self.stage = stage
        self.core = core
        self.warn = warn
        self._time: Usd.TimeCode | None = None
        self._materials: dict[Sdf.Path, _Material] = {}
        self._dirty: set[Sdf.Path] = set()

    def at(self, frame: Usd.TimeCode) -> None:
        """Read materials at ``frame`` from now on; the time-varying ones are read again."""
        if frame != self._time:
            self._dirty.update(path for path, material in self._materials.items() if material.varying)
            self._time = frame

    def acquire(self, material_path: Sdf.Path, user: Sdf.Path | str) -> None:
        """Note ``user`` of the material, reading it into the delegate if it is new."""
        material = self._materials.get(material_path)
        if material is None:
            material = self._materials[material_path] = _Material(users=set(), sources=set())
            self._read(material_path, material)
        material.users.add(Sdf.Path(user) if isinstance(user, str) else user)

    def release(self, material_path: Sdf.Path, user: Sdf.Path | str) -> None:
        """Forget ``user`` of the material, which leaves the delegate with its last user."""
        material = self._materials.get(material_path)
        if material is None:
            return
        material.users.discard(Sdf.Path(user) if isinstance(user, str) else user)
        if not material.users:
            del self._materials[material_path]
            self._dirty.discard(material_path)
            if material.in_core:
                self.core.remove_prim(str(material_path))

    def bind(self, user: Sdf.Path, old: str, new: Sdf.Path | None) -> str:
        """Move ``user`` from material ``old`` (its id, "" for none) to ``new`` (``None``:
        unbound), acquiring and releasing as needed; returns the delegate id of ``new`` ("" when
        there is none or it cannot be used)."""
        previous = Sdf.Path(old) if old else None
        if new != previous:
            if previous is not None:
                self.release(previous, user)
            if new is not None:
                self.acquire(new, user)
        return "" if new is None else self.material_id(new)

    def use(self, user: Sdf.Path, old: set[Sdf.Path], new: set[Sdf.Path]) -> None:
        """Move ``user`` from the materials ``old`` to ``new`` (a mesh's own and its subsets'),
        acquiring those it starts to use before releasing those it no longer does."""
        for material_path in sorted(new - old):
            self.acquire(material_path, user)
        for material_path in sorted(old - new):
            self.release(material_path, user)

    def material_id(self, material_path: Sdf.Path) -> str:
        """The delegate id of the material, "" when it cannot be used."""
        material = self._materials.get(material_path)
        return str(material_path) if material is not None and material.in_core else ""

    def note_edited(self, prim_path: Sdf.Path) -> None:
        """Read again the materials read from ``prim_path``."""
        for material_path, material in self._materials.items():
            if prim_path in material.sources:
                self._dirty.add(material_path)

    def note_resynced(self, root: Sdf.Path) -> list[Sdf.Path]:
        """Read again the materials at or read from below ``root``; returns their users, whose
        bindings must be resolved again."""
        users = []
        for material_path, material in self._materials.items():
            if material_path.HasPrefix(root) or any(s.HasPrefix(root) for s in material.sources):
                self._dirty.add(material_path)
                users.extend(material.users)
        return users

    @property
    def dirty(self) -> bool:
        """Whether some material is to be read again."""
        return bool(self._dirty)

    def sync(self) -> list[Sdf.Path]:
        """Read again the materials noted; returns the users of those that became usable or
        unusable (their meshes must be bound again)."""
        materials, self._dirty = self._dirty, set()
        rebind: list[Sdf.Path] = []
        for path in sorted(materials):
            material = self._materials.get(path)
            if material is None:
                continue
            was_in_core = material.in_core
            self._read(path, material)
            if material.in_core != was_in_core:
                rebind.extend(material.users)
        return rebind

    def _read(self, material_path: Sdf.Path, material: _Material) -> None:
        """Read the material and insert, update or remove it in the delegate."""
        prim = self.stage.GetPrimAtPath(material_path)
        reader = SampleReader(self._time)
        data = None
        if prim and prim.IsA(UsdShade.Material):
            data = read_material(prim, reader, self.warn)
        material.varying = reader.varying
        path_str = str(material_path)
        if data is None:
            material.sources = {material_path}
            if material.in_core:
                self.core.remove_prim(path_str)
                material.in_core = False
            return
        material.sources = data.sources
        if not material.in_core:
            self.core.insert_sprim("material", path_str)
            material.in_core = True
        push_material(self.core, path_str, data, self.warn)
