"""Opening stages with errors that name the file."""

from __future__ import annotations

import os
import stat
from collections.abc import Iterable

from pxr import Ar, Sdf, Tf, Usd

from ..errors import SceneError, warn
from .mtlx_documents import compose_materialx_documents


def stage_name(stage: Usd.Stage) -> str:
    """The file a stage was opened from (or the identifier of its in-memory root layer)."""
    layer = stage.GetRootLayer()
    return layer.realPath or layer.identifier


def _tf_error_text(error: Tf.ErrorException) -> str:
    """The first message of a Tf error, without USD's source-location prefix."""
    try:
        text = str(error)
    except UnicodeDecodeError:  # the message quotes bytes of the file that are not UTF-8
        return "malformed text (bytes that are not UTF-8)"
    for part in text.split("\n\tError in "):
        _, sep, message = part.partition(" : '")
        if sep:
            return message.strip().rstrip("'").strip()
    return text.strip()


RESOLVERS = ("root", "inherit")
"""usdrecord's ``--resolver`` choices: a resolver context for the root layer's asset, or the
default context (inherited from the environment)."""


def _refuse_special_file(path: str, role: str) -> None:
    """Raise :class:`SceneError` when ``path`` names a directory, FIFO, socket or device:
    reading a FIFO blocks until something writes to it, and the others are no layers. Paths
    that name no file on disk (resolver identifiers) are left to USD. ``os.stat`` does not
    open the file, so it cannot block."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return
    if stat.S_ISREG(mode):
        return
    kind = (
        "a directory"
        if stat.S_ISDIR(mode)
        else "a FIFO (named pipe)"
        if stat.S_ISFIFO(mode)
        else "not a regular file"
    )
    raise SceneError(f"{path}: cannot read the {role}: it is {kind}")


def _open_layer(path: str, role: str) -> Sdf.Layer:
    _refuse_special_file(path, role)
    try:
        layer = Sdf.Layer.FindOrOpen(path)
    except Tf.ErrorException as error:
        raise SceneError(f"{path}: cannot read the {role}: {_tf_error_text(error)}") from None
    if layer is None:
        reason = "no such file" if not os.path.exists(path) else f"cannot read the {role}"
        raise SceneError(f"{path}: {reason}")
    return layer


def _names_any(text: str, documents: set[str]) -> bool:
    """Whether a diagnostic's or composition error's ``text`` is about one of ``documents``
    (the MaterialX files compose_materialx_documents handled)."""
    return any(os.path.basename(document) in text for document in documents)


def _open(
    path: str, layer: Sdf.Layer, session: Sdf.Layer, context: Ar.ResolverContext,
    mask_paths: list[str],
) -> Usd.Stage:
    """The stage of ``layer``, populated by ``mask_paths`` when given."""
    try:
        if mask_paths:
            population = Usd.StagePopulationMask()
            for mask_path in mask_paths:
                if not Sdf.Path.IsValidPathString(mask_path) or not mask_path.startswith("/"):
                    raise SceneError(f"{path}: --mask path {mask_path!r} is not an absolute prim path")
                population.Add(Sdf.Path(mask_path))
            stage = Usd.Stage.OpenMasked(layer, session, context, population)
        else:
            stage = Usd.Stage.Open(layer, session, context)
    except Tf.ErrorException as error:
        raise SceneError(f"{path}: cannot open the stage: {_tf_error_text(error)}") from None
    if not stage:
        raise SceneError(f"{path}: cannot open the stage")
    return stage


def open_stage(
    path: str | os.PathLike,
    *,
    mask: Iterable[str] = (),
    session_layer: str | os.PathLike | None = None,
    resolver: str = "root",
) -> Usd.Stage:
    """Open the stage whose root layer is ``path``, as usdrecord opens it: populated only with
    the prims of ``mask`` (their ancestors and descendants) when paths are given, with the
    layer at ``session_layer`` as its session layer (else an anonymous one), and with a
    resolver context for ``path`` (``resolver="root"``) or the default one (``"inherit"``).
    :class:`SceneError` names the file or prim path at fault."""
    path = os.fspath(path)
    if resolver not in RESOLVERS:
        raise ValueError(f"resolver must be one of {RESOLVERS}, not {resolver!r}")
    layer = _open_layer(path, "file")
    session = (
        _open_layer(os.fspath(session_layer), "session layer")
        if session_layer
        else Sdf.Layer.CreateAnonymous()
    )
    ar = Ar.GetResolver()
    context = (
        ar.CreateDefaultContext() if resolver == "inherit" else ar.CreateDefaultContextForAsset(path)
    )
    mask_paths = list(mask)
    # usd-core reports each arc to a .mtlx document as a failed composition (it has no file
    # format for them) while opening; those Penumbra composes itself, so their raw warnings
    # are dropped and every other diagnostic is posted as usual when the trap closes.
    with Tf.DiagnosticTrap() as trap:
        stage = _open(path, layer, session, context, mask_paths)
        documents = compose_materialx_documents(stage, warn)
        trap.EraseMatching(lambda diagnostic: _names_any(diagnostic.commentary, documents))
    for error in stage.GetCompositionErrors():
        if _names_any(str(error), documents):
            continue  # translated by compose_materialx_documents
        warn(f"{path}: composition error, the arc is ignored: {' '.join(str(error).split())}")
    return stage
