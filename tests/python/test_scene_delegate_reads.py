"""How the scene delegate reads a stage cheaply (docs/architecture.md, "Scene delegate"): state
inherited from ancestors handed down per parent agrees with USD's own computations, attribute
queries of time-varying meshes are reused from one time to the next but never outlive a stage
edit, batched pushes check world transforms as single calls did, and the fast path for plain
meshes sends what the general path does."""

from __future__ import annotations

import gc

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt

import penumbra
from penumbra.usd import mesh_sync, tracking
from penumbra.usd.inherited import InheritedState
from stages import (
    add_camera,
    add_distant_light,
    add_preview_material,
    add_quad,
    bind,
    lit_quad_stage,
    new_stage,
    pixel,
)
from test_api import FAST, sync_counts


def test_inherited_purpose_visibility_and_primvars_agree_with_usd():
    stage = Usd.Stage.CreateInMemory()
    time = Usd.TimeCode(2.0)
    guide = UsdGeom.Xform.Define(stage, "/guide")
    guide.CreatePurposeAttr(UsdGeom.Tokens.guide)
    UsdGeom.Mesh.Define(stage, "/guide/render_inside").CreatePurposeAttr(UsdGeom.Tokens.render)
    untyped = stage.DefinePrim("/guide/untyped")  # not imageable: its opinions do not count
    untyped.CreateAttribute("purpose", Sdf.ValueTypeNames.Token).Set(UsdGeom.Tokens.proxy)
    untyped.CreateAttribute("visibility", Sdf.ValueTypeNames.Token).Set(UsdGeom.Tokens.invisible)
    UsdGeom.Mesh.Define(stage, "/guide/untyped/mesh")
    plain = UsdGeom.Xform.Define(stage, "/plain")
    primvars = UsdGeom.PrimvarsAPI(plain)
    primvars.CreatePrimvar("tint", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1, 0, 0))
    primvars.CreatePrimvar("uniform", Sdf.ValueTypeNames.Float, UsdGeom.Tokens.uniform).Set(1)
    proxy = UsdGeom.Mesh.Define(stage, "/plain/proxy")
    proxy.CreatePurposeAttr(UsdGeom.Tokens.proxy)
    blinking = UsdGeom.Xform.Define(stage, "/plain/blinking")
    blinking.CreateVisibilityAttr().Set(UsdGeom.Tokens.invisible, 2.0)
    blinking.CreateVisibilityAttr().Set(UsdGeom.Tokens.inherited, 3.0)
    shadowing = UsdGeom.Mesh.Define(stage, "/plain/blinking/mesh")
    UsdGeom.PrimvarsAPI(shadowing).CreatePrimvar("tint", Sdf.ValueTypeNames.Color3f).Set(
        Gf.Vec3f(0, 1, 0)
    )

    state = InheritedState()
    state.at(time)
    for prim in stage.Traverse():
        path = prim.GetPath()
        imageable = UsdGeom.Imageable(prim)
        assert state.purpose(prim, path) == imageable.ComputePurpose(), prim.GetPath()
        expected_visible = imageable.ComputeVisibility(time) != UsdGeom.Tokens.invisible
        assert state.visible(prim, path) == expected_visible, prim.GetPath()
        assert state.visibility(prim, path)[0] == expected_visible, prim.GetPath()
        # What a prim inherits: the constant primvars its parent has or inherits.
        expected = {
            p.GetPrimvarName()
            for p in UsdGeom.PrimvarsAPI(prim.GetParent()).FindPrimvarsWithInheritance()
            if p.GetInterpolation() == UsdGeom.Tokens.constant
        } if not prim.GetParent().IsPseudoRoot() else set()
        assert {p.GetPrimvarName() for p in state.inherited_primvars(prim, path)} == expected
    mesh = stage.GetPrimAtPath("/plain/blinking/mesh")
    assert state.visibility(mesh, mesh.GetPath())[1]  # might vary
    proxy_prim = stage.GetPrimAtPath("/plain/proxy")
    assert not state.visibility(proxy_prim, proxy_prim.GetPath())[1]
    state.at(Usd.TimeCode(3.0))  # visibility is read anew at another time
    assert state.visible(mesh, mesh.GetPath())


