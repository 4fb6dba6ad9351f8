"""Primvars that shade: authored normals (every interpolation, primvars:normals first) and
displayOpacity."""

from __future__ import annotations

import math

import pytest
from pxr import Sdf, UsdGeom, Vt

import penumbra
from stages import add_camera, add_distant_light, add_preview_material, add_quad, bind, new_stage

SMALL = dict(camera="/cam", width=8, samples=4, max_path_depth=1)


def lit_quad(normals=None, interpolation=UsdGeom.Tokens.vertex, as_primvar=False):
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)  # along -Z, onto the quad facing +Z
    quad = add_quad(stage, "/World/quad", half_size=4.0, color=(0.5, 0.5, 0.5))
    if normals is not None:
        if as_primvar:
            primvar = UsdGeom.PrimvarsAPI(quad).CreatePrimvar(
                "normals", Sdf.ValueTypeNames.Normal3fArray, interpolation
            )
            primvar.Set(Vt.Vec3fArray(normals))
        else:
            quad.CreateNormalsAttr(Vt.Vec3fArray(normals))
            quad.SetNormalsInterpolation(interpolation)
    image = penumbra.Renderer(stage).render(**SMALL)
    return float(image["color"][..., 0].mean())


@pytest.mark.parametrize(
    "count, interpolation, as_primvar",
    [(4, "vertex", False), (4, "faceVarying", False), (1, "uniform", True), (1, "constant", True)],
)
def test_authored_normals_shade(count, interpolation, as_primvar):
    flat = lit_quad()
    tilt = math.radians(60)
    normals = [(math.sin(tilt), 0.0, math.cos(tilt))] * count
    assert lit_quad(normals, interpolation, as_primvar) / flat == pytest.approx(0.5, abs=0.01)


def test_subdivided_meshes_ignore_authored_normals():
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage)
    quad = add_quad(stage, "/World/quad", half_size=4.0)
    quad.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.bilinear)
    renderer = penumbra.Renderer(stage)
    flat = float(renderer.render(**SMALL)["color"][..., 0].mean())
    quad.CreateNormalsAttr(Vt.Vec3fArray([(1, 0, 0)] * 4))
    assert float(renderer.render(**SMALL)["color"][..., 0].mean()) == pytest.approx(flat, rel=1e-6)


@pytest.mark.parametrize("opacity", [1.0, 0.0])
def test_display_opacity_makes_surfaces_without_a_material_translucent(opacity):
    # A black open quad (displayColor 0) in front of an emitter of radiance 1, in the dark (a
    # light of intensity 0 keeps the default dome away). Opaque, the quad hides the emitter;
    # with displayOpacity 0 it is a clear thin sheet, which lets through all but its Fresnel
    # reflection (4 % at normal incidence for ior 1.5, from both faces with the bounces between
    # them: 1 - 2·0.04/(1 + 0.04) ≈ 0.923).
    stage = new_stage()
    add_camera(stage)
    add_distant_light(stage, intensity=0.0)
    emitter = add_quad(stage, "/World/emitter", center=(0, 0, -1), half_size=4.0)
    glow = add_preview_material(
        stage,
        "/World/glow",
        emissiveColor=(1.0, 1.0, 1.0),
        diffuseColor=(0.0, 0.0, 0.0),
        specularColor=(0.0, 0.0, 0.0),
        useSpecularWorkflow=1,
    )  # emits, reflects nothing
    bind(emitter, glow)
    sheet = add_quad(stage, "/World/sheet", half_size=4.0, color=(0.0, 0.0, 0.0))
    sheet.CreateDisplayOpacityPrimvar(UsdGeom.Tokens.constant).Set([opacity])
    image = penumbra.Renderer(stage).render(camera="/cam", width=8, samples=16)
    value = float(image["color"][2:6, 2:6, :3].mean())
    if opacity == 1.0:
        assert value < 0.01
    else:
        assert value == pytest.approx(1 - 2 * 0.04 / 1.04, abs=0.01)
