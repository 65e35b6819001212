"""Object visibility against Cycles (single scattering, BLENDER.md settings), 160x90: a bar that
casts no shadow loses its shaft in both; a holdout ground cuts alpha in both."""

import time

import bpy
import numpy as np
import pytest
from blender_helpers import render_passes, smoke

from tfm_addon.blender import scene_builder
from tfm_addon.engine import RenderSettings, metrics

SETTINGS = RenderSettings(view_steps=128, light_steps=128, map_resolution=256, coefficients=16)
CYCLES_SAMPLES = 512


def _build(tmp_path):
    builder = scene_builder
    made = builder.build(smoke(width=160, height=90, n=32), str(tmp_path), settings=SETTINGS)
    return builder, {ob.name.split(".")[0]: ob for ob in made["meshes"]}


def _cycles(builder, tmp_path, name):
    builder.cycles_single_scattering(bpy.context.scene, samples=CYCLES_SAMPLES)
    t0 = time.perf_counter()
    image = render_passes(tmp_path, name)["Combined"]
    return image, time.perf_counter() - t0


def _alpha_as_rgb(image):
    return np.repeat(image[..., 3:4], 3, axis=-1)


@pytest.mark.parametrize("case", ["no_shadow", "holdout"])
def test_visibility_agrees_with_cycles(blank, tmp_path, case):
    builder, meshes = _build(tmp_path)
    assert set(meshes) == {"Bar", "Ground"}
    usual = render_passes(tmp_path, "usual")["Combined"]
    if case == "no_shadow":
        meshes["Bar"].visible_shadow = False
    else:
        meshes["Ground"].is_holdout = True
    tfm = render_passes(tmp_path, "tfm")["Combined"]
    cycles, seconds = _cycles(builder, tmp_path, "cycles")
    ssim = metrics.ssim(tfm, cycles)
    ssim_alpha = metrics.ssim(_alpha_as_rgb(tfm), _alpha_as_rgb(cycles))
    # The flag matters to Cycles: its image is further from TFM's usual render than from TFM's.
    ssim_usual = min(metrics.ssim(usual, cycles), metrics.ssim(_alpha_as_rgb(usual), _alpha_as_rgb(cycles)))
    print(f"{case}: TFM vs Cycles ({CYCLES_SAMPLES} spp, {seconds:.1f} s): SSIM {ssim:.4f}, "
          f"alpha SSIM {ssim_alpha:.4f}, brightness ratio {metrics.brightness_ratio(tfm, cycles):.4f}; "
          f"TFM without the flag against this Cycles: SSIM {ssim_usual:.4f}")
    assert ssim >= 0.98 and ssim_alpha >= 0.98
    assert ssim_usual < min(ssim, ssim_alpha) - 0.005
    ground = usual[..., 3] == 1.0
    if case == "no_shadow":
        # The shaft: light the bar kept from the smoke is back, in both renderers.
        shaft = (tfm[..., :3] - usual[..., :3]).sum(axis=-1) > 0.05 * usual[..., :3].max()
        assert shaft.sum() > 20
        np.testing.assert_array_equal(tfm[..., 3], usual[..., 3])
    else:
        assert ground.mean() > 0.2
        # Where the ground was: no radiance of its own, alpha as the smoke in front leaves it.
        assert tfm[..., 3][ground].mean() < 0.2 and cycles[..., 3][ground].mean() < 0.2
        assert abs(tfm[..., 3][ground].mean() - cycles[..., 3][ground].mean()) < 0.02
