"""Caustics by light tracing and photons (docs/caustics.md) from the front ends: the
``caustics`` option reaches the renderer, changes the noise and not the image, and light-traced
images (with photons or not) stay bit-identical across threads, regions, farm bands and
checkpoints."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Usd, UsdLux

import penumbra
from farm_bands import assert_farm_bands_match_local
from stages import add_camera, add_preview_material, add_quad, add_sphere_mesh, bind, new_stage

LIGHT = dict(width=32, samples=8, caustics="light")
# Both of the light tracer's modes: photons gather the floor seen through the ball.
TRACED = ("light", "photons")


def add_ball_and_bulb(stage: Usd.Stage) -> None:
    """A smooth glass ball on a grey floor, lit from the side by a small sphere light."""
    add_quad(stage, "/World/floor", half_size=20.0, color=(0.5, 0.5, 0.5), facing="y")
    ball = add_sphere_mesh(stage, "/World/ball", center=(0.0, 1.0, 0.0), radius=0.5, rings=24,
                           sectors=48)
    bind(ball, add_preview_material(stage, "/World/glass", opacity=0.0, ior=1.5, roughness=0.1))
    bulb = UsdLux.SphereLight.Define(stage, "/World/bulb")
    bulb.CreateRadiusAttr(0.3)
    bulb.CreateIntensityAttr(20.0)
    bulb.AddTranslateOp().Set(Gf.Vec3d(-1.5, 2.5, 0.0))


@pytest.fixture(scope="module")
def glass_ball(tmp_path_factory):
    """A grey floor under a smooth glass ball lit from the side by a small sphere light, seen
    from above where the ball focuses that light onto the floor; as a file, for the CLI."""
    path = tmp_path_factory.mktemp("caustics") / "glass_ball.usda"
    stage = new_stage(path)
    add_camera(stage, translate=(0.9, 4.0, 0.0), rotate_x=-90.0, focal_length=2.0,
               aperture=(1.0, 1.0))
    add_ball_and_bulb(stage)
    stage.GetRootLayer().Save()
    return path


def test_light_tracing_changes_the_noise_not_the_image(glass_ball):
    renderer = penumbra.Renderer(glass_ball)
    path = renderer.render(width=32, samples=1024, caustics="path")["color"][..., :3]
    light = renderer.render(width=32, samples=1024, caustics="light")["color"][..., :3]
    assert not np.array_equal(path, light)
    assert renderer.render(width=32, samples=2, caustics="light").metadata["lightPaths"] == 206
    assert renderer.render(width=32, samples=2, caustics="path").metadata["lightPaths"] == 0
    assert light.mean() == pytest.approx(path.mean(), rel=0.02)
    # The caustic (the middle of the image) is most of the image's light.
    middle = (slice(11, 21), slice(11, 21))
    assert path[middle].mean() > 2 * path.mean()
    assert light[middle].mean() == pytest.approx(path[middle].mean(), rel=0.05)


def test_photons_gather_what_the_camera_sees_through_the_ball(glass_ball):
    renderer = penumbra.Renderer(glass_ball)
    light = renderer.render(width=32, samples=1024, caustics="light")
    photons = renderer.render(width=32, samples=1024, caustics="photons")
    assert photons.metadata["caustics"] == "photons"
    assert photons.metadata["lightPaths"] == light.metadata["lightPaths"]
    # Only where the camera sees the floor through the ball (the image's left edge) do they
    # differ, and there by the noise alone.
    differs = np.any(photons["color"] != light["color"], axis=2)
    assert differs[:, :8].any() and not differs[:, 16:].any()
    assert photons["color"].mean() == pytest.approx(light["color"].mean(), rel=0.02)


@pytest.mark.parametrize("caustics", TRACED)
def test_light_traced_images_are_bit_identical_across_threads_and_regions(glass_ball, caustics):
    renderer = penumbra.Renderer(glass_ball)
    options = dict(LIGHT, caustics=caustics)
    whole = renderer.render(**options)["color"]
    assert np.array_equal(whole, renderer.render(**options, threads=1)["color"])
    part = renderer.render(**options, region=(3, 10, 20, 9))["color"]
    assert np.array_equal(part, whole[10:19, 3:23])


@pytest.mark.parametrize("caustics", TRACED)
def test_farm_bands_of_a_light_traced_frame_are_bit_identical_to_a_local_render(
        glass_ball, tmp_path, capsys, caustics):
    flags = ["-w", "32", "-spp", "8", "--caustics", caustics]
    assert_farm_bands_match_local(glass_ball, flags, tmp_path, capsys)


@pytest.fixture(scope="module")
def mirrored_strip(tmp_path_factory):
    """The glass ball's scene under a metal ceiling, seen by a camera four times as tall as
    wide: the ceiling's light paths land all over the floor, and adaptive sampling stops the
    strip's ends long before the caustic in its middle."""
    path = tmp_path_factory.mktemp("caustics") / "mirrored_strip.usda"
    stage = new_stage(path)
    add_camera(stage, translate=(0.9, 4.0, 0.0), rotate_x=-90.0, focal_length=2.0,
               aperture=(1.0, 4.0))
    ceiling = add_quad(stage, "/World/ceiling", center=(0.0, 5.0, 0.0), half_size=6.0,
                       facing="y")
    bind(ceiling, add_preview_material(stage, "/World/metal", metallic=1.0, roughness=0.2))
    add_ball_and_bulb(stage)
    stage.GetRootLayer().Save()
    return path


def test_adaptive_farm_bands_of_a_light_traced_frame_are_bit_identical_to_a_local_render(
        mirrored_strip, tmp_path, capsys):
    # Bands at the strip's ends stop before the whole frame does: a pixel takes the light paths
    # of its own sample indices alone, so they resolve as the whole frame does.
    flags = ["-w", "24", "-spp", "256", "--adaptiveThreshold", "0.3", "--adaptiveMinSamples", "4"]
    assert_farm_bands_match_local(mirrored_strip, flags, tmp_path, capsys)


class Interrupted(Exception):
    pass


@pytest.mark.parametrize("caustics", TRACED)
def test_a_light_traced_render_resumes_from_its_checkpoint_bit_identically(
        glass_ball, tmp_path, caplog, caustics):
    caplog.set_level("INFO", logger="penumbra")
    renderer = penumbra.Renderer(glass_ball)
    kwargs = dict(LIGHT, samples=32, threads=1, caustics=caustics)
    expected = renderer.render(**kwargs)["color"]
    output = tmp_path / "out.exr"
    passes = []

    def interrupt(_done: int, _total: int) -> None:
        passes.append(1)
        if len(passes) > 2:
            raise Interrupted

    with pytest.raises(Interrupted):
        renderer.render(**kwargs, checkpoint=penumbra.Checkpoint(output, 0), progress=interrupt)
    resumed = renderer.render(**kwargs, checkpoint=penumbra.Checkpoint(output, resume=True))
    assert "resuming from" in caplog.text
    assert np.array_equal(resumed["color"], expected)


def test_an_unknown_caustics_level_is_refused(glass_ball):
    with pytest.raises(ValueError, match="caustics"):
        penumbra.Renderer(glass_ball).render(width=8, samples=1, caustics="bidirectional")
