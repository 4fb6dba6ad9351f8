"""A camera framing the stage, for stages without one (as usdrecord frames them).

The framing camera is authored in the stage's session layer, so the user's layers are never
touched and the scene delegate picks it up like any other camera. (The default light of a stage
without lights is in :mod:`.default_light`.)
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from pxr import Gf, Sdf, Usd, UsdGeom

FRAMING_CAMERA_PATH = Sdf.Path("/PenumbraFramingCamera")


def framing_camera(stage: Usd.Stage, time: Usd.TimeCode, purposes: Iterable[str]) -> Usd.Prim | None:
    """A camera (in the session layer) that sees the stage's bounds whole, looking along the
    stage's horizontal axis with its up axis up; ``None`` when there is nothing to frame."""
    cache = UsdGeom.BBoxCache(time, [UsdGeom.Tokens.default_, *purposes], useExtentsHint=True)
    bounds = cache.ComputeWorldBound(stage.GetPseudoRoot()).ComputeAlignedRange()
    if bounds.IsEmpty():
        return None
    centre = bounds.GetMidpoint()
    radius = max(bounds.GetSize().GetLength() / 2, 1e-6)
    with Usd.EditContext(stage, stage.GetSessionLayer()):
        camera = UsdGeom.Camera.Define(stage, FRAMING_CAMERA_PATH)
        # The fallback 50 mm lens on the fallback 20.955 x 15.2908 mm film: fit the bounding
        # sphere in the narrower (vertical) half angle.
        focal = camera.GetFocalLengthAttr().Get()
        half_angle = math.atan(camera.GetVerticalApertureAttr().Get() / 2 / focal)
        distance = radius / math.sin(half_angle)
        camera.CreateClippingRangeAttr(Gf.Vec2f(max(distance - 2 * radius, distance * 1e-3), distance + 2 * radius))
        if UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z:
            # Look along +Y with +Z up.
            rotation = Gf.Matrix4d(1, 0, 0, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 1)
            eye = centre - Gf.Vec3d(0, distance, 0)
        else:
            rotation = Gf.Matrix4d(1)
            eye = centre + Gf.Vec3d(0, 0, distance)
        camera.MakeMatrixXform().Set(rotation * Gf.Matrix4d().SetTranslate(eye))
    return camera.GetPrim()
