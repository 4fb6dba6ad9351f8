"""The ``dome_sampling`` option (docs/dome-sampling.md): an untextured dome at the surfaces the
camera sees is sampled by a shadow ray (``mis``) or left to the BSDF ray (``bsdf``); ``auto``
gives the shadow ray the share of the sky's light its pilot finds least noisy for the stage
(none: ``bsdf`` bit for bit)."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Sdf, UsdLux

import penumbra
from penumbra import _core
from stages import add_camera, add_distant_light, add_quad, add_sphere_mesh, new_stage


def balls_under_sky(sun: bool, texture: str | None = None):
    """Grey balls (albedo 0.4) on a grey ground under a sky of radiance 0.35, seen from above;
    with ``sun``, a sun of irradiance 6 lights them, and their sunlit sides outshine the sky."""
    stage = new_stage()
    add_camera(stage, translate=(0.0, 0.0, 5.0))
    add_quad(stage, "/ground", half_size=20.0, color=(0.5, 0.5, 0.5))
    for i in range(3):
        ball = add_sphere_mesh(stage, f"/ball{i}", center=(1.3 * (i - 1), 0.0, 0.6), radius=0.6)
        ball.CreateDisplayColorPrimvar().Set([(0.4, 0.4, 0.4)])
    sky = UsdLux.DomeLight.Define(stage, "/sky")
    sky.CreateIntensityAttr(0.35)
    if texture:
        sky.CreateTextureFileAttr(Sdf.AssetPath(texture))
    if sun:
        add_distant_light(stage, intensity=6.0)
    return stage


def color(stage, samples: int = 4, **options) -> np.ndarray:
    image = penumbra.render(stage, width=32, samples=samples, threads=2, **options)
    return np.asarray(image.get("color"))


def test_auto_leaves_a_sunlit_sky_to_the_bsdf_ray_and_shares_a_lone_one():
    sunlit = balls_under_sky(True)
    assert np.array_equal(color(sunlit), color(sunlit, dome_sampling="bsdf"))
    assert not np.array_equal(color(sunlit), color(sunlit, dome_sampling="mis"))
    # Under the sky alone the shadow ray pays, with a share of the sky's light between none
    # and MIS's: an image of neither.
    alone = balls_under_sky(False)
    auto = color(alone)
    for strategy in ("mis", "bsdf"):
        assert not np.array_equal(auto, color(alone, dome_sampling=strategy))


def test_the_share_used_is_in_the_metadata():
    def share(stage, **options) -> float:
        image = penumbra.render(stage, width=32, samples=1, threads=2, **options)
        return image.metadata["constantDomeShare"]

    assert share(balls_under_sky(True)) == 0.0
    assert 0.0 < share(balls_under_sky(False)) < 1.0
    assert share(balls_under_sky(True), dome_sampling="mis") == 1.0


@pytest.mark.parametrize("sun", [True, False])
def test_every_strategy_converges_to_the_same_image(sun):
    stage = balls_under_sky(sun)
    means = [
        color(stage, dome_sampling=strategy, samples=64)[..., :3].mean()
        for strategy in ("mis", "bsdf", "auto")
    ]
    assert means[0] > 0.1
    assert means[1:] == pytest.approx([means[0]] * 2, rel=0.01)


def test_a_textured_dome_is_sampled_either_way(tmp_path):
    # A sky map's bright spots are found by sampling its texture, which the BSDF ray could not
    # do: only untextured domes are left to it.
    sky = np.full((16, 32, 3), 0.5, dtype=np.float32)
    sky[2:4, 8:10] = 40.0  # a sun in the map
    path = tmp_path / "sky.exr"
    _core.write_image(str(path), sky, ["R", "G", "B"], {})
    stage = balls_under_sky(False, texture=str(path))
    assert np.array_equal(color(stage, dome_sampling="mis"), color(stage, dome_sampling="bsdf"))
