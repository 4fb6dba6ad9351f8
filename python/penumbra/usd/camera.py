"""UsdGeomCamera → the render delegate's ``camera`` sprim (USD units, see docs/design.md §3), and the
shutter a camera gives a frame."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from pxr import Usd, UsdGeom

from ..errors import SceneError
from .core_batch import MAX_COORDINATE
from .sampling import (
    DEFAULT_MAX_MOTION_SEGMENTS,
    SampleReader,
    Shutter,
    changes_within,
    value_at,
)
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
    and the attribute when shutter:open or shutter:close is not a finite number, or
    shutter:close < shutter:open."""
    camera = UsdGeom.Camera(prim)
    ends = []
    for attr in (camera.GetShutterOpenAttr(), camera.GetShutterCloseAttr()):
        value = value_at(attr, frame)
        if not (is_number_value(value) and math.isfinite(value)):
            raise SceneError(
                f"{prim.GetPath()}: {attr.GetName()} must be a finite number, not {value!r}"
            )
        ends.append(float(value))
    shutter_open, shutter_close = ends
    if shutter_close < shutter_open:
        raise SceneError(
            f"{prim.GetPath()}: shutter:close < shutter:open "
            f"({shutter_close:g} < {shutter_open:g})"
        )
    if not motion_blur:
        return Shutter(frame, max_segments=max_segments)
    return Shutter(frame, shutter_open, shutter_close, max_segments)


PROJECTIONS = ("perspective", "orthographic")

# Bounds that keep the render delegate's camera rays finite in single precision (Embree aborts
# the process on one that is not). A perspective ray points at its film position, up to
# aperture / 2 + |aperture offset| from the axis (film units: tenths of a scene unit), over the
# focal length, a vector squared as it is normalised; a thin lens's rays leave up to its radius,
# 0.05 * focalLength / fStop scene units, off the axis for that vector times the focus
# distance; an orthographic ray leaves a tenth of its film position off the axis. Each bound
# leaves the others orders of magnitude, and the film the delegate widens to the image's aspect.
MAX_FILM_EXTENT = 1e12
"""Film units from the optical axis."""
MAX_FIELD_TANGENT = 1e4
"""Film extent over focal length: a field of view within 0.012 degrees of 180."""
MAX_LENS_RADIUS = 1e6
"""Scene units."""
MAX_FOCUS_DISTANCE = 1e12
"""Scene units."""


def _number(attr: Usd.Attribute, time: Usd.TimeCode) -> float | None:
    """The attribute's value as a float (a value blocked at ``time`` reads as the schema's
    fallback), or None when it is not a number (an attribute authored with the wrong or an
    unknown type)."""
    value = value_at(attr, time)
    return float(value) if is_number_value(value) else None


def _exposure_attributes(camera: UsdGeom.Camera) -> tuple[Usd.Attribute, ...]:
    """exposure, exposure:time, exposure:iso, exposure:responsivity, exposure:fStop."""
    return (
        camera.GetExposureAttr(), camera.GetExposureTimeAttr(), camera.GetExposureIsoAttr(),
        camera.GetExposureResponsivityAttr(), camera.GetExposureFStopAttr(),
    )


def _exposure_scale(camera: UsdGeom.Camera, time: Usd.TimeCode) -> float | str:
    """UsdGeomCamera's linear exposure scale at ``time`` (ComputeLinearExposureScale: 2^exposure
    · exposure:time · exposure:iso / 100 · exposure:responsivity / exposure:fStop²), or what
    makes it unusable (an input that is not a number, a scale not finite or negative)."""
    path = camera.GetPath()
    inputs = {}
    for attr in _exposure_attributes(camera):
        value = _number(attr, time)
        if value is None:
            return (
                f"{path}: {attr.GetName()} must be a number, not a "
                f"{type(attr.Get(time)).__name__} (a wrong or unknown type in the file)"
            )
        inputs[attr.GetName()] = value
    exposure, seconds, iso, responsivity, f_stop = inputs.values()
    try:
        scale = 2.0**exposure * seconds * iso / 100 * responsivity / (f_stop * f_stop)
    except (OverflowError, ZeroDivisionError):
        scale = math.inf
    if not (math.isfinite(scale) and 0 <= scale <= 3.4e38):
        described = ", ".join(f"{name} {value:g}" for name, value in inputs.items())
        return (
            f"{path}: the exposure scale 2^exposure · time · iso / 100 · responsivity / fStop² "
            f"must be finite and >= 0 ({described})"
        )
    return scale


