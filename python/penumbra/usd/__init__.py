"""The USD side of Penumbra: the scene delegate and the choice of camera and image size."""

from .scene import DEFAULT_PURPOSES, SceneDelegate
from .settings import (
    RenderSettings,
    find_camera,
    image_size,
    read_render_settings,
    render_pass_settings,
    resolve_camera,
)
from .stage import open_stage, stage_name

__all__ = [
    "DEFAULT_PURPOSES",
    "RenderSettings",
    "SceneDelegate",
    "find_camera",
    "image_size",
    "open_stage",
    "read_render_settings",
    "render_pass_settings",
    "resolve_camera",
    "stage_name",
]
