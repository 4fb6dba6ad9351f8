"""Choosing the camera and the image size of a render, as usdrecord does.

The camera is the one asked for (a prim path, or a bare prim name searched in the stage), else
the stage's ``main_cam``, else the render settings' camera. The image height follows from the
width and the aspect ratio of the render settings' ``resolution`` when one is authored, else of
the camera's apertures. With render settings, the part of the film the image covers follows
UsdRender's rules (:func:`film_window`): ``aspectRatioConformPolicy``, ``pixelAspectRatio`` and
``dataWindowNDC``. Its ``penumbra:KEY`` attributes set render options
(:mod:`penumbra.render_options`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdRender, UsdUtils

from .. import render_options
from ..errors import SceneError, warn
from .framing import FRAMING_CAMERA_PATH, framing_camera
from .render_pass import find_render_pass
from .sampling import value_at
from .stage import stage_name
from .values import as_floats, is_number_value

logger = logging.getLogger("penumbra")


@dataclass(frozen=True)
class RenderSettings:
    """What Penumbra uses from a ``UsdRenderSettings`` prim."""

    path: str
    camera: str | None
    """The single target of the ``camera`` relationship, if there is exactly one."""
    resolution: tuple[int, int] | None
    """``resolution`` when authored (the schema fallback is not a request)."""
    disable_motion_blur: bool = False
    """``disableMotionBlur``, or the deprecated ``instantaneousShutter``."""
    disable_depth_of_field: bool = False
    pixel_aspect_ratio: float = 1.0
    aspect_ratio_conform_policy: str = "expandAperture"
    data_window_ndc: tuple[float, float, float, float] = (0.0, 0.0, 1.0, 1.0)
    """(xmin, ymin, xmax, ymax) of the conformed aperture, (0, 0) bottom left."""
    options: Mapping[str, render_options.OptionValue] = field(default_factory=dict, hash=False)
    """The render options its ``penumbra:KEY`` attributes author, by Python keyword."""


CONFORM_POLICIES = (
    "expandAperture",
    "cropAperture",
    "adjustApertureWidth",
    "adjustApertureHeight",
    "adjustPixelAspectRatio",
)


PIXEL_ASPECT_RATIO_RANGE = (1e-2, 1e2)
"""Anamorphic pixels are at most 2 wide; beyond 100 either way the film the render delegate
fits to the image could pass the camera's bounds (camera.py; 1e-30 aborted the render)."""


def read_pixel_aspect_ratio(attr: Usd.Attribute) -> float:
    """The pixelAspectRatio of a RenderSettings or RenderProduct prim (``attr``); raises
    :class:`SceneError` naming the prim when it is not a number in PIXEL_ASPECT_RATIO_RANGE."""
    ratio = value_at(attr, Usd.TimeCode.Default())
    path, (low, high) = attr.GetPrim().GetPath(), PIXEL_ASPECT_RATIO_RANGE
    if not is_number_value(ratio):
        raise SceneError(f"{path}: pixelAspectRatio must be a number, not {ratio!r}")
    if not low <= ratio <= high:
        raise SceneError(f"{path}: pixelAspectRatio must be in [{low:g}, {high:g}], not {ratio:g}")
    return float(ratio)


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
        # Whole pixels first: a float2 of fractions would otherwise be a resolution of 0.
        width, height = (int(v) for v in _finite_numbers(path, resolution_attr, 2))
        if width > 0 and height > 0:
            resolution = (width, height)
    pixel_aspect_ratio = read_pixel_aspect_ratio(settings.GetPixelAspectRatioAttr())
    policy = str(settings.GetAspectRatioConformPolicyAttr().Get())
    if policy not in CONFORM_POLICIES:
        raise SceneError(
            f"{path}: unknown aspectRatioConformPolicy {policy!r} "
            f"(expected one of {', '.join(CONFORM_POLICIES)})"
        )
    x_min, y_min, x_max, y_max = _finite_numbers(path, settings.GetDataWindowNDCAttr(), 4)
    if not (x_min < x_max and y_min < y_max):
        raise SceneError(f"{path}: dataWindowNDC {(x_min, y_min, x_max, y_max)} is empty")
    return RenderSettings(
        path=str(path),
        camera=str(targets[0]) if len(targets) == 1 else None,
        resolution=resolution,
        disable_motion_blur=bool(settings.GetDisableMotionBlurAttr().Get())
        or bool(settings.GetInstantaneousShutterAttr().Get()),
        disable_depth_of_field=bool(settings.GetDisableDepthOfFieldAttr().Get()),
        pixel_aspect_ratio=float(pixel_aspect_ratio),
        aspect_ratio_conform_policy=policy,
        data_window_ndc=(x_min, y_min, x_max, y_max),
        options=_authored_options(settings.GetPrim()),
    )