def _lens_times(
    attrs: tuple[Usd.Attribute, ...], time: Usd.TimeCode, shutter: Shutter
) -> list[Usd.TimeCode]:
    """``time`` and, over a blurred ``shutter``, its ends and the times inside where ``attrs``
    have samples: held or interpolated linearly between, every value the shutter's samples
    read lies between the values at these times."""
    if not shutter.blurred:
        return [time]
    interval = shutter.interval
    inside = {t for attr in attrs for t in attr.GetTimeSamplesInInterval(interval)}
    return [time, *(Usd.TimeCode(t) for t in sorted(inside | {interval.min, interval.max}))]


def _lens_problem(
    camera: UsdGeom.Camera, time: Usd.TimeCode, shutter: Shutter, film_extent: float
) -> str | None:
    """What makes the focal length, focus distance or f-stop of perspective ``camera`` unusable
    at ``time`` or at any time ``shutter`` covers (see the bounds above), or ``None``."""
    path = camera.GetPath()
    focal_attr, focus_attr = camera.GetFocalLengthAttr(), camera.GetFocusDistanceAttr()
    f_stop = _number(camera.GetFStopAttr(), time)
    # As the delegate's camera decides, from the values at the frame.
    thin_lens = f_stop > 0 and _number(focus_attr, time) > 0
    for sample_time in _lens_times((focal_attr, focus_attr), time, shutter):
        at = "" if sample_time == time else f" at time {sample_time.GetValue():g}"
        focal_length = _number(focal_attr, sample_time)
        focus = _number(focus_attr, sample_time)
        if focal_length is None or focus is None:  # a stronger layer's value of another type
            return f"{path}: focalLength and focusDistance must be numbers{at}"
        if not (math.isfinite(focal_length) and focal_length > 0):
            return f"{path}: focalLength must be a positive number, not {focal_length:g}{at}"
        if film_extent / focal_length > MAX_FIELD_TANGENT:
            return (
                f"{path}: focalLength {focal_length:g}{at} is too short for the film: "
                f"(aperture / 2 + |aperture offset|) / focalLength is "
                f"{film_extent / focal_length:g}, above {MAX_FIELD_TANGENT:g} (a field of view "
                "within 0.012 degrees of 180)"
            )
        if not (math.isfinite(focus) and focus >= 0):
            return f"{path}: focusDistance must be a finite number >= 0, not {focus:g}{at}"
        if not thin_lens:
            continue
        if not 0 < focus <= MAX_FOCUS_DISTANCE:
            return (
                f"{path}: focusDistance must be in (0, {MAX_FOCUS_DISTANCE:g}] with depth of "
                f"field (fStop {f_stop:g} > 0), not {focus:g}{at}"
            )
        lens_radius = 0.05 * focal_length / f_stop
        if lens_radius > MAX_LENS_RADIUS:
            return (
                f"{path}: fStop {f_stop:g} is too small for focalLength {focal_length:g}{at}: "
                f"the lens radius, 0.05 * focalLength / fStop, would be {lens_radius:g} units, "
                f"above {MAX_LENS_RADIUS:g}"
            )
    return None


