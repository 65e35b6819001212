"""A blackbody fire whose temperature grid is in kelvin (Principled Volume: Blackbody Intensity 2,
Temperature 1, Temperature Attribute 'temperature', Density Attribute 'density'), no lights, a black
world: TFM's emission against Cycles' (single scattering, BLENDER.md settings; the volume hidden
from volume-scatter rays in both renders, and from diffuse rays in Cycles', so that each shows
its emission alone)."""

import dataclasses
import importlib

import bpy
import numpy as np
import pytest
from blender_helpers import MODULE, render_passes

from tfm_addon import scenes
from tfm_addon.blender import scene_builder
from tfm_addon.engine import RenderSettings, metrics
from tfm_addon.engine.scene import GridValue

SETTINGS = RenderSettings(view_steps=128, light_steps=128, map_resolution=256, coefficients=16)
W, H, N, SAMPLES = 96, 54, 24, 512


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


def _kelvin(density: np.ndarray, uniform: bool) -> np.ndarray:
    """800-1800 K rising with the density where there is smoke (or 1300 K throughout it), 0 K
    elsewhere."""
    d = density / float(density.max())
    t = np.full_like(d, 1300.0) if uniform else 800.0 + 1000.0 * d
    return np.where(density > 0.0, t, 0.0).astype(np.float32)


@pytest.mark.parametrize("uniform", [False, True], ids=["800-1800K", "1300K"])
def test_a_blackbody_fire_in_kelvin_glows_as_in_cycles(blank, tmp_path, uniform):
    base = scenes.fire_scene(W, H, N, kind="BLACKBODY")
    m = base.media[0]
    medium = dataclasses.replace(
        m, grids={"temperature": _kelvin(m.density, uniform)}, blackbody_intensity=GridValue(offset=2.0),
        temperature=GridValue("temperature", 1.0, 0.0), blackbody_tint=(1.0, 1.0, 1.0))
    scene = dataclasses.replace(base, media=(medium,))
    made = scene_builder.build(scene, str(tmp_path), settings=SETTINGS, samples=16)
    extraction = _mod("extract").extract(bpy.context.evaluated_depsgraph_get())
    print(extraction.all_warnings, extraction.media[0].blackbody_intensity, extraction.media[0].temperature)
    made["medium"].visible_volume_scatter = False    # both renders: the emission alone, unscattered
    tfm = render_passes(tmp_path, "tfm")["Combined"][..., :3]
    scene_builder.cycles_single_scattering(bpy.context.scene, samples=SAMPLES)
    made["medium"].visible_diffuse = False
    cycles = render_passes(tmp_path, "cycles")["Combined"][..., :3]
    s = metrics.ssim(tfm, cycles)
    ratio = tfm.sum(axis=(0, 1)) / cycles.sum(axis=(0, 1))
    print(f"blackbody {'uniform' if uniform else 'gradient'}: TFM vs Cycles ({W}x{H}, {SAMPLES} spp): "
          f"SSIM {s:.4f}, brightness per channel {np.round(ratio, 4)}")
    np.save(tmp_path / "tfm.npy", tfm)
    np.save(tmp_path / "cycles.npy", cycles)
    assert cycles.max() > 1e-2
    # Cycles emits nothing where mix(1, T^4, 2) is negative (T = 0 K around the smoke): no red
    # below 0 (the blackbody's red is positive at every temperature)
    assert float(cycles[..., 0].min()) >= 0.0 and float(tfm[..., 0].min()) >= 0.0, tfm[..., 0].min()
    assert s >= 0.98
    assert np.all(np.abs(ratio - 1.0) <= 0.03)
