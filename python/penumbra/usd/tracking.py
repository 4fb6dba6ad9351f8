"""Change tracking for the scene delegate: which tracked prims must be read again, and what of them.

Stage edits arrive as ``Usd.Notice.ObjectsChanged`` and are queued until the next update; then
an edit inside a prototype reaches the corresponding paths in its instances, an ancestor's
transform or visibility edit reaches its whole subtree, a shader edit its materials, and a
structural change re-populates the changed subtree (:meth:`ChangeTracker.resync`), and an edit
of a collection (its properties, or its prim resynced) the bindings made through collections.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Protocol

from pxr import Sdf, Tf, Usd, UsdGeom, UsdSkel

from .classification import Classifier
from .inherited import Inherited
from .material_registry import MaterialRegistry
from .ray_visibility import ATTRIBUTES as RAY_VISIBILITY_ATTRIBUTES
from .skinning import skel_root


class Dirty:
    """The aspects of a prim that can be re-read independently: bits of a plain ``int`` (an
    ``enum.IntFlag`` costs microseconds per operation, which a sync of 100,000 prims feels)."""

    DATA = 1  # the prim's own attributes (geometry, camera, light inputs)
    TRANSFORM = 2
    VISIBILITY = 4
    BINDING = 8  # meshes, points, curves and volumes: which material is bound
    ALL = DATA | TRANSFORM | VISIBILITY | BINDING


# Which aspects each kind of prim has.
_ASPECTS = {
    "mesh": Dirty.ALL,
    "points": Dirty.ALL,
    "basisCurves": Dirty.ALL,
    "volume": Dirty.ALL,  # a volume's binding is part of its data
    "camera": Dirty.DATA | Dirty.TRANSFORM,
}
_POINT_BASED = frozenset({"mesh", "points", "basisCurves"})  # the kinds UsdSkel can pose
_LIGHT_ASPECTS = Dirty.DATA | Dirty.TRANSFORM | Dirty.VISIBILITY


def aspects(kind: str) -> int:
    """The aspects prims of ``kind`` have."""
    return _ASPECTS.get(kind, _LIGHT_ASPECTS)


def set_flag(flags: int, flag: int, on: bool) -> int:
    return flags | flag if on else flags & ~flag


@dataclass(slots=True)  # one per tracked prim: slots keep it small
class TrackedPrim:
    """A tracked rprim or sprim."""

    kind: str  # the delegate's prim type: "mesh", "camera", "rectLight", ...
    in_core: bool = False  # False while the prim is unusable (e.g. a mesh without points)
    varying: int = 0  # aspects whose inputs might vary with time
    unknown: int = 0  # aspects whose variability is found out at the first new time
    # Meshes whose data varies: attribute queries reused at each new time (dropped on edits).
    queries: dict[str, Usd.AttributeQuery] | None = None
    material: str = ""  # meshes and points: id of the bound material ("" = none)
    subset_materials: tuple[str, ...] = ()  # meshes: those their GeomSubsets bind

    def materials(self) -> set[Sdf.Path]:
        """The materials it uses: its own and its subsets'."""
        return {Sdf.Path(m) for m in (self.material, *self.subset_materials) if m}


@dataclass
class Flush:
    """The dirty tracked prims of one flush, as lists aligned by index."""

    paths: list[Sdf.Path]
    ids: list[str]
    prims: list[Usd.Prim]
    states: list[Inherited | None]  # meshes found by this update's traversals: their state
    records: list[TrackedPrim]
    bits: list[int]  # the aspects to read
    new: list[bool] = field(default_factory=list)  # entering the delegate

    def subset(self, indices: list[int]) -> Flush:
        def pick(values: list) -> list:
            return [values[n] for n in indices] if values else []

        fields = (self.paths, self.ids, self.prims, self.states, self.records, self.bits)
        return Flush(*(pick(v) for v in fields), new=pick(self.new))


class EditListener(Protocol):
    """What else hears of stage edits (native and point instancing)."""

    def note_changes(self, resynced: Iterable[Sdf.Path], changed: Iterable[Sdf.Path]) -> None: ...


def path_order_key(path: str) -> list[str]:
    """A sort key putting prim paths (as strings) in ``Sdf.Path`` order: name by name from the
    root, a parent before its children. Sorting by it is several times faster than comparing
    ``Sdf.Path`` objects from Python, and a flush inserts its prims in this order."""
    return path.split("/")