def _finite_numbers(path: str, attr: Usd.Attribute, count: int) -> tuple[float, ...]:
    """The value of render settings ``path``'s ``attr`` as ``count`` finite numbers;
    :class:`SceneError` naming the attribute when it is anything else (a wrong or unknown type
    in the file, or an infinity that no image size or window could follow)."""
    value = attr.Get()
    numbers = (
        not isinstance(value, (str, bytes))
        and hasattr(value, "__len__")
        and len(value) == count
        and all(is_number_value(v) and math.isfinite(v) for v in value)
    )
    if not numbers:
        raise SceneError(f"{path}: {attr.GetName()} must be {count} finite numbers, not {value!r}")
    return as_floats(value)


def _authored_options(prim: Usd.Prim) -> dict[str, render_options.OptionValue]:
    """The render options authored on ``prim`` as ``penumbra:KEY`` attributes, by Python
    keyword; :class:`SceneError` names an attribute whose value no option takes, and a
    ``penumbra:`` attribute that names no option is warned about and ignored."""
    known = {option.usd_attribute for option in render_options.OPTIONS}
    for attribute in prim.GetAuthoredAttributes():
        name = attribute.GetName()
        if name.startswith(render_options.USD_ATTRIBUTE_PREFIX) and name not in known:
            warn(f"{attribute.GetPath()}: no render option is named {name!r}; ignored")
    options: dict[str, render_options.OptionValue] = {}
    for option in render_options.OPTIONS:
        attribute = prim.GetAttribute(option.usd_attribute)
        if not attribute or not attribute.HasAuthoredValue():
            continue
        value = attribute.Get()
        if option.type == "level" or isinstance(value, str):
            value = str(value)  # a token
        problem = option.problem(value)
        if problem is not None:
            raise SceneError(f"{attribute.GetPath()}: {problem}, not {value!r}")
        options[option.keyword] = option.value_type(value)
    return options


CameraPath = str | Sdf.Path
"""A camera as a prim path or a bare prim name, as ``str`` or ``Sdf.Path``."""


def _camera_path(name_or_path: CameraPath) -> Sdf.Path | None:
    """``name_or_path`` as an ``Sdf.Path`` (``None`` if it is no prim path)."""
    if isinstance(name_or_path, Sdf.Path):
        path = name_or_path
    else:
        text = str(name_or_path)
        if not text or not Sdf.Path.IsValidPathString(text):
            return None
        path = Sdf.Path(text)
    return path if path.IsPrimPath() or path == Sdf.Path.absoluteRootPath else None


def render_pass_settings(stage: Usd.Stage, pass_path: str) -> str:
    """The render settings prim named by the ``renderSource`` of the UsdRenderPass at
    ``pass_path`` (its first target, with a warning when there are several, as usdrecord).
    Raises :class:`SceneError` naming the pass when it is not a render pass or names no
    source. (Its collections are applied by the scene delegate: see ``render_pass.py``.)"""
    render_pass = find_render_pass(stage, pass_path)
    targets = render_pass.GetRenderSourceRel().GetForwardedTargets()
    if not targets:
        raise SceneError(f"{stage_name(stage)}: render pass {pass_path} has no renderSource")
    if len(targets) > 1:
        warn(f"{pass_path}: the render pass has {len(targets)} render sources; using {targets[0]}")
    return str(targets[0])


def camera_at_path(stage: Usd.Stage, name_or_path: CameraPath) -> Usd.Prim | None:
    """The camera usdrecord's ``UsdAppUtils.GetCameraAtPath`` finds, or ``None``.

    An absolute path names the prim; a relative path of several elements is made absolute
    (with a warning, as usdrecord does); a single name is searched for among the stage's
    cameras (instance proxies too), the first in traversal order.
    """
    path = _camera_path(name_or_path)
    if path is None:
        return None
    if not path.IsAbsolutePath():
        if path.pathElementCount > 1:
            absolute = path.MakeAbsolutePath(Sdf.Path.absoluteRootPath)
            warn(f'{stage_name(stage)}: camera path "{path}" is not absolute; using "{absolute}"')
            path = absolute
        else:
            predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
            for prim in Usd.PrimRange(stage.GetPseudoRoot(), predicate):
                if prim.GetName() == path.name and prim.IsA(UsdGeom.Camera):
                    return prim
            return None
    prim = stage.GetPrimAtPath(path)
    return prim if prim and prim.IsA(UsdGeom.Camera) else None


