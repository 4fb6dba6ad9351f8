"""UsdGeomCamera → the render delegate's ``camera`` sprim (USD units, see DESIGN §3)."""

from __future__ import annotations

from pxr import Usd, UsdGeom

from .sampling import SampleReader


def sync_camera(core, prim: Usd.Prim, reader: SampleReader) -> None:
    """Push the projection, apertures, lens and shutter of camera ``prim`` to ``core``."""
    camera = UsdGeom.Camera(prim)
    near, far = reader.get(camera.GetClippingRangeAttr())
    core.set_camera(
        str(prim.GetPath()),
        focal_length=float(reader.get(camera.GetFocalLengthAttr())),
        horizontal_aperture=float(reader.get(camera.GetHorizontalApertureAttr())),
        vertical_aperture=float(reader.get(camera.GetVerticalApertureAttr())),
        horizontal_aperture_offset=float(reader.get(camera.GetHorizontalApertureOffsetAttr())),
        vertical_aperture_offset=float(reader.get(camera.GetVerticalApertureOffsetAttr())),
        f_stop=float(reader.get(camera.GetFStopAttr())),
        focus_distance=float(reader.get(camera.GetFocusDistanceAttr())),
        clipping_range=(float(near), float(far)),
        shutter_open=float(reader.get(camera.GetShutterOpenAttr())),
        shutter_close=float(reader.get(camera.GetShutterCloseAttr())),
        projection=str(reader.get(camera.GetProjectionAttr())),
    )
