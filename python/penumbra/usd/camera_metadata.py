"""The camera facts an EXR carries: OIIO's ``worldtocamera`` and ``worldtoscreen`` matrices and
the lens (docs/aovs.md, "Metadata")."""

from __future__ import annotations

from pxr import Gf, Usd, UsdGeom

from .sampling import value_at
from .settings import conform_aperture


def camera_metadata(
    camera: Usd.Prim,
    time: Usd.TimeCode,
    width: int,
    height: int,
    policy: str = "expandAperture",
    pixel_aspect_ratio: float = 1.0,
) -> dict[str, object]:
    """``worldtocamera`` (world to USD camera space, which looks down −Z) and ``worldtoscreen``
    (on to the [−1, 1] screen window of the aperture fitted to a ``width`` × ``height`` image by
    ``policy``), as 4x4 row-major tuples in OIIO's row-vector convention (Gf's), the pixels'
    width over their height as rendered (``PixelAspectRatio``, OpenEXR's: a compositor shows
    anamorphic pixels by it; ``pixel_aspect_ratio`` unless ``policy`` adjusts it), and the
    camera's fStop, focusDistance and shutter."""
    geom = UsdGeom.Camera(camera)
    gf_camera = geom.GetCamera(time)
    # adjustPixelAspectRatio renders pixels of the aperture's aspect over the image's, not
    # the settings' ratio: the file must say the one rendered.
    (aperture_width, aperture_height), rendered_pixel_aspect_ratio = conform_aperture(
        policy,
        (width, height),
        pixel_aspect_ratio,
        (gf_camera.horizontalAperture, gf_camera.verticalAperture),
    )
    gf_camera.horizontalAperture = aperture_width
    gf_camera.verticalAperture = aperture_height
    frustum = gf_camera.frustum
    world_to_camera = frustum.ComputeViewMatrix()
    world_to_screen = world_to_camera * frustum.ComputeProjectionMatrix()
    return {
        "worldtocamera": _row_major(world_to_camera),
        "worldtoscreen": _row_major(world_to_screen),
        "PixelAspectRatio": float(rendered_pixel_aspect_ratio),
        # Read as the camera was (camera_problem passed them): a value blocked at ``time``
        # is the fallback, where Get answers None.
        "fStop": float(value_at(geom.GetFStopAttr(), time)),
        "focusDistance": float(value_at(geom.GetFocusDistanceAttr(), time)),
    }


def _row_major(matrix: Gf.Matrix4d) -> tuple[float, ...]:
    return tuple(float(matrix[row][column]) for row in range(4) for column in range(4))
