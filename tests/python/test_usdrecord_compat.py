"""``penumbra-record`` as a drop-in for usdrecord (issue 11, items 1, 3 and 6): every flag,
no abbreviations, camera lookup and image size as usdrecord's, and the Python API's
ergonomics."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdRender, UsdShade

import penumbra
from penumbra import _core
from penumbra.cli import main
from penumbra.usd.settings import usdrecord_height
from stages import add_camera, add_quad, bind, emitter_stage, lit_quad_stage

TINY = ["-w", "8", "-spp", "1"]


def camera_of(path: Path) -> str:
    return str(_core.read_image(str(path))[2]["penumbra:camera"])


@pytest.fixture
def quad_file(tmp_path) -> Path:
    path = tmp_path / "quad.usda"
    lit_quad_stage(path).Save()
    return path


# ------------------------------------------------------------------------------------------
# Item 1: flags


@pytest.mark.parametrize(
    "flags",
    [
        ["--disableGpu"],
        ["--renderer", "Penumbra"],
        ["-r", "penumbra"],
        ["--disableDrawMode"],
        ["--resolver", "inherit"],
        ["--resolver", "root"],
        ["--enableDomeLightVisibility", "--disableCameraLight"],
    ],
)
def test_usdrecord_flags_are_accepted(tmp_path, quad_file, flags):
    assert main([str(quad_file), str(tmp_path / "o.exr"), *TINY, *flags]) == 0


@pytest.mark.parametrize(
    "flags, message",
    [
        (["-r", "GL"], "--renderer GL: penumbra-record renders with Penumbra only"),
        (["--samp", "4"], "unrecognized arguments: --samp"),  # no abbreviations
        (["--render", "Penumbra"], "unrecognized arguments: --render"),
        (["-rs", "/a", "-rp", "/b"], "not both"),
        (["--traceFormat", "trace"], "--traceFormat needs --traceToFile"),
    ],
)
def test_usage_errors_exit_2(tmp_path, quad_file, capsys, flags, message):
    assert main([str(quad_file), str(tmp_path / "o.exr"), *TINY, *flags]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "o.exr").exists()


def test_version_quiet_verbose_memstats(tmp_path, quad_file, capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"penumbra-record {_core.version()}"
    assert main([str(quad_file), str(tmp_path / "q.exr"), *TINY, "-q"]) == 0
    out, err = capsys.readouterr()
    assert out == "" and err == ""
    assert main([str(quad_file), str(tmp_path / "v.exr"), *TINY, "-v", "--memstats"]) == 0
    out, err = capsys.readouterr()
    assert "Penumbra trace" in err and "render delegate sync" in err and "render pass" in err
    assert "Peak memory (resident set):" in out
    # One summary line per frame: size, samples, time, rate, peak memory.
    summary = [line for line in out.splitlines() if line.startswith("time code 1: 8x8")]
    assert len(summary) == 1 and "samples/pixel in" in summary[0] and "peak memory" in summary[0]


@pytest.mark.parametrize("trace_format", ["chrome", "trace"])
def test_trace_to_file(tmp_path, quad_file, trace_format):
    trace = tmp_path / f"trace.{trace_format}"
    args = [str(quad_file), str(tmp_path / "o.####.exr"), *TINY, "-f", "1:2"]
    assert main([*args, "--traceToFile", str(trace), "--traceFormat", trace_format]) == 0
    text = trace.read_text()
    if trace_format == "trace":
        assert "open stage" in text and "write image" in text
        return
    events = json.loads(text)["traceEvents"]
    names = [event["name"] for event in events]
    assert names.count("sync stage (USD to render delegate)") == 2
    assert names.count("write image") == 2 and "open stage" in names
    assert all(event["ph"] == "X" and event["dur"] >= 0 for event in events)
    # Tessellation and acceleration structures inside the render delegate's sync, in order.
    first_sync = next(e for e in events if e["name"].startswith("render delegate sync"))
    parts = [e for e in events if e["name"].startswith(("tessellation", "acceleration"))]
    assert [p["name"].split()[0] for p in parts[:2]] == ["tessellation", "acceleration"]
    assert parts[0]["args"]["meshes"] == 1  # the first frame triangulates the quad
    assert parts[1]["ts"] == pytest.approx(parts[0]["ts"] + parts[0]["dur"], abs=1)
    for part in parts[:2]:
        assert first_sync["ts"] <= part["ts"]
        assert part["ts"] + part["dur"] <= first_sync["ts"] + first_sync["dur"] + 1


def test_mask_session_layer_and_render_pass(tmp_path, capsys):
    path = tmp_path / "scene.usda"
    stage = lit_quad_stage(path)
    add_quad(stage, "/Other/blocker", center=(0, 0, 1), color=(1, 0, 0))
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateResolutionAttr(Gf.Vec2i(16, 8))
    settings.GetCameraRel().SetTargets(["/cam"])
    render_pass = UsdRender.Pass.Define(stage, "/Render/Pass")
    render_pass.GetRenderSourceRel().SetTargets(["/Render/Settings"])
    stage.Save()
    size = ["-w", "16", "-spp", "1"]

    assert main([str(path), str(tmp_path / "all.exr"), *size]) == 0
    red = _core.read_image(str(tmp_path / "all.exr"))[0][4, 8]  # the red blocker
    assert red[0] > 0.1 and red[1] < 0.05 * red[0]
    # --mask: only /World, /cam and /sun are populated (the blocker is not).
    assert main([str(path), str(tmp_path / "m.exr"), *size, "--mask", "/World,/cam /sun"]) == 0
    grey = _core.read_image(str(tmp_path / "m.exr"))[0][4, 8]
    assert grey[1] > 0.1 and grey[0] == pytest.approx(grey[1])
    # --sessionLayer: its opinions win over the file's (here: the blocker is hidden).
    session = Sdf.Layer.CreateNew(str(tmp_path / "session.usda"))
    over = Sdf.CreatePrimInLayer(session, "/Other/blocker")
    over.specifier = Sdf.SpecifierOver
    Sdf.AttributeSpec(over, "visibility", Sdf.ValueTypeNames.Token).default = "invisible"
    session.Save()
    args = [str(path), str(tmp_path / "s.exr"), *size, "--sessionLayer", str(session.realPath)]
    assert main(args) == 0
    np.testing.assert_allclose(_core.read_image(str(tmp_path / "s.exr"))[0][4, 8], grey)
    # -rp: the pass's render source gives the resolution (16 x 8).
    assert main([str(path), str(tmp_path / "p.exr"), *size, "-rp", "/Render/Pass"]) == 0
    assert _core.read_image(str(tmp_path / "p.exr"))[0].shape == (8, 16, 4)
    capsys.readouterr()
    assert main([str(path), str(tmp_path / "x.exr"), *size, "-rp", "/Render/Settings"]) == 1
    assert "/Render/Settings is not a RenderPass prim" in capsys.readouterr().err
    assert main([str(path), str(tmp_path / "x.exr"), *size, "--sessionLayer", "nope.usda"]) == 1
    assert "nope.usda: no such file" in capsys.readouterr().err


def test_outputs_are_validated_before_rendering(tmp_path, quad_file, capsys):
    assert main([str(quad_file), str(tmp_path / "o.hdr"), *TINY]) == 2
    assert "o.hdr: cannot write .hdr" in capsys.readouterr().err
    assert main([str(quad_file), str(tmp_path / "no" / "o.exr"), *TINY]) == 1
    out, err = capsys.readouterr()
    assert "does not exist" in err and "Recording" not in out


# ------------------------------------------------------------------------------------------
# Item 3: camera lookup and image size


def test_camera_order_is_usdrecords(tmp_path):
    """main_cam comes before the render settings' camera; relative paths become absolute."""
    path = tmp_path / "cams.usda"
    stage = lit_quad_stage(path)
    add_camera(stage, "/rig/main_cam")
    add_camera(stage, "/rig/shot")
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.GetCameraRel().SetTargets(["/rig/shot"])
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    stage.Save()
    assert main([str(path), str(tmp_path / "a.exr"), *TINY]) == 0
    assert camera_of(tmp_path / "a.exr") == "/rig/main_cam"
    assert main([str(path), str(tmp_path / "b.exr"), *TINY, "-cam", "rig/shot"]) == 0
    assert camera_of(tmp_path / "b.exr") == "/rig/shot"
    assert main([str(path), str(tmp_path / "c.exr"), *TINY, "-cam", "shot"]) == 0
    assert camera_of(tmp_path / "c.exr") == "/rig/shot"
    stage.RemovePrim("/rig/main_cam")
    stage.Save()
    assert main([str(path), str(tmp_path / "d.exr"), *TINY]) == 0
    assert camera_of(tmp_path / "d.exr") == "/rig/shot"


