"""The physical reference: Cycles with single scattering only (BLENDER.md) against TFM."""

import time

import bpy
from blender_helpers import render_passes, smoke

from tfm_addon.blender import scene_builder
from tfm_addon.engine import RenderSettings, metrics

SETTINGS = RenderSettings(view_steps=128, light_steps=128, map_resolution=256, coefficients=16)
CYCLES_SAMPLES = 1024  # 128x72: about 17 s on 2 cores


def test_tfm_agrees_with_cycles(blank, tmp_path):
    scene_builder.build(smoke(width=128, height=72, n=32), str(tmp_path), settings=SETTINGS)
    tfm = render_passes(tmp_path, "tfm")["Combined"]
    scene_builder.cycles_single_scattering(bpy.context.scene, samples=CYCLES_SAMPLES)
    t0 = time.perf_counter()
    cycles = render_passes(tmp_path, "cycles")["Combined"]
    seconds = time.perf_counter() - t0
    ssim = metrics.ssim(tfm, cycles)
    ratio = metrics.brightness_ratio(tfm, cycles)
    print(f"TFM vs Cycles ({CYCLES_SAMPLES} spp, {seconds:.1f} s): SSIM {ssim:.4f}, "
          f"brightness ratio {ratio:.4f}, PSNR {metrics.psnr(tfm, cycles):.1f} dB")
    assert ssim >= 0.98
    assert abs(ratio - 1.0) <= 0.03
