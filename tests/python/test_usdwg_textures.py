"""The usd-wg texture assets (issue 5): UsdUVTexture, UsdPrimvarReader_float2 and UsdTransform2d
render with the orientation, transforms and colours the UsdPreviewSurface spec gives them.

Assets (tests/assets/usd-wg/test_assets, not edited; every change below is made in the
stage's session layer):

- TextureCoordinateTest.usda: four quads, each showing one corner (0.4 × 0.4 of st space) of
  TextureCoordinateTemplate.png (black marks on white, sRGB), st from ``primvars:st0``
  (vertex), tinted by UsdUVTexture ``scale`` (yellow, orange-red, blue, green); a grey back
  plane. No camera, no light.
- TextureTransformTest.usd (crate): six panels (root xform: scale 100, rotated 180° about Y,
  metersPerUnit 0.01); Offset U/V/UV show one quadrant of a four-colour "UV" texture through a
  UsdTransform2d translation; Rotation, Scale and All show an arrow texture through rotation
  22.5°, scale 1.5 and all three (wrap clamp). Small "Correct" / "Error" / "Not Supported"
  marker quads say where each arrow must point. Textures use the legacy ``isSRGB = "auto"``
  (no sourceColorSpace): 8-bit PNGs, so sRGB. No camera, no light.

Expectations come from ``texture_expectations`` (pxr + its own PNG decoder, no renderer code):
the albedo every pixel should show, by the spec's conventions. The renders use an orthographic
camera of ours looking down −Z and the default uniform white dome (the assets have no lights),
so a diffuse surface renders as ``offset + gain · albedo``; gain and offset are measured on a
white and a black calibration patch of ours that copy the asset's UsdPreviewSurface inputs
(roughness 1; specular F0 0.04 in TextureCoordinateTest, none in TextureTransformTest).

Noise (measured at 16 spp): per pixel σ ≈ 3 % of the value, σ ≈ 1 % for a 3×3-pixel mean.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdShade

import penumbra
import texture_expectations as te
from stages import SCENES

USDWG = SCENES / "usd-wg" / "test_assets"
TCT_FILE = USDWG / "TextureCoordinateTest" / "TextureCoordinateTest.usda"
TTT_FILE = USDWG / "TextureTransformTest" / "TextureTransformTest.usd"
SAMPLES = 16
CAMERA = "/TestCamera"
WHITE, BLACK = "/TestCalibration/white", "/TestCalibration/black"

# The whole of each asset plus the calibration patches above it, at a round pixel size.
TCT_VIEW = te.OrthoView(cx=0.0, cy=0.2, width=2.6, height=3.0, pixels=260)  # 0.01 unit / px
TTT_VIEW = te.OrthoView(cx=0.0, cy=22.0, width=330.0, height=264.0, pixels=275)  # 1.2 units / px

TCT_MAT = "/Asset/Materials/UsdPreviewSurface/Materials"
TCT_MESH = "/Asset/Scenes/Scene/{0}Obj/{0}Mesh/submesh"
TTT_ROOT = "/TextureTransformTest"

# A 3×3-pixel mean of a uniform region must be within ABS_TOL + REL_TOL · expected of
# offset + gain · albedo, per channel: 6 % is 6σ of the 16-spp noise of such a mean (so a
# correct render never fails), yet a tenth of the smallest error looked for (linear vs sRGB
# decoding of 192/255: 0.527 vs 0.753; clamp border 0.745 vs white 1).
ABS_TOL, REL_TOL = 0.02, 0.06
UNIFORM_MARGIN = 3
"""px around a pixel (beyond the 1.5-px filter) that must show one colour for the pixel to count
as uniform: room for a 3×3 mean (1 px) and a mip level whose texels are 2 px."""
UNIFORM_PASS_FRACTION = 0.995  # of the uniform pixels of each mesh (noise outliers, not errors)


@dataclass
class Rendered:
    stage: Usd.Stage
    view: te.OrthoView
    ref: te.Reference
    color: np.ndarray  # (H, W, 4) scene-linear
    gain: np.ndarray
    offset: np.ndarray
    warnings: list[str]
    wrong: dict[str, np.ndarray] | None = None  # see wrong_references()
    masks: dict[str, np.ndarray] = field(default_factory=dict)  # see interior()
    boxes: dict[str, np.ndarray] = field(default_factory=dict)  # see box_means()

    def albedo(self, color=None) -> np.ndarray:
        """Rendered colour turned back into albedo with the calibration."""
        color = self.color[..., :3] if color is None else color
        return (color - self.offset) / self.gain

    def index(self, path: str) -> int:
        return [s.path for s in self.ref.surfaces].index(path)

    def surface(self, path: str) -> te.Surface:
        return te.surface_named(self.ref.surfaces, path)

    def surface_at(self, x: float, y: float) -> str:
        """Path of the surface the reference sees at world (x, y)."""
        column, row = self.view.to_pixel(x, y)
        return self.ref.surfaces[self.ref.surface[int(row), int(column)]].path

    def pixel_mean(self, x: float, y: float, radius: int = 0) -> np.ndarray:
        """Mean colour of the (2r+1)² pixels around the pixel containing world (x, y)."""
        column, row = self.view.to_pixel(x, y)
        c, r = int(column), int(row)
        block = self.color[r - radius : r + radius + 1, c - radius : c + radius + 1, :3]
        return block.reshape(-1, 3).astype(np.float64).mean(axis=0)


def _render(stage: Usd.Stage, view: te.OrthoView) -> np.ndarray:
    image = penumbra.render(stage, camera=CAMERA, width=view.pixels, samples=SAMPLES)
    assert image["color"].shape[:2] == (view.rows, view.pixels)
    return image["color"]


def _prepare(stage: Usd.Stage, view: te.OrthoView, camera_z: float, like_shader: str, patches):
    """Camera and calibration patches in the session layer."""
    shader = UsdShade.Shader(stage.GetPrimAtPath(like_shader))
    assert shader, like_shader
    with Usd.EditContext(stage, stage.GetSessionLayer()):
        view.define_camera(stage, CAMERA, camera_z)
        te.add_calibration_patches(
            stage, shader, {"white": (patches[0], (1, 1, 1)), "black": (patches[1], (0, 0, 0))}
        )


def _finish(stage: Usd.Stage, view: te.OrthoView, ref: te.Reference) -> Rendered:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        color = _render(stage, view)
    gain, offset = te.calibrate(color, ref, WHITE, BLACK)
    return Rendered(stage, view, ref, color, gain, offset, [str(w.message) for w in caught])


def texture_coordinate_stage() -> tuple[Usd.Stage, te.OrthoView]:
    stage = Usd.Stage.Open(str(TCT_FILE))
    _prepare(
        stage, TCT_VIEW, 10.0, f"{TCT_MAT}/TopLeftMat/UsdPreviewSurface",
        ((-1.2, 1.3, -0.2, 1.65), (0.2, 1.3, 1.2, 1.65)),
    )
    return stage, TCT_VIEW


def marker_panel(name: str) -> str:
    return name.split("___")[0]


def texture_transform_stage() -> tuple[Usd.Stage, te.OrthoView]:
    """The asset, with its marker quads put back where the glTF original and the usdview
    screenshot have them: in this version of the asset they are siblings of their panels
    (e.g. /TextureTransformTest/Rotation___Correct) with transforms relative to the panel, so
    as authored they pile up in the middle of the stage, over the Scale panel's arrow."""
    stage = Usd.Stage.Open(str(TTT_FILE))
    _prepare(
        stage, TTT_VIEW, 500.0, f"{TTT_ROOT}/Materials/Offset_U_53148/PreviewSurface",
        ((-150, 112, -60, 145), (60, 112, 150, 145)),
    )
    with Usd.EditContext(stage, stage.GetSessionLayer()):
        for prim in stage.GetPrimAtPath(TTT_ROOT).GetChildren():
            if "___" not in prim.GetName():
                continue
            panel = stage.GetPrimAtPath(f"{TTT_ROOT}/{marker_panel(prim.GetName())}")
            own = UsdGeom.Xformable(prim).GetLocalTransformation()
            parent = UsdGeom.Xformable(panel).GetLocalTransformation()
            op = UsdGeom.Xformable(prim).GetOrderedXformOps()[0]
            assert op.GetOpType() == UsdGeom.XformOp.TypeTransform
            op.Set(Gf.Matrix4d(own * parent))
    return stage, TTT_VIEW