class ChangeTracker:
    """The tracked prims of ``stage`` and their dirty aspects. The one listener to the stage:
    ``listeners`` hear of its edits too."""

    def __init__(
        self,
        stage: Usd.Stage,
        classifier: Classifier,
        materials: MaterialRegistry,
        listeners: list[EditListener],
    ):
        self.stage = stage
        self.prims: dict[Sdf.Path, TrackedPrim] = {}
        self._classifier = classifier
        self._materials = materials
        self._listeners = listeners
        self._removed: list[tuple[Sdf.Path, TrackedPrim]] = []
        self._dirty: dict[Sdf.Path, int] = {}
        self._resynced: set[Sdf.Path] = set()
        self._changed: set[Sdf.Path] = set()
        self._prims_resynced = True  # since take_prims_resynced(); the stage is new to us
        # Prims found by the traversals of this update, for its flush (no second look-up), with
        # the inherited state of the meshes among them.
        self._found: dict[Sdf.Path, tuple[Usd.Prim, Inherited | None]] = {}
        self._collection_binders = _CollectionBinders(stage)
        self._skel_edits: set[Sdf.Path] = set()  # SkelRoots whose prims an edit may pose anew
        self._listener = Tf.Notice.Register(
            Usd.Notice.ObjectsChanged, self._on_objects_changed, stage
        )

    def close(self) -> None:
        """Stop listening to the stage."""
        if self._listener is not None:
            self._listener.Revoke()
            self._listener = None

    @property
    def dirty(self) -> bool:
        """Whether some tracked prim is to be read again."""
        return bool(self._dirty)

    def take_prims_resynced(self) -> bool:
        """Whether prims were resynced since the last call."""
        resynced, self._prims_resynced = self._prims_resynced, False
        return resynced

    def take_removed(self) -> list[tuple[Sdf.Path, TrackedPrim]]:
        """The prims no longer tracked since the last call, in the order they went."""
        removed, self._removed = self._removed, []
        return removed

    def take_flush(self) -> Flush:
        """The dirty tracked prims in path order (a parent before its children), no longer
        dirty."""
        dirty, self._dirty = self._dirty, {}
        found, self._found = self._found, {}
        tracked = [path for path in dirty if path in self.prims]
        ids = [str(path) for path in tracked]  # the delegate's prim ids
        order = sorted(range(len(tracked)), key=lambda n: path_order_key(ids[n]))
        paths = [tracked[n] for n in order]
        seen = [found.get(path) or (self.stage.GetPrimAtPath(path), None) for path in paths]
        todo = Flush(
            paths=paths,
            ids=[ids[n] for n in order],
            prims=[prim for prim, _ in seen],
            states=[state for _, state in seen],
            records=[self.prims[path] for path in paths],
            bits=[dirty[path] for path in paths],
        )
        todo.new = [not record.in_core for record in todo.records]
        return todo

    def _on_objects_changed(self, notice, _sender) -> None:
        resynced = notice.GetResyncedPaths()
        self._prims_resynced = self._prims_resynced or any(
            not path.IsPropertyPath() for path in resynced
        )
        self._resynced.update(resynced)
        self._changed.update(notice.GetChangedInfoOnlyPaths())

    def _instance_paths(self, path: Sdf.Path) -> Iterator[Sdf.Path]:
        """``path`` itself, or, inside a prototype, the corresponding paths in its instances."""
        root = path.GetPrefixes()[0] if path != Sdf.Path.absoluteRootPath else path
        prototype = self.stage.GetPrimAtPath(root)
        if not (prototype and prototype.IsPrototype()):
            yield path
            return
        for instance in prototype.GetInstances():
            yield from self._instance_paths(path.ReplacePrefix(root, instance.GetPath()))

    def process_notices(self) -> None:
        """Mark what the edits queued since the last call affect."""
        for listener in self._listeners:
            listener.note_changes(self._resynced, self._changed)
        resynced = {p for q in self._resynced for p in self._instance_paths(q)}
        changed = {p for q in self._changed for p in self._instance_paths(q)}
        self._resynced.clear()
        self._changed.clear()
        # A resynced property (created or removed) is an edit of that property.
        changed |= {p for p in resynced if p.IsPropertyPath()}
        prim_roots = sorted(p for p in resynced if not p.IsPropertyPath())
        roots: list[Sdf.Path] = []
        for path in prim_roots:  # sorted: an ancestor comes before its descendants
            if not roots or not path.HasPrefix(roots[-1]):
                roots.append(path)
        for root in roots:
            self.resync(root)
        for path in sorted(changed):
            self._on_changed(path)
        self._mark_skinned_prims()
        # As Linking re-reads every link on any collection edit: membership may also follow a
        # collection that one includes or names in its expression, so every binding made
        # through a collection is resolved again.
        if any(p.IsPropertyPath() and p.name.startswith("collection:") for p in changed):
            for binder in self._collection_binders.binders():
                self._mark_subtree(binder, Dirty.BINDING)

    def _on_changed(self, path: Sdf.Path) -> None:
        """Mark what an edit of ``path`` (a property, or a prim's metadata) affects."""
        prim_path = path.GetPrimPath()
        name = path.name if path.IsPropertyPath() else ""
        if name == UsdGeom.Tokens.purpose:
            self.resync(prim_path)
            return
        self._materials.note_edited(prim_path)
        self._mark_subset_owner(prim_path)
        self._note_skel_edit(prim_path, name)
        if _is_xform_property(name):
            self._mark_subtree(prim_path, Dirty.TRANSFORM)
        elif name == UsdGeom.Tokens.visibility:
            self._mark_subtree(prim_path, Dirty.VISIBILITY)
        elif name.startswith("material:binding"):
            self._mark_subtree(prim_path, Dirty.BINDING)
            self._collection_binders.rescan(prim_path, subtree=False)
        elif name in RAY_VISIBILITY_ATTRIBUTES:
            self._mark_subtree(prim_path, Dirty.VISIBILITY)
        elif name.startswith("primvars:") and prim_path not in self.prims:
            self._mark_subtree(prim_path, Dirty.DATA)  # inherited constant primvars
        elif prim_path in self.prims:
            self.mark(prim_path, Dirty.DATA if name else Dirty.ALL)

    def mark(self, path: Sdf.Path, bits: int, edited: bool = True) -> None:
        """Mark aspects ``bits`` of a tracked prim dirty; ``edited``: because the stage changed
        (rather than the time), which makes its attribute queries stale."""
        record = self.prims.get(path)
        if record is not None:
            if edited and bits & Dirty.DATA:
                record.queries = None
            self._dirty[path] = self._dirty.get(path, 0) | (bits & aspects(record.kind))

    def _mark_subset_owner(self, path: Sdf.Path) -> None:
        """An edit of an untracked child of a tracked mesh (a GeomSubset: its faces and binding
        are part of the mesh's binding) resolves the mesh's binding again."""
        owner = self.prims.get(path.GetParentPath())
        if owner is not None and owner.kind == "mesh" and path not in self.prims:
            self.mark(path.GetParentPath(), Dirty.BINDING)

    def _note_skel_edit(self, path: Sdf.Path, name: str) -> None:
        """Note the SkelRoot above an edit that may pose the prims below it otherwise: of a
        Skeleton, SkelAnimation or BlendShape, a transform, a binding (``skel:*``), or a prim
        itself (``name`` empty: added, removed, its metadata)."""
        prim = self.stage.GetPrimAtPath(path)
        for ancestor in reversed(path.GetPrefixes()[:-1]):  # removed: its nearest ancestor stays
            if prim:
                break
            prim = self.stage.GetPrimAtPath(ancestor)
        if not prim:  # not a prim path (the stage's own metadata): no prim to pose
            return
        if name and not (
            _is_xform_property(name)
            or name.startswith(("skel:", "primvars:skel:"))
            or prim.IsA(UsdSkel.Skeleton)
            or prim.IsA(UsdSkel.Animation)
            or prim.IsA(UsdSkel.BlendShape)
        ):
            return
        root = skel_root(prim)
        if root is not None:
            self._skel_edits.add(root.GetPath())

    def _mark_skinned_prims(self) -> None:
        """Read again the meshes, curves and points under the SkelRoots edited (each once)."""
        for root in self._skel_edits:
            for tracked in self._tracked_under(root):
                if self.prims[tracked].kind in _POINT_BASED:
                    self.mark(tracked, Dirty.DATA)
        self._skel_edits.clear()

    def _mark_subtree(self, root: Sdf.Path, bits: int) -> None:
        for path in self._tracked_under(root):
            self.mark(path, bits)

    def _tracked_under(self, root: Sdf.Path) -> list[Sdf.Path]:
        """The tracked prims at or below ``root``, found in time proportional to the subtree
        (an edit of one leaf prim costs no walk over every tracked prim)."""
        prim = self.stage.GetPrimAtPath(root)
        if not prim:
            return [path for path in self.prims if path.HasPrefix(root)]
        subtree = Usd.PrimRange(prim, Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate))
        return [p.GetPath() for p in subtree if p.GetPath() in self.prims]

    def resync(self, root: Sdf.Path) -> None:
        """Re-populate the subtree at ``root``: remove what is gone, insert what is new, and
        re-read everything else in it."""
        wanted = {}
        for path, kind, prim, state in self._classifier.traverse(self.stage.GetPrimAtPath(root)):
            wanted[path] = kind
            self._found[path] = prim, state
        for path in [p for p in self.prims if p.HasPrefix(root)]:
            if wanted.get(path) != self.prims[path].kind:
                self._remove(path)
        for path, kind in wanted.items():
            if path in self.prims:
                self.mark(path, Dirty.ALL)
            else:  # new: marked as mark() would, without looking it up again
                self.prims[path] = TrackedPrim(kind)
                self._dirty[path] = aspects(kind)
        for user in self._materials.note_resynced(root):
            self.mark(user, Dirty.BINDING)
        if root != Sdf.Path.absoluteRootPath:
            self._mark_subset_owner(root)  # a subset added or removed
            self._note_skel_edit(root, "")  # a skeleton, animation or blend shape
        if root != Sdf.Path.absoluteRootPath:  # else every binding is resolved again anyway
            # A collection owned in the subtree may have changed (or gone) with it.
            for binder, collections in self._collection_binders.binders().items():
                if not binder.HasPrefix(root) and any(c.HasPrefix(root) for c in collections):
                    self._mark_subtree(binder, Dirty.BINDING)
        self._collection_binders.rescan(root, subtree=True)

    def _remove(self, path: Sdf.Path) -> None:
        record = self.prims.pop(path)
        self._dirty.pop(path, None)
        self._removed.append((path, record))


