"""The ``indirect_samples`` option's default (docs/branching.md): a pilot chooses how many paths
go on from each camera ray's first surface, per region of the image, more where the noise lies
beyond it, one where it is the pixel's own; the count used (the mean over the image) is in the
image metadata."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, UsdLux

import penumbra
from stages import add_camera, add_preview_material, add_quad, bind, lit_quad_stage, new_stage


def floor_lit_by_ceiling():
    """A grey floor under a grey ceiling, lit only by a panel facing the ceiling, seen from
    between them: all the light the camera sees has bounced off the ceiling first."""
    stage = new_stage()
    add_camera(stage, translate=(0.0, 0.0, 2.0), focal_length=10.0)
    add_quad(stage, "/floor", half_size=50.0, color=(0.5, 0.5, 0.5))
    ceiling = add_quad(stage, "/ceiling", center=(0.0, 0.0, 3.0), half_size=50.0,
                       color=(0.5, 0.5, 0.5))
    ceiling.CreateDoubleSidedAttr(True)
    panel = UsdLux.RectLight.Define(stage, "/panel")
    panel.CreateIntensityAttr(20.0)
    panel.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 2.5))
    panel.AddRotateXOp().Set(180.0)  # emitting along +Z, towards the ceiling
    return stage


def render(stage, samples: int = 1, **options):
    return penumbra.render(stage, width=32, samples=samples, threads=2, **options)


def test_the_pilot_branches_where_the_light_comes_from_beyond_the_first_surface():
    image = render(floor_lit_by_ceiling())
    assert image.metadata["indirectSamplesUsed"] >= 2
    assert image.metadata["indirectSamples"] == 0  # the setting: the pilot's choice


def test_the_pilot_does_not_branch_where_the_noise_is_the_pixels_own():
    # A quad's edges under a sun: the bounces off the quad escape to an empty sky.
    assert render(lit_quad_stage()).metadata["indirectSamplesUsed"] == 1


@pytest.mark.parametrize("count", [1, 3])
def test_a_count_set_is_used_as_set(count):
    image = render(floor_lit_by_ceiling(), indirect_samples=count)
    assert image.metadata["indirectSamplesUsed"] == count
    assert image.metadata["indirectSamples"] == count


def test_the_pilots_choice_converges_to_the_unbranched_image():
    stage = floor_lit_by_ceiling()
    chosen = np.asarray(render(stage, samples=64).get("color"))[..., :3].mean()
    single = np.asarray(render(stage, samples=64, indirect_samples=1).get("color"))[..., :3].mean()
    assert chosen > 0.01
    assert chosen == pytest.approx(single, rel=0.01)


def floor_lit_by_ceiling_beside_a_shade():
    """floor_lit_by_ceiling with a lamp's shade over the view's half x > 0: a dark quad glowing
    brightly, whose pixels are their own light, while the floor's is all found beyond it."""
    stage = floor_lit_by_ceiling()
    shade = add_quad(stage, "/shade", center=(10.0, 0.0, 1.0), half_size=10.0)
    bind(shade, add_preview_material(stage, "/Looks/shade", diffuseColor=(0.05, 0.05, 0.05),
                                     emissiveColor=(4.0, 4.0, 4.0)))
    return stage


def test_the_pilot_branches_per_region_of_the_image():
    stage = floor_lit_by_ceiling_beside_a_shade()
    image = render(stage)
    # Several branches over the floor, one over the shade: their mean over the image, which no
    # one count for the whole image gives.
    used = image.metadata["indirectSamplesUsed"]
    assert 1.5 < used < 3.5
    assert used != round(used)
    color = np.asarray(render(stage, samples=64).get("color"))[..., :3]
    single = np.asarray(render(stage, samples=64, indirect_samples=1).get("color"))[..., :3]
    for half in (slice(0, 16), slice(16, 32)):  # each converges to the unbranched image
        assert color[:, half].mean() == pytest.approx(single[:, half].mean(), rel=0.01)


def floor_under_many_bulbs():
    """A grey floor under 64 small sphere lights, of powers spread over two orders of magnitude,
    seen from just below them (the camera sees none): which light a point samples is its noise."""
    stage = new_stage()
    add_camera(stage, translate=(0.0, 0.0, 0.9), focal_length=1.0)
    add_quad(stage, "/floor", half_size=20.0, color=(0.5, 0.5, 0.5))
    for index in range(64):
        bulb = UsdLux.SphereLight.Define(stage, f"/bulbs/bulb_{index:02d}")
        bulb.CreateRadiusAttr(0.05)
        bulb.CreateIntensityAttr(20.0 * 10 ** ((index * 37 % 64) / 32))
        bulb.AddTranslateOp().Set(
            Gf.Vec3d(-3.5 + index % 8, -3.5 + index // 8, 1.0 + 1.5 * (index * 13 % 64) / 64))
    return stage


def test_the_pilot_estimates_light_several_times_among_many_lights():
    stage = floor_under_many_bulbs()
    image = render(stage, max_path_depth=1)
    assert image.metadata["lightSamplesUsed"] >= 2
    assert image.metadata["lightSamples"] == 0  # the setting: the pilot's choice
    # Where the choice of light is no noise (a sun over a quad), one estimate.
    assert render(lit_quad_stage()).metadata["lightSamplesUsed"] == 1


@pytest.mark.parametrize("count", [1, 5])
def test_a_light_estimate_count_set_is_used_as_set(count):
    image = render(floor_under_many_bulbs(), max_path_depth=1, light_samples=count)
    assert image.metadata["lightSamplesUsed"] == count
    assert image.metadata["lightSamples"] == count


def test_light_estimates_converge_to_the_single_estimate_image():
    stage = floor_under_many_bulbs()
    many = np.asarray(render(stage, samples=64, light_samples=4).get("color"))[..., :3].mean()
    one = np.asarray(render(stage, samples=64, light_samples=1).get("color"))[..., :3].mean()
    assert one > 0.01
    assert many == pytest.approx(one, rel=0.01)
