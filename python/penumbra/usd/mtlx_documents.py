"""References and payloads to MaterialX documents (``.mtlx``), composed without a file-format
plugin (docs/materialx.md).

usd-core cannot open ``.mtlx`` files, so such arcs fail to compose. For each prim whose prim
stack authors one, the document is read with the MaterialX library and translated to UsdShade
prims laid out as OpenUSD's usdMtlx lays them out (``/MaterialX/Materials/<material>``, the
surface shader and the nodes and node graphs it uses as its children), so that bindings to those
paths resolve. The translation lives in one anonymous layer inserted as the strongest sublayer of
the stage's session layer: under an abstract (``class``) root prim, out of the way of traversals,
and brought to each referencing prim by an internal reference with the arc's target path
(inside instance prototypes, through a patch prim each instance references). The user's layers
are not edited; the added layer's customLayerData records what it composed.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

from pxr import Sdf, Usd, UsdShade

HIDDEN_ROOT = Sdf.Path("/_PenumbraMaterialX")
# customLayerData key of the layers this module adds: what they compose, so that later calls
# only add what is new.
_DATA_KEY = "penumbraMaterialX"
_DEFAULT_PRIM = Sdf.Path("/MaterialX")
# The overs for arcs inside instance prototypes, one prim per prototype.
_PATCH_ROOT = HIDDEN_ROOT.AppendChild("instancePatches")

_TYPES = {
    "float": Sdf.ValueTypeNames.Float, "integer": Sdf.ValueTypeNames.Int,
    "boolean": Sdf.ValueTypeNames.Bool, "color3": Sdf.ValueTypeNames.Color3f,
    "color4": Sdf.ValueTypeNames.Color4f, "vector2": Sdf.ValueTypeNames.Float2,
    "vector3": Sdf.ValueTypeNames.Float3, "vector4": Sdf.ValueTypeNames.Float4,
    "string": Sdf.ValueTypeNames.String, "filename": Sdf.ValueTypeNames.Asset,
    "surfaceshader": Sdf.ValueTypeNames.Token, "displacementshader": Sdf.ValueTypeNames.Token,
}


def _prim_arcs(prim: Usd.Prim) -> list[tuple[str, Sdf.Path]]:
    """(resolved .mtlx file, target prim path) for every reference or payload to a MaterialX
    document authored in the prim stack of ``prim``."""
    arcs = []
    for spec in prim.GetPrimStack():
        items = [*spec.referenceList.GetAddedOrExplicitItems(),
                 *spec.payloadList.GetAddedOrExplicitItems()]
        for item in items:
            if item.assetPath.lower().endswith(".mtlx"):
                target = item.primPath if not item.primPath.isEmpty else _DEFAULT_PRIM
                arcs.append((spec.layer.ComputeAbsolutePath(item.assetPath), target))
    return arcs


def _mtlx_arcs(stage: Usd.Stage) -> list[tuple[Sdf.Path, str, Sdf.Path]]:
    """(prim, resolved .mtlx file, target prim path) for every reference or payload to a
    MaterialX document authored in the prim stacks of the stage (outside instances)."""
    return [(prim.GetPath(), file, target)
            for prim in Usd.PrimRange.Stage(stage, Usd.PrimAllPrimsPredicate)
            for file, target in _prim_arcs(prim)]


def _prototype_arcs(
    stage: Usd.Stage,
) -> list[tuple[list[Sdf.Path], list[tuple[Sdf.Path, str, Sdf.Path]]]]:
    """For each instance prototype whose prims author arcs to MaterialX documents: the paths
    of its instances (those outside other prototypes) and the arcs, each as (prim path
    relative to the prototype, resolved .mtlx file, target prim path)."""
    found = []
    for prototype in stage.GetPrototypes():
        arcs = [(prim.GetPath().MakeRelativePath(prototype.GetPath()), file, target)
                for prim in Usd.PrimRange(prototype, Usd.PrimAllPrimsPredicate)
                if prim != prototype
                for file, target in _prim_arcs(prim)]
        instances = [p.GetPath() for p in prototype.GetInstances() if not p.IsInPrototype()]
        if arcs and instances:
            found.append((instances, arcs))
    return found


def _composed_arcs(stage: Usd.Stage) -> list[str]:
    """The arcs to MaterialX documents the stage has now, as tab-separated prim, file, target:
    what the added layer is authored from (not their layer offsets: the internal references
    carry none, and translations hold no time samples). usd-core reports each as a composition
    error at the prim whose index it fails in (inside a prototype, at its source instance's
    prim), so the prim stacks of those prims alone hold them all, without a traversal. The
    errors' messages are no key: they name the file and the introducing prim, not the target."""
    sites = {e.rootSite.path for e in stage.GetCompositionErrors() if ".mtlx" in str(e)}
    return sorted(f"{path}\t{file}\t{target}"
                  for path in sites if (prim := stage.GetPrimAtPath(path))
                  for file, target in _prim_arcs(prim))


