"""Multiple scattering by octaves (engine/multiple_scattering.py, shaders/octaves.glsl): the bounce
count reads the same maps (counters), and the octave sum against independent renders: an octave
whose light transmittance is T^0 = 1 adds the unshadowed image (times the albedo), one with T^1 the
single-scattering image again. (Against Cycles with bounces: tests/blender/test_multiple_scattering.py.)"""

import dataclasses

import numpy as np

from tfm_addon import scenes
from tfm_addon.engine import RenderSettings
from tfm_addon.engine.multiple_scattering import SINGLE, Octaves, octaves

SETTINGS = RenderSettings(view_steps=48, light_steps=48, map_resolution=64, coefficients=6, ambient=False)
MAPS = ("tfms", "shadow_maps", "grid_uploads", "gbuffers")
ALBEDO = 2.0 / 2.2      # smoke_scene: sigma_s 2, sigma_a 0.2 per unit density


def _scene():
    return scenes.smoke_scene(width=48, height=32, n=24, with_ground=True)


def _scatter(renderer, **kw) -> np.ndarray:
    out = renderer.render(_scene(), dataclasses.replace(SETTINGS, **kw))
    return out.passes["scattering"].astype(np.float64)


def test_bounce_count_rebuilds_no_map(fresh):
    single = _scatter(fresh)
    built = {k: fresh.counters[k] for k in MAPS}
    sixteen = _scatter(fresh, volume_bounces=16)
    many = _scatter(fresh, volume_bounces=128)
    assert {k: fresh.counters[k] for k in MAPS} == built
    assert built["tfms"] >= 1
    assert sixteen.sum() > 1.05 * single.sum()
    assert many.sum() >= sixteen.sum()
    assert np.array_equal(_scatter(fresh, volume_bounces=0), single)


def test_zero_bounces_is_single_scattering():
    assert octaves(0) == SINGLE and SINGLE.count == 1
    assert octaves(16).count > 1 and octaves(128).count >= octaves(16).count


def test_octave_with_no_light_extinction_adds_the_unshadowed_image(renderer):
    single = _scatter(renderer)
    unshadowed = _scatter(renderer, method="UNSHADOWED")
    both = _scatter(renderer, volume_bounces=1, octaves=Octaves(2, a=0.0, b=1.0, c=1.0))
    assert unshadowed.sum() > 1.2 * single.sum()        # the medium shadows itself
    np.testing.assert_allclose(both, single + ALBEDO * unshadowed, rtol=2e-3, atol=1e-5 * single.max())


def test_octave_with_the_same_extinction_repeats_single_scattering(renderer):
    single = _scatter(renderer)
    twice = _scatter(renderer, volume_bounces=1, octaves=Octaves(3, a=1.0, b=0.5, c=1.0))
    factor = 1.0 + 0.5 * ALBEDO + (0.5 * ALBEDO) ** 2
    np.testing.assert_allclose(twice, factor * single, rtol=2e-3, atol=1e-5 * single.max())
