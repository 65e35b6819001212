"""AUTO on a dense, production-scale cloud (scattering up to 50 per metre, 5 cm voxels): within
SSIM 0.99 of the same engine at high quality (512 view and light steps, 16 coefficients, 1024²
maps); the TFM keeps a texel per voxel where a voxel is optically thick, however smooth the
density (quality.footprint_texels_per_voxel)."""

import dataclasses

import pytest

from tfm_addon import scenes
from tfm_addon.engine import RenderSettings, metrics, quality
from tfm_addon.engine.passes import tfm

HIGH = RenderSettings(view_steps=512, light_steps=512, coefficients=16, map_resolution=1024)


def _dense_cloud():
    scene = scenes.cloud_scene(160, 90, shape=(240, 160, 80))
    m = scene.media[0]
    k = 50.0 / 6.0
    dense = dataclasses.replace(m, sigma_a=tuple(k * c for c in m.sigma_a),
                                sigma_s=tuple(k * c for c in m.sigma_s))
    return dataclasses.replace(scene, media=(dense,))


def test_optically_thick_voxels_get_a_texel_each():
    thin = scenes.cloud_scene(160, 90, shape=(240, 160, 80)).media[0]
    thick = _dense_cloud().media[0]
    assert quality.footprint_texels_per_voxel(thin) == pytest.approx(tfm.SMOOTH_TEXELS_PER_VOXEL)
    assert quality.footprint_texels_per_voxel(thick) == pytest.approx(tfm.TEXELS_PER_VOXEL)


def test_auto_holds_on_a_dense_cloud(renderer):
    scene = _dense_cloud()
    high = renderer.render(scene, HIGH).combined
    auto = renderer.render(scene, RenderSettings(quality="AUTO"))
    ssim = metrics.ssim(auto.combined, high)
    ratio = metrics.brightness_ratio(auto.combined, high)
    print(f"AUTO {auto.chosen}: SSIM {ssim:.4f}, brightness {ratio:.4f} of the high-quality frame")
    assert ssim >= 0.99
    assert abs(ratio - 1.0) <= 0.03
    assert auto.chosen["coefficients"] == 16 and auto.chosen["tfm_side"] > 0


def test_a_sample_keeps_view_steps_where_the_medium_is_optically_deep():
    from tfm_addon.engine.sampling import MIN_VIEW_STEPS, view_steps_per_sample

    assert view_steps_per_sample(32, 16, 0.5) == MIN_VIEW_STEPS          # thin: spread over the samples
    assert view_steps_per_sample(32, 16, 11.8) == 32                     # deep: 0.25 per step at most
    assert view_steps_per_sample(96, 16, 11.8) == 48
