"""UsdSkel: skinned meshes are posed by their skeleton's animation and blend shapes, as
``UsdSkel.BakeSkinning`` (usd-core's own reference) poses them. They rendered in their bind pose,
without a word: an animated character stood in its T-pose."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdSkel

import penumbra
from stages import add_camera, assert_live_edit_renders_as_fresh, covers, new_stage

RENDER = dict(camera="/cam", width=48, samples=4, seed=1)
QUARTER_TURN = Gf.Quatf(Gf.Rotation(Gf.Vec3d(0, 0, 1), 90).GetQuat())


def arm_stage(
    rigid: bool = False,
    normals: bool = False,
    blend_shape: bool = False,
    geom_bind: float | None = 1.0,
    method: str = "classicLinear",
    shapes_alone: bool = False,
) -> Usd.Stage:
    """A strip from x = 0 to 2 (height 0.5) skinned to a shoulder at 0 and an elbow at 1; the
    elbow turns 90° about +Z from frame 1 to frame 2 (the forearm then points up). The SkelRoot
    is moved by (-1, -0.5, 0); the mesh's own transform (ignored by UsdSkel) by (0, 3, 0).
    ``rigid``: the whole strip bound to the elbow (constant influences); ``normals``: authored
    vertex normals, unsubdivided; ``blend_shape``: the strip's tip moved by (0, 0.4, 0.5) at
    weight 1, keyed 0 → 1 with the elbow (and its normals turned by normalOffsets);
    ``geom_bind``: the scale about the origin the geomBindTransform authors (``None``: none
    authored, the optional attribute's identity); ``method``:
    the skinning method; ``shapes_alone``: no joint influences (the blend shape alone poses, in
    the mesh's own space, which is then not moved)."""
    stage = new_stage()
    stage.SetEndTimeCode(2)
    root = UsdSkel.Root.Define(stage, "/Root")
    root.AddTranslateOp().Set(Gf.Vec3d(-1, -0.5, 0))
    skeleton = UsdSkel.Skeleton.Define(stage, "/Root/Skel")
    joints = ["shoulder", "shoulder/elbow"]
    skeleton.CreateJointsAttr(joints)
    elbow = Gf.Matrix4d().SetTranslate(Gf.Vec3d(1, 0, 0))
    skeleton.CreateBindTransformsAttr([Gf.Matrix4d(1), elbow])
    skeleton.CreateRestTransformsAttr([Gf.Matrix4d(1), elbow])
    animation = UsdSkel.Animation.Define(stage, "/Root/Anim")
    animation.CreateJointsAttr(joints)
    animation.CreateTranslationsAttr([Gf.Vec3f(0), Gf.Vec3f(1, 0, 0)])
    animation.CreateScalesAttr([Gf.Vec3h(1), Gf.Vec3h(1)])
    rotations = animation.CreateRotationsAttr()
    rotations.Set([Gf.Quatf(1), Gf.Quatf(1)], 1)
    rotations.Set([Gf.Quatf(1), QUARTER_TURN], 2)
    UsdSkel.BindingAPI.Apply(skeleton.GetPrim()).CreateAnimationSourceRel().SetTargets(
        [animation.GetPath()]
    )
    mesh = UsdGeom.Mesh.Define(stage, "/Root/Arm")
    mesh.CreatePointsAttr([(0.5 * (i // 2), 0.25 if i % 2 else -0.25, 0) for i in range(10)])
    mesh.CreateFaceVertexCountsAttr([4] * 4)
    mesh.CreateFaceVertexIndicesAttr(
        [v for i in range(4) for v in (2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1)]
    )
    if not shapes_alone:  # else the mesh keeps its own transform (no joints place it)
        mesh.AddTranslateOp().Set(Gf.Vec3d(0, 3, 0))
    mesh.CreateDoubleSidedAttr(True)
    if normals:
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        tilted = [Gf.Vec3f(0, -0.6 if i % 2 else 0.6, 0.8) for i in range(10)]
        mesh.CreateNormalsAttr(tilted)
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skeleton.GetPath()])
    if shapes_alone:
        pass
    elif rigid:
        binding.CreateJointIndicesPrimvar(True, 1).Set([1])
        binding.CreateJointWeightsPrimvar(True, 1).Set([1.0])
    else:  # the upper arm on the shoulder, the elbow's points shared, the forearm on the elbow
        weights = [(1.0, 0.0)] * 4 + [(0.5, 0.5)] * 2 + [(0.0, 1.0)] * 4
        binding.CreateJointIndicesPrimvar(False, 2).Set([0, 1] * 10)
        binding.CreateJointWeightsPrimvar(False, 2).Set([w for pair in weights for w in pair])
    if geom_bind is not None:
        binding.CreateGeomBindTransformAttr(Gf.Matrix4d().SetScale(geom_bind))
    binding.CreateSkinningMethodAttr(method)
    if blend_shape or shapes_alone:
        shape = UsdSkel.BlendShape.Define(stage, "/Root/Arm/lift")
        shape.CreateOffsetsAttr([Gf.Vec3f(0, 0.4, 0.5)] * 2)
        shape.CreateNormalOffsetsAttr([Gf.Vec3f(0.5, 0, -0.3)] * 2)
        shape.CreatePointIndicesAttr([8, 9])
        binding.CreateBlendShapesAttr(["lift"])
        binding.CreateBlendShapeTargetsRel().SetTargets([shape.GetPath()])
        animation.CreateBlendShapesAttr(["lift"])
        keyed = animation.CreateBlendShapeWeightsAttr()
        keyed.Set([0.0], 1)
        keyed.Set([1.0], 2)
    add_camera(stage, translate=(0.0, 0.0, 5.0))  # sees [-2, 2]² of z = 0
    sun = UsdLux.DistantLight.Define(stage, "/sun")
    sun.CreateIntensityAttr(2.0)
    sun.CreateNormalizeAttr(True)  # irradiance 2 on a facing surface
    return stage


def add_skinned_hair(stage: Usd.Stage) -> None:
    """A strand of hair (BasisCurves) and a row of particles (Points) along the strip, the
    strand blended like the strip, the particles carried by the elbow alone."""
    strand = UsdGeom.BasisCurves.Define(stage, "/Root/Strand")
    strand.CreateTypeAttr(UsdGeom.Tokens.linear)
    strand.CreateCurveVertexCountsAttr([5])
    strand.CreatePointsAttr([(0.5 * i, 0, 0.3) for i in range(5)])
    strand.CreateWidthsAttr([0.1])
    strand.SetWidthsInterpolation(UsdGeom.Tokens.constant)
    binding = UsdSkel.BindingAPI.Apply(strand.GetPrim())
    binding.CreateSkeletonRel().SetTargets(["/Root/Skel"])
    binding.CreateJointIndicesPrimvar(False, 2).Set([0, 1] * 5)
    binding.CreateJointWeightsPrimvar(False, 2).Set([1, 0, 1, 0, 0.5, 0.5, 0, 1, 0, 1])
    particles = UsdGeom.Points.Define(stage, "/Root/Particles")
    particles.CreatePointsAttr([(1.25 + 0.25 * i, 0, 0.3) for i in range(4)])
    particles.CreateWidthsAttr([0.2] * 4)
    binding = UsdSkel.BindingAPI.Apply(particles.GetPrim())
    binding.CreateSkeletonRel().SetTargets(["/Root/Skel"])
    binding.CreateJointIndicesPrimvar(True, 1).Set([1])
    binding.CreateJointWeightsPrimvar(True, 1).Set([1.0])


def baked(stage: Usd.Stage) -> Usd.Stage:
    """A copy of ``stage`` with its skinning baked by usd-core into points and transforms."""
    copy = Usd.Stage.CreateInMemory()
    copy.GetRootLayer().TransferContent(stage.GetRootLayer())
    assert UsdSkel.BakeSkinning(copy.Traverse())
    return copy


def render(stage: Usd.Stage, time: float, **options) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("error", penumbra.PenumbraWarning)  # skel primvars are not named
        return penumbra.Renderer(stage).render(time=time, **{**RENDER, **options})["color"]


@pytest.mark.parametrize(
    "variant",
    [
        {}, {"rigid": True}, {"normals": True}, {"blend_shape": True}, {"hair": True},
        {"geom_bind": None}, {"geom_bind": 1.2, "normals": True},
        {"method": "dualQuaternion", "normals": True},
        {"normals": True, "blend_shape": True}, {"shapes_alone": True, "normals": True},
    ],
    ids=[
        "blended", "rigid", "normals", "blend-shape", "curves-and-points", "no-geom-bind",
        "scaled-geom-bind",
        "dual-quaternion", "normal-offsets", "blend-shapes-alone",
    ],
)
def test_a_skinned_mesh_renders_as_usdskel_bakes_it(variant):
    hair = variant.pop("hair", False)
    stage = arm_stage(**variant)
    if hair:
        UsdGeom.Imageable(stage.GetPrimAtPath("/Root/Arm")).MakeInvisible()
        add_skinned_hair(stage)
    reference = baked(stage)
    bent = render(stage, 2)
    np.testing.assert_allclose(bent, render(reference, 2), atol=2e-5)
    np.testing.assert_allclose(render(stage, 1), render(reference, 1), atol=2e-5)
    assert not np.array_equal(bent, render(stage, 1))  # the pose shows


def test_the_skeleton_places_a_skinned_mesh_and_its_own_transform_is_ignored():
    """Bent at frame 2: the forearm rises from the elbow at (0, -0.5) to (0, 0.5) (the root's
    offset), the upper arm lies along y = -0.5 from x = -1; nothing is 3 units up."""
    image = render(arm_stage(), 2)
    assert covers(image, -0.5, -0.5) and covers(image, 0.0, 0.3)
    assert not covers(image, 0.7, -0.5)  # where the straight forearm lay
    straight = render(arm_stage(), 1)
    assert covers(straight, 0.7, -0.5) and not covers(straight, 0.0, 0.3)


def test_a_shutter_over_the_turn_blurs_the_forearm_along_its_arc():
    """Shutter [1, 2]: the forearm sweeps a quarter disc about the elbow. Its keys are at the
    shutter's ends; samples there alone would move its tip along the chord (0.73 from the
    elbow at 45°), and a point 0.95 out at 45° would never be covered."""
    stage = arm_stage()
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/cam"))
    camera.CreateShutterOpenAttr(0.0)
    camera.CreateShutterCloseAttr(1.0)
    alpha = render(stage, 1, samples=64)[..., 3]
    height, width = alpha.shape

    def coverage(radius: float) -> float:  # at 45° about the elbow (0, -0.5)
        x, y = radius * 0.7071, -0.5 + radius * 0.7071
        return alpha[int((2 - y) / 4 * height), int((x + 2) / 4 * width)]

    assert 0.1 < coverage(0.95) < 0.7
    assert coverage(1.3) == 0


@pytest.mark.parametrize(
    "edit",
    ["turn", "skeleton moved", "shape weight", "influences"],
)
def test_live_edits_of_the_skeleton_its_animation_and_shapes_pose_the_mesh_again(edit):
    stage = arm_stage(blend_shape=True)

    def apply() -> None:
        if edit == "turn":
            UsdSkel.Animation(stage.GetPrimAtPath("/Root/Anim")).GetRotationsAttr().Set(
                [Gf.Quatf(1), Gf.Quatf(Gf.Rotation(Gf.Vec3d(0, 0, 1), -60).GetQuat())], 2
            )
        elif edit == "skeleton moved":
            UsdGeom.Xformable(stage.GetPrimAtPath("/Root/Skel")).AddTranslateOp().Set(
                Gf.Vec3d(0, 0.7, 0)
            )
        elif edit == "shape weight":
            anim = UsdSkel.Animation(stage.GetPrimAtPath("/Root/Anim"))
            anim.GetBlendShapeWeightsAttr().Set([0.2], 2)
            UsdSkel.BlendShape(stage.GetPrimAtPath("/Root/Arm/lift")).GetOffsetsAttr().Set(
                [Gf.Vec3f(0, -1, 0)] * 2
            )
        else:  # the whole strip on the shoulder: nothing bends
            binding = UsdSkel.BindingAPI(stage.GetPrimAtPath("/Root/Arm"))
            binding.GetJointWeightsPrimvar().Set([1.0, 0.0] * 10)

    assert_live_edit_renders_as_fresh(stage, apply, time=2, **RENDER)


def test_a_live_renderer_poses_each_frame():
    stage = arm_stage()
    renderer = penumbra.Renderer(stage)
    renderer.render(time=1, **RENDER)
    np.testing.assert_array_equal(
        renderer.render(time=2, **RENDER)["color"],
        penumbra.Renderer(stage).render(time=2, **RENDER)["color"],
    )


def test_influences_outside_a_skelroot_are_left_as_usdskel_leaves_them():
    """UsdSkel skins only below a SkelRoot (BakeSkinning's output keeps its influences there):
    the points as authored, without a warning."""
    stage = arm_stage()
    stage.GetPrimAtPath("/Root").SetTypeName("Xform")
    image = render(stage, 2)
    assert not covers(image, 0.0, 0.3)


def test_a_skinned_mesh_inside_an_instance_is_named_in_a_warning():
    stage = arm_stage()
    stage.GetPrimAtPath("/Root").SetTypeName("Xform")
    holder = stage.DefinePrim("/Holder", "SkelRoot")
    holder.GetReferences().AddInternalReference("/Root")
    holder.SetInstanceable(True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        penumbra.Renderer(stage).render(time=2, **RENDER)
    messages = [str(w.message) for w in caught]
    assert any("joint influences inside an instance's prototype" in m for m in messages), messages


def rendered_with_warnings(stage: Usd.Stage, time: float) -> tuple[np.ndarray, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        color = penumbra.Renderer(stage).render(time=time, **RENDER)["color"]
    return color, [str(w.message) for w in caught if issubclass(w.category, penumbra.PenumbraWarning)]


def test_a_broken_blend_shape_is_named_and_the_joints_still_pose():
    """A target that is no BlendShape: UsdSkel.BakeSkinning poses without the shapes."""
    stage = arm_stage(blend_shape=True)
    UsdSkel.BindingAPI(stage.GetPrimAtPath("/Root/Arm")).GetBlendShapeTargetsRel().SetTargets(
        ["/Root/Skel"]
    )
    color, messages = rendered_with_warnings(stage, 2)
    assert any("/Root/Arm: its blend shapes cannot apply" in m for m in messages), messages
    np.testing.assert_allclose(color, render(baked(stage), 2), atol=2e-5)
    assert covers(color, 0.0, 0.3)  # the forearm turned


def test_a_skeleton_without_a_bind_pose_leaves_its_meshes_unposed_and_says_so():
    """One bindTransform for two joints: UsdSkel has no bind pose to skin from (BakeSkinning
    leaves the mesh as authored)."""
    stage = arm_stage()
    UsdSkel.Skeleton(stage.GetPrimAtPath("/Root/Skel")).GetBindTransformsAttr().Set(
        [Gf.Matrix4d(1)]
    )
    color, messages = rendered_with_warnings(stage, 2)
    assert any("/Root/Arm: its Skeleton /Root/Skel has no usable bind pose" in m for m in messages)
    np.testing.assert_allclose(color, render(baked(stage), 2), atol=2e-5)


def test_curves_bound_through_an_ancestor_are_posed():
    """The skeleton and a rigid influence on an Xform above the strand (the curves prim has no
    SkelBindingAPI of its own)."""
    stage = arm_stage()
    UsdGeom.Imageable(stage.GetPrimAtPath("/Root/Arm")).MakeInvisible()
    group = UsdGeom.Xform.Define(stage, "/Root/Groom")
    binding = UsdSkel.BindingAPI.Apply(group.GetPrim())
    binding.CreateSkeletonRel().SetTargets(["/Root/Skel"])
    binding.CreateJointIndicesPrimvar(True, 1).Set([1])
    binding.CreateJointWeightsPrimvar(True, 1).Set([1.0])
    strand = UsdGeom.BasisCurves.Define(stage, "/Root/Groom/Strand")
    strand.CreateTypeAttr(UsdGeom.Tokens.linear)
    strand.CreateCurveVertexCountsAttr([3])
    strand.CreatePointsAttr([(1.0, 0, 0), (1.5, 0, 0), (2.0, 0, 0)])
    strand.CreateWidthsAttr([0.5])
    strand.SetWidthsInterpolation(UsdGeom.Tokens.constant)
    bent = render(stage, 2)
    np.testing.assert_allclose(bent, render(baked(stage), 2), atol=2e-5)
    assert covers(bent, 0.0, 0.3)


def test_an_edit_under_a_skelroot_that_cannot_pose_reads_no_skinned_prim_again(monkeypatch):
    """A colour edit of one mesh re-reads that mesh alone; an animation edit every skinned
    prim under the root (each once, however many edits the change holds)."""
    from penumbra.usd import mesh_sync

    stage = arm_stage()
    for n in range(3):
        copy = stage.DefinePrim(f"/Root/Arm{n}")
        copy.GetReferences().AddInternalReference("/Root/Arm")
    renderer = penumbra.Renderer(stage)
    renderer.render(time=2, **RENDER)
    reads: list[str] = []
    original = mesh_sync.sync_mesh_data

    def counting(core, prim, *args, **kwargs):
        reads.append(str(prim.GetPath()))
        return original(core, prim, *args, **kwargs)

    monkeypatch.setattr(mesh_sync, "sync_mesh_data", counting)
    UsdGeom.Gprim(stage.GetPrimAtPath("/Root/Arm1")).CreateDisplayColorAttr([(1, 0, 0)])
    renderer.render(time=2, **RENDER)
    assert reads == ["/Root/Arm1"]
    reads.clear()
    rotations = UsdSkel.Animation(stage.GetPrimAtPath("/Root/Anim")).GetRotationsAttr()
    with Sdf.ChangeBlock():
        rotations.Set([Gf.Quatf(1), Gf.Quatf(1)], 2)
        rotations.Set([Gf.Quatf(1), Gf.Quatf(1)], 1)
    renderer.render(time=2, **RENDER)
    assert sorted(reads) == ["/Root/Arm", "/Root/Arm0", "/Root/Arm1", "/Root/Arm2"]
