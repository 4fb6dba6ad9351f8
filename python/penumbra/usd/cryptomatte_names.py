"""The names Cryptomatte layers give what the delegate renders (docs/aovs.md, "Cryptomatte").

* ``CryptoObject``: the prim path of a mesh, points or curves prim; for a copy made by native
  instancing, the instance proxy path of its mesh (``/World/tree_3/leaves``); for a point
  instancer's copy, the path of its prototype's mesh (``/World/forest/prototypes/pine/leaves``):
  all copies of one prototype mesh share that name.
* ``CryptoMaterial``: the path of the material bound for final renders (``full`` purpose, then
  all-purpose, resolved on the instance proxy for native instances), or :data:`NO_MATERIAL`.
* ``CryptoAsset``: the path of the object's nearest model root: the nearest prim, the object's
  prim or an ancestor (through instance proxies, by namespace), whose ``kind`` is
  ``component`` or ``assembly`` or a kind derived from them; else :data:`NO_ASSET`.

The placeholders hold characters no prim path can, so they never collide with a real path.
"""

from __future__ import annotations

from collections.abc import Iterable

from pxr import Kind, Sdf, Usd

from .material import bound_materials

NO_MATERIAL = "(no material)"
NO_ASSET = "(no asset)"
LAYERS = ("CryptoObject", "CryptoMaterial", "CryptoAsset")

InstancedCopies = tuple[str, Sdf.Path | None, list[str]]
"""(instancer id, bound material, each copy's object name)."""


def cryptomatte_names(
    stage: Usd.Stage,
    rprims: Iterable[tuple[str, Sdf.Path]],
    copies: Iterable[InstancedCopies],
    layers: Iterable[str],
) -> dict[str, dict[str, list[str]]]:
    """For each layer of ``layers`` (of :data:`LAYERS`): delegate prim id → the names of its
    placements, one for each of ``rprims`` (id, prim path), one per copy for each of
    ``copies``' instancers."""
    rprims, copies, layers = list(rprims), list(copies), list(layers)
    unknown = [layer for layer in layers if layer not in LAYERS]
    if unknown:
        raise ValueError(f"unknown Cryptomatte layers {unknown} (known: {', '.join(LAYERS)})")
    result: dict[str, dict[str, list[str]]] = {}
    if "CryptoObject" in layers:
        result["CryptoObject"] = {id_: [str(path)] for id_, path in rprims}
        result["CryptoObject"].update({id_: list(names) for id_, _, names in copies})
    if "CryptoMaterial" in layers:
        prims = [stage.GetPrimAtPath(path) for _, path in rprims]
        bound = bound_materials(prims)
        result["CryptoMaterial"] = {
            id_: [_material_name(material)] for (id_, _), material in zip(rprims, bound)
        }
        result["CryptoMaterial"].update(
            {id_: [_material_name(material)] * len(names) for id_, material, names in copies}
        )
    if "CryptoAsset" in layers:
        assets = _AssetFinder(stage)
        result["CryptoAsset"] = {id_: [assets.name(str(path))] for id_, path in rprims}
        result["CryptoAsset"].update(
            {id_: [assets.name(name) for name in names] for id_, _, names in copies}
        )
    return result


def _material_name(material: Sdf.Path | None) -> str:
    return str(material) if material else NO_MATERIAL


def is_asset_root(prim: Usd.Prim) -> bool:
    """Whether ``prim``'s kind is component or assembly (or derived from them)."""
    kind = Usd.ModelAPI(prim).GetKind()
    return bool(kind) and (
        Kind.Registry.IsA(kind, Kind.Tokens.component)
        or Kind.Registry.IsA(kind, Kind.Tokens.assembly)
    )


class _AssetFinder:
    """Nearest asset roots by path, each prim looked at once."""

    def __init__(self, stage: Usd.Stage):
        self.stage = stage
        self._roots: dict[Sdf.Path, bool] = {}

    def name(self, object_path: str) -> str:
        path = Sdf.Path(object_path)
        for prefix in reversed(path.GetPrefixes()):  # the object's own prim first
            if prefix not in self._roots:
                prim = self.stage.GetPrimAtPath(prefix)
                self._roots[prefix] = bool(prim) and is_asset_root(prim)
            if self._roots[prefix]:
                return str(prefix)
        return NO_ASSET
