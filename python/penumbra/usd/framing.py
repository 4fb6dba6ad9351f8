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

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom

from . import curves, points

FRAMING_CAMERA_PATH = Sdf.Path("/PenumbraFramingCamera")


def framing_camera(stage: Usd.Stage, time: Usd.TimeCode, purposes: Iterable[str]) -> Usd.Prim | None:
    """A camera (in the session layer) placed as usdrecord places it
    (``UsdAppUtilsFrameRecorder``'s ``_ComputeCameraToFrameStage``): GfCamera's default lens,
    film and clipping range, looking along the stage's horizontal axis with its up axis up, back
    from the bounds' centre by the distance at which half their diagonal across the image plane
    fills half the horizontal field of view, plus half their depth; ``None`` when there is
    nothing to frame."""
    cache = UsdGeom.BBoxCache(time, [UsdGeom.Tokens.default_, *purposes], useExtentsHint=True)
    bounds = cache.ComputeWorldBound(stage.GetPseudoRoot()).ComputeAlignedRange()
    for grown in _default_width_bounds(stage, cache, time):
        bounds.UnionWith(grown)
    if bounds.IsEmpty():
        return None
    # The aligned range's midpoint is usdrecord's centroid of the world bound (an affine
    # image of a box is centred on the image of its centre).
    centre, size = bounds.GetMidpoint(), bounds.GetSize()
    z_up = UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
    across, up, depth = (size[0], size[2], size[1]) if z_up else (size[0], size[1], size[2])
    gf_camera = Gf.Camera()
    # Rounded to single precision where usdrecord stores floats (its arithmetic is in double),
    # so that the placement is its own to the bit.
    plane_radius = float(np.float32(math.sqrt((across / 2) ** 2 + (up / 2) ** 2)))
    half_fov = float(np.float32(gf_camera.GetFieldOfView(Gf.Camera.FOVHorizontal) / 2))
    distance = np.float32(plane_radius / math.tan(math.radians(half_fov)))
    distance = np.float32(float(distance) + depth / 2)
    near = np.float32(gf_camera.clippingRange.min)
    if distance < near:  # usdrecord backs small scenes off so the near plane cannot cut them
        distance = distance + near  # in float, as usdrecord's
    if z_up:
        transform = Gf.Matrix4d().SetRotate(Gf.Rotation(Gf.Vec3d(1, 0, 0), 90))
        transform.SetTranslateOnly(centre - Gf.Vec3d(0, float(distance), 0))
    else:
        transform = Gf.Matrix4d().SetTranslate(centre + Gf.Vec3d(0, 0, float(distance)))
    gf_camera.transform = transform
    with Usd.EditContext(stage, stage.GetSessionLayer()):
        camera = UsdGeom.Camera.Define(stage, FRAMING_CAMERA_PATH)
        # Every lens, film and clipping value authored from the GfCamera, not the schema's
        # fallbacks (which match it today).
        camera.SetFromCamera(gf_camera, Usd.TimeCode.Default())
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
