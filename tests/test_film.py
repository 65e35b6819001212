"""The film as Blender sets it: transparent (alpha = 1 - view transmittance, no world seen) or
opaque (alpha 1, the world seen behind the medium and attenuated by it), against the numpy
reference, which composes the film on its own (RenderOutput.compose)."""

from __future__ import annotations

import numpy as np
import pytest
from references import render_reference

from tfm_addon import scenes
from tfm_addon.engine import RenderSettings, metrics

WORLD = (0.2, 0.3, 0.5)


@pytest.fixture(scope="module")
def smoke():
    return scenes.smoke_scene(width=64, height=48, n=32, with_ground=False, ambient=WORLD,
                              sigma_s=(0.6, 0.6, 0.6), sigma_a=(0.05, 0.15, 0.3))


def _settings(transparent: bool) -> RenderSettings:
    return RenderSettings(view_steps=96, light_steps=64, map_resolution=128, film_transparent=transparent)


def test_transparent_film_alpha_is_one_minus_view_transmittance(renderer, smoke):
    out = renderer.render(smoke, _settings(True))
    ref = render_reference(smoke, _settings(True), view_steps=96, light_steps=64)
    t = ref.passes["transmittance"].mean(axis=2)
    smoke_px = (t < 0.99) & (t > 0.01)
    assert smoke_px.sum() > 100                              # the test looks at the smoke
    alpha = out.combined[..., 3]
    np.testing.assert_allclose(alpha[smoke_px], 1.0 - t[smoke_px], atol=0.01)
    bar = ref.combined[..., 3] == 1.0
    assert bar.any() and (alpha[bar] == 1.0).all()
    empty = (t == 1.0) & ~bar
    assert empty.any() and (alpha[empty] == 0.0).all() and (out.rgb[empty] == 0.0).all()  # no world


def test_opaque_film_shows_the_world_through_the_medium(renderer, smoke):
    out = renderer.render(smoke, _settings(False))
    ref = render_reference(smoke, _settings(False), view_steps=96, light_steps=64)
    assert (out.combined[..., 3] == 1.0).all() and (ref.combined[..., 3] == 1.0).all()
    t = ref.passes["transmittance"]
    empty = (t.mean(axis=2) == 1.0) & (ref.passes["surfaces"].sum(axis=2) == 0.0)
    np.testing.assert_allclose(out.rgb[empty], np.broadcast_to(WORLD, out.rgb[empty].shape), rtol=1e-5)
    assert metrics.ssim(out.rgb, ref.rgb) >= 0.99
    assert abs(metrics.brightness_ratio(out.rgb, ref.rgb) - 1.0) < 0.01
    # The world behind is attenuated: the transparent film's image plus T * world.
    clear = renderer.render(smoke, _settings(True))
    behind = (clear.combined[..., 3] < 1.0)[..., None]      # no solid seen
    np.testing.assert_allclose(out.rgb, clear.rgb + behind * out.passes["transmittance"] * np.asarray(WORLD),
                               atol=1e-4)


def test_holdout_keeps_its_alpha_with_an_opaque_film(renderer, smoke):
    """Cycles' holdout cuts the image whatever the film: no world, alpha as the medium in front."""
    import dataclasses

    holes = tuple(dataclasses.replace(m, holdout=True) for m in smoke.meshes)
    held = dataclasses.replace(smoke, meshes=holes)
    out = renderer.render(held, _settings(False))
    ref = render_reference(held, _settings(False), view_steps=96, light_steps=64)
    bar = renderer.render(smoke, _settings(True)).combined[..., 3] == 1.0
    assert bar.sum() >= 10
    np.testing.assert_allclose(out.combined[..., 3][bar], ref.combined[..., 3][bar], atol=0.01)
    assert out.combined[..., 3][bar].max() < 0.9 and (out.combined[..., 3][~bar] == 1.0).all()
    np.testing.assert_allclose(out.rgb[bar], out.passes["scattering"][bar], atol=1e-5)   # no world


@pytest.mark.parametrize("transparent", [True, False])
def test_a_lone_pass_composes_the_image_the_composite_pass_makes(renderer, smoke, transparent):
    """A frame of one light pass writes its combined image in that pass (scatter.frag COMPOSE, no
    composite pass, read back bottom row first); the same frame as a one-sample frame goes through
    the composite pass (into the sample sums). Both give the same image, holdout included, and the
    lone frame's passes are unchanged."""
    import dataclasses

    from tfm_addon.engine.sampling import render_samples

    holes = tuple(dataclasses.replace(m, holdout=True) if i == 0 else m for i, m in enumerate(smoke.meshes))
    for scene in (smoke, dataclasses.replace(smoke, meshes=holes)):
        before = renderer.counters["light_passes"]
        lone = renderer.render(scene, _settings(transparent))
        assert renderer.counters["light_passes"] - before == 1            # one pass: it composed
        composed = render_samples(renderer, scene, _settings(transparent), 1)
        peak = float(np.abs(composed.combined).max())
        assert peak > 0.05
        assert np.abs(lone.combined - composed.combined).max() <= 1e-6 * peak
        for name, image in composed.passes.items():
            top = max(float(np.abs(image).max()), 1.0)
            assert np.abs(lone.passes[name] - image).max() <= 1e-6 * top, name