@pytest.fixture(scope="module")
def tct_expected():
    stage, view = texture_coordinate_stage()
    return stage, view, te.reference_render(stage, view, margin=UNIFORM_MARGIN)


@pytest.fixture(scope="module")
def ttt_expected():
    stage, view = texture_transform_stage()
    return stage, view, te.reference_render(stage, view, margin=UNIFORM_MARGIN)


@pytest.fixture(scope="module")
def tct(tct_expected) -> Rendered:
    return _finish(*tct_expected)


@pytest.fixture(scope="module")
def ttt(ttt_expected) -> Rendered:
    return _finish(*ttt_expected)


# ------------------------------------------------------------------------------------------
# Checks shared by both assets


def textured(r: Rendered) -> list[te.Surface]:
    return [s for s in r.ref.surfaces if s.texture is not None]


def check_uniform_pixels(r: Rendered, exclude: np.ndarray | None = None) -> None:
    """Every pixel well inside a region of one texture colour (see te.Reference.uniform)
    matches offset + gain · expected albedo (3×3-pixel means)."""
    means = te.box_mean(r.color, 1)
    expected = r.offset + r.gain * r.ref.albedo
    ok = np.abs(means - expected) <= ABS_TOL + REL_TOL * np.abs(expected)
    failures = []
    for surface in textured(r):
        mask = r.ref.uniform & (r.ref.surface == r.index(surface.path))
        if exclude is not None:
            mask &= ~exclude
        if (r.ref.surface == r.index(surface.path)).sum() >= 2000:  # not the small markers
            assert mask.sum() >= 50, f"{surface.path}: too few uniform pixels ({mask.sum()})"
        if not mask.any():
            continue
        good = ok[mask].all(axis=-1)
        if good.mean() < UNIFORM_PASS_FRACTION:
            rows, cols = np.nonzero(mask)
            worst = np.argmax(np.abs(means[mask] - expected[mask]).max(axis=-1))
            failures.append(
                f"{surface.path}: {100 * (1 - good.mean()):.1f} % of {mask.sum()} uniform pixels "
                f"off; e.g. pixel (col {cols[worst]}, row {rows[worst]}) "
                f"rendered {np.round(means[mask][worst], 3)}, "
                f"expected {np.round(expected[mask][worst], 3)}"
            )
    assert not failures, "\n".join(failures)