def test_queries_of_a_deforming_mesh_do_not_outlive_a_stage_edit():
    stage = lit_quad_stage()
    mover = add_quad(stage, "/World/mover", half_size=0.3, color=(1, 0, 0))
    points = mover.GetPointsAttr()
    square = np.array(points.Get(), dtype=np.float32)
    for time, dx in ((1.0, -1.2), (2.0, 0.0), (3.0, 1.2)):
        points.Set([Gf.Vec3f(*(p + (dx, 0, 0.5))) for p in square], time)
    renderer = penumbra.Renderer(stage)
    renderer.render(time=1.0, **FAST)
    at_2 = renderer.render(time=2.0, **FAST)  # read through queries from here on
    assert pixel(at_2, 0.5, 0.5)[0] > 2 * pixel(at_2, 0.5, 0.5)[1]  # red mover in the middle
    # A stronger opinion (the session layer) than the samples the queries resolved to.
    with Usd.EditContext(stage, stage.GetSessionLayer()):
        points.Set([Gf.Vec3f(*(p + (-1.2, 0, 0.5))) for p in square], 3.0)
    before = sync_counts(renderer)
    at_3 = renderer.render(time=3.0, **FAST)
    assert sync_counts(renderer)["/World/mover"] == before["/World/mover"] + 1
    assert pixel(at_3, 0.17, 0.5)[0] > 2 * pixel(at_3, 0.17, 0.5)[1]  # on the left, not right
    fresh = penumbra.Renderer(stage).render(time=3.0, **FAST)
    np.testing.assert_array_equal(at_3["color"], fresh["color"])


def test_a_static_stage_rendered_at_another_time_resyncs_nothing():
    stage = lit_quad_stage()
    add_quad(stage, "/World/still", center=(0.5, 0.5, 0.1), half_size=0.3, color=(0, 1, 0))
    renderer = penumbra.Renderer(stage)
    renderer.render(time=1.0, **FAST)  # variability found out here
    before = sync_counts(renderer)
    renderer.render(time=2.0, **FAST)
    assert sync_counts(renderer) == before


def test_each_unusable_transform_of_a_batch_is_reported_and_not_rendered():
    stage = lit_quad_stage()
    add_quad(stage, "/World/nan", center=(float("nan"), 0, 0), half_size=0.3)
    add_quad(stage, "/World/far", center=(1e19, 0, 0), half_size=0.3)
    add_quad(stage, "/World/fine", center=(0, 0, 0.1), half_size=0.3, color=(1, 0, 0))
    with pytest.warns(penumbra.PenumbraWarning) as record:
        image = penumbra.Renderer(stage).render(**FAST)
    messages = [str(warning.message) for warning in record]
    assert sum("/World/nan: the world transform is not finite" in m for m in messages) == 1
    far = "/World/far: the world transform translates it beyond 1e+18"
    assert sum(far in m for m in messages) == 1
    assert not any("/World/fine" in m for m in messages)
    assert pixel(image, 0.5, 0.5)[0] > 2 * pixel(image, 0.5, 0.5)[1]


