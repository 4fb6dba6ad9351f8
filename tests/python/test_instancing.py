"""UsdGeomPointInstancer: copies of prototypes placed by positions, orientations, scales and
protoIndices, masked by invisibleIds, sharing one BVH per prototype mesh."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux, Vt

import penumbra
from measure import centroid, intensity
from stages import (
    add_camera,
    add_distant_light,
    add_emissive_sphere,
    add_preview_material,
    add_quad,
    assert_live_edit_renders_as_fresh,
    bind,
    bind_through_a_collection,
    covers,
    emitter_stage,
    new_stage,
    render_with_warnings,
)

SMALL = dict(camera="/cam", width=40, samples=1)
ORBIT = dict(camera="/cam", width=128, samples=16, max_path_depth=0)  # emitters on black


def instancer_stage():
    """Two prototypes (a red and a blue quad, each a quarter unit wide) placed by a point
    instancer; the camera sees the square [-2, 2]² of the z = 0 plane."""
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    instancer = UsdGeom.PointInstancer.Define(stage, "/World/copies")
    UsdGeom.Xform.Define(stage, "/World/copies/Prototypes")
    for name, color in (("red", (1, 0, 0)), ("blue", (0, 0, 1))):
        quad = add_quad(stage, f"/World/copies/Prototypes/{name}/quad", half_size=0.125)
        bind(quad, add_preview_material(stage, f"/World/Looks/{name}", diffuseColor=color))
        instancer.GetPrototypesRel().AddTarget(f"/World/copies/Prototypes/{name}")
    instancer.CreatePositionsAttr(Vt.Vec3fArray([(-1, 1, 0), (1, 1, 0), (-1, -1, 0), (1, -1, 0)]))
    instancer.CreateProtoIndicesAttr(Vt.IntArray([0, 1, 1, 0]))
    return stage, instancer


def color_at(image, x: float, y: float):
    """Pixel colour at plane point (x, y) for the 40x40 view of [-2, 2]²."""
    height, width = image["color"].shape[:2]
    column = int((x + 2) / 4 * width)
    row = int((2 - y) / 4 * height)
    return image["color"][row, column]


def test_copies_follow_positions_and_proto_indices():
    stage, _ = instancer_stage()
    renderer = penumbra.Renderer(stage)
    image = renderer.render(**SMALL)
    # Diffuse red and blue under a white specular layer.
    red, blue = color_at(image, -1, 1), color_at(image, 1, 1)
    assert red[0] > 5 * red[2] and blue[2] > 5 * blue[0]
    assert color_at(image, -1, -1)[2] > 5 * color_at(image, -1, -1)[0]
    assert color_at(image, 0, 0)[3] == 0  # the prototypes themselves do not render
    # Only two meshes in the delegate, however many copies.
    meshes = [p for p in renderer.delegate.prim_ids() if "/prototypes/" in p]
    assert len(meshes) == 2


def test_orientations_scales_and_invisible_ids():
    stage, instancer = instancer_stage()
    # Scale the first copy by 4 and hide the second; turn the third a quarter about Z.
    instancer.CreateScalesAttr(Vt.Vec3fArray([(4, 4, 1), (1, 1, 1), (1, 1, 1), (1, 1, 1)]))
    instancer.CreateInvisibleIdsAttr(Vt.Int64Array([1]))
    instancer.CreateOrientationsAttr(
        Vt.QuathArray([Gf.Quath(1), Gf.Quath(1), Gf.Quath(0.7071, 0, 0, 0.7071), Gf.Quath(1)])
    )
    image = penumbra.Renderer(stage).render(**SMALL)
    assert color_at(image, -1 + 0.4, 1 + 0.4)[3] == 1  # inside the scaled copy (half size 0.5)
    assert color_at(image, 1, 1)[3] == 0  # invisibleIds
    assert color_at(image, -1, -1)[3] == 1


def test_edits_resync_the_instancer_and_bad_indices_warn():
    stage, instancer = instancer_stage()
    renderer = penumbra.Renderer(stage)
    renderer.render(**SMALL)
    instancer.GetPositionsAttr().Set(Vt.Vec3fArray([(0, 0, 0), (1, 1, 0), (-1, -1, 0), (1, -1, 0)]))
    image = renderer.render(**SMALL)
    assert color_at(image, 0, 0)[3] == 1 and color_at(image, -1, 1)[3] == 0
    instancer.GetProtoIndicesAttr().Set(Vt.IntArray([0, 1, 7, 0]))
    with pytest.warns(penumbra.PenumbraWarning, match="/World/copies: 1 protoIndices are out of range"):
        image = renderer.render(**SMALL)
    assert image["color"][..., 3].max() == 0


def test_copies_blur_along_their_velocities():
    stage, instancer = instancer_stage()
    # Shutter [0, 1] at frame 1 (24 time codes per second): 24 units/s moves a copy 1 unit.
    UsdGeom.Camera.Get(stage, "/cam").CreateShutterCloseAttr(1.0)
    instancer.CreateVelocitiesAttr(Vt.Vec3fArray([(24, 0, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0)]))
    renderer = penumbra.Renderer(stage)
    blurred = renderer.render(camera="/cam", width=40, samples=16)
    # The first copy sweeps from x = -1 to x = 0; the others stay sharp.
    for x in (-0.9, -0.5, -0.1):
        assert color_at(blurred, x, 1)[3] > 0.1
    assert color_at(blurred, 0.3, 1)[3] == 0
    sharp = renderer.render(**SMALL, disable_motion_blur=True)
    assert color_at(sharp, -0.5, 1)[3] == 0 and color_at(sharp, -1, 1)[3] == 1


def orbit_stage(turns: dict[float, float], spin: float = 0.0, shutter_close: float = 0.0):
    """One copy at (0, 0, -10) of an emissive ball (radius 0.25) 1 unit along +X of its
    prototype's origin, turned about Z by ``orientationsf`` (float quaternions) keyed ``turns``
    (degrees by time code) and spun by ``spin`` angularVelocities (degrees per second, 24 time
    codes per second, keyed with the first turn); the camera at the origin sees the copy's
    position at the image centre."""
    stage = emitter_stage()
    stage.SetEndTimeCode(2)
    camera = add_camera(stage, translate=(0, 0, 0), focal_length=50.0, aperture=(36.0, 36.0))
    camera.CreateShutterCloseAttr(shutter_close)
    instancer = UsdGeom.PointInstancer.Define(stage, "/orbit")
    add_emissive_sphere(stage, "/orbit/Prototypes/ball", (1, 0, 0), 0.25)
    instancer.CreatePrototypesRel().SetTargets(["/orbit/Prototypes/ball"])
    instancer.CreateProtoIndicesAttr(Vt.IntArray([0]))
    instancer.CreatePositionsAttr(Vt.Vec3fArray([(0, 0, -10)]))
    orientations = instancer.CreateOrientationsfAttr()
    for time, degrees in turns.items():
        turn = Gf.Quatf(Gf.Rotation(Gf.Vec3d(0, 0, 1), degrees).GetQuat())
        orientations.Set(Vt.QuatfArray([turn]), time)
    if spin:
        instancer.CreateAngularVelocitiesAttr().Set(Vt.Vec3fArray([(0, 0, spin)]), min(turns))
    return stage


def ball_angle(image) -> float:
    """The direction of the light's centroid from the image centre (degrees from +X, counter-
    clockwise): half the swept angle for a ball turning at a steady rate from 0."""
    weights = intensity(image)
    x, y = centroid(weights)
    height, width = weights.shape
    return math.degrees(math.atan2(height / 2 - y, x - width / 2))


def test_keyed_orientationsf_turn_copies_within_and_across_frames():
    renderer = penumbra.Renderer(orbit_stage({1.0: 0.0, 2.0: 90.0}, shutter_close=1.0))
    # Frame 1 sweeps the quarter turn over its shutter [1, 2]; frame 2 holds the last key.
    assert ball_angle(renderer.render(time=1.0, **ORBIT)) == pytest.approx(45, abs=2)
    assert ball_angle(renderer.render(time=2.0, **ORBIT)) == pytest.approx(90, abs=2)


def test_angular_velocities_spin_keyed_orientationsf_once():
    # usd-core spins time-sampled orientationsf itself: 2160°/s at 24 time codes per second
    # over the shutter [0, 0.5] sweeps 45°, not twice that.
    stage = orbit_stage({1.0: 0.0}, spin=2160.0, shutter_close=0.5)
    image = penumbra.Renderer(stage).render(time=1.0, **ORBIT)
    assert ball_angle(image) == pytest.approx(22.5, abs=2)


def test_id_aovs_tell_copies_apart():
    stage, _ = instancer_stage()
    # Ids keep the sample nearest each pixel's centre: with 8, one lies well inside the copy.
    image = penumbra.Renderer(stage).render(aovs=("primId", "instanceId"), **{**SMALL, "samples": 8})
    manifest = json.loads(image.metadata["primIds"])

    def ids_at(x: float, y: float) -> tuple[str | None, int]:
        pixel = {name: int(ids[..., 0][int((2 - y) / 4 * 40), int((x + 2) / 4 * 40)])
                 for name, ids in image.items()}  # fmt: skip
        return manifest.get(str(pixel["primId"])), pixel["instanceId"]

    copies = [ids_at(x, y) for x, y in ((-1, 1), (1, 1), (-1, -1), (1, -1))]
    # primId: the prototype mesh (red, blue, blue, red); instanceId: the copy of it.
    assert [path.rsplit("/", 1)[-1] for path, _ in copies] == ["red", "blue", "blue", "red"]
    assert len(set(copies)) == 4 and all(copy >= 0 for _, copy in copies)
    assert ids_at(0, 0) == (None, -1)  # nothing there


def hidden_prototypes_stage(how: str):
    """Copies at (±1, 0.5) of a quad prototype in a group ``Protos`` (under the instancer, or
    outside it, translated to (0, -1) where it would show itself), which ``how`` hides in place:
    "invisible", "outside invisible", "outside class"; "" for a visible group in the instancer."""
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    group = "/World/Protos" if how.startswith("outside") else "/World/copies/Protos"
    UsdGeom.Xform.Define(stage, group).AddTranslateOp().Set(Gf.Vec3d(0, -1, 0))
    UsdGeom.Xform.Define(stage, f"{group}/tile")
    add_quad(stage, f"{group}/tile/quad", half_size=0.4)
    instancer = UsdGeom.PointInstancer.Define(stage, "/World/copies")
    instancer.CreatePrototypesRel().SetTargets([f"{group}/tile"])
    instancer.CreatePositionsAttr(Vt.Vec3fArray([(-1, 0.5, 0), (1, 0.5, 0)]))
    instancer.CreateProtoIndicesAttr(Vt.IntArray([0, 0]))
    if how.endswith("invisible"):
        UsdGeom.Imageable(stage.GetPrimAtPath(group)).MakeInvisible()
    elif how.endswith("class"):
        stage.GetPrimAtPath(group).SetSpecifier(Sdf.SpecifierClass)
    return stage


@pytest.mark.parametrize("how", ["invisible", "outside invisible", "outside class"])
def test_prototypes_hidden_in_place_still_have_their_copies(how: str):
    """As in UsdImaging, a copy's visibility counts from its prototype root down (and the
    instancer's), and prototypes may be abstract: an invisible or ``class`` group above the
    prototypes hides them in place, not their copies."""
    image, messages = render_with_warnings(hidden_prototypes_stage(how), 40)
    expected, _ = render_with_warnings(hidden_prototypes_stage(""), 40)
    assert messages == []
    assert covers(expected, -1, 0.5) and covers(expected, 1, 0.5) and not covers(expected, 0, -1)
    assert np.array_equal(image, expected)


def sliding_prototype_stage(instanced: bool):
    """Two copies, at (-1.5, ±1), of a quad whose prototype root slides 1 unit along +X over
    the shutter [1, 2] (a keyed translate): by a point instancer, or as plain prims."""
    stage = new_stage()
    stage.SetEndTimeCode(2)
    add_camera(stage).CreateShutterCloseAttr(1.0)
    add_distant_light(stage)
    positions = [(-1.5, 1, 0), (-1.5, -1, 0)]
    roots = ["/World/copies/Protos/tile"] if instanced else [f"/World/c{n}/tile" for n in range(2)]
    for n, root in enumerate(roots):
        if not instanced:
            place = UsdGeom.Xform.Define(stage, f"/World/c{n}")
            place.AddTranslateOp().Set(Gf.Vec3d(*positions[n]))
        slide = UsdGeom.Xform.Define(stage, root).AddTranslateOp()
        slide.Set(Gf.Vec3d(0, 0, 0), 1.0)
        slide.Set(Gf.Vec3d(1, 0, 0), 2.0)
        add_quad(stage, f"{root}/quad", half_size=0.25)
    if instanced:
        instancer = UsdGeom.PointInstancer.Define(stage, "/World/copies")
        instancer.CreatePrototypesRel().SetTargets(roots)
        instancer.CreatePositionsAttr(Vt.Vec3fArray(positions))
        instancer.CreateProtoIndicesAttr(Vt.IntArray([0, 0]))
    return stage


def test_copies_blur_with_their_prototype_roots_motion():
    """The prototype root's own transform is part of each copy (UsdGeomPointInstancer): when
    it moves over the shutter, the copies blur as the same prims placed by hand."""
    image, messages = render_with_warnings(sliding_prototype_stage(instanced=True), 40)
    expected, _ = render_with_warnings(sliding_prototype_stage(instanced=False), 40)
    assert messages == []
    # Each quad sweeps from x = -1.5 to x = -0.5: partly covered along the way.
    for y in (1, -1):
        assert 0 < expected[int((2 - y) * 10), int((-1 + 2) * 10), 3] < 1
    assert np.allclose(image, expected, atol=1e-4)


def test_an_ancestors_keyed_visibility_hides_the_copies_at_its_frames():
    # Only the instancer's own visibility was followed over time: copies under a parent keyed
    # invisible at frame 2 still rendered there (a fresh render and the CLI alike).
    stage, _ = instancer_stage()
    visibility = UsdGeom.Xform.Define(stage, "/World").CreateVisibilityAttr()
    visibility.Set(UsdGeom.Tokens.inherited, 1)
    visibility.Set(UsdGeom.Tokens.invisible, 2)
    renderer = penumbra.Renderer(stage)
    assert renderer.render(**SMALL, time=1)["color"][..., 3].sum() > 0
    assert renderer.render(**SMALL, time=2)["color"][..., 3].sum() == 0
    assert penumbra.Renderer(stage).render(**SMALL, time=2)["color"][..., 3].sum() == 0


def test_editing_a_collection_that_binds_materials_recolours_the_copies():
    # A collection-based binding's collection gaining the instancer left the copies in their
    # old material until a new Renderer (a plain mesh was recoloured).
    stage, _ = instancer_stage()
    green = add_preview_material(stage, "/World/Looks/green", diffuseColor=(0, 1, 0))
    collection = bind_through_a_collection(stage, "/World", green)
    assert_live_edit_renders_as_fresh(
        stage, lambda: collection.CreateIncludesRel().AddTarget("/World/copies"), **SMALL
    )
