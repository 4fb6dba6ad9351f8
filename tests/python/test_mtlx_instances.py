"""``.mtlx`` references inside native instances (docs/materialx.md, "Referenced .mtlx
documents"): an asset whose material scope references a MaterialX document, instanced twice."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
from pxr import Sdf, UsdGeom, UsdShade

import penumbra
from penumbra.usd import open_stage
from penumbra.usd.material import bound_material
from stages import add_camera, add_quad, new_stage
from test_materialx import MATERIALX_ASSETS, TERRACOTTA, white_dome

CENTRES = {"/World/A": -1.0, "/World/B": 1.0}  # x of each instance's quad


def instanced_scene(tmp_path: Path) -> Path:
    """Two instanceable references to an asset whose /Asset/Looks references materials.mtlx
    and whose quad (half size 0.5) is bound to M_terracotta in it; a camera sees [-2, 2]²."""
    asset = new_stage(tmp_path / "asset.usda")
    root = UsdGeom.Xform.Define(asset, "/Asset")
    asset.SetDefaultPrim(root.GetPrim())
    looks = asset.DefinePrim("/Asset/Looks", "Scope")
    looks.GetReferences().AddReference(str(MATERIALX_ASSETS / "materials.mtlx"), "/MaterialX")
    quad = add_quad(asset, "/Asset/quad", half_size=0.5)
    UsdShade.MaterialBindingAPI.Apply(quad.GetPrim()).GetDirectBindingRel().SetTargets(
        [Sdf.Path("/Asset/Looks/Materials/M_terracotta")])
    asset.GetRootLayer().Save()

    scene = new_stage(tmp_path / "scene.usda")
    add_camera(scene)
    white_dome(scene)
    for path, x in CENTRES.items():
        instance = UsdGeom.Xform.Define(scene, path)
        instance.AddTranslateOp().Set((x, 0.0, 0.0))
        instance.GetPrim().GetReferences().AddReference(str(tmp_path / "asset.usda"))
        instance.GetPrim().SetInstanceable(True)
    scene.GetRootLayer().Save()
    return tmp_path / "scene.usda"


def test_mtlx_references_inside_instance_prototypes_bind_and_render(tmp_path):
    path = instanced_scene(tmp_path)
    originals = {p: p.read_text() for p in (path, tmp_path / "asset.usda")}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        stage = open_stage(path)
        image = penumbra.render(stage, camera="/cam", width=32, samples=64, seed=3)["color"]
    assert not [str(w.message) for w in caught if w.category is penumbra.PenumbraWarning]
    assert len(stage.GetPrototypes()) == 1  # the instances still share one prototype
    for instance, x in CENTRES.items():
        quad = stage.GetPrimAtPath(f"{instance}/quad")
        assert quad.IsInstanceProxy()
        material = bound_material(quad)
        assert material is not None
        assert material.GetPath() == Sdf.Path(f"{instance}/Looks/Materials/M_terracotta")
        column = int((x + 2) / 4 * 32)  # the quad covers columns column ± 4
        patch = image[14:18, column - 2:column + 2, :3].reshape(-1, 3).mean(axis=0)
        np.testing.assert_allclose(patch, TERRACOTTA, rtol=0.03)
    assert {p: p.read_text() for p in originals} == originals  # the user's layers are untouched