def _mixed_mesh_stage() -> Usd.Stage:
    """Meshes the fast path reads (colours own or none, vertex colours, left-handed, double-sided,
    subdivided, purpose and visibility authored) beside meshes it leaves to the
    general path (normals, indexed colours, a material primvar, inherited colours)."""
    stage = lit_quad_stage()
    spots = iter((x, y) for y in (-1.5, -0.5, 0.5, 1.5) for x in (-1.5, -0.5, 0.5, 1.5))

    def quad(name: str, color=(0.8, 0.3, 0.1), parent: str = "/World") -> UsdGeom.Mesh:
        x, y = next(spots)
        return add_quad(stage, f"{parent}/{name}", center=(x, y, 0.2), half_size=0.4, color=color)

    quad("plain")
    quad("uncoloured", color=None)
    # Left-handed, these quads face away: seen only when double-sided.
    quad("left_handed").CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
    double_sided = quad("double_sided", color=(0.2, 0.9, 0.3))
    double_sided.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
    double_sided.CreateDoubleSidedAttr(True)
    per_vertex = quad("per_vertex", color=None)
    per_vertex.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set(
        [Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 1, 0), Gf.Vec3f(0, 0, 1), Gf.Vec3f(1, 1, 1)]
    )
    quad("subdivided").CreateSubdivisionSchemeAttr(UsdGeom.Tokens.catmullClark)
    quad("proxy_purpose").CreatePurposeAttr(UsdGeom.Tokens.proxy)
    quad("hidden").CreateVisibilityAttr(UsdGeom.Tokens.invisible)
    tilted = quad("normals")
    tilted.CreateNormalsAttr([Gf.Vec3f(0.6, 0, 0.8)] * 4)
    tilted.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    indexed = quad("indexed", color=None)
    colors = indexed.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform)
    colors.Set([Gf.Vec3f(0.1, 0.2, 0.9), Gf.Vec3f(0.9, 0.9, 0.1)])
    colors.SetIndices(Vt.IntArray([1]))
    UsdGeom.PrimvarsAPI(quad("with_st")).CreatePrimvar(
        "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex
    ).Set([(0, 0), (1, 0), (1, 1), (0, 1)])
    group = UsdGeom.Xform.Define(stage, "/World/tinted")
    UsdGeom.PrimvarsAPI(group).CreatePrimvar(
        "displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.constant
    ).Set([Gf.Vec3f(0.3, 0.3, 1.0)])
    quad("inherits_colour", color=None, parent="/World/tinted")
    return stage


_FAST_PATH_MESHES = {
    "plain", "uncoloured", "double_sided", "left_handed", "per_vertex", "subdivided",
    "proxy_purpose", "hidden", "quad",  # lit_quad_stage's own quad
}


def test_fast_path_meshes_render_as_the_general_path_reads_them(monkeypatch):
    stage = _mixed_mesh_stage()
    fast_path = mesh_sync.push_plain_meshes
    taken: list[str] = []

    def recording(core, prims, *args):
        pushed = fast_path(core, prims, *args)
        taken.extend(prim.GetName() for prim, usable in zip(prims, pushed) if usable)
        return pushed

    monkeypatch.setattr(mesh_sync, "push_plain_meshes", recording)
    fast = penumbra.Renderer(stage).render(**FAST)
    assert set(taken) == _FAST_PATH_MESHES
    monkeypatch.setattr(mesh_sync, "is_plain", lambda names: False)
    taken.clear()
    general = penumbra.Renderer(stage).render(**FAST)
    assert not taken
    np.testing.assert_array_equal(fast["color"], general["color"])
    assert fast["color"].std() > 0.05  # the meshes are in view


