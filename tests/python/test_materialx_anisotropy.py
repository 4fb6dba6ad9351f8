"""Specular anisotropy of MaterialX surfaces (docs/materialx.md): standard_surface's
specular_anisotropy and specular_rotation, open_pbr_surface's specular_roughness_anisotropy,
mapped onto the renderer's anisotropic GGX lobes along the mesh's ∂P/∂s.

A flat metal quad seen from straight above, lit by a narrow distant light from straight above:
the highlight is where the half vector between the view and the light tilts by the microfacet
slopes D(h) spreads, so it stretches along the axis with the larger α. Its second moments along
the image's x and y axes say which.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

import penumbra
from stages import add_camera, add_distant_light, add_quad, bind, new_stage
from test_materialx import add_mtlx_material

STANDARD = "ND_standard_surface_surfaceshader"
OPEN_PBR = "ND_open_pbr_surface_surfaceshader"
METAL = {
    STANDARD: {"base_color": (1.0, 1.0, 1.0), "metalness": 1.0, "specular_roughness": 0.3},
    OPEN_PBR: {"base_color": (1.0, 1.0, 1.0), "base_metalness": 1.0, "specular_roughness": 0.3},
}
ANISOTROPY = {STANDARD: "specular_anisotropy", OPEN_PBR: "specular_roughness_anisotropy"}


def highlight_moments(node_def: str, st_axes: str | None = "xy",
                      tangent: tuple[float, float, float] | None = None,
                      **inputs) -> tuple[float, float]:
    """Second moments (in scene units², about the image centre) of the highlight on a 4 × 4 metal
    quad filling the view, along the image's x (scene +X) and y (scene +Y) axes. ``st_axes``:
    which scene axes s and t run along ("xy", or "yx": s along +Y, t along −X); None: no st.
    ``tangent``: a constant ``tangent`` primvar."""
    stage = new_stage()
    add_camera(stage)  # at z = 5, sees [-2, 2]² of the z = 0 plane
    quad = add_quad(stage, "/World/quad", half_size=2.0)
    if st_axes is not None:
        corners = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
        st = [(x, y) if st_axes == "xy" else (y, -x) for x, y in corners]
        UsdGeom.PrimvarsAPI(quad).CreatePrimvar(
            "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex
        ).Set([Gf.Vec2f(*c) for c in st])
    if tangent is not None:
        UsdGeom.PrimvarsAPI(quad).CreatePrimvar(
            "tangent", Sdf.ValueTypeNames.Vector3fArray, UsdGeom.Tokens.constant
        ).Set([Gf.Vec3f(*tangent)])
    add_distant_light(stage).CreateAngleAttr(0.2)
    add_mtlx_material(stage, "/World/Looks/brushed", node_def, **METAL[node_def], **inputs)
    bind(quad, UsdShade.Material(stage.GetPrimAtPath("/World/Looks/brushed")))
    with warnings.catch_warnings():
        warnings.simplefilter("error", penumbra.PenumbraWarning)  # anisotropy is not ignored
        image = penumbra.render(stage, camera="/cam", width=96, samples=16, seed=11)["color"]
    luminance = image[..., :3].mean(axis=2)
    weight = np.clip(luminance - np.percentile(luminance, 10), 0, None)
    size = luminance.shape[0]
    coordinate = (np.arange(size) + 0.5) / size * 4 - 2
    x, y = np.meshgrid(coordinate, -coordinate)  # image rows run down, scene +Y up
    total = weight.sum()
    return float((weight * x * x).sum() / total), float((weight * y * y).sum() / total)


@pytest.mark.parametrize("node_def", [STANDARD, OPEN_PBR])
def test_anisotropy_stretches_the_highlight_along_the_tangent(node_def):
    """Measured (x/y moments): isotropic 0.41/0.41; anisotropy 0.8 1.04/0.13 (standard_surface)
    and 0.79/0.07 (OpenPBR); st turned by 90° turns the highlight with it."""
    round_x, round_y = highlight_moments(node_def)
    assert round_x == pytest.approx(round_y, rel=0.1)
    along_x, across_x = highlight_moments(node_def, **{ANISOTROPY[node_def]: 0.8})
    assert along_x > 3 * across_x
    assert along_x > 1.5 * round_x and across_x < round_y
    across_y, along_y = highlight_moments(node_def, st_axes="yx", **{ANISOTROPY[node_def]: 0.8})
    assert along_y > 3 * across_y
    assert along_y == pytest.approx(along_x, rel=0.1)


def test_specular_rotation_turns_the_highlight_a_quarter_turn():
    along_x, across_x = highlight_moments(STANDARD, specular_anisotropy=0.8)
    across_y, along_y = highlight_moments(STANDARD, specular_anisotropy=0.8,
                                          specular_rotation=0.25)
    assert along_y > 3 * across_y
    assert along_y == pytest.approx(along_x, rel=0.1)


def test_without_texture_coordinates_the_highlight_still_stretches_along_a_fixed_tangent():
    x, y = highlight_moments(OPEN_PBR, st_axes=None, specular_roughness_anisotropy=0.8)
    assert max(x, y) > 3 * min(x, y)


def test_a_tangent_primvar_wins_over_the_texture_coordinates():
    across_y, along_y = highlight_moments(OPEN_PBR, tangent=(0.0, 1.0, 0.0),
                                          specular_roughness_anisotropy=0.8)
    assert along_y > 3 * across_y


def _params(node_def: str, **inputs) -> dict:
    from penumbra.usd.material import read_material
    from penumbra.usd.sampling import SampleReader

    stage = new_stage()
    add_mtlx_material(stage, "/Looks/m", node_def, **inputs)
    return read_material(stage.GetPrimAtPath("/Looks/m"), SampleReader(Usd.TimeCode(1)),
                         pytest.fail).params


@pytest.mark.parametrize(
    "node_def, inputs, expected",
    [
        (STANDARD, {"specular_anisotropy": 0.5, "specular_rotation": 0.125},
         {"penumbra:anisotropy": 0.5, "penumbra:anisotropyRotation": 0.125,
          "penumbra:anisotropyModel": "standardSurface"}),
        # The coat's rotation serves when the specular lobe is isotropic.
        (STANDARD, {"coat": 1.0, "coat_anisotropy": 0.3, "coat_rotation": 0.5},
         {"penumbra:clearcoatAnisotropy": 0.3, "penumbra:anisotropyRotation": 0.5,
          "penumbra:anisotropyModel": "standardSurface"}),
        (OPEN_PBR, {"specular_roughness_anisotropy": 0.7, "coat_weight": 0.5,
                    "coat_roughness_anisotropy": 0.2},
         {"penumbra:anisotropy": 0.7, "penumbra:clearcoatAnisotropy": 0.2,
          "penumbra:anisotropyModel": "openPBR"}),
    ],
)
def test_anisotropy_inputs_map_onto_the_renderer_with_each_surface_model(node_def, inputs,
                                                                          expected):
    params = _params(node_def, **inputs)
    for name, value in expected.items():
        assert params[name] == pytest.approx(value) if isinstance(value, float) else \
            params[name] == value, name


def test_isotropic_surfaces_send_no_anisotropy():
    for node_def in (STANDARD, OPEN_PBR):
        params = _params(node_def, **METAL[node_def])
        assert not any("nisotropy" in name for name in params)
    # A coat anisotropy under a coat of weight 0 has nothing to act on.
    assert not any("nisotropy" in name for name in _params(STANDARD, coat_anisotropy=0.5))


def test_a_coat_rotation_other_than_the_specular_one_warns():
    from penumbra.usd.material import read_material
    from penumbra.usd.sampling import SampleReader

    stage = new_stage()
    add_mtlx_material(stage, "/Looks/m", STANDARD, specular_anisotropy=0.5, coat=1.0,
                      coat_anisotropy=0.5, coat_rotation=0.25)
    messages: list[str] = []
    params = read_material(stage.GetPrimAtPath("/Looks/m"), SampleReader(Usd.TimeCode(1)),
                           messages.append).params
    assert len(messages) == 1 and "coat_rotation other than specular_rotation" in messages[0]
    assert "penumbra:anisotropyRotation" not in params  # the specular lobe's: 0


def test_the_delegate_rejects_non_finite_anisotropy_and_unknown_models():
    from penumbra import _core

    delegate = _core.RenderDelegate()
    delegate.insert_sprim("material", "/m")
    delegate.set_material("/m", {"penumbra:anisotropy": 0.5, "penumbra:anisotropyRotation": 0.1,
                                 "penumbra:anisotropyModel": "standardSurface"})
    delegate.set_material("/m", {"penumbra:anisotropy": {"primvar": "brushed"}})
    for name in ("penumbra:anisotropy", "penumbra:clearcoatAnisotropy",
                 "penumbra:anisotropyRotation"):
        with pytest.raises(ValueError, match=f"/m: {name} must be finite"):
            delegate.set_material("/m", {name: float("nan")})
    with pytest.raises(ValueError, match="unknown anisotropy model 'ward'"):
        delegate.set_material("/m", {"penumbra:anisotropyModel": "ward"})


@pytest.mark.parametrize("anisotropy, warned", [(0.5, True), (0.0, False)])
def test_a_connected_tangent_warns_only_where_a_lobe_is_anisotropic(anisotropy, warned):
    from penumbra.usd.material import read_material
    from penumbra.usd.sampling import SampleReader

    stage = new_stage()
    surface = add_mtlx_material(stage, "/Looks/m", OPEN_PBR,
                                specular_roughness_anisotropy=anisotropy)
    tangent = UsdShade.Shader.Define(stage, "/Looks/m/tangent")
    tangent.CreateIdAttr("ND_geompropvalue_vector3")
    tangent.CreateInput("geomprop", Sdf.ValueTypeNames.String).Set("brush")
    surface.CreateInput("geometry_tangent", Sdf.ValueTypeNames.Vector3f).ConnectToSource(
        tangent.CreateOutput("out", Sdf.ValueTypeNames.Vector3f))
    messages: list[str] = []
    read_material(stage.GetPrimAtPath("/Looks/m"), SampleReader(Usd.TimeCode(1)),
                  messages.append)
    assert [m for m in messages if "geometry_tangent" in m] == (
        ["/Looks/m: MaterialX node /Looks/m/Surface: geometry_tangent is not supported by "
         "Penumbra's BSDF and ignored (docs/materialx.md)"] if warned else [])