def _added_layer(stage: Usd.Stage) -> Sdf.Layer | None:
    """The session sublayer this module added to ``stage``, if any."""
    for path in stage.GetSessionLayer().subLayerPaths:
        layer = Sdf.Layer.Find(path)
        if layer and _DATA_KEY in layer.customLayerData:
            return layer
    return None


def compose_materialx_documents(stage: Usd.Stage, warn: Callable[[str], None]) -> set[str]:
    """Translate the ``.mtlx`` documents the stage references and compose them (see the module
    docstring). Returns the paths of the documents translated or reported unreadable, so that
    the composition errors of their original arcs are not reported again.

    Cheap to call again (the renderer does, before each sync): unless the stage's arcs to
    ``.mtlx`` documents have changed since the last call — a variant selection that swaps
    documents, a reference retargeted to another prim of its document, say — it does
    nothing. Otherwise the internal references are authored anew for the arcs the stage has
    now (documents already translated are kept), in one change to the added layer."""
    arcs = _composed_arcs(stage)
    layer = _added_layer(stage)
    data = dict(layer.customLayerData[_DATA_KEY]) if layer else {"documents": {}, "arcs": []}
    documents: dict[str, str] = dict(data["documents"])  # file → translation root, "" if none
    if list(data["arcs"]) == arcs:
        return set(documents)
    fresh = Sdf.Layer.CreateAnonymous("materialx.usda")
    if layer and layer.GetPrimAtPath(HIDDEN_ROOT):
        Sdf.CopySpec(layer, HIDDEN_ROOT, fresh, HIDDEN_ROOT)  # the translations so far
        if fresh.GetPrimAtPath(_PATCH_ROOT):  # authored anew below
            del fresh.GetPrimAtPath(HIDDEN_ROOT).nameChildren[_PATCH_ROOT.name]
    scratch = Usd.Stage.Open(fresh)

    def translation(file: str, target: Sdf.Path, referrer: Sdf.Path) -> Sdf.Path | None:
        """The translated prim standing for ``target`` in ``file`` (translated on first use);
        None, after a warning if needed, when there is none."""
        if file not in documents:
            root = HIDDEN_ROOT.AppendChild(f"document{len(documents)}")
            scratch.OverridePrim(HIDDEN_ROOT).SetSpecifier(Sdf.SpecifierClass)
            documents[file] = str(root) if _translate(file, scratch, root, warn) else ""
        if not documents[file]:
            return None
        internal = Sdf.Path(documents[file]).AppendPath(
            target.MakeRelativePath(Sdf.Path.absoluteRootPath))
        if not scratch.GetPrimAtPath(internal):
            warn(f"{file}: has no prim {target}; the reference from {referrer} stays empty")
            return None
        return internal

    for prim_path, file, target in _mtlx_arcs(stage):
        internal = translation(file, target, prim_path)
        if internal is not None:
            scratch.OverridePrim(prim_path).GetReferences().AddInternalReference(internal)
    # Inside instances, the prims are instance proxies that take no opinions of their own; the
    # overs go into a patch prim that each instance references, so that they become part of
    # the arcs its prototype is composed from (instances that shared a prototype still do).
    for index, (instances, arcs) in enumerate(_prototype_arcs(stage)):
        patch = _PATCH_ROOT.AppendChild(f"prototype{index}")
        for relative, file, target in arcs:
            internal = translation(file, target, instances[0].AppendPath(relative))
            if internal is not None:
                scratch.OverridePrim(patch.AppendPath(relative)).GetReferences() \
                    .AddInternalReference(internal)
        if scratch.GetPrimAtPath(patch):
            for instance in instances:
                scratch.OverridePrim(instance).GetReferences().AddInternalReference(patch)
    fresh.customLayerData = {_DATA_KEY: {"documents": documents, "arcs": arcs}}
    if layer:
        layer.TransferContent(fresh)
    else:
        stage.GetSessionLayer().subLayerPaths.insert(0, fresh.identifier)
    return set(documents)