class _CollectionBinders:
    """The prims that author collection-based material bindings, with the collections these
    name: such a binding binds the collection's members at or below its prim, so a collection
    edit must resolve again the bindings of the tracked prims below them. Found by one traversal
    when first asked for (populating the stage resolves every binding without them), then kept
    up to date as bindings are edited and subtrees resynced."""

    _NAMESPACE = "material:binding:collection"  # of every purpose's collection bindings

    def __init__(self, stage: Usd.Stage):
        self._stage = stage
        self._found: dict[Sdf.Path, frozenset[Sdf.Path]] | None = None

    def binders(self) -> dict[Sdf.Path, frozenset[Sdf.Path]]:
        """Binding prim → the collections (property paths) its collection bindings name."""
        if self._found is None:
            self._found = {}
            self._scan(Sdf.Path.absoluteRootPath, subtree=True)
        return self._found

    def rescan(self, path: Sdf.Path, subtree: bool) -> None:
        """Read the bindings of the prim at ``path`` (and its descendants if ``subtree``) again."""
        if self._found is None:
            return  # read when first asked for
        if subtree and path == Sdf.Path.absoluteRootPath:
            self._found = None  # likewise
            return
        for stale in [p for p in self._found if p.HasPrefix(path)] if subtree else [path]:
            self._found.pop(stale, None)
        self._scan(path, subtree)

    def _scan(self, path: Sdf.Path, subtree: bool) -> None:
        prim = self._stage.GetPrimAtPath(path)
        # Tracked meshes are never inside instances: bindings there cannot reach them.
        if not prim or prim.IsInstanceProxy():
            return
        for prim in Usd.PrimRange(prim) if subtree else (prim,):
            collections = frozenset(
                target
                for rel in prim.GetAuthoredPropertiesInNamespace(self._NAMESPACE)
                if isinstance(rel, Usd.Relationship)
                for target in rel.GetTargets()
                if target.IsPropertyPath()
            )
            if collections:
                self._found[prim.GetPath()] = collections


def _is_xform_property(name: str) -> bool:
    return name.startswith("xformOp:") or name == UsdGeom.Tokens.xformOpOrder