def find_camera(stage: Usd.Stage, name_or_path: CameraPath) -> Usd.Prim:
    """:func:`camera_at_path`, raising :class:`SceneError` naming the stage and the prim when
    there is no such camera."""
    prim = camera_at_path(stage, name_or_path)
    if prim is not None:
        return prim
    path = _camera_path(name_or_path)
    if path is None:
        raise SceneError(f"{stage_name(stage)}: {str(name_or_path)!r} is not a camera prim path")
    if path.IsAbsolutePath() or path.pathElementCount > 1:
        absolute = path.MakeAbsolutePath(Sdf.Path.absoluteRootPath)
        prim = stage.GetPrimAtPath(absolute)
        if not prim:
            raise SceneError(f"{stage_name(stage)}: no prim at camera path {absolute}")
        raise SceneError(
            f"{stage_name(stage)}: {absolute} is not a camera "
            f"(it is a {prim.GetTypeName() or 'typeless prim'})"
        )
    raise SceneError(f"{stage_name(stage)}: no camera named {path.name!r}")


def _stage_cameras(stage: Usd.Stage) -> list[Usd.Prim]:
    predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
    return [
        prim
        for prim in Usd.PrimRange(stage.GetPseudoRoot(), predicate)
        if prim.IsA(UsdGeom.Camera) and prim.GetPath() != FRAMING_CAMERA_PATH
    ]