WRONG_CONVENTIONS = {
    "t flipped (t = 0 at the top row)": te.Conventions(flip_t=True),
    "s and t swapped": te.Conventions(swap_st=True),
    "translate before scale and rotate": te.Conventions(transform_order="TRS"),
    "translate before rotate": te.Conventions(transform_order="STR"),
    "rotation clockwise": te.Conventions(clockwise=True),
    "UsdTransform2d ignored": te.Conventions(ignore_transform=True),
    "sRGB textures not decoded": te.Conventions(decode_srgb=False),
    "UsdUVTexture scale/bias ignored": te.Conventions(apply_scale_bias=False),
    "wrap repeat instead of clamp": te.Conventions(wrap_override="repeat"),
}
MATTERS = 0.0008
"""Mean squared difference of 3×3-pixel means of albedo over a mesh above which a wrong
convention "matters" for it: 10 × the 16-spp noise variance of such means (σ ≈ 1 % of ≤ 0.9).
(A flipped t changes TextureCoordinateTest's quads by 0.0014–0.003, TextureTransformTest's
panels by ≥ 0.005.)"""


def interior(r: Rendered, surface: te.Surface, margin: int = 1) -> np.ndarray:
    """Pixels of ``surface`` at least ``margin`` px from its silhouette."""
    key = f"{surface.path}:{margin}"
    if key in r.masks:
        return r.masks[key]
    mask = r.ref.surface == r.index(surface.path)
    inner = mask.copy()
    inner[margin:] &= mask[:-margin]
    inner[:-margin] &= mask[margin:]
    inner[:, margin:] &= mask[:, :-margin]
    inner[:, :-margin] &= mask[:, margin:]
    r.masks[key] = inner
    return inner