@pytest.mark.parametrize(
    "aperture, width, height",
    [((36.0, 24.0), 160, 106), ((0.36, 0.036), 960, 95), ((20.955, 15.2908), 960, 700), ((4, 4), 7, 7)],
)
def test_height_is_usdrecords_truncation(aperture, width, height):
    assert usdrecord_height(width, *aperture) == height


def test_image_height_truncates_like_usdrecord(tmp_path):
    path = tmp_path / "three_two.usda"
    stage = lit_quad_stage(path)
    add_camera(stage, "/wide", aperture=(36.0, 24.0))
    stage.Save()
    assert main([str(path), str(tmp_path / "o.exr"), "-w", "160", "-spp", "1", "-cam", "/wide"]) == 0
    assert _core.read_image(str(tmp_path / "o.exr"))[0].shape[:2] == (106, 160)


# usdrecord's camera for a stage without one (UsdAppUtilsFrameRecorder's
# _ComputeCameraToFrameStage) looks at the bounds' front face from r / tan(h) in front of it,
# r the half-diagonal of the bounds across the image plane and h half GfCamera's horizontal
# field of view (tan h = 20.955 / 2 / 50): a face w x v spans w / 2r of the image's width and
# v / 2r of it high. Closer than the near clipping distance (1), it backs off by that.
TAN_HALF_FOV = 20.955 / 2 / 50


