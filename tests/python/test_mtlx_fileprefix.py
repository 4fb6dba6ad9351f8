"""MaterialX documents as real assets write them (docs/materialx.md): the usd-wg MaterialXTest
teapot's ``standard_surface_brass_tiled.mtlx`` sets ``fileprefix="./textures/"`` and file
values that already start with ``./textures/``; usdview finds its textures beside the document,
and so must Penumbra. Opening a stage that references ``.mtlx`` documents shows Penumbra's
messages only, not usd-core's raw "Cannot determine file format" warnings."""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdShade

import penumbra
from penumbra.usd import open_stage
from stages import add_camera, add_quad, new_stage
from test_textures import write_texture

# 8-bit values read back exactly (the file input is declared linear: no transfer function).
TEXTURE_COLOR = (64 / 255, 128 / 255, 192 / 255)

DOCUMENT = """<?xml version="1.0"?>
<materialx version="1.38" colorspace="lin_rec709" fileprefix="./textures/">
  <nodegraph name="NG_glow">
    <image name="image_color" type="color3">
      <input name="file" type="filename" value="{value}" colorspace="lin_rec709" />
    </image>
    <output name="out_color" type="color3" nodename="image_color" />
  </nodegraph>
  <standard_surface name="SR_glow" type="surfaceshader">
    <input name="base" type="float" value="0" />
    <input name="specular" type="float" value="0" />
    <input name="emission" type="float" value="1" />
    <input name="emission_color" type="color3" nodegraph="NG_glow" output="out_color" />
  </standard_surface>
  <surfacematerial name="Glow" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="SR_glow" />
  </surfacematerial>
</materialx>
"""


def asset(tmp_path: Path, value: str) -> Path:
    """A stage file whose quad fills the view and is bound to the Glow material of a document
    whose image file input is ``value``, the texture being textures/glow.png beside it."""
    (tmp_path / "textures").mkdir()
    write_texture(tmp_path / "textures" / "glow.png", np.full((8, 8, 3), TEXTURE_COLOR))
    (tmp_path / "glow.mtlx").write_text(DOCUMENT.format(value=value))
    stage = new_stage()
    add_camera(stage, aperture=(1.6, 1.6))
    quad = add_quad(stage, "/World/quad")
    UsdGeom.PrimvarsAPI(quad).CreatePrimvar(
        "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex
    ).Set([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)])
    stage.DefinePrim("/MaterialX", "Scope").GetReferences().AddReference(
        "./glow.mtlx", "/MaterialX"
    )
    UsdShade.MaterialBindingAPI.Apply(quad.GetPrim()).GetDirectBindingRel().SetTargets(
        [Sdf.Path("/MaterialX/Materials/Glow")]
    )
    path = tmp_path / "scene.usda"
    stage.GetRootLayer().Export(str(path))
    return path


def render_warned(path: Path) -> tuple[np.ndarray, list[str]]:
    """The quad's mean RGB, and the Penumbra warnings opening and rendering the stage gave."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = penumbra.render(open_stage(path), camera="/cam", width=8, samples=4)["color"]
    messages = [str(w.message) for w in caught if w.category is penumbra.PenumbraWarning]
    return image[..., :3].reshape(-1, 3).mean(axis=0), messages


def test_a_value_that_repeats_the_fileprefix_finds_its_texture_beside_the_document(tmp_path):
    path = asset(tmp_path, "./textures/glow.png")
    color, messages = render_warned(path)
    np.testing.assert_allclose(color, TEXTURE_COLOR, atol=0.01)
    prefixed = tmp_path / "textures" / "textures" / "glow.png"
    found = tmp_path / "textures" / "glow.png"
    assert len(messages) == 1, messages
    assert str(prefixed) in messages[0] and str(found) in messages[0]
    assert "glow.mtlx" in messages[0] and "fileprefix" in messages[0]


def test_a_value_under_its_fileprefix_needs_no_fallback(tmp_path):
    color, messages = render_warned(asset(tmp_path, "glow.png"))
    np.testing.assert_allclose(color, TEXTURE_COLOR, atol=0.01)
    assert not messages


def test_a_file_found_neither_way_is_the_prefixed_one_and_reported_missing(tmp_path):
    color, messages = render_warned(asset(tmp_path, "./textures/none.png"))
    assert any(str(tmp_path / "textures" / "textures" / "none.png") in m for m in messages)
    assert not any("the value alone" in m for m in messages)


@pytest.mark.parametrize("document", ["glow.mtlx", "absent.mtlx"])
def test_opening_shows_no_raw_usd_warning_for_mtlx_references(tmp_path, document):
    path = asset(tmp_path, "glow.png")
    if document != "glow.mtlx":
        path.write_text(path.read_text().replace("./glow.mtlx", f"./{document}"))
    script = f"from penumbra.usd import open_stage; open_stage({str(path)!r})"
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120, check=True
    )
    assert "Cannot determine file format" not in result.stderr
    assert "Warning: in " not in result.stderr  # usd-core's own diagnostic prefix
    if document == "absent.mtlx":  # Penumbra's own message stays
        assert f"{document}: MaterialX document not found" in result.stderr
