"""Grouped copies of instanced meshes → hidden mesh rprims and instancer rprims.

:class:`InstancedMeshes` pushes the copies :mod:`.flattening` found, grouped by mesh and bound
materials (the mesh's and its GeomSubsets', :class:`Group`), to the delegate and, on later
updates, only what changed (new or edited meshes, changed transforms): every group is one hidden
mesh rprim (its geometry read once, from the prim that holds it) and one instancer rprim naming
it as its prototype, so that Embree shares the mesh's BVH among all copies.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from pxr import Sdf, Usd, UsdGeom

from .flattening import Leaf, user_facing_path
from .curves import sync_curves_data
from .mesh import sync_mesh_data
from .points import sync_points_data
from .render_pass import HIDING_RAYS, SHOWN, PassVisibility, set_pass_visibility
from .sampling import SampleReader, Shutter
from .subset_bindings import bound_faces, read_subset_faces, warn_subset_bindings

class MaterialSource(Protocol):
    """Where instanced meshes get their material sprims (reference-counted by user id)."""

    def acquire(self, material: Sdf.Path, user: str) -> None: ...

    def release(self, material: Sdf.Path, user: str) -> None: ...

    def material_id(self, material: Sdf.Path) -> str:
        """The delegate id of the material, "" when it cannot be used."""
        ...


@dataclass
class Group:
    """All copies of one mesh rendered with one material (and one per material subset)."""

    mesh: Usd.Prim
    material: Sdf.Path | None
    # The materials of the mesh's material subsets (subset_bindings.material_subsets' order).
    subset_materials: tuple[Sdf.Path | None, ...] = ()
    transforms: list[np.ndarray] = field(default_factory=list)  # (N_i, K_i, 4, 4) each
    primvars: list[dict[str, np.ndarray]] = field(default_factory=list)  # N_i rows each
    names: list[str] = field(default_factory=list)  # each copy's Cryptomatte object name
    # Linking classes (linking.py), N_i each; None: those copies are linked to every light.
    linking: list[np.ndarray | None] = field(default_factory=list)

    def stacked(self) -> np.ndarray:
        """(N, 4, 4) for static copies, else (N, K, 4, 4) with static ones held over K."""
        samples = max(t.shape[1] for t in self.transforms)
        parts = [t if t.shape[1] == samples else t.repeat(samples, axis=1) for t in self.transforms]
        stacked = parts[0] if len(parts) == 1 else np.concatenate(parts)
        return np.ascontiguousarray(stacked[:, 0] if samples == 1 else stacked)

    def stacked_primvars(self) -> dict[str, np.ndarray]:
        """Per-copy primvars in the order of :meth:`stacked`; copies without a primvar others
        have get NaN, which tells the delegate to use the mesh's own value for them."""
        widths = {name: values.shape[1:] for part in self.primvars for name, values in part.items()}
        stacked = {}
        for name in sorted(widths):
            rows = [
                part.get(name, np.full((len(transforms),) + widths[name], np.nan, np.float32))
                for part, transforms in zip(self.primvars, self.transforms)
            ]
            stacked[name] = np.ascontiguousarray(np.concatenate(rows), dtype=np.float32)
        return stacked

    def stacked_linking(self) -> np.ndarray | None:
        """Linking classes in the order of :meth:`stacked`; None when every copy is linked to
        every light."""
        if all(classes is None for classes in self.linking):
            return None
        return np.concatenate(
            [
                np.zeros(len(transforms), np.uint32) if classes is None else classes
                for classes, transforms in zip(self.linking, self.transforms)
            ]
        )


GroupKey = tuple[Sdf.Path, Sdf.Path | None, PassVisibility, tuple[Sdf.Path | None, ...]]
"""(mesh, bound material, how the render pass shows the copies, its subsets' materials)."""


def materials_of(key: GroupKey) -> set[Sdf.Path]:
    """The materials a group's copies use: the mesh's and its subsets'."""
    return {key[1], *key[3]} - {None}


def group_leaves(
    groups: dict[GroupKey, Group],
    leaf: Leaf,
    material: Sdf.Path | None,
    transforms: np.ndarray,
    primvars: dict[str, np.ndarray],
    shown: PassVisibility = SHOWN,
    names: list[str] | None = None,
    linking: np.ndarray | None = None,
    subset_materials: tuple[Sdf.Path | None, ...] = (),
) -> None:
    """Add ``transforms`` (copies of ``leaf``'s mesh bound to ``material``, with their per-copy
    ``primvars``, shown by the render pass as ``shown``, of linking classes ``linking``, None:
    linked to every light) to ``groups``. ``names``: each copy's Cryptomatte object name (by
    default the path of the leaf's mesh, ``leaf.proxy``); ``subset_materials``: the materials
    its material subsets bind."""
    key = (leaf.mesh.GetPath(), material, shown, subset_materials)
    group = groups.get(key)
    if group is None:
        group = groups[key] = Group(leaf.mesh, material, subset_materials)
    group.transforms.append(transforms)
    group.primvars.append(primvars)
    group.names += names if names is not None else [str(leaf.proxy)] * len(transforms)
    group.linking.append(linking)