def grow(mask: np.ndarray, radius: int) -> np.ndarray:
    return te.box_mean(mask[..., None].astype(np.float64) * np.ones(3), radius)[..., 0] > 0


def near_clamped(r: Rendered) -> np.ndarray:
    """Pixels within 2 px of a sample clamped off its image: what clamp shows there depends
    on the mip level (see check_clamped_regions), so no exact expectation holds."""
    if "near_clamped" not in r.masks:
        r.masks["near_clamped"] = grow(r.ref.clamped_any, 2)
    return r.masks["near_clamped"]


def check_clamped_regions(r: Rendered) -> None:
    """Where a panel's transformed st is off the image along a clamped axis (and 3 px from
    where it is not), clamp extends the image's edge texels: its 1-texel frame of 224/255 grey
    (0.745 decoded) at full resolution, averaged with the white inside at coarser mip levels
    (Penumbra: 0.83–0.90). So light grey to white (3×3 means within [0.70, 1.06]), and never
    a copy of the arrow as repeat would show (dark pixels)."""
    means = r.albedo(te.box_mean(r.color, 1))
    far = r.ref.clamped_all & ~grow(~r.ref.clamped_all, 3)
    failures = []
    for surface in textured(r):
        mask = far & (r.ref.surface == r.index(surface.path))
        if not mask.any():
            continue
        values = means[mask]
        if values.min() < 0.70 or values.max() > 1.06:
            failures.append(
                f"{surface.path}: {mask.sum()} px clamped off the image show albedo "
                f"{values.min():.3f}–{values.max():.3f}, not the edge's light grey to white"
            )
    assert not failures, "\n".join(failures)


def wrong_references(r: Rendered) -> dict[str, np.ndarray]:
    """The expected albedo image under each wrong convention (computed once per render)."""
    if r.wrong is None:
        r.wrong = {name: te.reshade(r.ref, conv) for name, conv in WRONG_CONVENTIONS.items()}
    return r.wrong


def box_means(r: Rendered) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """3×3-pixel means of the spec's and of each wrong convention's expected albedo."""
    if "spec" not in r.boxes:
        r.boxes["spec"] = te.box_mean(r.ref.albedo)
        for name, image in wrong_references(r).items():
            r.boxes[name] = te.box_mean(image)
    return r.boxes["spec"], {name: r.boxes[name] for name in WRONG_CONVENTIONS}


def check_closer_to_spec_than_to_wrong_conventions(r: Rendered) -> list[str]:
    """For every textured mesh and every wrong convention that changes what the mesh shows,
    the render is much closer to the spec's expectation than to the wrong one's: the mean
    squared error of 3×3-pixel means of albedo (rendered colour calibrated back to albedo) at
    most half. Returns the checks made."""
    rendered = te.box_mean(r.albedo())
    spec_image, wrong_images = box_means(r)
    made, failures = [], []
    for name, wrong in wrong_images.items():
        for surface in textured(r):
            mask = interior(r, surface, margin=2) & ~near_clamped(r)
            if mask.sum() < 2000:
                continue  # the small markers: edges dominate (they have probes of their own)
            spec = spec_image[mask]
            other = wrong[mask]
            if ((spec - other) ** 2).mean() < MATTERS:
                continue
            to_spec = ((rendered[mask] - spec) ** 2).mean()
            to_wrong = ((rendered[mask] - other) ** 2).mean()
            made.append(f"{surface.path}: {name}")
            if not to_spec <= 0.5 * to_wrong:
                failures.append(
                    f"{surface.path}: the render is not closer to the spec than to '{name}' "
                    f"(mean squared error {to_spec:.5f} vs {to_wrong:.5f})"
                )
    assert not failures, "\n".join(failures)
    return made


