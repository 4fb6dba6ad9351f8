"""Native USD instancing (instanceable prims sharing a prototype) → shared BVHs.

Instead of one mesh rprim per instance proxy, each mesh inside a USD prototype is synced once,
as a hidden mesh rprim read from the prototype prim, and one instancer rprim places it at every
instance: the instance root's world transform × the mesh's transform relative to the prototype
(motion-sampled over the shutter like any transform). Nested instancing — instanceable prims and
point instancers inside prototypes, and deeper — is flattened by
:class:`~penumbra.usd.flattening.Flattener` into the same instancers, sharing the innermost
mesh's BVH.

* Materials resolve on the instance proxy (bindings on an instance or its ancestors may differ
  between instances): copies are grouped by (prototype mesh, resolved material), and each group
  gets its own hidden mesh with that material.
* Visibility and purpose are inherited through the instance and the prims inside the prototype;
  invisible copies are dropped.
* Lights and cameras inside prototypes stay instance proxies of the scene delegate.

Top-level instances are instanceable prims outside prototypes and outside point instancers
(whose prototypes :class:`~penumbra.usd.point_instancers.PointInstancerDelegate` flattens). Any edit
that can change the placement, visibility, purpose or binding of copies — below a prototype,
on or above an instance, a binding anywhere, prims added or removed — re-flattens the instances
(cheap: transforms only); meshes are read again only when edited, or at a new shutter when
time-varying (see :class:`~penumbra.usd.instanced_meshes.InstancedMeshes`).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Iterable, Iterator
from dataclasses import replace

import numpy as np
from pxr import Sdf, Usd, UsdGeom

from .flattening import (
    Flattener,
    combine_segments,
    inherited_primvars,
    nest_primvars,
    outer_primvars,
)
from .inherited import InheritedState
from .instanced_meshes import Group, GroupKey, InstancedMeshes, MaterialSource, group_leaves
from .linking import Linking
from .material import bound_materials
from .subset_bindings import copies_subset_materials
from .ray_visibility import PRIMVAR_NAMES, VISIBLE, authored_below
from .render_pass import SHOWN, RenderPassCollections
from .sampling import SampleReader, Shutter, visibility_might_vary


class NativeInstancing:
    """Mirrors the native instances of ``stage`` into ``core`` as instancer rprims."""

    def __init__(
        self,
        stage: Usd.Stage,
        core,
        purposes: frozenset[str],
        warn: Callable[[str], None],
        materials: MaterialSource,
        render_pass: RenderPassCollections | None = None,
        linking: Linking | None = None,
    ):
        self.stage = stage
        self.purposes = purposes
        self.render_pass = render_pass
        self.linking = linking
        self.warn = warn
        self.meshes = InstancedMeshes(core, warn, materials)
        self.shutter: Shutter | None = None
        self._dirty = True
        self._varying = False
        self._skipped_lights = False
        self._stale: set[Sdf.Path] = set()  # edited prims: meshes below them are read again
        self._roots: set[Sdf.Path] = set()  # top-level instances last flattened
        self._above: set[Sdf.Path] = set()  # their ancestors

    def invalidate(self) -> None:
        """Re-flatten at the next update (e.g. a material became usable or unusable)."""
        self._dirty = True

    def note_changes(self, resynced: Iterable[Sdf.Path], changed: Iterable[Sdf.Path]) -> None:
        """Note stage edits (the paths of ``Usd.Notice.ObjectsChanged``)."""
        for path in (*resynced, *changed):
            prim_path = path.GetPrimPath()
            if self._affects_copies(path, prim_path):
                self._dirty = True
                self._stale.add(prim_path)

    def _affects_copies(self, path: Sdf.Path, prim_path: Sdf.Path) -> bool:
        if not path.IsPropertyPath() or path.name.startswith(("material:binding", "collection:")):
            # Prims added or removed, a binding that may reach instances, or a collection a
            # collection-based binding may name.
            return True
        if prim_path in self._roots or prim_path in self._above:
            return True
        prefixes = prim_path.GetPrefixes()
        if any(prefix in self._roots for prefix in prefixes):
            return True
        prototype = self.stage.GetPrimAtPath(prefixes[0]) if prefixes else None
        return bool(prototype and prototype.IsPrototype())

    def update(self, shutter: Shutter) -> None:
        """Push the instances as edited since the last update, over ``shutter``."""
        time_changed = shutter != self.shutter
        if not (self._dirty or (time_changed and self._varying)):
            return
        self.shutter = shutter
        flattener = Flattener(self.stage, shutter, self.warn)
        groups = self._groups(flattener)
        stale, self._stale = self._stale, set()
        self.meshes.update(groups, shutter, stale, time_changed)
        self._varying = flattener.varying or self.meshes.varying
        self._skipped_lights = bool(flattener.lights)
        self._dirty = False

    def has_lights(self) -> bool:
        """Whether the point instancers in its prototypes hold lights (skipped, Flattener.lights):
        they make the stage one with lights of its own (no default light)."""
        return self._skipped_lights

    def copies(self) -> Iterator[tuple[str, Sdf.Path | None, list[str]]]:
        """``(instancer id, bound material, Cryptomatte object names)`` of every instancer rprim
        placing copies (see :meth:`InstancedMeshes.copies`)."""
        return self.meshes.copies()

    def subset_names(self) -> Iterator[tuple[str, list[str]]]:
        """See :meth:`InstancedMeshes.subset_names`."""
        return self.meshes.subset_names()

    def close(self) -> None:
        """Remove every prim this put into the delegate."""
        self.meshes.clear()

    # ----------------------------------------------------------------------------------------

    def _top_level_instances(self) -> Iterator[Usd.Prim]:
        if not self.stage.GetPrototypes():  # no instances at all: no walk over every prim
            return
        walk = iter(Usd.PrimRange(self.stage.GetPseudoRoot(), Usd.PrimDefaultPredicate))
        for prim in walk:
            if prim.IsA(UsdGeom.PointInstancer):  # its prototypes are its own
                walk.PruneChildren()
            elif prim.IsInstance():
                walk.PruneChildren()
                yield prim

    def _groups(self, flattener: Flattener) -> dict[GroupKey, Group]:
        """Every visible copy of every instanced mesh, grouped by (mesh, material)."""
        by_prototype: dict[Sdf.Path, list[tuple[Usd.Prim, int, str]]] = defaultdict(list)
        frame = self.shutter.frame
        limit = self.shutter.max_segments
        segments = 0  # one grid for every moving instance, so groups stack
        roots = []
        for instance in self._top_level_instances():
            roots.append(instance.GetPath())
            imageable = UsdGeom.Imageable(instance)
            if visibility_might_vary(instance):
                flattener.varying = True
            if imageable.ComputeVisibility(frame) == UsdGeom.Tokens.invisible:
                continue
            if self.render_pass is not None and not self.render_pass.rendered(instance.GetPath()):
                continue
            prototype = instance.GetPrototype()
            own = combine_segments(
                flattener.motion_segments(instance), flattener.content_segments(prototype), limit
            )
            segments = combine_segments(segments, own, limit)
            by_prototype[prototype.GetPath()].append((instance, own, imageable.ComputePurpose()))
        self._roots = set(roots)
        self._above = {p for root in roots for p in root.GetParentPath().GetPrefixes()}

        pending = []  # (leaf, transforms (N, M, K, 4, 4), instances kept)
        proxies: list[Usd.Prim] = []
        meshes: list[Usd.Prim] = []  # each proxy's mesh in the prototype
        for prototype_path, instances in by_prototype.items():
            prototype = self.stage.GetPrimAtPath(prototype_path)
            moving = any(own for _, own, _ in instances)
            world = np.stack(
                [_held(flattener.world(i, segments if own else 0), segments if moving else 0) for i, own, _ in instances]
            )  # (N, K, 4, 4)
            finite = np.isfinite(world).all(axis=(1, 2, 3))
            for n in np.flatnonzero(~finite):
                flattener.warn_not_finite(instances[n][0])
            for leaf in flattener.expand(prototype, segments):
                kept = [
                    n for n, (_, _, purpose) in enumerate(instances)
                    if finite[n] and (leaf.purpose or purpose) in self.purposes
                ]
                if not kept:
                    continue
                transforms = leaf.transforms[None] @ world[kept][:, None]
                pending.append((leaf, transforms, [instances[n][0].GetPath() for n in kept]))
                proxies.extend(
                    self.stage.GetPrimAtPath(
                        leaf.proxy.ReplacePrefix(prototype_path, instances[n][0].GetPath())
                    )
                    for n in kept
                )
                meshes.extend([leaf.mesh] * len(kept))
        materials = bound_materials(proxies)
        subsets = copies_subset_materials(meshes, proxies)
        reader = SampleReader(frame)
        inherited = {
            instance.GetPath(): inherited_primvars(instance, reader, self.warn)
            for instances in by_prototype.values()
            for instance, _, _ in instances
        }
        flattener.varying |= reader.varying
        # Ray visibility: each instance's (inherited), and what its prototype authors on the
        # way to the mesh, nearer. Instances that inherit none of its primvars (most) are
        # visible to every ray without asking USD again.
        ray_visibility = InheritedState(self.warn)
        ray_visibility.at(frame)
        groups: dict[GroupKey, Group] = {}
        start = 0
        for leaf, transforms, kept_instances in pending:
            count = len(transforms)
            bound = materials[start : start + count]
            bound_subsets = subsets[start : start + count]
            # Each copy's Cryptomatte object name: the instance proxy path of its mesh.
            names = [str(proxy.GetPath()) for proxy in proxies[start : start + count]]
            # Each copy's linking class, by its instance proxy's path.
            linked = np.array(
                [self.linking.class_of(proxy.GetPath()) for proxy in proxies[start : start + count]]
                if self.linking is not None and self.linking.active
                else np.zeros(count),
                np.uint32,
            )
            start += count
            copies_per_instance = len(leaf.transforms)
            within = authored_below(
                self.stage, leaf.proxy.GetPrefixes()[0], leaf.proxy, frame, self.warn
            )
            shown = []
            for path in kept_instances:
                rays = VISIBLE
                if not PRIMVAR_NAMES.isdisjoint(inherited[path]):
                    rays = ray_visibility.ray_visibility(self.stage.GetPrimAtPath(path), path)
                passed = SHOWN if self.render_pass is None else self.render_pass.visibility(path)
                shown.append((replace(rays, **within) if within else rays).shown(passed))
            for binding in dict.fromkeys(zip(bound, bound_subsets, shown)):
                material, subset_materials, pass_shown = binding
                chosen = [
                    n for n in range(count) if (bound[n], bound_subsets[n], shown[n]) == binding
                ]
                if not any(inherited[kept_instances[n]] for n in chosen):
                    selected = transforms[chosen]
                    primvars = nest_primvars({}, leaf.primvars, len(chosen), copies_per_instance)
                    group_leaves(
                        groups,
                        leaf,
                        material,
                        selected.reshape(-1, *selected.shape[2:]),
                        primvars,
                        pass_shown,
                        [names[n] for n in chosen for _ in range(copies_per_instance)],
                        _linking(np.repeat(linked[chosen], copies_per_instance)),
                        subset_materials,
                    )
                    continue
                # Each instance's own primvars reach its copies of the mesh (unless the mesh
                # authors the name, nearer); the group fills in what some instances lack.
                for n in chosen:
                    primvars = nest_primvars(
                        outer_primvars(inherited[kept_instances[n]], {}, leaf.mesh, 1),
                        leaf.primvars,
                        1,
                        copies_per_instance,
                    )
                    group_leaves(
                        groups,
                        leaf,
                        material,
                        transforms[n],
                        primvars,
                        pass_shown,
                        [names[n]] * copies_per_instance,
                        _linking(np.full(copies_per_instance, linked[n], np.uint32)),
                        subset_materials,
                    )
        return groups


def _linking(classes: np.ndarray) -> np.ndarray | None:
    """Copies' linking classes, None when all are linked to every light."""
    return classes if classes.any() else None


def _held(matrices: np.ndarray, segments: int) -> np.ndarray:
    """(K, 4, 4) ``matrices`` with a static transform held over the grid of ``segments``."""
    samples = segments + 1 if segments else 1
    return matrices if len(matrices) == samples else np.repeat(matrices[:1], samples, axis=0)
