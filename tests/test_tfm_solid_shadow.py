"""A solid between the light and the medium (the smoke's bar) leaves the TFM to the medium: the
texels in its shadow hold the medium's transmittance, so that the filtered lookups next to the
shadow's edge do not blend in an empty (T = 1) texel. Reference: the brute-force light march,
which reads no TFM."""

import dataclasses

import numpy as np

from tfm_addon.engine import RenderSettings
from tfm_addon.engine.light import LightFrame
from tfm_addon.engine.sampling import frame_settings
from tfm_addon.scenes import smoke_scene


def test_the_bars_shadow_does_not_empty_the_tfm(renderer):
    scene = smoke_scene(width=48, height=32, n=32)
    settings = frame_settings(scene, RenderSettings(quality="AUTO", map_resolution=256), 1)
    assert settings.tfm_resolution == "FOOTPRINT" and settings.tfm_filter == "LINEAR"
    rng = np.random.default_rng(1)
    n = scene.media[0].density.shape[0]
    idx = rng.uniform(0.2 * n, 0.8 * n, (6000, 3))
    points = (np.c_[idx, np.ones(len(idx))] @ scene.media[0].index_to_world.T)[:, :3]
    # The points whose light ray crosses the bar: in the light's view, inside the bar's outline.
    frame = LightFrame.of(scene.lights[0])
    bar = scene.meshes[0].world_vertices()

    def view(p):
        q = p @ frame.world_to_light[:3, :3].T + frame.world_to_light[:3, 3]
        return q[:, :2] / -q[:, 2:3]

    lo, hi = view(bar).min(axis=0), view(bar).max(axis=0)
    uv = view(points)
    shadowed = np.all((uv > lo) & (uv < hi), axis=1)
    assert 200 < shadowed.sum() < len(points) - 200
    tfm = renderer.light_transmittance_at(scene, settings, 0, points)[:, 0]
    brute = renderer.light_transmittance_at(
        scene, dataclasses.replace(settings, method="BRUTE_FORCE", light_steps=128), 0, points)[:, 0]
    assert brute[shadowed].min() < 0.9                # the medium does attenuate there
    assert np.abs(tfm - brute)[shadowed].max() < 0.1, np.abs(tfm - brute)[shadowed].max()
    assert np.abs(tfm - brute).mean() < 0.01