def close(rendered_albedo, expected, what: str) -> None:
    """A probe (one pixel, or a 3×3 mean) against an albedo: 16-spp noise (σ 3 % per pixel)
    plus a pixel filter that reaches 1.5 px: ±0.06 + 12 %."""
    rendered_albedo = np.asarray(rendered_albedo)
    expected = np.asarray(expected, dtype=np.float64)
    assert np.all(np.abs(rendered_albedo - expected) <= 0.06 + 0.12 * expected), (
        f"{what}: rendered albedo {np.round(rendered_albedo, 3)}, expected {np.round(expected, 3)}"
    )


def assert_dark(rendered_albedo, tint, what: str) -> None:
    """A black feature of 4–5 px: at most 30 % of the tint (+ 0.05) in every channel, room for a
    texture filter blurring it with its white surroundings (white would give 100 %)."""
    limit = 0.3 * np.asarray(tint, dtype=np.float64) + 0.05
    assert np.all(np.asarray(rendered_albedo) <= limit), (
        f"{what} is not black: rendered albedo {np.round(rendered_albedo, 3)}"
    )


def no_shading_warnings(r: Rendered) -> None:
    """No warning names a material or shader of the asset, or a texture file."""
    network = [w for w in r.warnings if "/Materials/" in w or ".png" in w.lower()]
    assert not network, "warnings about the shading networks:\n" + "\n".join(network)


# ------------------------------------------------------------------------------------------
# TextureCoordinateTest


TCT_QUADS = {
    # quad: (centre in the render's layout as in the README screenshot, UsdUVTexture scale)
    "TopLeft": ((-0.7, 0.7), (0.8, 0.8, 0.0)),  # yellow
    "TopRight": ((0.7, 0.7), (0.8, 0.08, 0.0)),  # orange-red
    "BottomLeft": ((-0.7, -0.7), (0.0, 0.16, 0.8)),  # blue
    "BottomRight": ((0.7, -0.7), (0.0, 0.8, 0.0)),  # green
}
# The biggest black square of each corner's checker strip, texel centre (column, row; row 0 at
# the top), as in TextureCoordinateTemplate.png: each quad shows its own corner of the image, so
# the square sits in the quad's outer corner (README screenshot).
TCT_CORNER_SQUARES = {
    "TopLeft": (15.0, 15.0), "TopRight": (497.0, 15.0),
    "BottomLeft": (15.0, 497.0), "BottomRight": (497.0, 497.0),
}