def test_bindings_on_ancestors_and_collections_reach_meshes_as_usd_resolves_them():
    # Only meshes with a binding on themselves or an ancestor are given to UsdShade to resolve:
    # each kind of binding must still arrive.
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    looks = {
        name: add_preview_material(stage, f"/Looks/{name}", diffuseColor=color, roughness=1.0)
        for name, color in (("red", (0.8, 0.05, 0.05)), ("green", (0.05, 0.8, 0.05)),
                            ("blue", (0.05, 0.05, 0.8)))
    }
    spots = iter((-1.6, -0.8, 0.0, 0.8, 1.6))

    def quad(parent: str) -> UsdGeom.Mesh:
        UsdGeom.Xform.Define(stage, parent)
        x = next(spots)
        return add_quad(stage, f"{parent}/q", center=(x, 0, 0), half_size=0.3, color=(1, 1, 1))

    bind(quad("/World/direct"), looks["red"])
    quad("/World/inherited")
    bind(UsdGeom.Xform(stage.GetPrimAtPath("/World/inherited")), looks["green"])
    quad("/World/collection")
    owner = UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath("/World/collection"))
    targets = Usd.CollectionAPI.Apply(owner.GetPrim(), "set")
    targets.GetIncludesRel().AddTarget("/World/collection/q")
    owner.Bind(targets, looks["blue"])
    bind(quad("/World/stronger"), looks["green"])
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath("/World/stronger")).Bind(
        looks["red"], UsdShade.Tokens.strongerThanDescendants
    )
    quad("/World/unbound")
    expected = {"direct": "red", "inherited": "green", "collection": "blue", "stronger": "red"}
    for group, name in expected.items():  # the premise: what UsdShade resolves
        mesh = UsdShade.MaterialBindingAPI(stage.GetPrimAtPath(f"/World/{group}/q"))
        assert mesh.ComputeBoundMaterial()[0].GetPath() == looks[name].GetPath()

    image = penumbra.Renderer(stage).render(camera="/cam", width=40, samples=4)
    channel = {"red": 0, "green": 1, "blue": 2}
    for u, group in zip((0.1, 0.3, 0.5, 0.7, 0.9), list(expected) + ["unbound"]):
        rgb = pixel(image, u, 0.5)
        if group == "unbound":  # its white displayColor
            assert min(rgb) > 0.5 * max(rgb) > 0, group
        else:
            dominant = channel[expected[group]]
            assert rgb[dominant] > 3 * max(np.delete(rgb, dominant)), group


def test_path_order_key_sorts_prim_paths_as_sdf_does():
    names = ["a", "b", "A", "Z", "z", "a_b", "ab", "a0", "a9", "_x", "c1", "c10", "c2", "é"]
    rng = np.random.default_rng(7)
    paths = {
        "/" + "/".join(rng.choice(names, size=int(rng.integers(1, 5))))
        for _ in range(2000)
    }
    expected = [str(p) for p in sorted(Sdf.Path(p) for p in paths)]
    assert sorted(paths, key=tracking.path_order_key) == expected


def test_mesh_light_api_applied_then_removed_renders_as_a_fresh_delegate():
    # A UsdLuxMeshLightAPI mesh is read by the general path, the others by the fast path, and
    # the meshes that are not lights are switched off in one batched call: an edit either way
    # must leave the delegate as a fresh sync of the edited stage would.
    stage = new_stage()
    add_camera(stage)
    add_quad(stage, "/World/floor", half_size=2.0, color=(0.5, 0.5, 0.5))
    lamp = add_quad(stage, "/World/lamp", center=(0, 0, 0.5), half_size=0.3, color=(0.2, 0.2, 0.2))
    UsdLux.MeshLightAPI.Apply(lamp.GetPrim())
    UsdLux.LightAPI(lamp.GetPrim()).CreateIntensityAttr(20.0)
    renderer = penumbra.Renderer(stage)
    lit = renderer.render(**FAST)
    np.testing.assert_array_equal(lit["color"], penumbra.Renderer(stage).render(**FAST)["color"])

    lamp.GetPrim().RemoveAPI(UsdLux.MeshLightAPI)
    unlit = renderer.render(**FAST)
    np.testing.assert_array_equal(unlit["color"], penumbra.Renderer(stage).render(**FAST)["color"])
    assert pixel(lit, 0.5, 0.5)[0] > 4 * pixel(unlit, 0.5, 0.5)[0]  # the lamp itself glowed

    UsdLux.MeshLightAPI.Apply(lamp.GetPrim())
    np.testing.assert_array_equal(renderer.render(**FAST)["color"], lit["color"])


def test_a_sync_leaves_the_garbage_collector_as_it_found_it():
    stage = lit_quad_stage()
    assert gc.isenabled()
    penumbra.Renderer(stage).render(**FAST)
    assert gc.isenabled()
    gc.disable()
    try:
        penumbra.Renderer(stage).render(**FAST)
        assert not gc.isenabled()
    finally:
        gc.enable()