def _translate(file: str, stage: Usd.Stage, root: Sdf.Path, warn: Callable[[str], None]) -> bool:
    """Translate the MaterialX document ``file`` under ``root``; False (after a warning naming
    the file) when it cannot be read."""
    import MaterialX as mx

    if not os.path.isfile(file):
        warn(f"{file}: MaterialX document not found; its materials are missing")
        return False
    document = mx.createDocument()
    try:
        mx.readFromXmlFile(document, file)
    except Exception as error:  # MaterialX's parse and file errors share no narrower base
        warn(f"{file}: cannot read the MaterialX document ({error}); its materials are missing")
        return False
    from .materialx_library import library

    document.setDataLibrary(library())  # node definitions, without copying them
    _Translator(document, stage, root, file, warn).run()
    return True


class _Translator:
    def __init__(self, document: Any, stage: Usd.Stage, root: Sdf.Path, file: str,
                 warn: Callable[[str], None]):
        self.document = document
        self.stage = stage
        self.materialx = root.AppendChild("MaterialX")
        self.file = file
        self.directory = os.path.dirname(file)
        self.warn = warn

    def run(self) -> None:
        self.stage.DefinePrim(self.materialx, "Scope")
        materials = self.materialx.AppendChild("Materials")
        self.stage.DefinePrim(materials, "Scope")
        for node in self.document.getMaterialNodes():
            material = UsdShade.Material.Define(self.stage, materials.AppendChild(node.getName()))
            copied: dict[str, UsdShade.Shader] = {}
            for terminal in ("surfaceshader", "volumeshader"):
                shader_input = node.getInput(terminal)
                shader_node = shader_input.getConnectedNode() if shader_input else None
                if shader_node is None:
                    continue
                shader = self._node(shader_node, material.GetPath(), copied, None)
                # A volume node keeps its ``out`` output (_node); a surface gets ``surface``.
                source = shader.CreateOutput("surface", Sdf.ValueTypeNames.Token) \
                    if terminal == "surfaceshader" else shader.GetOutput("out")
                material.CreateOutput(f"mtlx:{terminal[:-len('shader')]}",
                                      Sdf.ValueTypeNames.Token).ConnectToSource(source)

    def _node(self, node: Any, parent: Sdf.Path, copied: dict[str, UsdShade.Shader],
              graph: UsdShade.NodeGraph | None) -> UsdShade.Shader:
        """Copy ``node`` (a document-level node, or one of ``graph``) under ``parent``, with the
        nodes it reads from the same scope."""
        if node.getName() in copied:
            return copied[node.getName()]
        shader = UsdShade.Shader.Define(self.stage, parent.AppendChild(node.getName()))
        copied[node.getName()] = shader
        node_def = node.getNodeDef()
        # An unknown node keeps its category as info:id: the material reader names it.
        shader.SetShaderId(node_def.getName() if node_def else node.getCategory())
        if node.getType() not in ("multioutput", "surfaceshader"):
            shader.CreateOutput("out", _TYPES.get(node.getType(), Sdf.ValueTypeNames.Token))
        elif node_def is not None:
            for output in node_def.getActiveOutputs():
                if output.getType() != "surfaceshader":
                    shader.CreateOutput(output.getName(), _TYPES.get(output.getType(),
                                                                     Sdf.ValueTypeNames.Token))
        for mx_input in node.getInputs():
            self._input(mx_input, shader, parent, copied, graph)
        return shader

    def _input(self, mx_input: Any, shader: UsdShade.Shader, parent: Sdf.Path,
               copied: dict[str, UsdShade.Shader], graph: UsdShade.NodeGraph | None) -> None:
        value_type = _TYPES.get(mx_input.getType(), Sdf.ValueTypeNames.Token)
        usd_input = shader.CreateInput(mx_input.getName(), value_type)
        output = mx_input.getOutputString() or "out"
        if mx_input.getNodeGraphString():
            mx_graph = self.document.getNodeGraph(mx_input.getNodeGraphString())
            if mx_graph is None:
                return
            graph_prim = self._graph(mx_graph, parent)
            if not mx_input.getOutputString() and mx_graph.getOutputs():
                output = mx_graph.getOutputs()[0].getName()
            usd_input.ConnectToSource(graph_prim.GetOutput(output))
        elif mx_input.getNodeName():
            scope = graph.GetPrim() if graph else None
            source = (scope and self._graph_node(graph, mx_input.getNodeName(), copied)) or \
                self._document_node(mx_input.getNodeName(), parent, copied)
            if source is not None:
                usd_output = source.GetOutput(output) or source.GetOutput("out")
                if usd_output:
                    usd_input.ConnectToSource(usd_output)
        elif mx_input.getInterfaceName() and graph is not None:
            graph_input = graph.GetInput(mx_input.getInterfaceName())
            if graph_input:
                usd_input.ConnectToSource(graph_input)
        else:
            self._set_value(mx_input, usd_input)

    def _graph_node(self, graph: UsdShade.NodeGraph, name: str,
                    copied: dict[str, UsdShade.Shader]) -> UsdShade.Shader | None:
        mx_graph = self.document.getNodeGraph(graph.GetPrim().GetName())
        node = mx_graph.getNode(name) if mx_graph else None
        if node is None:
            return None
        return self._node(node, graph.GetPath(), copied, graph)

    def _document_node(self, name: str, parent: Sdf.Path,
                       copied: dict[str, UsdShade.Shader]) -> UsdShade.Shader | None:
        node = self.document.getNode(name)
        return self._node(node, parent, copied, None) if node is not None else None

    def _graph(self, mx_graph: Any, parent: Sdf.Path) -> UsdShade.NodeGraph:
        path = parent.AppendChild(mx_graph.getName())
        existing = UsdShade.NodeGraph.Get(self.stage, path)
        if existing:
            return existing
        graph = UsdShade.NodeGraph.Define(self.stage, path)
        for mx_input in mx_graph.getInputs():
            usd_input = graph.CreateInput(mx_input.getName(),
                                          _TYPES.get(mx_input.getType(), Sdf.ValueTypeNames.Token))
            self._set_value(mx_input, usd_input)
        copied: dict[str, UsdShade.Shader] = {}
        for mx_output in mx_graph.getOutputs():
            usd_output = graph.CreateOutput(mx_output.getName(),
                                            _TYPES.get(mx_output.getType(),
                                                       Sdf.ValueTypeNames.Token))
            node = mx_graph.getNode(mx_output.getNodeName()) if mx_output.getNodeName() else None
            if node is not None:
                source = self._node(node, path, copied, graph)
                source_output = source.GetOutput(mx_output.getOutputString() or "out")
                if source_output:
                    usd_output.ConnectToSource(source_output)
        return graph

    def _absolute(self, path: str) -> str:
        """``path`` relative to the document's directory, unless absolute."""
        return os.path.normpath(os.path.join(self.directory, path)) if path else path

    def _file_path(self, mx_input: Any) -> str:
        """The file a ``filename`` input names: its value under the document's ``fileprefix``,
        as MaterialX resolves it. Some assets repeat the prefix in the value
        (``fileprefix="./textures/"``, ``value="./textures/a.jpg"``), which viewers that
        resolve values beside the document accept: where prefix + value names no file but the
        value alone does, that file, after a warning naming both."""
        resolved = self._absolute(mx_input.getResolvedValueString())
        if not resolved or "<UDIM>" in resolved or os.path.exists(resolved):
            return resolved
        plain = self._absolute(mx_input.getValueString())
        if plain != resolved and os.path.exists(plain):
            self.warn(
                f"{self.file}: {mx_input.getNamePath()}: {resolved} (fileprefix and value) "
                f"does not exist; using {plain} (the value alone)"
            )
            return plain
        return resolved

    def _set_value(self, mx_input: Any, usd_input: UsdShade.Input) -> None:
        from .materialx_library import mx_value

        if not mx_input.getValueString():
            return
        attr = usd_input.GetAttr()
        if mx_input.getType() == "filename":
            attr.Set(Sdf.AssetPath(self._file_path(mx_input)))
        else:
            value = mx_value(mx_input.getValue())
            if value is None:
                return
            attr.Set(value)
        space = mx_input.getActiveColorSpace()
        if space and space != "lin_rec709" and mx_input.getType() in (
            "color3", "color4", "filename"
        ):
            attr.SetMetadata("colorSpace", space)