def test_texture_coordinate_quadrants_as_in_the_screenshot(tct):
    """Each quad is tinted by its own UsdUVTexture scale (white texels × scale) in the
    screenshot's layout, and shows the checker strip of its own image corner in its outer
    corner, at the scale st0 gives (0.4 of the image across the quad)."""
    for quad, ((x, y), scale) in TCT_QUADS.items():
        mesh = TCT_MESH.format(quad)
        assert tct.surface_at(x, y) == mesh, f"{quad}: {tct.surface_at(x, y)} there"
        # Centre: white texel (102 or 410, 102 or 410) × scale.
        close(tct.albedo(tct.pixel_mean(x, y, radius=2)), scale, f"{quad} quad centre")
        # Outer-corner checker square: 10 texels ≈ 4.9 px, black.
        surface = tct.surface(mesh)
        corner = te.world_at_st(surface, te.texel_to_st(surface.texture, *TCT_CORNER_SQUARES[quad]))
        outer_x, outer_y = np.sign(x), np.sign(y)
        assert corner[0] * outer_x > 1.05 and corner[1] * outer_y > 1.05  # the outer corner
        assert_dark(tct.albedo(tct.pixel_mean(corner[0], corner[1])), scale,
                    f"{quad}: the checker square in the outer corner")
        # Diagonally next to it (texel + 10, + 10 towards the image centre): black again; one
        # step along an edge: white × scale.
        step_x = 10.0 if quad.endswith("Left") else -10.0
        step_y = 10.0 if quad.startswith("Top") else -10.0
        cx, cy = TCT_CORNER_SQUARES[quad]
        for dx, dy, black in ((step_x, step_y, True), (step_x, 0.0, False)):
            p = te.world_at_st(surface, te.texel_to_st(surface.texture, cx + dx, cy + dy))
            got = tct.albedo(tct.pixel_mean(p[0], p[1]))
            what = f"{quad}: checker texel ({cx + dx}, {cy + dy})"
            if black:
                assert_dark(got, scale, what)
            else:
                close(got, scale, what)


def test_texture_coordinate_uniform_regions_match_expectation(tct):
    check_uniform_pixels(tct)


def test_texture_coordinate_orientation_is_the_specs(tct):
    """The quads (their labels and marks, not only the tints) match the spec's st
    orientation far better than a flipped or transposed one."""
    made = check_closer_to_spec_than_to_wrong_conventions(tct)
    for quad in TCT_QUADS:
        mesh = TCT_MESH.format(quad)
        for convention in ("t flipped", "s and t swapped", "scale/bias ignored"):
            assert any(m.startswith(mesh) and convention in m for m in made), (mesh, convention)


def test_texture_coordinate_renders_without_shading_warnings(tct):
    no_shading_warnings(tct)


# ------------------------------------------------------------------------------------------
# TextureTransformTest

UV_TEXELS = {
    # panel: texel of the UV texture (256²) showing its label's background, sRGB (0, 192, 0)…
    "Offset_U": ((140.0, 20.0), (0, 192, 0)),  # green "U" quadrant (top right)
    "Offset_V": ((20.0, 140.0), (0, 0, 192)),  # blue "V" quadrant (bottom left)
    "Offset_UV": ((140.0, 140.0), (0, 192, 192)),  # cyan "UV" quadrant (bottom right)
}
ARROW_TEXELS = {
    # Arrow texture (128²), black: the deepest point of the arrowhead and the shaft's middle.
    "arrowhead": (75.5, 75.5),
    "shaft": (45.5, 45.5),
}
SRGB_192 = 0.527115  # (192/255) through the sRGB transfer function


def test_texture_transform_offsets_show_their_quadrant(ttt):
    """Offset U/V/UV show the U, V and UV quadrants (never the yellow "not supported" one),
    sRGB-decoded (192/255 → 0.527, not 0.753)."""
    for panel, ((column, row), srgb) in UV_TEXELS.items():
        surface = ttt.surface(f"{TTT_ROOT}/{panel}")
        assert np.allclose(surface.texture.texels[int(row), int(column), :3] * 255, srgb)
        p = te.world_at_st(surface, te.texel_to_st(surface.texture, column, row))
        got = ttt.albedo(ttt.pixel_mean(p[0], p[1], radius=1))
        expected = [SRGB_192 if v else 0.0 for v in srgb]
        close(got, expected, f"{panel} at texel {(column, row)}")
        # The panel's centre: the same quadrant (its background or its white check mark).
        centre = ttt.albedo(ttt.pixel_mean(*surface.triangles.reshape(-1, 3).mean(axis=0)[:2], 3))
        yellow = centre[0] > 0.3 and centre[1] > 0.3 and centre[2] < 0.15
        assert not yellow, f"{panel} shows the 'not supported' quadrant: {np.round(centre, 3)}"


