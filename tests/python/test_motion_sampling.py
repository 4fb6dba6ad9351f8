"""Which motion samples the scene delegate sends (no rendering unless stated), and incremental
sync over changes of frame, shutter and the disable switches."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom

import penumbra
from penumbra.usd.camera import sync_camera
from penumbra.usd.motion import XformCaches, point_samples, transform_samples
from penumbra.usd.sampling import SampleReader, Shutter
from stages import add_camera, add_quad, lit_quad_stage, new_stage
from test_api import sync_counts

FRAME = Usd.TimeCode(1.0)
SHUTTER = Shutter(FRAME, 0.0, 1.0)
FAST = dict(camera="/cam", width=16, samples=1)


@pytest.mark.parametrize(
    "authored, segments",
    [
        ([], 1),
        ([1.0, 2.0], 1),  # the ends are sampled anyway
        ([1.5], 2),
        ([1.25, 1.5], 4),
        ([0.0, 1.3, 3.0], 10),  # outside the shutter: ignored
        ([1.1234], 16),  # on no grid up to the maximum
    ],
)
def test_segments_form_the_smallest_uniform_grid_holding_the_keys(authored, segments):
    assert SHUTTER.segments(authored) == segments


def test_shutter_times():
    assert [t.GetValue() for t in Shutter(Usd.TimeCode(1.5), -0.5, 0.5).times(4)] == [
        1.0,
        1.25,
        1.5,
        1.75,
        2.0,
    ]
    assert Shutter(FRAME).times(4) == [FRAME]  # closed shutter: the frame alone
    assert Shutter(Usd.TimeCode.Default(), 0.0, 1.0).times(4) == [Usd.TimeCode.Default()]


def keyed_stage(op: str, keys: dict[float, object], parent: bool = False) -> Usd.Stage:
    """A stage with /group/prim, animated by an op of type ``op`` with the given keys (or,
    with ``parent``, a child 0.5 along X of /group so animated)."""
    stage = new_stage()
    animated = UsdGeom.Xform.Define(stage, "/group" if parent else "/group/prim")
    attr = getattr(animated, f"Add{op}Op")().GetAttr()
    for time, value in keys.items():
        attr.Set(value, time)
    if parent:
        UsdGeom.Xform.Define(stage, "/group/prim").AddTranslateOp().Set(Gf.Vec3d(0.5, 0, 0))
    return stage


@pytest.mark.parametrize(
    "op, keys, parent, count",
    [
        ("Translate", {1.0: Gf.Vec3d(0, 0, 0)}, False, 1),  # static
        ("Translate", {1.0: Gf.Vec3d(0, 0, 0), 2.0: Gf.Vec3d(1, 0, 0)}, False, 2),
        ("Translate", {1.0: Gf.Vec3d(0, 0, 0), 1.25: Gf.Vec3d(1, 0, 0), 2.0: Gf.Vec3d()}, True, 5),
        ("Translate", {0.0: Gf.Vec3d(1, 0, 0), 1.0: Gf.Vec3d(1, 0, 0)}, False, 1),  # held
        ("RotateZ", {1.0: 0.0, 2.0: 90.0}, False, 2),  # about its own origin: slerp's arc
        ("RotateZ", {1.0: 0.0, 2.0: 90.0}, True, 9),  # an orbit: 11.25° steps
        ("RotateZ", {1.0: 0.0, 2.0: 360.0}, False, 5),  # a whole turn: 90° steps
        ("RotateZ", {1.0: 0.0, 2.0: 1080.0}, False, 17),  # three turns: as many as allowed
    ],
)
def test_transform_sample_counts(op, keys, parent, count):
    stage = keyed_stage(op, keys, parent)  # kept: prims do not keep their stage alive
    samples = transform_samples(stage.GetPrimAtPath("/group/prim"), SHUTTER, XformCaches())
    assert samples.shape == ((4, 4) if count == 1 else (count, 4, 4))


def test_transform_samples_are_world_matrices_at_uniform_times():
    stage = keyed_stage("Translate", {1.0: Gf.Vec3d(0, 0, 0), 2.0: Gf.Vec3d(4, 0, 0)}, True)
    prim = stage.GetPrimAtPath("/group/prim")
    samples = transform_samples(prim, Shutter(FRAME, 0.25, 0.75), XformCaches())
    np.testing.assert_allclose(samples[:, 3, :3], [[1.5, 0, 0], [3.5, 0, 0]])
    assert transform_samples(prim, Shutter(FRAME), XformCaches())[3, 0] == 0.5
    assert transform_samples(prim, Shutter(FRAME, 0, 1, max_segments=1), XformCaches()).shape == (
        2,
        4,
        4,
    )


def point_stage(time_codes_per_second: float = 24.0) -> Usd.Stage:
    """A stage with the quad /quad."""
    stage = new_stage()
    stage.SetTimeCodesPerSecond(time_codes_per_second)
    add_quad(stage, "/quad")
    return stage


def samples_of(mesh: UsdGeom.Mesh, shutter: Shutter = SHUTTER, warnings=None) -> np.ndarray:
    reader = SampleReader(shutter.frame, shutter)
    at_frame = np.asarray(mesh.GetPointsAttr().Get(shutter.frame), dtype=np.float32)
    collect = warnings.append if warnings is not None else pytest.fail
    return point_samples(mesh, at_frame, reader, collect, str(mesh.GetPath()))


def test_deformation_samples_follow_authored_points():
    stage = point_stage()
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/quad"))
    rest = np.array(mesh.GetPointsAttr().Get())
    for time, dx in ((1.0, 0.0), (1.5, 1.0), (2.0, 0.0)):
        mesh.GetPointsAttr().Set((rest + (dx, 0, 0)).tolist(), time)
    samples = samples_of(mesh)
    assert samples.shape == (3, 4, 3) and samples.dtype == np.float32
    np.testing.assert_allclose(samples[:, 0, 0] - rest[0, 0], [0, 1, 0])


def test_topology_change_within_shutter_uses_frame_and_warns_once_per_prim():
    stage = point_stage()
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/quad"))
    rest = np.array(mesh.GetPointsAttr().Get())
    mesh.GetPointsAttr().Set(rest.tolist(), 1.0)
    mesh.GetPointsAttr().Set((rest + 1).tolist(), 2.0)
    mesh.GetFaceVertexIndicesAttr().Set([0, 1, 2, 3], 1.0)
    mesh.GetFaceVertexIndicesAttr().Set([3, 2, 1, 0], 1.5)
    warnings: list[str] = []
    samples = samples_of(mesh, warnings=warnings)
    np.testing.assert_array_equal(samples, rest)
    assert warnings == [
        "/quad: the point count or topology changes within the shutter; deformation motion "
        "blur ignored (points at the frame used)"
    ]


def test_velocities_and_accelerations_use_time_codes_per_second():
    stage = point_stage(time_codes_per_second=10.0)
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/quad"))
    rest = np.array(mesh.GetPointsAttr().Get())
    mesh.GetPointsAttr().Set(rest.tolist(), 0.0)  # t0 = 0: the sample before the frame
    mesh.CreateVelocitiesAttr([Gf.Vec3f(1, 0, 0)] * 4)
    samples = samples_of(mesh)
    # Δ = (t − 0) / 10 s for t = 1, 2.
    np.testing.assert_allclose(samples[:, 0, 0] - rest[0, 0], [0.1, 0.2], rtol=1e-6)
    mesh.CreateAccelerationsAttr([Gf.Vec3f(0, 20, 0)] * 4)
    samples = samples_of(mesh)
    delta = np.linspace(1, 2, 5) / 10
    assert samples.shape == (5, 4, 3)
    np.testing.assert_allclose(samples[:, 0, 1] - rest[0, 1], 0.5 * 20 * delta**2, rtol=1e-5)
    np.testing.assert_array_equal(samples_of(mesh, Shutter(FRAME)), rest)  # no blur


@pytest.mark.parametrize("in_step", [True, False])
def test_keyed_points_move_by_velocities_sampled_with_them_as_usd_core_does(in_step):
    """Points keyed within the shutter move by their velocities (and accelerations) when those
    are sampled at the points' times, as usd-core's ComputePointsAtTimes has it; velocities
    authored otherwise leave the keys interpolated, with a warning."""
    stage = point_stage()
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/quad"))
    rest = np.array(mesh.GetPointsAttr().Get())
    up, fall = [Gf.Vec3f(0, 12, 0)] * 4, [Gf.Vec3f(0, 0, -24)] * 4  # units/s, units/s²
    for time, dx in ((1.0, 0.0), (2.0, 1.0)):  # the keys: one unit along +X
        mesh.GetPointsAttr().Set((rest + (dx, 0, 0)).tolist(), time)
        mesh.CreateAccelerationsAttr().Set(fall, time)
        if in_step:
            mesh.CreateVelocitiesAttr().Set(up, time)
    if not in_step:
        mesh.CreateVelocitiesAttr(up)
    warnings: list[str] = []
    samples = samples_of(mesh, warnings=warnings)
    usd = mesh.ComputePointsAtTimes(SHUTTER.times(len(samples) - 1), FRAME)
    np.testing.assert_allclose(samples, np.asarray(usd), atol=1e-6)
    # At shutter close (1/24 s after the key): ½ unit up, ½·24/24² below; or the next key.
    moved = (0, 0.5, -0.5 / 24) if in_step else (1, 0, 0)
    np.testing.assert_allclose(samples[-1] - rest, [moved] * 4, atol=1e-6)
    ignored = "/quad: velocities are not sampled at the times of the points' samples; the points"
    assert warnings == ([] if in_step else [f"{ignored} are interpolated instead"])


def test_mismatched_velocities_are_ignored_with_a_warning():
    stage = point_stage()
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/quad"))
    mesh.CreateVelocitiesAttr([Gf.Vec3f(1, 0, 0)] * 3)
    warnings: list[str] = []
    assert samples_of(mesh, warnings=warnings).shape == (4, 3)
    assert warnings == ["/quad: 3 velocities for 4 points; ignored"]


class Recorder:
    """Stands in for the render delegate: records the calls made to it."""

    def __init__(self) -> None:
        self.calls: dict[str, tuple] = {}

    def __getattr__(self, name: str):
        return lambda *args, **kwargs: self.calls.__setitem__(name, (args, kwargs))


def test_animated_lens_is_sampled_over_the_shutter():
    stage = new_stage()
    camera = add_camera(stage)
    camera.CreateFStopAttr(2.8)
    camera.GetFocalLengthAttr().Set(5.0, 1.0)
    camera.GetFocalLengthAttr().Set(7.0, 2.0)
    camera.CreateFocusDistanceAttr(3.0)
    core = Recorder()
    sync_camera(core, camera.GetPrim(), SampleReader(FRAME, SHUTTER))
    args, _ = core.calls["set_camera_motion"]
    np.testing.assert_allclose(args[1], [5.0, 7.0])
    np.testing.assert_allclose(args[2], [3.0, 3.0])
    assert core.calls["set_camera"][1]["f_stop"] == pytest.approx(2.8)
    core = Recorder()
    sync_camera(core, camera.GetPrim(), SampleReader(FRAME, Shutter(FRAME)), depth_of_field=False)
    assert "set_camera_motion" not in core.calls
    assert core.calls["set_camera"][1]["f_stop"] == 0.0


def resynced(renderer: penumbra.Renderer, **options) -> set[str]:
    before = sync_counts(renderer)
    renderer.render(**{**FAST, **options})
    after = sync_counts(renderer)
    return {prim_id for prim_id in after if after[prim_id] != before.get(prim_id)}


def test_shutter_and_switch_changes_resync_only_what_depends_on_them():
    stage = lit_quad_stage()
    mover = add_quad(stage, "/World/mover", half_size=0.2)
    translate = mover.GetOrderedXformOps()[0].GetAttr()
    translate.Set(Gf.Vec3d(0, 0, 0.1), 1.0)
    translate.Set(Gf.Vec3d(1, 0, 0.1), 2.0)
    streaming = add_quad(stage, "/World/streaming", center=(0, 1, 0.1), half_size=0.2)
    streaming.CreateVelocitiesAttr([Gf.Vec3f(24, 0, 0)] * 4)  # static data, moves with time
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/cam"))
    other = add_camera(stage, "/other")
    other.CreateShutterCloseAttr(0.5)
    renderer = penumbra.Renderer(stage)
    renderer.render(**FAST)
    moving = {"/World/mover", "/World/streaming"}

    assert resynced(renderer) == set()
    camera.CreateShutterCloseAttr(1.0)
    assert resynced(renderer) == moving | {"/cam", "/other"}  # cameras: the shutter they use
    assert resynced(renderer, disable_motion_blur=True) == moving | {"/cam", "/other"}
    assert resynced(renderer, disable_motion_blur=True, disable_depth_of_field=True) == {
        "/cam",
        "/other",
    }
    assert resynced(renderer) == moving | {"/cam", "/other"}
    assert resynced(renderer, camera="/other") == moving | {"/cam", "/other"}
    assert resynced(renderer, camera="/other", time=2.0) == moving
    assert renderer.render(**{**FAST, "time": 2.0}).metadata["shutterClose"] == 1.0


def test_renderer_rejects_a_maximum_below_one_segment():
    with pytest.raises(ValueError, match="max_motion_segments"):
        penumbra.Renderer(new_stage(), max_motion_segments=0)


def test_render_settings_flags_are_read():
    stage = new_stage()
    settings = stage.DefinePrim("/Render/Settings", "RenderSettings")
    settings.CreateAttribute("disableMotionBlur", Sdf.ValueTypeNames.Bool).Set(True)
    read = penumbra.usd.read_render_settings(stage, "/Render/Settings")
    assert read.disable_motion_blur and not read.disable_depth_of_field