@dataclass
class _Pushed:
    name: str  # what its ids end with (see _id_tail)
    mesh_id: str
    instancer_id: str
    material_id: str | None = None  # None: not sent yet
    subset_ids: tuple[str, ...] = ()  # the material ids of the subsets sent (none at first)
    subset_names: list[str] = field(default_factory=list)  # their Cryptomatte material names
    subset_faces: list[np.ndarray | None] = field(default_factory=list)  # read_subset_faces
    subset_faces_read: bool = False  # read since last sent
    digest: bytes | None = None  # of the copies' transforms last sent (None: not sent)
    linked: bool = False  # linking classes were sent for its copies
    varying: bool = False  # the mesh's data might change with time
    usable: bool = True  # False when the mesh could not be read (no instancer then)
    names: list[str] = field(default_factory=list)  # the copies' Cryptomatte object names


class InstancedMeshes:
    """Hidden mesh + instancer rprims for groups of copies, updated by difference: a mesh is
    re-read only when new, edited or time-varying; copies are re-sent only when they moved."""

    def __init__(
        self,
        core,
        warn: Callable[[str], None],
        materials: MaterialSource,
        prefix: str = "",
    ):
        self.core = core
        self.warn = warn
        self.materials = materials
        self.prefix = prefix
        self._pushed: dict[GroupKey, _Pushed] = {}

    @property
    def varying(self) -> bool:
        """Whether any pushed mesh's data might change with time."""
        return any(p.varying for p in self._pushed.values())

    def ids(self) -> Iterator[str]:
        for pushed in self._pushed.values():
            yield pushed.mesh_id
            yield pushed.instancer_id

    def subset_names(self) -> Iterator[tuple[str, list[str]]]:
        """``(mesh id, Cryptomatte material name of each subset sent)`` of every hidden mesh
        with subset bindings."""
        for pushed in self._pushed.values():
            if pushed.usable and pushed.subset_names:
                yield pushed.mesh_id, pushed.subset_names

    def copies(self) -> Iterator[tuple[str, Sdf.Path | None, list[str]]]:
        """``(instancer id, bound material, Cryptomatte object name of each copy)`` of every
        instancer placing copies."""
        for (_, material, _, _), pushed in self._pushed.items():
            if pushed.usable and pushed.names:
                yield pushed.instancer_id, material, pushed.names

    def update(
        self,
        groups: dict[GroupKey, Group],
        shutter: Shutter,
        stale: Iterable[Sdf.Path] = (),
        time_changed: bool = False,
    ) -> None:
        """Make the delegate hold exactly ``groups``; meshes below any ``stale`` path (and
        time-varying ones when ``time_changed``) are read again."""
        stale = list(stale)
        # Named and ordered by user-facing paths: USD numbers its prototypes in no fixed order.
        names = {key: (user_facing_path(group.mesh), *key[1:]) for key, group in groups.items()}
        ids = {key: _id_tail(*name) for key, name in names.items()}
        for key in [k for k, p in self._pushed.items() if ids.get(k) != p.name]:
            self._remove(key)  # gone, or renamed (another instance became the first)
        for key in sorted(groups, key=lambda k: str(names[k])):
            group = groups[key]
            pushed = self._pushed.get(key)
            if pushed is None:
                pushed = self._pushed[key] = self._insert(key, ids[key], group, shutter)
            elif (time_changed and pushed.varying) or any(
                key[0].HasPrefix(p) or p.HasPrefix(key[0]) for p in stale  # its subsets too
            ):
                self._read_mesh(pushed, group, shutter)
            if not pushed.usable:
                continue
            material_id = self.materials.material_id(key[1]) if key[1] else ""
            if material_id != pushed.material_id:
                self.core.set_mesh_material(pushed.mesh_id, material_id)
                pushed.material_id = material_id
            subsets = bound_faces(key[3], pushed.subset_faces)
            subset_ids = tuple(self.materials.material_id(m) for m, _ in subsets)
            if subset_ids != pushed.subset_ids or (subsets and pushed.subset_faces_read):
                self.core.set_subset_materials(
                    pushed.mesh_id, [(i, f) for i, (_, f) in zip(subset_ids, subsets)]
                )
                pushed.subset_ids = subset_ids
                pushed.subset_names = [str(material) for material, _ in subsets]
            pushed.subset_faces_read = False
            transforms = group.stacked()
            primvars = group.stacked_primvars()
            linking = group.stacked_linking()
            arrays = (*primvars.values(), *(() if linking is None else (linking,)))
            digest = _digest(transforms, *arrays) + str(sorted(primvars)).encode()
            if digest != pushed.digest:
                self.core.set_instances(pushed.instancer_id, pushed.mesh_id, transforms)
                self.core.set_instance_primvars(pushed.instancer_id, primvars)
                if linking is not None or pushed.linked:
                    self.core.set_instance_linking_classes(
                        pushed.instancer_id, np.zeros(0, np.uint32) if linking is None else linking
                    )
                    pushed.linked = linking is not None
                pushed.digest = digest
            pushed.names = group.names

    def clear(self) -> None:
        for key in list(self._pushed):
            self._remove(key)

    def _insert(self, key: GroupKey, name: str, group: Group, shutter: Shutter) -> _Pushed:
        shown = key[2]
        pushed = _Pushed(
            name=name,
            mesh_id=f"{self.prefix}/prototypes{name}",
            instancer_id=f"{self.prefix}/instances{name}",
        )
        for material in sorted(materials_of(key)):
            self.materials.acquire(material, pushed.mesh_id)
        self.core.insert_rprim(_rprim_type(group.mesh), pushed.mesh_id)
        self.core.insert_rprim("instancer", pushed.instancer_id)
        if shown != SHOWN:
            set_pass_visibility(self.core, pushed.instancer_id, shown)
        self._read_mesh(pushed, group, shutter)
        return pushed

    def _read_mesh(self, pushed: _Pushed, group: Group, shutter: Shutter) -> None:
        reader = SampleReader(shutter.frame, shutter)
        name = str(user_facing_path(group.mesh))

        def warn(message: str) -> None:  # name the prim the user knows, not the hidden id
            self.warn(message.replace(pushed.mesh_id, name))

        rprim_type = _rprim_type(group.mesh)
        pushed.usable = _READERS[rprim_type](self.core, group.mesh, reader, warn, pushed.mesh_id)
        faces_vary = False
        if rprim_type == "mesh" and group.mesh.GetTypeName() != "Mesh":
            warn_subset_bindings(group.mesh, name, self.warn)
        if group.subset_materials and pushed.usable:
            pushed.subset_faces, faces_vary = read_subset_faces(group.mesh, shutter.frame, warn)
            pushed.subset_faces_read = True
        pushed.varying = reader.varying or faces_vary
        self.core.set_visible(pushed.mesh_id, False)  # only its copies render
        if not pushed.usable:  # no copies of an unreadable mesh
            self.core.set_instances(pushed.instancer_id, pushed.mesh_id, np.empty((0, 4, 4)))
            self.core.set_instance_primvars(pushed.instancer_id, {})
            pushed.digest = None
            pushed.names = []
        pushed.material_id = None  # re-sent with the mesh

    def _remove(self, key: GroupKey) -> None:
        pushed = self._pushed.pop(key)
        self.core.remove_prim(pushed.instancer_id)  # copies before their prototype
        self.core.remove_prim(pushed.mesh_id)
        for material in sorted(materials_of(key)):
            self.materials.release(material, pushed.mesh_id)


