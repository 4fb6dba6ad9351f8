"""Opening stages with errors that name the file."""

from __future__ import annotations

import os

from pxr import Sdf, Tf, Usd

from ..errors import SceneError


def stage_name(stage: Usd.Stage) -> str:
    """The file a stage was opened from (or the identifier of its in-memory root layer)."""
    layer = stage.GetRootLayer()
    return layer.realPath or layer.identifier


def _tf_error_text(error: Tf.ErrorException) -> str:
    """The first message of a Tf error, without USD's source-location prefix."""
    for part in str(error).split("\n\tError in "):
        _, sep, message = part.partition(" : '")
        if sep:
            return message.strip().rstrip("'").strip()
    return str(error).strip()


def open_stage(path: str | os.PathLike) -> Usd.Stage:
    """Open the stage whose root layer is ``path``; :class:`SceneError` names the file."""
    path = os.fspath(path)
    try:
        layer = Sdf.Layer.FindOrOpen(path)
    except Tf.ErrorException as error:
        raise SceneError(f"{path}: cannot read the file: {_tf_error_text(error)}") from None
    if layer is None:
        reason = "no such file" if not os.path.exists(path) else "cannot read the file"
        raise SceneError(f"{path}: {reason}")
    try:
        stage = Usd.Stage.Open(layer)
    except Tf.ErrorException as error:
        raise SceneError(f"{path}: cannot open the stage: {_tf_error_text(error)}") from None
    if not stage:
        raise SceneError(f"{path}: cannot open the stage")
    return stage