def test_texture_transform_arrows(ttt):
    """Rotation, Scale and All: the arrow is black where the spec's scale → rotate → translate
    puts it, and where the transformed st is off the image, clamp extends its edge."""
    for panel in ("Rotation", "Scale", "All"):
        surface = ttt.surface(f"{TTT_ROOT}/{panel}")
        for part, texel in ARROW_TEXELS.items():
            p = te.world_at_st(surface, te.texel_to_st(surface.texture, *texel))
            got = ttt.albedo(ttt.pixel_mean(p[0], p[1]))
            assert np.all(got < 0.15), f"{panel}: the {part} is not black: {np.round(got, 3)}"
    for panel in ("Rotation", "Scale", "All"):  # each has a clamped region of ≥ 1600 px
        surface = ttt.surface(f"{TTT_ROOT}/{panel}")
        assert (ttt.ref.clamped_all & (ttt.ref.surface == ttt.index(surface.path))).sum() > 1000
    check_clamped_regions(ttt)


def test_texture_transform_uniform_regions_match_expectation(ttt):
    """All panels and markers; panel pixels within 6 units (5 px) of a marker are left out:
    the markers float 1 unit in front and shade them from part of the dome."""
    near_marker = np.zeros(ttt.ref.surface.shape, bool)
    for surface in ttt.ref.surfaces:
        if "___" not in surface.path:
            continue
        corners = surface.triangles.reshape(-1, 3)
        (c0, r0), (c1, r1) = (ttt.view.to_pixel(corners[:, 0].min(), corners[:, 1].max()),
                              ttt.view.to_pixel(corners[:, 0].max(), corners[:, 1].min()))
        pad = 6.0 / ttt.view.pixel_size
        near_marker[max(int(r0 - pad), 0): int(r1 + pad) + 1,
                    max(int(c0 - pad), 0): int(c1 + pad) + 1] = True
    markers = np.isin(ttt.ref.surface, [ttt.index(s.path) for s in ttt.ref.surfaces
                                        if "___" in s.path])
    check_uniform_pixels(ttt, exclude=near_marker & ~markers)


def test_texture_transform_is_the_specs(ttt):
    """Every panel matches the spec's transform order, rotation direction, wrap and colour
    decoding far better than any wrong convention that changes it."""
    made = check_closer_to_spec_than_to_wrong_conventions(ttt)
    for panel, conventions in {
        "Offset_U": ("t flipped", "UsdTransform2d ignored"),
        "Offset_V": ("t flipped", "UsdTransform2d ignored", "sRGB"),
        "Rotation": ("rotation clockwise", "translate before rotate", "UsdTransform2d ignored"),
        "Scale": ("translate before scale", "UsdTransform2d ignored"),
        "All": ("rotation clockwise", "translate before rotate", "translate before scale"),
    }.items():
        for convention in conventions:
            assert any(m.startswith(f"{TTT_ROOT}/{panel}:") and convention in m for m in made), (
                panel, convention)