@pytest.mark.parametrize(
    "up_axis, half_size, face",
    [
        ("Y", (1.0, 1.0, 1.0), (1 / math.sqrt(2), 1 / math.sqrt(2))),  # the fitted sphere: 45%
        # 2 wide, 1 high and 4 deep: Z up, the camera looks along +Y at the face the XZ plane's.
        ("Z", (1.0, 2.0, 0.5), (1 / math.hypot(1, 0.5), 0.5 / math.hypot(1, 0.5))),
        # 0.2 across: r / tan h + 0.1 < 1, so the front face is at 0.1 √2 / tan h + 1.
        ("Y", (0.1, 0.1, 0.1), (0.1 / (0.1 * math.sqrt(2) + TAN_HALF_FOV),) * 2),
    ],
)
def test_a_stage_without_a_camera_is_framed_as_usdrecord_frames_it(up_axis, half_size, face):
    stage = emitter_stage()
    UsdGeom.SetStageUpAxis(stage, up_axis)
    box = UsdGeom.Cube.Define(stage, "/box")
    box.CreateExtentAttr([(-1, -1, -1), (1, 1, 1)])
    box.AddScaleOp().Set(Gf.Vec3f(*half_size))
    bind(box, UsdShade.Material(stage.GetPrimAtPath("/Looks/glow")))
    # 400 x 292 is a little narrower than the film (20.955 x 15.2908): its width is kept.
    width, height = 400, 292
    image = penumbra.render(stage, width=width, height=height, samples=16, max_path_depth=0)
    assert image.metadata["camera"] == "/PenumbraFramingCamera"
    coverage = image["color"][..., :3].mean(axis=2).astype(np.float64)
    # The face's width and height in pixels (the pixel filter keeps a row's and a column's sums).
    measured = coverage[height // 2].sum(), coverage[:, width // 2].sum()
    assert measured == pytest.approx((face[0] * width, face[1] * width), abs=0.5)
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/PenumbraFramingCamera"))
    assert camera.GetClippingRangeAttr().Get() == Gf.Vec2f(1, 1000000)  # GfCamera's


# ------------------------------------------------------------------------------------------
# Item 6: Python ergonomics


def test_renderer_takes_a_path_or_a_stage(tmp_path, quad_file):
    image = penumbra.Renderer(quad_file).render(camera=Sdf.Path("/cam"), width=8, samples=1, aovs="color")
    assert list(image) == ["color"] and image.metadata["camera"] == "/cam"
    assert penumbra.Renderer(str(quad_file)).render(camera="cam", width=8, samples=1).width == 8
    with pytest.raises(TypeError, match=r"expected a pxr\.Usd\.Stage or the path of a USD file"):
        penumbra.Renderer(42)
    with pytest.raises(penumbra.SceneError, match="missing.usda: no such file"):
        penumbra.Renderer(tmp_path / "missing.usda")


def test_package_is_typed():
    assert (Path(penumbra.__file__).parent / "py.typed").exists()
