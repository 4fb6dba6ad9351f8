"""Choosing the camera and the image size of a render, as usdrecord does.

The camera is the one asked for (a prim path, or a bare prim name searched in the stage), else
the render settings' camera, else the stage's ``main_cam``. The image height follows from the
width and the aspect ratio of the render settings' ``resolution`` when one is authored, else of
the camera's apertures.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from pxr import Sdf, Usd, UsdGeom, UsdRender, UsdUtils

from ..errors import SceneError
from .framing import framing_camera
from .stage import stage_name


@dataclass(frozen=True)
class RenderSettings:
    """What Penumbra uses from a ``UsdRenderSettings`` prim."""

    path: str
    camera: str | None
    """The single target of the ``camera`` relationship, if there is exactly one."""
    resolution: tuple[int, int] | None
    """``resolution`` when authored (the schema fallback is not a request)."""
    disable_motion_blur: bool = False
    disable_depth_of_field: bool = False


def read_render_settings(stage: Usd.Stage, path: str | None = None) -> RenderSettings | None:
    """Read the render settings prim at ``path``, or the one named by the stage metadata.

    An explicitly given path that is not a RenderSettings prim raises :class:`SceneError`; a
    dangling path in the stage metadata is ignored, as usdrecord does.
    """
    explicit = bool(path)
    if not explicit:
        path = stage.GetMetadata("renderSettingsPrimPath") or None
    if not path:
        return None
    settings = UsdRender.Settings(stage.GetPrimAtPath(path))
    if not settings:
        if explicit:
            raise SceneError(f"{stage_name(stage)}: {path} is not a RenderSettings prim")
        return None
    targets = settings.GetCameraRel().GetForwardedTargets()
    resolution_attr = settings.GetResolutionAttr()
    resolution = None
    if resolution_attr.HasAuthoredValue():
        width, height = resolution_attr.Get()
        if width > 0 and height > 0:
            resolution = (int(width), int(height))
    return RenderSettings(
        path=str(path),
        camera=str(targets[0]) if len(targets) == 1 else None,
        resolution=resolution,
        disable_motion_blur=bool(settings.GetDisableMotionBlurAttr().Get()),
        disable_depth_of_field=bool(settings.GetDisableDepthOfFieldAttr().Get()),
    )


def find_camera(stage: Usd.Stage, name_or_path: str) -> Usd.Prim:
    """The camera prim at an absolute path, or the first camera whose name is ``name_or_path``.

    Instance proxies are searched too. Raises :class:`SceneError` naming the stage and the prim.
    """
    if name_or_path.startswith("/"):
        prim = (
            stage.GetPrimAtPath(name_or_path) if Sdf.Path.IsValidPathString(name_or_path) else None
        )
        if not prim:
            raise SceneError(f"{stage_name(stage)}: no prim at camera path {name_or_path}")
        if not prim.IsA(UsdGeom.Camera):
            raise SceneError(
                f"{stage_name(stage)}: {name_or_path} is not a camera "
                f"(it is a {prim.GetTypeName() or 'typeless prim'})"
            )
        return prim
    predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
    for prim in Usd.PrimRange(stage.GetPseudoRoot(), predicate):
        if prim.GetName() == name_or_path and prim.IsA(UsdGeom.Camera):
            return prim
    raise SceneError(f"{stage_name(stage)}: no camera named {name_or_path!r}")


def resolve_camera(
    stage: Usd.Stage,
    camera: str | None,
    settings: RenderSettings | None,
    time: Usd.TimeCode | None = None,
    purposes: Iterable[str] = (),
) -> Usd.Prim:
    """The camera to render: ``camera`` if given, else the render settings' camera, else
    ``main_cam``, else a camera framing the stage (at ``time``, of the geometry with
    ``purposes``). Raises :class:`SceneError` when there is none and nothing to frame."""
    if camera:
        return find_camera(stage, camera)
    if settings is not None and settings.camera:
        return find_camera(stage, settings.camera)
    try:
        return find_camera(stage, UsdUtils.GetPrimaryCameraName())
    except SceneError:
        pass
    framing = framing_camera(stage, time or Usd.TimeCode(stage.GetStartTimeCode()), purposes)
    if framing is None:
        raise SceneError(
            f"{stage_name(stage)}: no camera: none was given, the render settings name none, "
            f"there is no {UsdUtils.GetPrimaryCameraName()!r} and there is no geometry to frame"
        )
    return framing


def image_size(
    camera: Usd.Prim,
    time: Usd.TimeCode,
    width: int,
    height: int | None = None,
    settings: RenderSettings | None = None,
) -> tuple[int, int]:
    """``(width, height)``; a missing height keeps the aspect ratio of the render settings'
    resolution when authored, else of the camera's apertures at ``time``."""
    if width < 1:
        raise ValueError(f"image width must be at least 1, not {width}")
    if height is not None:
        if height < 1:
            raise ValueError(f"image height must be at least 1, not {height}")
        return width, height
    if settings is not None and settings.resolution is not None:
        aspect = settings.resolution[1] / settings.resolution[0]
    else:
        geom = UsdGeom.Camera(camera)
        horizontal = geom.GetHorizontalApertureAttr().Get(time)
        vertical = geom.GetVerticalApertureAttr().Get(time)
        if not horizontal or horizontal <= 0 or not vertical or vertical <= 0:
            raise SceneError(
                f"{camera.GetPath()}: camera apertures must be positive "
                f"(horizontal {horizontal}, vertical {vertical})"
            )
        aspect = vertical / horizontal
    return width, max(1, round(width * aspect))
