"""The usd-wg UsdGeom schema test assets (tests/assets/usd-wg/test_assets/schemaTests): every
one renders, and meshes whose attributes have types a mesh cannot use are skipped with a warning
naming them, as Storm skips them, while the others render."""

from __future__ import annotations

import warnings

import pytest
from pxr import Usd

import penumbra
from stages import SCENES

SCHEMA_TESTS = SCENES / "usd-wg" / "test_assets" / "schemaTests"
ASSETS = sorted(SCHEMA_TESTS.rglob("*.usda"))


def render_collecting_warnings(stage: Usd.Stage) -> tuple[penumbra.Image, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", penumbra.PenumbraWarning)
        image = penumbra.render(stage, width=48, samples=1)
    return image, [str(w.message) for w in caught if issubclass(w.category, penumbra.PenumbraWarning)]


@pytest.mark.parametrize("path", ASSETS, ids=lambda p: p.stem)
def test_schema_assets_render(path):
    stage = Usd.Stage.Open(str(path))
    if path.stem == "empty":  # one mesh without points: no camera and nothing to frame
        with pytest.raises(penumbra.SceneError, match="nothing to frame|no geometry to frame"):
            render_collecting_warnings(stage)
        return
    image, _ = render_collecting_warnings(stage)
    assert image["color"][..., 3].max() == 1.0  # something is there


def test_points_of_unusable_types_skip_their_mesh_with_a_warning():
    stage = Usd.Stage.Open(str(SCHEMA_TESTS / "usdGeom/meshes/points_types/pointsTypes.usda"))
    _, messages = render_collecting_warnings(stage)
    # Arrays of 3-vectors (float or double, any role) are points; scalars, int and double
    # arrays are not.
    unusable = {"/World/point3f", "/World/float3", "/World/color3f", "/World/normal3f",
                "/World/int", "/World/intArray", "/World/doubleArray"}
    warned = {m.split(":")[0] for m in messages if "which a mesh cannot use" in m}
    assert warned == unusable
    assert any(m.startswith("/World/empty: mesh has no points") for m in messages)
