"""A camera framing the stage, for stages without one (as usdrecord frames them).

The framing camera is authored in the stage's session layer, so the user's layers are never
touched and the scene delegate picks it up like any other camera. The bounds are UsdGeom's,
which include points' and curves' widths where they are authored; where they are not, the
width they render with (:data:`~.points.DEFAULT_WIDTH`, :data:`~.curves.DEFAULT_WIDTH`) is
added. (The default light of a stage without lights is in :mod:`.default_light`.)
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from pxr import Gf, Sdf, Usd, UsdGeom

from . import curves, points

FRAMING_CAMERA_PATH = Sdf.Path("/PenumbraFramingCamera")


def framing_camera(stage: Usd.Stage, time: Usd.TimeCode, purposes: Iterable[str]) -> Usd.Prim | None:
    """A camera (in the session layer) that sees the stage's bounds whole, looking along the
    stage's horizontal axis with its up axis up; ``None`` when there is nothing to frame."""
    cache = UsdGeom.BBoxCache(time, [UsdGeom.Tokens.default_, *purposes], useExtentsHint=True)
    bounds = cache.ComputeWorldBound(stage.GetPseudoRoot()).ComputeAlignedRange()
    for grown in _default_width_bounds(stage, cache, time):
        bounds.UnionWith(grown)
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


def _default_width_bounds(
    stage: Usd.Stage, cache: UsdGeom.BBoxCache, time: Usd.TimeCode
) -> Iterable[Gf.Range3d]:
    """World bounds of the visible points and curves without authored widths (instance proxies
    included; point-instancer prototypes are the instancer's bound; the cache's purposes apply),
    grown by half the width they render with (their extent, from their positions alone, leaves
    it out)."""
    walk = iter(Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies()))
    for prim in walk:
        imageable = UsdGeom.Imageable(prim)
        if prim.IsA(UsdGeom.PointInstancer) or (
            imageable and imageable.GetVisibilityAttr().Get(time) == UsdGeom.Tokens.invisible
        ):
            walk.PruneChildren()
            continue
        if prim.IsA(UsdGeom.Points):
            width = points.DEFAULT_WIDTH
        elif prim.IsA(UsdGeom.Curves):
            width = curves.DEFAULT_WIDTH
        else:
            continue
        widths = UsdGeom.PrimvarsAPI(prim).GetPrimvar(UsdGeom.Tokens.widths)
        if prim.GetAttribute(UsdGeom.Tokens.widths).HasAuthoredValue() or (
            widths and widths.HasAuthoredValue()
        ):
            continue
        local = cache.ComputeUntransformedBound(prim).ComputeAlignedRange()
        if local.IsEmpty():
            continue
        half = Gf.Vec3d(width / 2)
        local = Gf.Range3d(local.GetMin() - half, local.GetMax() + half)
        world = UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(time)
        yield Gf.BBox3d(local, world).ComputeAlignedRange()
