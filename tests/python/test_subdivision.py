"""Subdivision surfaces through the whole stack: the usd-wg assets render their limit surface
with every tag, without a warning."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pxr import Usd, UsdGeom

import penumbra
from stages import SCENES

USD_WG_SUBDIVISION = SCENES / "usd-wg" / "full_assets" / "SubdivisionSurfaces"


@pytest.mark.parametrize(
    "asset", ["Creases_SpinningPyramids.usda", "Pyramid/Pyramid.usd"], ids=lambda name: name
)
def test_usd_wg_subdivision_assets_render_without_warnings(asset):
    stage = Usd.Stage.Open(str(USD_WG_SUBDIVISION / asset))
    assert any(
        UsdGeom.Mesh(prim).GetSubdivisionSchemeAttr().Get() != UsdGeom.Tokens.none
        for prim in Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies())
        if prim.IsA(UsdGeom.Mesh)
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        image = penumbra.Renderer(stage).render(width=64, samples=2, aovs=("color", "depth"))
    surface = np.isfinite(image["depth"])
    assert 0.02 < surface.mean() < 0.9  # the framing camera sees the surfaces and the dome


def test_complexity_dices_finer_but_renders_the_same_surface(tmp_path):
    stage = Usd.Stage.Open(str(USD_WG_SUBDIVISION / "Pyramid" / "Pyramid.usd"))
    renderer = penumbra.Renderer(stage)
    low = renderer.render(width=64, samples=4, complexity="low", aovs=("depth",))["depth"]
    high = renderer.render(width=64, samples=4, complexity="veryhigh", aovs=("depth",))["depth"]
    hit = np.isfinite(low) & np.isfinite(high)
    assert hit.mean() > 0.05
    # The limit surface is the same: depths agree to well under a pixel's footprint.
    assert np.abs(low[hit] - high[hit]).max() < 0.02 * float(np.median(low[hit]))
    with pytest.raises(ValueError, match="complexity must be one of"):
        renderer.render(width=16, samples=1, complexity="extreme")
