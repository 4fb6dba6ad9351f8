"""Inputs out of their type or range: a volume's fieldIndex, light inputs UsdLux bounds, and
camera and render product values blocked or out of range. Each skips its prim (or falls back)
with one warning naming the prim and the attribute, or fails the render cleanly."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pxr import Sdf, UsdLux

from malformed_corpus import Case, write_case
from stages import render_with_warnings
from test_input_validation import add_light, author, lit_stage, skipped_light_image
from test_volumes import cube_stage

WIDTH = 16

BAD_FIELD_INDICES = [
    (Sdf.ValueTypeNames.String, "x", "fieldIndex 'x' is a str, not an int"),
    (Sdf.ValueTypeNames.Double, 1.5, "fieldIndex 1.5 is a float, not an int"),
    (Sdf.ValueTypeNames.Int64, 2**32, "fieldIndex 4294967296 is outside [0, 2147483647]"),
    (Sdf.ValueTypeNames.Int, -1, "fieldIndex -1 is outside [0, 2147483647]"),
]


@pytest.mark.parametrize(
    ("type_name", "value", "expected"),
    BAD_FIELD_INDICES,
    ids=[f"{type_name} {value}" for type_name, value, _ in BAD_FIELD_INDICES],
)
def test_a_bad_field_index_skips_the_volume_with_one_warning(
    type_name: Sdf.ValueTypeName, value, expected: str, tmp_path: Path
) -> None:
    """A string raised a ValueError, 2^32 a TypeError in the render delegate, 1.5 read as 1."""
    stage = cube_stage(tmp_path)
    author(stage.GetPrimAtPath("/World/smoke/density"), "fieldIndex", type_name, value)
    image, messages = render_with_warnings(stage, WIDTH)
    assert messages == [
        f"/World/smoke: field density (/World/smoke/density): {expected}; the volume is skipped "
        f"(file {tmp_path / 'cube.vdb'})"
    ]
    stage.RemovePrim("/World/smoke")
    assert np.array_equal(image, render_with_warnings(stage, WIDTH)[0])


OUT_OF_RANGE = [
    ("inputs:diffuse", -1.0, "inputs:diffuse must be at least 0, not -1"),
    ("inputs:specular", -1.0, "inputs:specular must be at least 0, not -1"),
    ("inputs:shaping:cone:angle", -10.0, "inputs:shaping:cone:angle must be in [0, 180], not -10"),
    ("inputs:colorTemperature", -100.0, "inputs:colorTemperature must be above 0 K, not -100"),
]


@pytest.mark.parametrize(
    ("name", "value", "expected"), OUT_OF_RANGE, ids=[f"{n} {v}" for n, v, _ in OUT_OF_RANGE]
)
def test_a_light_input_out_of_its_usdlux_range_skips_the_light(
    name: str, value: float, expected: str
) -> None:
    """They were sent as they were: negative multipliers made negative light, the others were
    clamped silently."""
    stage = lit_stage()
    light = add_light(stage, "SphereLight")
    UsdLux.ShapingAPI.Apply(light)
    UsdLux.LightAPI(light).CreateEnableColorTemperatureAttr(True)
    author(light, name, Sdf.ValueTypeNames.Float, value)
    image, messages = render_with_warnings(stage, WIDTH)
    assert messages == [f"/World/L: {expected}; the light is skipped (intensity 0)"]
    assert np.array_equal(image, skipped_light_image("SphereLight"))


@pytest.mark.parametrize("name", ["fStop", "focusDistance"])
def test_a_lens_value_blocked_at_the_frame_reads_as_its_fallback(name: str) -> None:
    """The image's lens metadata read it with Get, and float(None) raised a TypeError."""
    expected_stage, blocked_stage = lit_stage(), lit_stage()
    attr = blocked_stage.GetPrimAtPath("/cam").GetAttribute(name)
    attr.Set(2.0, 0)
    attr.Set(Sdf.ValueBlock(), 1)
    image, messages = render_with_warnings(blocked_stage, WIDTH)
    assert messages == []
    assert np.array_equal(image, render_with_warnings(expected_stage, WIDTH)[0])


def product_case(name: str, aspect: str, expect: str) -> Case:
    """Render settings /rs whose one product /rs/p authors ``aspect`` (a pixelAspectRatio)."""
    extra = (
        'def RenderSettings "rs"\n{\n    rel camera = </cam>\n    rel products = </rs/p>\n'
        '    def RenderProduct "p"\n    {\n        token productName = "product.exr"\n'
        f"        {aspect}\n        rel orderedVars = </rs/v>\n    }}\n"
        '    def RenderVar "v"\n    {\n        string sourceName = "color"\n    }\n}'
    )
    return Case(name, 1, expect, extra=extra, args=("-rs", "/rs"))


BAD_PRODUCTS = [
    product_case("pixel aspect ratio 1e-30", "uniform float pixelAspectRatio = 1e-30",
                 "/rs/p: pixelAspectRatio must be in [0.01, 100], not 1e-30"),
    product_case("pixel aspect ratio string", 'uniform string pixelAspectRatio = "wide"',
                 "/rs/p: pixelAspectRatio must be a number, not 'wide'"),
]


@pytest.mark.parametrize("case", BAD_PRODUCTS, ids=[case.name for case in BAD_PRODUCTS])
def test_a_product_pixel_aspect_ratio_out_of_range_fails_cleanly(
    case: Case, tmp_path: Path
) -> None:
    """In a child process: bounded as the render settings' own; 1e-30 aborted it in Embree (a
    ray not finite), a string failed with a TypeError without the prim."""
    stage = write_case(case, tmp_path)
    result = subprocess.run(
        [sys.executable, "-m", "penumbra.cli", str(stage), str(tmp_path / "out.png")]
        + ["-w", "32", "-spp", "2", "-q", *case.args],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert result.returncode == case.exit, result.stderr[-2000:]
    assert "Traceback" not in result.stderr
    assert case.expect in result.stderr
    assert not (tmp_path / "product.exr").exists()
