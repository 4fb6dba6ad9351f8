"""UsdGeomCamera → the render delegate's ``camera`` sprim (USD units, see docs/design.md §3), and the
shutter a camera gives a frame."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from pxr import Usd, UsdGeom

from ..errors import SceneError
from .core_batch import MAX_COORDINATE
from .sampling import DEFAULT_MAX_MOTION_SEGMENTS, SampleReader, Shutter, changes_within
from .values import is_number_value

if TYPE_CHECKING:
    from .settings import FilmWindow


def read_shutter(
    prim: Usd.Prim,
    frame: Usd.TimeCode,
    motion_blur: bool = True,
    max_segments: int = DEFAULT_MAX_MOTION_SEGMENTS,
) -> Shutter:
    """The shutter of camera ``prim`` for ``frame``: [frame+shutter:open, frame+shutter:close],
    or the frame alone without ``motion_blur``. Raises :class:`SceneError` naming the camera
    when shutter:close < shutter:open."""
    camera = UsdGeom.Camera(prim)
    shutter_open = float(camera.GetShutterOpenAttr().Get(frame))
    shutter_close = float(camera.GetShutterCloseAttr().Get(frame))
    if shutter_close < shutter_open:
        raise SceneError(
            f"{prim.GetPath()}: shutter:close < shutter:open "
            f"({shutter_close:g} < {shutter_open:g})"
        )
    if not motion_blur:
        return Shutter(frame, max_segments=max_segments)
    return Shutter(frame, shutter_open, shutter_close, max_segments)


PROJECTIONS = ("perspective", "orthographic")


def _number(attr: Usd.Attribute, time: Usd.TimeCode) -> float | None:
    """The attribute's value as a float, or None when it is not a number (an attribute authored
    with the wrong or an unknown type)."""
    value = attr.Get(time)
    return float(value) if is_number_value(value) else None


def camera_problem(prim: Usd.Prim, time: Usd.TimeCode) -> str | None:
    """What makes camera ``prim`` unusable at ``time`` (naming the camera and the attribute),
    or ``None``: every value rays are built from must be finite, lengths positive, the
    clipping range 0 <= near < far, the projection known and the world transform invertible."""
    camera = UsdGeom.Camera(prim)
    path = prim.GetPath()
    projection = str(camera.GetProjectionAttr().Get(time))
    if projection not in PROJECTIONS:
        return f"{path}: unknown projection {projection!r} (known: {', '.join(PROJECTIONS)})"
    positive = [camera.GetHorizontalApertureAttr(), camera.GetVerticalApertureAttr()]
    if projection == "perspective":
        positive.append(camera.GetFocalLengthAttr())
    offsets = (camera.GetHorizontalApertureOffsetAttr(), camera.GetVerticalApertureOffsetAttr())
    lens = (camera.GetFStopAttr(), camera.GetFocusDistanceAttr())
    for attr in (*positive, *offsets, *lens):
        if _number(attr, time) is None:
            return (
                f"{path}: {attr.GetName()} must be a number, not a "
                f"{type(attr.Get(time)).__name__} (a wrong or unknown type in the file)"
            )
    for attr in positive:
        value = _number(attr, time)
        if not (math.isfinite(value) and value > 0):
            return f"{path}: {attr.GetName()} must be a positive number, not {value:g}"
    for attr in offsets:
        value = _number(attr, time)
        if not math.isfinite(value):
            return f"{path}: {attr.GetName()} must be a finite number, not {value:g}"
    for attr in lens:
        value = _number(attr, time)
        if not (math.isfinite(value) and value >= 0):
            return f"{path}: {attr.GetName()} must be a finite number >= 0, not {value:g}"
    clipping = camera.GetClippingRangeAttr()
    try:
        near, far = (float(value) for value in clipping.Get(time))
    except (TypeError, ValueError):
        return (
            f"{path}: clippingRange must be two numbers, not a "
            f"{type(clipping.Get(time)).__name__} (a wrong or unknown type in the file)"
        )
    if not (math.isfinite(near) and math.isfinite(far) and 0 <= near < far):
        return (
            f"{path}: clippingRange ({near:g}, {far:g}) must be finite with 0 <= near < far "
            "(nothing would be visible)"
        )
    matrix = np.array(camera.ComputeLocalToWorldTransform(time))
    if not np.isfinite(matrix).all() or abs(np.linalg.det(matrix[:3, :3])) < 1e-30:
        return (
            f"{path}: the camera's world transform is not finite or not invertible "
            "(a NaN or a zero scale in its xformOps or an ancestor's)"
        )
    if np.abs(matrix[3, :3]).max() > MAX_COORDINATE:
        return (
            f"{path}: the camera's world transform translates it beyond {MAX_COORDINATE:g} "
            "units, where single-precision rays cannot start"
        )
    return None


def sync_camera(
    core,
    prim: Usd.Prim,
    reader: SampleReader,
    depth_of_field: bool = True,
    window: FilmWindow | None = None,
) -> bool:
    """Push the projection, apertures, lens and the reader's shutter of camera ``prim`` to
    ``core``; an animated focal length or focus distance is sampled over the shutter. Without
    ``depth_of_field`` the camera is a pinhole (f-stop 0). ``window``: the part of the film
    the image covers (render settings' conform policy and data window) instead of the whole
    aperture. Returns ``False`` (pushing nothing) when the camera is unusable (see
    :func:`camera_problem`): rendering through it then fails with that reason."""
    if camera_problem(prim, reader.time) is not None:
        return False
    camera = UsdGeom.Camera(prim)
    path = str(prim.GetPath())
    shutter = reader.shutter
    near, far = reader.get(camera.GetClippingRangeAttr())
    focal_attr, focus_attr = camera.GetFocalLengthAttr(), camera.GetFocusDistanceAttr()
    horizontal = float(reader.get(camera.GetHorizontalApertureAttr()))
    vertical = float(reader.get(camera.GetVerticalApertureAttr()))
    horizontal_offset = float(reader.get(camera.GetHorizontalApertureOffsetAttr()))
    vertical_offset = float(reader.get(camera.GetVerticalApertureOffsetAttr()))
    pixel_aspect_ratio = 1.0
    if window is not None:
        horizontal_offset += window.horizontal_shift * horizontal
        vertical_offset += window.vertical_shift * vertical
        horizontal *= window.horizontal_scale
        vertical *= window.vertical_scale
        pixel_aspect_ratio = window.pixel_aspect_ratio
    core.set_camera(
        path,
        focal_length=float(reader.get(focal_attr)),
        horizontal_aperture=horizontal,
        vertical_aperture=vertical,
        horizontal_aperture_offset=horizontal_offset,
        vertical_aperture_offset=vertical_offset,
        pixel_aspect_ratio=pixel_aspect_ratio,
        f_stop=float(reader.get(camera.GetFStopAttr())) if depth_of_field else 0.0,
        focus_distance=float(reader.get(focus_attr)),
        clipping_range=(float(near), float(far)),
        shutter_open=shutter.open,
        shutter_close=shutter.close,
        projection=str(reader.get(camera.GetProjectionAttr())),
    )
    lens = (focal_attr, focus_attr)
    if shutter.blurred and any(changes_within(attr, shutter.interval) for attr in lens):
        authored = [t for attr in lens for t in attr.GetTimeSamplesInInterval(shutter.interval)]
        times = shutter.times(shutter.segments(authored))
        focal_lengths, focus_distances = (
            np.array([attr.Get(time) for time in times], dtype=np.float32) for attr in lens
        )
        if not (np.isfinite(focal_lengths).all() and np.isfinite(focus_distances).all()):
            return False
        core.set_camera_motion(path, focal_lengths, focus_distances)
    return True
