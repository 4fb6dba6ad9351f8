"""The MaterialX standard libraries: node definitions and the defaults of their inputs."""

from __future__ import annotations

from functools import cache
from typing import Any

from . import materialx_values as mv


@cache
def library() -> Any:
    """The MaterialX standard libraries (node definitions and their defaults)."""
    import MaterialX as mx

    document = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), document)
    return document


def mx_value(value: Any) -> Any:
    """A MaterialX value as Python: tuples of floats for vectors and colours."""
    if hasattr(value, "asTuple"):
        return tuple(float(c) for c in value.asTuple())
    return value


def definition_default(shader_id: str, name: str) -> mv.Constant | None:
    """The default of input ``name`` in node definition ``shader_id`` (``None`` for strings and
    geometric properties such as the texture coordinates)."""
    node_def = library().getNodeDef(shader_id)
    definition = node_def.getActiveInput(name) if node_def else None
    if definition is None or definition.hasDefaultGeomPropString():
        return None
    value = mx_value(definition.getValue())
    return None if value is None or isinstance(value, str) else to_constant(value)


def to_constant(value: Any) -> mv.Constant:
    """A number or vector as a :class:`~.materialx_values.Constant` of floats."""
    if isinstance(value, (bool, int, float)):
        return mv.Constant((float(value),))
    return mv.Constant(tuple(float(c) for c in value))