def test_texture_transform_arrows_point_at_the_correct_markers(ttt):
    """The semantic outcome: each arrow ends at its panel's "Correct" marker (green with a
    white tick) and reaches neither its "Error" nor its "Not Supported" marker."""
    for panel in ("Rotation", "Scale", "All"):
        mask = ttt.ref.surface == ttt.index(f"{TTT_ROOT}/{panel}")
        dark = mask & (ttt.albedo().max(axis=-1) < 0.25)
        rows, cols = np.nonzero(dark)
        assert len(rows) > 30, f"{panel}: no arrow"
        for marker in ttt.ref.surfaces:
            name = marker.path.rsplit("/", 1)[1]
            if "___" not in name or marker_panel(name) != panel:
                continue
            corners = marker.triangles.reshape(-1, 3)
            (c0, r0), (c1, r1) = (ttt.view.to_pixel(corners[:, 0].min(), corners[:, 1].max()),
                                  ttt.view.to_pixel(corners[:, 0].max(), corners[:, 1].min()))
            dc = np.maximum(np.maximum(c0 - (cols + 0.5), (cols + 0.5) - c1), 0)
            dr = np.maximum(np.maximum(r0 - (rows + 0.5), (rows + 0.5) - r1), 0)
            distance = float(np.hypot(dc, dr).min())  # px from the marker to the arrow
            kind = marker.path.rsplit("___", 1)[1]
            if kind == "Correct":
                # The spec's arrows end 3–5.4 px (4–7 units) short of the marker's square.
                assert distance <= 8.0, f"{panel}: the arrow ends {distance:.1f} px from Correct"
                # The marker itself: green (sRGB 192) beside the tick, inside its 8–12 px square.
                p = te.world_at_st(marker, np.array([0.25, 0.75]))
                r, g, b = ttt.albedo(ttt.pixel_mean(p[0], p[1]))
                # Green 0.527; the Error marker would be red, Not Supported yellow (g − r ≈ 0).
                assert g - max(r, b) > 0.25 and g < 0.75, f"{marker.path} not green: {r, g, b}"
            else:
                # ≥ 27 px by the spec; ignoring UsdTransform2d reaches Not Supported (3.4 px),
                # wrap repeat the Rotation panel's Error (2.7 px).
                assert distance >= 12.0, f"{panel}: the arrow reaches {kind} ({distance:.1f} px)"


def test_texture_transform_renders_without_shading_warnings(ttt):
    no_shading_warnings(ttt)


# The wrong conventions each asset can show (TextureCoordinateTest has no UsdTransform2d, clamp
# or mid-grey texels; TextureTransformTest has scale 1 and bias 0 everywhere).
DETECTABLE = {
    "TextureCoordinateTest": {
        "t flipped (t = 0 at the top row)", "s and t swapped", "UsdUVTexture scale/bias ignored"},
    "TextureTransformTest": set(WRONG_CONVENTIONS) - {"UsdUVTexture scale/bias ignored"},
}


@pytest.mark.parametrize("asset", ["TextureCoordinateTest", "TextureTransformTest"])
def test_wrong_conventions_would_fail(asset, request):
    """The tests' power, without rendering: an image made from the spec's expectation (blurred
    more than the reference, with 3 % noise) passes the dense checks, and images made the same
    way from each wrong convention's expectation fail them."""
    stage, view, ref = request.getfixturevalue(
        {"TextureCoordinateTest": "tct_expected", "TextureTransformTest": "ttt_expected"}[asset]
    )
    gain, offset = np.array([0.98, 0.98, 0.98]), np.array([0.01, 0.01, 0.01])
    r = Rendered(stage, view, ref, None, gain, offset, [])

    def fake(albedo) -> Rendered:
        return Rendered(stage, view, ref, _fake_color(albedo, gain, offset), gain, offset,
                        [], wrong=wrong_references(r), masks=r.masks, boxes=r.boxes)

    spec = fake(r.ref.albedo)
    check_uniform_pixels(spec)
    check_closer_to_spec_than_to_wrong_conventions(spec)
    check_clamped_regions(spec)
    caught = set()
    for name, wrong in wrong_references(r).items():
        for check in (check_uniform_pixels, check_closer_to_spec_than_to_wrong_conventions,
                      check_clamped_regions):
            try:
                check(fake(wrong))
            except AssertionError:
                caught.add(name)
                break
    assert DETECTABLE[asset] <= caught, f"not detected: {DETECTABLE[asset] - caught}"


def _fake_color(albedo, gain, offset, seed=0):
    """A render-like image: offset + gain · albedo, slightly blurred (a wider texture filter
    than the reference's) and with 3 % multiplicative noise."""
    blurred = te.box_mean(albedo, 1) * 0.5 + albedo * 0.5
    noise = np.random.default_rng(seed).normal(1.0, 0.03, albedo.shape)
    color = offset + gain * blurred * noise
    return np.concatenate([color, np.ones_like(color[..., :1])], axis=-1).astype(np.float32)
