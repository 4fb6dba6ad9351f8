"""Writes examples/dof.usda (depth of field) and examples/motion.usda (motion blur).

Run with the project's Python (`.venv/bin/python examples/camera_effects.py`); the .usda files
are committed, so this is only needed to change the scenes. Render them with
`.venv/bin/penumbra-record examples/dof.usda examples/images/dof.png`.
"""

from __future__ import annotations

from pathlib import Path

from pxr import Gf, Usd, UsdGeom, UsdLux, UsdRender

from showcase import add_floor, bind, new_stage, preview_material, uv_sphere_cage

HERE = Path(__file__).resolve().parent


def new_scene(name: str, end_time: float) -> Usd.Stage:
    """A metre, Y-up stage with a floor, a soft key light and a sky dome."""
    stage = new_stage(name, end_time)
    add_floor(stage, 30, diffuseColor=(0.5, 0.5, 0.48), roughness=0.6)
    key = UsdLux.RectLight.Define(stage, "/World/key")
    key.CreateWidthAttr(4.0)
    key.CreateHeightAttr(4.0)
    key.CreateIntensityAttr(8)
    key.AddTranslateOp().Set(Gf.Vec3d(-2, 6, 3))
    key.AddRotateXOp().Set(-65)
    sky = UsdLux.DomeLight.Define(stage, "/World/sky")
    sky.CreateColorAttr(Gf.Vec3f(0.6, 0.7, 1.0))
    sky.CreateIntensityAttr(0.35)
    return stage


def add_camera(stage: Usd.Stage, eye, tilt: float, focal_mm: float, **lens) -> UsdGeom.Camera:
    """A ``focal_mm`` lens on 36 × 20.25 mm film (metre scene: tenths of a unit), tilted down
    by ``tilt`` degrees; ``lens``: more UsdGeomCamera attributes (name → value)."""
    camera = UsdGeom.Camera.Define(stage, "/cam")
    camera.CreateFocalLengthAttr(focal_mm / 100)
    camera.CreateHorizontalApertureAttr(0.36)
    camera.CreateVerticalApertureAttr(0.2025)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.05, 1000))
    for name, value in lens.items():
        camera.GetPrim().GetAttribute(name).Set(value)
    camera.AddTranslateOp().Set(Gf.Vec3d(*eye))
    camera.AddRotateXOp().Set(-tilt)
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets([camera.GetPath()])
    settings.CreateResolutionAttr(Gf.Vec2i(640, 360))
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    return camera


def dof_scene() -> None:
    """A diagonal row of spheres seen through a 100 mm lens at f/1, the third in focus; small
    lamps far behind turn into disks (circles of confusion)."""
    stage = new_scene("dof", 1)
    colours = [(0.8, 0.15, 0.1), (0.85, 0.55, 0.1), (0.8, 0.8, 0.15), (0.2, 0.7, 0.2),
               (0.15, 0.55, 0.85), (0.45, 0.25, 0.8)]
    for index, colour in enumerate(colours):
        centre = (-0.6 + 0.36 * index, 0.35, 2.0 - 1.6 * index)
        sphere = uv_sphere_cage(stage, f"/World/spheres/sphere_{index}", centre, 0.35)
        look = preview_material(
            stage, f"/World/Looks/sphere_{index}", diffuseColor=colour, roughness=0.3
        )
        bind(sphere.GetPrim(), look)
    lamp_look = preview_material(
        stage, "/World/Looks/lamp", diffuseColor=(0, 0, 0), emissiveColor=(24.0, 16.0, 8.0)
    )
    for index in range(7):
        lamp = uv_sphere_cage(
            stage,
            f"/World/lamps/lamp_{index}",
            (-3 + 0.9 * index, 1.3 + 0.25 * (index % 2), -14),
            0.05,
        )
        bind(lamp.GetPrim(), lamp_look)
    # The third sphere is 8.2 m from the eye: focus there.
    add_camera(stage, (0, 1.2, 7), 4, 100, fStop=1.0, focusDistance=8.2)
    stage.GetRootLayer().Save()


def motion_scene() -> None:
    """Frame 1 with a 180° shutter centred on it ([−0.25, 0.25]): a ball flying to the right
    (translation keys), a turning pinwheel (a rotation key per frame: its balls orbit the
    hub), a ball rising by its velocities, and a static ball for reference."""
    stage = new_scene("motion", 2)
    looks = {
        name: preview_material(stage, f"/World/Looks/{name}", diffuseColor=colour, roughness=0.35)
        for name, colour in (("red", (0.8, 0.12, 0.08)), ("blue", (0.12, 0.3, 0.85)),
                             ("yellow", (0.85, 0.7, 0.1)), ("grey", (0.6, 0.6, 0.6)))
    }
    flyer = uv_sphere_cage(stage, "/World/flyer", (0, 0, 0), 0.35)
    flight = flyer.GetOrderedXformOps()[0].GetAttr()
    flight.Set(Gf.Vec3d(-3.2, 0.35, 0.8), 0)
    flight.Set(Gf.Vec3d(-0.4, 0.35, 0.8), 2)
    bind(flyer.GetPrim(), looks["red"])

    pinwheel = UsdGeom.Xform.Define(stage, "/World/pinwheel")
    pinwheel.AddTranslateOp().Set(Gf.Vec3d(1.4, 1.05, -1.0))
    spin = pinwheel.AddRotateZOp().GetAttr()
    for frame in range(3):
        spin.Set(-40.0 * frame, frame)
    hub = uv_sphere_cage(stage, "/World/pinwheel/hub", (0, 0, 0), 0.12)
    bind(hub.GetPrim(), looks["grey"])
    for index in range(4):
        arm = UsdGeom.Xform.Define(stage, f"/World/pinwheel/arm_{index}")
        arm.AddRotateZOp().Set(90.0 * index)
        ball = uv_sphere_cage(stage, f"/World/pinwheel/arm_{index}/ball", (0.8, 0, 0), 0.18)
        bind(ball.GetPrim(), looks["blue"])

    riser = uv_sphere_cage(stage, "/World/riser", (-0.1, 0.6, 2.0), 0.25)
    riser.CreateVelocitiesAttr([Gf.Vec3f(0, 14.0, 0)] * len(riser.GetPointsAttr().Get()))
    bind(riser.GetPrim(), looks["yellow"])

    still = uv_sphere_cage(stage, "/World/still", (-0.9, 0.3, -2.5), 0.3)
    bind(still.GetPrim(), looks["grey"])

    camera = add_camera(stage, (0, 1.6, 6.5), 8, 50)
    camera.CreateShutterOpenAttr(-0.25)
    camera.CreateShutterCloseAttr(0.25)
    stage.GetRootLayer().Save()


if __name__ == "__main__":
    dof_scene()
    motion_scene()
