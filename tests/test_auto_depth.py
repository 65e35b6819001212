"""AUTO across optical depths, against the numpy reference: a smooth density's coefficient count
(quality.AUTO_COEFFICIENTS_SMOOTH, read at tau x sharpness) keeps SSIM >= 0.995 (a small smoke,
sharpness 0.36, with its sigma scaled to tau 7, where 2 coefficients, the choice before, fall
below 0.995, and to tau 30); a thick sharp density gets more steps (quality.thick_steps_factor: a
constant block at tau 16 fell to 0.988 with the steps before)."""

import dataclasses

import numpy as np
import pytest
from references import render_reference

from tfm_addon import scenes
from tfm_addon.engine import RenderSettings, quality
from tfm_addon.engine.metrics import ssim


def _smoke_at(tau: float):
    base = scenes.paper_smoke_scene(96, 54, 48)
    m = base.media[0]
    k = tau / quality.medium_stats(base).optical_depth
    medium = dataclasses.replace(m, sigma_a=tuple(x * k for x in m.sigma_a),
                                 sigma_s=tuple(x * k for x in m.sigma_s))
    return dataclasses.replace(base, media=(medium,))


@pytest.mark.parametrize("tau,coefficients", [(7.0, 6), (30.0, 16)])
def test_auto_coefficients_for_a_smooth_density_keep_ssim_0995(fresh, tau, coefficients):
    scene = _smoke_at(tau)
    stats = quality.medium_stats(scene)
    assert stats.sharpness < quality.SHARP_FOOTPRINT and stats.optical_depth == pytest.approx(tau, rel=1e-6)
    auto = quality.auto_settings(scene, RenderSettings(map_resolution=128, quality="AUTO"))
    assert auto.coefficients == coefficients
    auto = dataclasses.replace(auto, quality="CUSTOM")
    ref = render_reference(scene, view_steps=128, light_steps=128).combined[..., :3]
    got = ssim(fresh.render(scene, auto, passes=False).rgb, ref)
    fresh.clear_maps()
    fewer = ssim(fresh.render(scene, dataclasses.replace(auto, coefficients=2, quality="CUSTOM"),
                              passes=False).rgb, ref)
    print(f"tau {tau}: AUTO ({coefficients} coefficients) SSIM {got:.5f}, 2 coefficients {fewer:.5f}")
    assert got >= 0.995
    assert fewer < got
    if tau == 7.0:
        assert fewer < 0.995        # why the smooth table gives 2 coefficients only to tau 5


def test_a_thick_sharp_density_gets_the_steps_its_edges_need(fresh):
    base = scenes.paper_smoke_scene(96, 54, 128)
    d = np.zeros((128, 128, 128), np.float32)
    d[16:112, 16:112, 16:112] = 1.0
    m = dataclasses.replace(base.media[0], density=d)
    k = 16.0 / quality.medium_stats(dataclasses.replace(base, media=(m,))).optical_depth
    m = dataclasses.replace(m, sigma_a=tuple(x * k for x in m.sigma_a),
                            sigma_s=tuple(x * k for x in m.sigma_s))
    scene = dataclasses.replace(base, media=(m,))
    stats = quality.medium_stats(scene)
    assert stats.sharpness == pytest.approx(1.0) and stats.optical_depth == pytest.approx(16.0)
    assert quality.thick_steps_factor(stats.optical_depth, stats.sharpness) == pytest.approx(2.0)
    assert quality.thick_steps_factor(8.0, 1.0) == 1.0 and quality.thick_steps_factor(30.0, 0.2) == 1.0
    base_settings = RenderSettings(map_resolution=128, quality="AUTO")
    auto = dataclasses.replace(quality.auto_settings(scene, base_settings), quality="CUSTOM")
    before = dataclasses.replace(auto, view_steps=quality.auto_steps(stats.view_voxels, stats.sharpness),
                                 light_steps=quality.auto_steps(stats.light_voxels, stats.sharpness,
                                                                quality.LIGHT_STEPS_PER_VOXEL,
                                                                quality.LIGHT_MIN_STEPS))
    assert auto.view_steps > 1.9 * before.view_steps and auto.light_steps > before.light_steps
    ref = render_reference(scene, view_steps=512, light_steps=512).combined[..., :3]
    got = ssim(fresh.render(scene, auto, passes=False).rgb, ref)
    fresh.clear_maps()
    old = ssim(fresh.render(scene, before, passes=False).rgb, ref)
    print(f"block at tau 16: AUTO ({auto.view_steps} view, {auto.light_steps} light steps) SSIM {got:.5f}; "
          f"the steps before ({before.view_steps}, {before.light_steps}) {old:.5f}")
    assert got >= 0.995
    assert old < 0.99
