"""UsdPreviewSurface read as its specification and other renderers read it: displacement,
which Penumbra does not render, is named in one warning per material; a primvar reader's
``varname`` may be written with the ``primvars:`` namespace, as hdPrman reads it."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

import penumbra
from stages import (
    add_camera,
    add_primvar_emission_material,
    add_quad,
    bind,
    emitter_stage,
    lit_quad_stage,
    render_with_warnings,
)
from test_textures import quadrants, textured_stage, write_texture

WIDTH = 16
MATERIAL = "/World/Looks/m"
SURFACE = f"{MATERIAL}/Surface"
UNDISPLACED = (
    f"{MATERIAL}: {{shader}}.inputs:displacement: displacement is not supported yet; the "
    "surface renders undisplaced"
)


def displaced_stage(how: str | None) -> Usd.Stage:
    """The lit quad of :func:`lit_quad_stage` bound to a UsdPreviewSurface material whose
    displacement is set as ``how`` says (``None``: not at all)."""
    stage = lit_quad_stage()
    material = UsdShade.Material.Define(stage, MATERIAL)
    surface = UsdShade.Shader.Define(stage, SURFACE)
    surface.CreateIdAttr("UsdPreviewSurface")
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.2, 0.5, 0.8))
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    if how is not None:
        DISPLACEMENTS[how](stage, material, surface)
    bind(UsdGeom.Mesh(stage.GetPrimAtPath("/World/quad")), material)
    return stage


def _displacement(shader: UsdShade.Shader) -> UsdShade.Input:
    return shader.CreateInput("displacement", Sdf.ValueTypeNames.Float)


def _authored(value: float, terminal: bool = True):
    def author(stage, material, surface) -> None:
        _displacement(surface).Set(value)
        if terminal:
            material.CreateDisplacementOutput().ConnectToSource(
                surface.ConnectableAPI(), "displacement"
            )

    return author


def _textured(stage, material, surface) -> None:
    texture = UsdShade.Shader.Define(stage, f"{MATERIAL}/Height")
    texture.CreateIdAttr("UsdUVTexture")
    texture.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath("height.png"))
    _displacement(surface).ConnectToSource(texture.CreateOutput("r", Sdf.ValueTypeNames.Float))
    material.CreateDisplacementOutput().ConnectToSource(surface.ConnectableAPI(), "displacement")


def _interface(value: float):
    def author(stage, material, surface) -> None:
        height = material.CreateInput("height", Sdf.ValueTypeNames.Float)
        height.Set(value)
        _displacement(surface).ConnectToSource(height)

    return author


def _own_shader(stage, material, surface) -> None:
    """The material's displacement terminal names a UsdPreviewSurface of its own."""
    displace = UsdShade.Shader.Define(stage, f"{MATERIAL}/Displace")
    displace.CreateIdAttr("UsdPreviewSurface")
    _displacement(displace).Set(0.2)
    material.CreateDisplacementOutput().ConnectToSource(displace.ConnectableAPI(), "displacement")


DISPLACEMENTS = {
    "authored 1": _authored(1.0),
    "authored -0.5, no terminal": _authored(-0.5, terminal=False),
    "textured": _textured,
    "interface 0.5": _interface(0.5),
    "own shader": _own_shader,
    "authored 0": _authored(0.0),
    "interface 0": _interface(0.0),
}


@pytest.mark.parametrize(
    ("how", "shader"),
    [
        ("authored 1", SURFACE),
        ("authored -0.5, no terminal", SURFACE),
        ("textured", SURFACE),
        ("interface 0.5", SURFACE),
        ("own shader", f"{MATERIAL}/Displace"),
    ],
)
def test_displacement_is_named_once_and_the_surface_renders_undisplaced(
    how: str, shader: str
) -> None:
    """It was ignored without a word."""
    expected, messages = render_with_warnings(displaced_stage(None), WIDTH)
    assert messages == []
    stage = displaced_stage(how)
    add_quad(stage, "/World/second", center=(1.5, 1.5, -0.5), half_size=0.25)
    bind(UsdGeom.Mesh(stage.GetPrimAtPath("/World/second")), UsdShade.Material.Get(stage, MATERIAL))
    image, messages = render_with_warnings(stage, WIDTH)
    assert messages == [UNDISPLACED.format(shader=shader)]  # once, for two meshes
    stage.RemovePrim("/World/second")
    image, _ = render_with_warnings(stage, WIDTH)
    assert np.array_equal(image, expected)


@pytest.mark.parametrize("how", ["authored 0", "interface 0"])
def test_displacement_of_zero_is_not_warned_of(how: str) -> None:
    _, messages = render_with_warnings(displaced_stage(how), WIDTH)
    assert messages == []


@pytest.mark.parametrize("mode", ["presence", "transparent"])
def test_opacity_mode_presence_is_named_once(mode: str) -> None:
    # It was ignored without a word; "transparent", the fallback, is what Penumbra renders.
    stage = displaced_stage(None)
    surface = UsdShade.Shader.Get(stage, SURFACE)
    surface.CreateInput("opacityMode", Sdf.ValueTypeNames.Token).Set(mode)
    surface.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(0.5)
    _, messages = render_with_warnings(stage, WIDTH)
    expected = [
        f"{SURFACE}: inputs:opacityMode 'presence' is not supported yet; opacity below 1 "
        "renders as translucency ('transparent' as Penumbra reads it)"
    ]
    assert messages == (expected if mode == "presence" else [])


def render_emission(stage: Usd.Stage) -> np.ndarray:
    """The colour of ``stage`` through ``/cam``, emission alone (no bounces)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = penumbra.Renderer(stage).render(
            camera="/cam", width=WIDTH, samples=4, seed=1, max_path_depth=0
        )
    assert not [w for w in caught if issubclass(w.category, penumbra.PenumbraWarning)]
    return np.asarray(image["color"])[..., :3]


@pytest.mark.parametrize("varname", ["displayColor", "primvars:displayColor"])
def test_a_primvar_readers_varname_may_be_written_with_its_namespace(varname: str) -> None:
    """``primvars:displayColor`` read the fallback, black."""
    stage = emitter_stage()
    add_camera(stage)
    quad = add_quad(stage, "/World/quad", half_size=2.0, color=(0.2, 0.4, 0.6))
    bind(quad, add_primvar_emission_material(stage, "/World/Looks/pv", varname))
    image = render_emission(stage)
    np.testing.assert_allclose(image[WIDTH // 2, WIDTH // 2], [0.2, 0.4, 0.6], rtol=1e-5)


def test_texture_coordinates_may_name_their_primvar_with_its_namespace(tmp_path: Path) -> None:
    """A texture's ``st`` read through ``primvars:st`` is the one read through ``st`` (it was
    the reader's fallback, (0, 0): the whole quad one texel's colour)."""
    file = write_texture(tmp_path / "quadrants.png", quadrants())
    images = []
    for varname in ("st", "primvars:st"):
        stage, _ = textured_stage(file)
        reader = UsdShade.Shader.Get(stage, "/World/Looks/textured/StReader")
        reader.GetInput("varname").Set(varname)
        images.append(render_emission(stage))
    assert np.array_equal(images[0], images[1])
    assert not np.allclose(images[1][2, 2], images[1][-3, -3])  # red top left, white bottom right