def resolve_camera(
    stage: Usd.Stage,
    camera: CameraPath | None,
    settings: RenderSettings | None,
    time: Usd.TimeCode | None = None,
    purposes: Iterable[str] = (),
) -> Usd.Prim:
    """The camera to render, in usdrecord's order: ``camera`` if given; else the stage's
    ``main_cam`` (usdrecord's default ``--camera``), else the render settings' camera; else, as
    husk does, the stage's only camera (named in an information message); else a camera
    framing the stage (at ``time``, of the geometry with ``purposes``).

    Raises :class:`SceneError` when the camera asked for (or the render settings') does not
    exist, or there is no camera and nothing to frame. (usdrecord silently falls back to the
    next choice there.)
    """
    if camera is not None and str(camera):
        return find_camera(stage, camera)
    primary = camera_at_path(stage, UsdUtils.GetPrimaryCameraName())
    if primary is not None:
        return primary
    if settings is not None and settings.camera:
        return find_camera(stage, settings.camera)
    cameras = _stage_cameras(stage)
    if len(cameras) == 1:
        logger.info(
            "%s: no camera given and no %r; rendering through the stage's only camera, %s",
            stage_name(stage),
            UsdUtils.GetPrimaryCameraName(),
            cameras[0].GetPath(),
        )
        return cameras[0]
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
    """``(width, height)`` of the full image (before any ``dataWindowNDC`` crop); a missing
    height keeps the aspect ratio of the render settings' resolution when authored, else of the
    camera's apertures at ``time`` (with the settings' ``pixelAspectRatio``: pixels that
    wide cover the aperture)."""
    if width < 1:
        raise ValueError(f"image width must be at least 1, not {width}")
    if height is not None:
        if height < 1:
            raise ValueError(f"image height must be at least 1, not {height}")
        return width, height
    if settings is not None and settings.resolution is not None:
        resolution_width, resolution_height = settings.resolution
        return width, max(1, width * resolution_height // resolution_width)
    geom = UsdGeom.Camera(camera)
    horizontal = value_at(geom.GetHorizontalApertureAttr(), time)
    vertical = value_at(geom.GetVerticalApertureAttr(), time)
    if not horizontal or horizontal <= 0 or not vertical or vertical <= 0:
        raise SceneError(
            f"{camera.GetPath()}: camera apertures must be positive "
            f"(horizontal {horizontal}, vertical {vertical})"
        )
    pixel_aspect_ratio = settings.pixel_aspect_ratio if settings is not None else 1.0
    return width, usdrecord_height(width * pixel_aspect_ratio, horizontal, vertical)


def usdrecord_height(width: float, horizontal_aperture: float, vertical_aperture: float) -> int:
    """The image height usdrecord gives a width: ``int(width / aspect)`` in single precision
    (as UsdAppUtilsFrameRecorder computes it from GfCamera's float aspect ratio), at least 1;
    an aspect ratio within 1e-4 of 0 counts as 1."""
    aspect = np.float32(horizontal_aperture) / np.float32(vertical_aperture)
    if abs(aspect) <= np.float32(1e-4):
        aspect = np.float32(1)
    return max(1, int(np.float32(width) / aspect))


@dataclass(frozen=True)
class FilmWindow:
    """The part of a camera's film an image covers, relative to the camera's apertures (so
    that it follows animated apertures), and the image's size in pixels."""

    width: int
    height: int
    horizontal_scale: float = 1.0
    """The window's width over the camera's horizontal aperture."""
    vertical_scale: float = 1.0
    horizontal_shift: float = 0.0
    """The window centre's offset from the aperture's centre, over the horizontal aperture."""
    vertical_shift: float = 0.0
    pixel_aspect_ratio: float = 1.0
    """Width over height of one pixel on the film."""
    x: int = 0
    y: int = 0
    """The image's top-left pixel in the frame (columns from the left, rows from the top; below
    0 or past the frame for overscan)."""
    frame: tuple[int, int] | None = None
    """(width, height) of the frame the image is cut from by ``dataWindowNDC``; None: the image
    is the whole frame."""


def conform_aperture(
    policy: str,
    resolution: tuple[int, int],
    pixel_aspect_ratio: float,
    aperture: tuple[float, float],
) -> tuple[tuple[float, float], float]:
    """UsdRender's ``aspectRatioConformPolicy``: the aperture (width, height) and pixel aspect
    ratio with which ``resolution`` pixels cover the film (as ``UsdRenderComputeSpec`` does:
    the adjusted side makes the aperture's aspect the image's, ``pixelAspectRatio`` ×
    width / height; ``adjustPixelAspectRatio`` changes the pixels instead)."""
    resolution_aspect = resolution[0] / resolution[1]
    image_aspect = pixel_aspect_ratio * resolution_aspect
    aperture_aspect = aperture[0] / aperture[1]
    if policy == "adjustPixelAspectRatio":
        return aperture, aperture_aspect / resolution_aspect
    adjust_width = {
        "adjustApertureWidth": True,
        "adjustApertureHeight": False,
        "expandAperture": aperture_aspect <= image_aspect,
        "cropAperture": aperture_aspect > image_aspect,
    }[policy]
    if adjust_width:
        return (aperture[1] * image_aspect, aperture[1]), pixel_aspect_ratio
    return (aperture[0], aperture[0] / image_aspect), pixel_aspect_ratio


def _window_pixels(low: float, high: float, count: int) -> tuple[int, int]:
    """The first and one past the last of ``count`` pixels along an axis whose centres
    ((i + 0.5) / count) lie in [low, high); pixels outside [0, count) are overscan."""
    return math.ceil(low * count - 0.5), math.ceil(high * count - 0.5)


def film_window(
    settings: RenderSettings | None,
    camera: Usd.Prim,
    time: Usd.TimeCode,
    width: int,
    height: int,
) -> FilmWindow:
    """The film window and pixel size of a ``width`` × ``height`` image under ``settings``:
    the camera's aperture conformed to the image by the ``aspectRatioConformPolicy``, then
    cut to the pixels whose centres lie in ``dataWindowNDC`` (a crop, or overscan beyond the
    unit square). Without settings, the whole image (the renderer expands the aperture)."""
    if settings is None:
        return FilmWindow(width, height)
    geom = UsdGeom.Camera(camera)
    aperture = (
        float(value_at(geom.GetHorizontalApertureAttr(), time)),
        float(value_at(geom.GetVerticalApertureAttr(), time)),
    )
    if not (aperture[0] > 0 and aperture[1] > 0):
        raise SceneError(f"{camera.GetPath()}: camera apertures must be positive {aperture}")
    (conformed_width, conformed_height), pixel_aspect_ratio = conform_aperture(
        settings.aspect_ratio_conform_policy,
        (width, height),
        settings.pixel_aspect_ratio,
        aperture,
    )
    x_min, y_min, x_max, y_max = settings.data_window_ndc
    first_column, end_column = _window_pixels(x_min, x_max, width)
    # NDC y grows upwards, image rows downwards.
    first_row, end_row = _window_pixels(1 - y_max, 1 - y_min, height)
    if end_column <= first_column or end_row <= first_row:
        raise SceneError(
            f"{settings.path}: dataWindowNDC {settings.data_window_ndc} holds no pixel centre "
            f"of the {width}x{height} image"
        )
    left, right = first_column / width, end_column / width
    bottom, top = 1 - end_row / height, 1 - first_row / height
    horizontal = conformed_width / aperture[0]
    vertical = conformed_height / aperture[1]
    return FilmWindow(
        width=end_column - first_column,
        height=end_row - first_row,
        horizontal_scale=horizontal * (right - left),
        vertical_scale=vertical * (top - bottom),
        horizontal_shift=horizontal * ((left + right) / 2 - 0.5),
        vertical_shift=vertical * ((bottom + top) / 2 - 0.5),
        pixel_aspect_ratio=pixel_aspect_ratio,
        x=first_column,
        y=first_row,
        frame=(width, height),
    )
