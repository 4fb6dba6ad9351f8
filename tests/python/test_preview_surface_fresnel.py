"""UsdPreviewSurface's Fresnel as its spec gives it, read off a smooth quad seen at a known angle
under a white dome (radiance 1), one bounce: the pixel is the reflectance at that angle. A metal's
reflectance is its albedo at every angle ("both F0 and edge F90 reflectivity will simply be the
Albedo"), and the clearcoat follows `ior` ("including the clearcoat if clearcoat > 0"), while
MaterialX's conductors whiten towards grazing angles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdLux, UsdShade

import penumbra
from stages import add_camera, add_quad, bind, new_stage

RED = (0.9, 0.1, 0.1)


def reflectance(tilt: float, shader_id: str = "UsdPreviewSurface", **inputs) -> np.ndarray:
    """The mean colour of the middle of a smooth quad tilted ``tilt`` degrees from the view."""
    stage = new_stage()
    add_camera(stage, translate=(0, 0, 40), focal_length=200.0, aperture=(2.0, 2.0))
    UsdLux.DomeLight.Define(stage, "/dome")
    quad = add_quad(stage, "/World/quad", half_size=3.0)
    quad.AddRotateXOp().Set(-tilt)
    material = UsdShade.Material.Define(stage, "/Looks/m")
    surface = UsdShade.Shader.Define(stage, "/Looks/m/Surface")
    surface.CreateIdAttr(shader_id)
    for name, value in inputs.items():
        if isinstance(value, tuple):
            surface.CreateInput(name, Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*value))
        elif isinstance(value, int):
            surface.CreateInput(name, Sdf.ValueTypeNames.Int).Set(value)
        else:
            surface.CreateInput(name, Sdf.ValueTypeNames.Float).Set(value)
    output = "mtlx:surface" if shader_id.startswith("ND_") else "surface"
    material.CreateOutput(output, Sdf.ValueTypeNames.Token).ConnectToSource(
        surface.ConnectableAPI(), "surface")
    bind(quad, material)
    image = penumbra.Renderer(stage).render(camera="/cam", width=16, samples=16,
                                            max_path_depth=1)
    return np.asarray(image["color"])[6:10, 6:10, :3].reshape(-1, 3).mean(axis=0)


@pytest.mark.parametrize("tilt", [0.0, 60.0, 75.0])
def test_a_smooth_metal_reflects_its_albedo_at_every_angle(tilt):
    # It whitened to (0.922, 0.301, 0.301) at 75 degrees.
    seen = reflectance(tilt, diffuseColor=RED, metallic=1.0, roughness=0.0)
    np.testing.assert_allclose(seen, RED, atol=2e-3)


@pytest.mark.parametrize("ior", [1.5, 2.0, 3.0])
def test_the_clearcoat_follows_ior(ior):
    # It kept 0.04, the reflectance of ior 1.5, whatever the ior.
    seen = reflectance(0.0, diffuseColor=(0.0, 0.0, 0.0), useSpecularWorkflow=1,
                       specularColor=(0.0, 0.0, 0.0), clearcoat=1.0, clearcoatRoughness=0.0,
                       ior=ior)
    np.testing.assert_allclose(seen, ((ior - 1) / (ior + 1)) ** 2, atol=2e-3)


def test_a_materialx_metal_whitens_towards_grazing_angles():
    # standard_surface's conductor (F82 edge tint, white by default): Schlick from the base
    # colour to white.
    cosine = math.cos(math.radians(75.0))
    expected = np.array(RED) + (1 - np.array(RED)) * (1 - cosine) ** 5
    seen = reflectance(75.0, "ND_standard_surface_surfaceshader", base=1.0, base_color=RED,
                       metalness=1.0, specular_roughness=0.0)
    np.testing.assert_allclose(seen, expected, atol=0.02)