_READERS = {"mesh": sync_mesh_data, "points": sync_points_data, "basisCurves": sync_curves_data}


def _rprim_type(prim: Usd.Prim) -> str:
    """The rprim type copies of ``prim`` share: points, curves, or a mesh (meshes and implicit
    surfaces)."""
    if prim.IsA(UsdGeom.Points):
        return "points"
    return "basisCurves" if prim.IsA(UsdGeom.Curves) else "mesh"


def _id_tail(
    mesh: Sdf.Path,
    material: Sdf.Path | None,
    shown: PassVisibility,
    subset_materials: tuple[Sdf.Path | None, ...],
) -> str:
    """What names a group's hidden mesh and instancer: the path of the ``mesh`` users know, and
    what sets the group apart."""
    suffix = f"/materials{material}" if material else ""
    if subset_materials:  # "_" for a subset without one: material paths are absolute
        suffix += "/subsetMaterials" + "".join(str(m) if m else "/_" for m in subset_materials)
    if shown != SHOWN:  # copies the render pass shows otherwise are an instancer of their own
        suffix += f"/pass{'' if shown.camera else '/cameraHidden'}{'/matte' if shown.matte else ''}"
        suffix += "".join(f"/{rays}Hidden" for rays in HIDING_RAYS if not getattr(shown, rays))
    return f"{mesh}{suffix}"


def _digest(*arrays: np.ndarray) -> bytes:
    """A fingerprint of copies' transforms (and primvars): cheaper to keep than a million
    matrices."""
    hasher = hashlib.blake2b(digest_size=16)
    for array in arrays:
        hasher.update(memoryview(np.ascontiguousarray(array)))
        hasher.update(bytes(str(array.shape), "ascii"))
    return hasher.digest()
