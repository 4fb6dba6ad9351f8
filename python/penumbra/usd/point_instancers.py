"""UsdGeomPointInstancer → the render delegate's instancer rprims.

:class:`PointInstancerDelegate` mirrors the point instancers that are not inside native
prototypes (those are flattened with their prototype, see :mod:`.native_instancing`); an edit
under an instancer, its prototypes or the materials they use re-flattens that instancer
(:mod:`.flattening`), and :mod:`.instanced_meshes` pushes what differs (meshes, points and
curves alike), :mod:`.instanced_lights` the lights of its prototypes, a light per copy.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field

from pxr import Sdf, Usd, UsdGeom

from .flattening import Flattener, LightCopies, prototype_roots, combine_segments
from .inherited import InheritedState
from .instanced_lights import InstancedLights
from .instanced_meshes import (
    Group,
    GroupKey,
    InstancedMeshes,
    MaterialSource,
    group_leaves,
    materials_of,
)
from .linking import Linking
from .material import bound_material
from .render_pass import SHOWN, RenderPassCollections
from .sampling import Shutter, visibility_might_vary
from .subset_bindings import copies_subset_materials

@dataclass
class _Instancer:
    """What one point instancer put in the delegate, and what it depends on."""

    meshes: InstancedMeshes
    lights: InstancedLights
    roots: set[Sdf.Path] = field(default_factory=set)  # edits below these re-flatten it
    varying: bool = False
    dirty: bool = True
    # Its prototypes hold lights, shown or not (rendered, or skipped: Flattener.lights): the
    # stage then has lights of its own, as hidden lights placed by hand make it.
    holds_lights: bool = False

    def clear(self) -> None:
        self.meshes.clear()
        self.lights.clear()


class PointInstancerDelegate:
    """Mirrors the point instancers of ``stage`` (outside native prototypes) into ``core``;
    hears of stage edits through :meth:`note_changes` (from the scene delegate's listener)."""

    def __init__(
        self,
        stage: Usd.Stage,
        core,
        purposes: Iterable[str],
        warn: Callable[[str], None],
        materials: MaterialSource,
        render_pass: RenderPassCollections | None = None,
        linking: Linking | None = None,
    ):
        self.stage = stage
        self.core = core
        self.render_pass = render_pass
        self.linking = linking
        self.materials = materials  # the scene delegate's registry
        self.purposes = frozenset(purposes) | {UsdGeom.Tokens.default_}
        self.warn = warn
        self.shutter: Shutter | None = None
        self._instancers: dict[Sdf.Path, _Instancer] = {}
        self._structure_changed = True  # prims were added or removed: look for instancers
        self._stale: set[Sdf.Path] = set()  # edited prims (their meshes are read again)

    def note_changes(self, resynced: Iterable[Sdf.Path], changed: Iterable[Sdf.Path]) -> None:
        """Note stage edits (paths of ``Usd.Notice.ObjectsChanged``) for the next update."""
        resynced = list(resynced)
        if any(not path.IsPropertyPath() for path in resynced):
            self._structure_changed = True
        for path in [*resynced, *changed]:
            prim_path = path.GetPrimPath()
            self._stale.add(prim_path)
            # A binding, or a collection a collection-based binding may name.
            binding = path.IsPropertyPath() and path.name.startswith(
                ("material:binding", "collection:")
            )
            for record in self._instancers.values():
                if binding or any(
                    prim_path.HasPrefix(root) or root.HasPrefix(prim_path) for root in record.roots
                ):
                    record.dirty = True

    def relink(self) -> None:
        """Classify every copy again at the next update (the lights' links changed)."""
        for record in self._instancers.values():
            record.dirty = True

    def update(self, shutter: Shutter) -> None:
        """Re-flatten the point instancers whose inputs changed (or, at a new frame or shutter,
        might vary with time) and push what differs."""
        time_changed = shutter != self.shutter
        self.shutter = shutter
        if self._structure_changed:
            self._structure_changed = False
            found = set(self._find())
            for path in [p for p in self._instancers if p not in found]:
                self._instancers.pop(path).clear()
            for path in found:
                if path not in self._instancers:
                    self._instancers[path] = self._new_record(path)
                self._instancers[path].dirty = True
        stale, self._stale = self._stale, set()
        for path, record in self._instancers.items():
            if record.dirty or (time_changed and record.varying):
                self._sync(self.stage.GetPrimAtPath(path), record, stale, time_changed)

    def has_lights(self) -> bool:
        """Whether the prototypes of a point instancer hold lights: shown or hidden, rendered
        or skipped, they make the stage one with lights of its own (no default light), as
        lights placed by hand do."""
        return any(record.holds_lights for record in self._instancers.values())

    def copies(self) -> Iterator[tuple[str, Sdf.Path | None, list[str]]]:
        """``(instancer id, bound material, Cryptomatte object names)`` of every instancer rprim
        placing copies (see :meth:`InstancedMeshes.copies`)."""
        for record in self._instancers.values():
            yield from record.meshes.copies()

    def subset_names(self) -> Iterator[tuple[str, list[str]]]:
        """See :meth:`InstancedMeshes.subset_names`."""
        for record in self._instancers.values():
            yield from record.meshes.subset_names()

    def _find(self) -> Iterator[Sdf.Path]:
        """Point instancers outside native prototypes and outside other instancers' prototypes
        (those are flattened into their outer instancer)."""
        walk = iter(Usd.PrimRange(self.stage.GetPseudoRoot(), Usd.PrimDefaultPredicate))
        for prim in walk:
            if prim.IsA(UsdGeom.PointInstancer):
                walk.PruneChildren()
                yield prim.GetPath()

    def _new_record(self, path: Sdf.Path) -> _Instancer:
        return _Instancer(
            InstancedMeshes(self.core, self.warn, self.materials, str(path)),
            InstancedLights(self.core, self.warn, str(path)),
        )

    def _sync(self, prim: Usd.Prim, record: _Instancer, stale: set[Sdf.Path], time_changed: bool) -> None:
        flattener = Flattener(self.stage, self.shutter, self.warn)
        lights: list[LightCopies] = []
        groups = self._groups(prim, flattener, lights)
        record.meshes.update(groups, self.shutter, stale, time_changed)
        record.lights.update(lights, self.shutter, stale, time_changed)
        # A material edit may make it usable or not: the copies then change material.
        materials = set().union(*map(materials_of, groups))
        record.roots = {prim.GetPath(), *flattener.roots, *materials}
        record.varying = flattener.varying or record.meshes.varying or record.lights.varying
        record.holds_lights = bool(flattener.lights) or any(
            flattener.lights_below(root) for root in prototype_roots(prim)
        )
        record.dirty = False

    def _groups(
        self, prim: Usd.Prim, flattener: Flattener, lights: list[LightCopies]
    ) -> dict[GroupKey, Group]:
        """The copies of the meshes in ``prim``'s prototypes, grouped; the copies of their
        lights are appended to ``lights``."""
        imageable = UsdGeom.Imageable(prim)
        purpose = imageable.ComputePurpose()
        if visibility_might_vary(prim):  # its own or an ancestor's
            flattener.varying = True
        if imageable.ComputeVisibility(self.shutter.frame) == UsdGeom.Tokens.invisible:
            return {}
        shown = SHOWN
        if self.render_pass is not None:
            if not self.render_pass.rendered(prim.GetPath()):
                return {}
            shown = self.render_pass.visibility(prim.GetPath())
        limit = self.shutter.max_segments
        segments = combine_segments(
            flattener.motion_segments(prim), flattener.point_instancer_segments(prim), limit
        )
        for prototype in prototype_roots(prim):
            segments = combine_segments(segments, flattener.content_segments(prototype), limit)
        groups: dict[GroupKey, Group] = {}
        materials: dict[Sdf.Path, Sdf.Path | None] = {}
        subsets: dict[Sdf.Path, tuple[Sdf.Path | None, ...]] = {}
        # Ray visibility: the instancer's and its ancestors', nearer in a prototype.
        inherited = InheritedState(self.warn)
        inherited.at(self.shutter.frame)
        leaves = flattener.point_instancer_leaves(
            prim, self.stage.GetPseudoRoot(), segments, lights
        )
        for leaf in leaves:
            if (leaf.purpose or purpose) not in self.purposes:
                continue
            proxy = self.stage.GetPrimAtPath(leaf.proxy)
            if leaf.proxy not in materials:
                material = bound_material(proxy)
                materials[leaf.proxy] = material.GetPath() if material else None
                subsets[leaf.proxy] = copies_subset_materials([leaf.mesh], [proxy])[0]
            leaf_shown = inherited.ray_visibility(proxy, leaf.proxy).shown(shown)
            # Copies are linked as their prototype is, by its path (below the instancer's).
            linking = (
                self.linking.classes_of(leaf.proxy, len(leaf.transforms))
                if self.linking is not None
                else None
            )
            group_leaves(
                groups,
                leaf,
                materials[leaf.proxy],
                leaf.transforms,
                leaf.primvars,
                leaf_shown,
                linking=linking,
                subset_materials=subsets[leaf.proxy],
            )
        return groups
