"""Fire and coloured smoke through Blender: the material's emission, blackbody and colour grid
read from its nodes, rendered against Cycles (single scattering, no volume bounces)."""

import importlib
import time

import bpy
import numpy as np
import pytest
from blender_helpers import MODULE, render_passes

from tfm_addon import scenes
from tfm_addon.engine import RenderSettings, metrics

SETTINGS = RenderSettings(view_steps=128, light_steps=128, map_resolution=256, coefficients=16)
CASES = {
    # name: (fire_scene arguments, Cycles samples)
    "emission": (dict(kind="EMISSION"), 1024),
    "blackbody": (dict(kind="BLACKBODY"), 1024),
    "smoke_fire_spot_occluder": (dict(kind="FIRE", with_light=True, with_occluder=True), 1024),
    "color_grid": (dict(kind="COLOR", with_light=True, with_occluder=True), 1024),
}


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


@pytest.mark.parametrize("case", sorted(CASES))
def test_fire_agrees_with_cycles(blank, tmp_path, case):
    kwargs, samples = CASES[case]
    scene = scenes.fire_scene(96, 54, 32, **kwargs)
    made = _mod("scene_builder").build(scene, str(tmp_path), settings=SETTINGS)
    extraction = _mod("extract").extract(bpy.context.evaluated_depsgraph_get())
    assert not [w for w in extraction.all_warnings if "Smoke" in w and "colour grid" not in w], \
        extraction.all_warnings
    assert extraction.medium.has_emission == scene.medium.has_emission
    tfm = render_passes(tmp_path, "tfm")["Combined"][..., :3]
    _mod("scene_builder").cycles_single_scattering(bpy.context.scene, samples=samples)
    # Cycles lets the fire light the ground and its own smoke (diffuse and volume-scatter rays that
    # meet the emission are direct light); the engine's emission lights nothing, so the comparison
    # keeps those rays from seeing the volume.
    made["medium"].visible_diffuse = False
    made["medium"].visible_volume_scatter = False
    t0 = time.perf_counter()
    cycles = render_passes(tmp_path, "cycles")["Combined"][..., :3]
    seconds = time.perf_counter() - t0
    s = metrics.ssim(tfm, cycles)
    ratio = tfm.sum(axis=(0, 1)) / cycles.sum(axis=(0, 1))
    print(f"{case}: TFM vs Cycles ({samples} spp, {seconds:.1f} s): SSIM {s:.4f}, brightness per "
          f"channel {np.round(ratio, 4)}, PSNR {metrics.psnr(tfm, cycles):.1f} dB")
    assert cycles.max() > 1e-2
    assert s >= 0.98
    assert np.all(np.abs(ratio - 1.0) <= 0.03)