def camera_problem(
    prim: Usd.Prim, time: Usd.TimeCode, shutter: Shutter | None = None
) -> str | None:
    """What makes camera ``prim`` unusable at ``time`` (naming the camera and the attribute),
    or ``None``: every value rays are built from must be finite, lengths positive, the
    clipping range 0 <= near < far, the projection known, the world transform invertible, and
    the film and lens within the bounds above. An animated focal length or focus distance is
    checked over ``shutter``, by default the camera's own (whose ends are checked too), with
    motion blur or without: whether a camera renders does not hang on that setting."""
    camera = UsdGeom.Camera(prim)
    path = prim.GetPath()
    if shutter is None:
        try:
            shutter = read_shutter(prim, time)
        except SceneError as error:
            return str(error)
    projection = str(value_at(camera.GetProjectionAttr(), time))
    if projection not in PROJECTIONS:
        return f"{path}: unknown projection {projection!r} (known: {', '.join(PROJECTIONS)})"
    apertures = (camera.GetHorizontalApertureAttr(), camera.GetVerticalApertureAttr())
    offsets = (camera.GetHorizontalApertureOffsetAttr(), camera.GetVerticalApertureOffsetAttr())
    lens = (camera.GetFStopAttr(), camera.GetFocusDistanceAttr())
    focal = (camera.GetFocalLengthAttr(),) if projection == "perspective" else ()
    exposure = _exposure_scale(camera, time)
    if isinstance(exposure, str):
        return exposure
    for attr in (*apertures, *focal, *offsets, *lens):
        if _number(attr, time) is None:
            return (
                f"{path}: {attr.GetName()} must be a number, not a "
                f"{type(attr.Get(time)).__name__} (a wrong or unknown type in the file)"
            )
    for attr in apertures:
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
    film_extent = 0.0
    for aperture, offset in zip(apertures, offsets):
        extent = _number(aperture, time) / 2 + abs(_number(offset, time))
        if extent > MAX_FILM_EXTENT:
            return (
                f"{path}: {aperture.GetName()} / 2 + |{offset.GetName()}| is {extent:g}, above "
                f"{MAX_FILM_EXTENT:g} (tenths of a unit)"
            )
        film_extent = max(film_extent, extent)
    if focal:
        problem = _lens_problem(camera, time, shutter, film_extent)
        if problem is not None:
            return problem
    clipping = camera.GetClippingRangeAttr()
    try:
        near, far = (float(value) for value in value_at(clipping, time))
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
    if camera_problem(prim, reader.time, reader.shutter) is not None:
        return False
    camera = UsdGeom.Camera(prim)
    path = str(prim.GetPath())
    shutter = reader.shutter
    read = reader.get_or_fallback  # as camera_problem reads: a blocked value is the fallback
    near, far = read(camera.GetClippingRangeAttr())
    focal_attr, focus_attr = camera.GetFocalLengthAttr(), camera.GetFocusDistanceAttr()
    horizontal = float(read(camera.GetHorizontalApertureAttr()))
    vertical = float(read(camera.GetVerticalApertureAttr()))
    horizontal_offset = float(read(camera.GetHorizontalApertureOffsetAttr()))
    vertical_offset = float(read(camera.GetVerticalApertureOffsetAttr()))
    pixel_aspect_ratio = 1.0
    if window is not None:
        horizontal_offset += window.horizontal_shift * horizontal
        vertical_offset += window.vertical_shift * vertical
        horizontal *= window.horizontal_scale
        vertical *= window.vertical_scale
        pixel_aspect_ratio = window.pixel_aspect_ratio
    core.set_camera(
        path,
        focal_length=float(read(focal_attr)),
        horizontal_aperture=horizontal,
        vertical_aperture=vertical,
        horizontal_aperture_offset=horizontal_offset,
        vertical_aperture_offset=vertical_offset,
        pixel_aspect_ratio=pixel_aspect_ratio,
        f_stop=float(read(camera.GetFStopAttr())) if depth_of_field else 0.0,
        focus_distance=float(read(focus_attr)),
        clipping_range=(float(near), float(far)),
        shutter_open=shutter.open,
        shutter_close=shutter.close,
        projection=str(read(camera.GetProjectionAttr())),
        exposure_scale=_exposure_scale(camera, reader.time),
    )
    for attr in _exposure_attributes(camera):
        reader.get(attr)  # notes whether the exposure might vary with time
    lens = (focal_attr, focus_attr)
    if shutter.blurred and any(changes_within(attr, shutter.interval) for attr in lens):
        authored = [t for attr in lens for t in attr.GetTimeSamplesInInterval(shutter.interval)]
        times = shutter.times(shutter.segments(authored))
        focal_lengths, focus_distances = (
            np.array([value_at(attr, time) for time in times], dtype=np.float32) for attr in lens
        )
        core.set_camera_motion(path, focal_lengths, focus_distances)
    return True
