"""Subsurface scattering and absorbing glass of MaterialX surfaces (docs/materialx.md):
standard_surface's and OpenPBR's subsurface inputs become the renderer's random-walk medium
(renderer/include/penumbra/subsurface.h) instead of a diffuse colour mixed towards the subsurface
colour, and a transmission colour reached at a transmission depth becomes absorbing glass."""

from __future__ import annotations

import math

import pytest
from pxr import Usd

from penumbra import _core
from penumbra.usd.material import read_material
from penumbra.usd.sampling import SampleReader
from stages import add_preview_material, new_stage
from test_materialx import add_mtlx_material

STANDARD = "ND_standard_surface_surfaceshader"
OPEN_PBR = "ND_open_pbr_surface_surfaceshader"


def read(node_def: str | None, warn=pytest.fail, **inputs) -> dict:
    """The delegate parameters of one material (a UsdPreviewSurface for node_def None);
    ``warn`` receives the warnings (by default none may come)."""
    stage = new_stage()
    if node_def is None:
        add_preview_material(stage, "/Looks/m", **inputs)
    else:
        add_mtlx_material(stage, "/Looks/m", node_def, **inputs)
    return read_material(stage.GetPrimAtPath("/Looks/m"), SampleReader(Usd.TimeCode(1)),
                         warn).params


def test_standard_surface_subsurface_becomes_the_walks_medium():
    params = read(STANDARD, base=1.0, base_color=(0.2, 0.3, 0.4), subsurface=0.6,
                  subsurface_color=(0.9, 0.4, 0.3), subsurface_radius=(1.0, 0.5, 0.25),
                  subsurface_scale=0.1, subsurface_anisotropy=0.3)
    assert params["penumbra:subsurface"] == pytest.approx(0.6)
    assert params["penumbra:subsurfaceColor"] == pytest.approx((0.9, 0.4, 0.3))
    # The mean free path is the radius times the scale.
    assert params["penumbra:subsurfaceRadius"] == pytest.approx((0.1, 0.05, 0.025))
    assert params["penumbra:subsurfaceAnisotropy"] == pytest.approx(0.3)
    # The base colour is no longer mixed towards the subsurface colour: the BSDF splits them.
    assert params["diffuseColor"] == pytest.approx((0.2, 0.3, 0.4))


def test_open_pbr_subsurface_becomes_the_walks_medium():
    params = read(OPEN_PBR, base_color=(0.5, 0.5, 0.5), subsurface_weight=1.0,
                  subsurface_color=(0.8, 0.2, 0.1), subsurface_radius=0.5,
                  subsurface_radius_scale=(1.0, 0.5, 0.25), subsurface_scatter_anisotropy=-0.2)
    assert params["penumbra:subsurface"] == pytest.approx(1.0)
    assert params["penumbra:subsurfaceColor"] == pytest.approx((0.8, 0.2, 0.1))
    assert params["penumbra:subsurfaceRadius"] == pytest.approx((0.5, 0.25, 0.125))
    assert params["penumbra:subsurfaceAnisotropy"] == pytest.approx(-0.2)
    assert params["diffuseColor"] == pytest.approx((0.5, 0.5, 0.5))  # base_weight 1


@pytest.mark.parametrize("node_def, weight", [(STANDARD, "subsurface"),
                                              (OPEN_PBR, "subsurface_weight")])
def test_no_subsurface_weight_sends_no_medium(node_def, weight):
    params = read(node_def, **{weight: 0.0, "subsurface_color": (0.9, 0.1, 0.1)})
    assert not any(name.startswith("penumbra:subsurface") for name in params)


@pytest.mark.parametrize("node_def, weight", [(STANDARD, "transmission"),
                                              (OPEN_PBR, "transmission_weight")])
def test_transmission_colour_at_a_depth_is_absorbing_glass(node_def, weight):
    params = read(node_def, **{weight: 1.0, "transmission_color": (0.5, 0.8, 0.9),
                               "transmission_depth": 2.0})
    assert params["opacity"] == pytest.approx(0.0)
    assert params["penumbra:transmissionDepth"] == pytest.approx(2.0)
    assert params["penumbra:transmissionColor"] == pytest.approx((0.5, 0.8, 0.9))


@pytest.mark.parametrize("node_def, weight", [(STANDARD, "transmission"),
                                              (OPEN_PBR, "transmission_weight")])
def test_transmission_colour_without_depth_is_still_reported(node_def, weight):
    warnings: list[str] = []
    params = read(node_def, warnings.append,
                  **{weight: 1.0, "transmission_color": (0.5, 0.8, 0.9)})
    assert "penumbra:transmissionColor" not in params
    assert "penumbra:transmissionDepth" not in params
    assert len(warnings) == 1 and "transmission_color" in warnings[0]


def test_non_finite_radius_warns_and_is_not_sent():
    warnings: list[str] = []
    params = read(STANDARD, warnings.append, subsurface=1.0,
                  subsurface_radius=(1.0, math.inf, 1.0))
    assert "penumbra:subsurfaceRadius" not in params
    assert params["penumbra:subsurface"] == pytest.approx(1.0)
    assert any("penumbra:subsurfaceRadius" in w and "finite" in w for w in warnings)


def test_a_preview_surface_carries_the_extensions():
    params = read(None, **{"penumbra:subsurface": 0.5, "penumbra:subsurfaceColor": (0.7, 0.5, 0.4),
                           "penumbra:subsurfaceRadius": (0.3, 0.2, 0.1),
                           "penumbra:transmissionDepth": 1.5})
    assert params["penumbra:subsurface"] == pytest.approx(0.5)
    assert params["penumbra:subsurfaceColor"] == pytest.approx((0.7, 0.5, 0.4))
    assert params["penumbra:subsurfaceRadius"] == pytest.approx((0.3, 0.2, 0.1))
    assert params["penumbra:transmissionDepth"] == pytest.approx(1.5)


@pytest.mark.parametrize("name, value", [
    ("penumbra:subsurface", math.nan),
    ("penumbra:subsurfaceColor", (0.5, math.inf, 0.5)),
    ("penumbra:subsurfaceRadius", (math.nan, 1.0, 1.0)),
    ("penumbra:subsurfaceAnisotropy", math.inf),
    ("penumbra:transmissionDepth", math.nan),
    ("penumbra:transmissionColor", (1.0, 1.0, math.inf)),
])
def test_the_delegate_refuses_non_finite_subsurface_and_absorption(name, value):
    delegate = _core.RenderDelegate()
    delegate.insert_sprim("material", "/m")
    with pytest.raises(ValueError, match="finite"):
        delegate.set_material("/m", {name: value})
