"""Fire and coloured smoke through Blender: the material's emission, blackbody and colour grid
read from its nodes, rendered against Cycles (single scattering, no volume bounces)."""

import importlib
import time

import bpy
import numpy as np
import pytest
from blender_helpers import MODULE, render_passes

from tfm_addon import scenes
from tfm_addon.blender import scene_builder
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
    made = scene_builder.build(scene, str(tmp_path), settings=SETTINGS)
    extraction = _mod("extract").extract(bpy.context.evaluated_depsgraph_get())
    assert not [w for w in extraction.all_warnings if "Smoke" in w and "colour grid" not in w
                and "emits and scatters" not in w], extraction.all_warnings
    assert extraction.media[0].has_emission == scene.media[0].has_emission
    # Cycles lets the fire light the bar and its own smoke (diffuse and volume-scatter rays that
    # meet the emission are direct light); the engine does not scatter the emission in the medium,
    # so both renders keep those rays from seeing the volume (the fire lighting the ground is the
    # conformance row fire_lights_ground).
    made["medium"].visible_diffuse = False
    made["medium"].visible_volume_scatter = False
    tfm = render_passes(tmp_path, "tfm")["Combined"][..., :3]
    scene_builder.cycles_single_scattering(bpy.context.scene, samples=samples)
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


def test_a_constant_emission_glows_where_cycles_puts_the_volume(blank, tmp_path):
    """A constant Emission Strength beside the density grid glows where there is no density too:
    over Cycles' volume mesh, the 8³ leaf blocks of the grid's active voxels grown by one voxel
    (extract.glow_blocks), not the grid's own box (0.82-0.85 of Cycles' brightness) nor the box of
    those blocks (1.66)."""
    import dataclasses

    from tfm_addon.engine.scene import GridValue

    scene = scenes.fire_scene(96, 54, 32, kind="EMISSION")
    scene = dataclasses.replace(scene, media=(dataclasses.replace(
        scene.media[0], emission_strength=GridValue(offset=0.3), blackbody_intensity=GridValue(offset=0.0)),))
    made = scene_builder.build(scene, str(tmp_path), settings=SETTINGS)
    extraction = _mod("extract").extract(bpy.context.evaluated_depsgraph_get())
    medium = extraction.media[0]
    n = np.asarray(medium.density.shape, np.float64)
    lo, hi = (np.asarray(c) for c in medium.glow.box)
    print(f"grid {medium.density.shape}, glow box {lo} .. {hi}; notes {extraction.all_warnings}")
    assert np.all(lo <= -1.0) and np.all(hi >= n) and np.any(hi - lo > n + 2.0)   # wider than [-1, n]
    tfm = render_passes(tmp_path, "tfm")["Combined"][..., :3]
    scene_builder.cycles_single_scattering(bpy.context.scene, samples=256)
    made["medium"].visible_diffuse = False
    made["medium"].visible_volume_scatter = False
    cycles = render_passes(tmp_path, "cycles")["Combined"][..., :3]
    s = metrics.ssim(tfm, cycles)
    ratio = tfm.sum(axis=(0, 1)) / cycles.sum(axis=(0, 1))
    print(f"constant emission: SSIM {s:.4f}, brightness {np.round(ratio, 4)} of Cycles'")
    assert cycles.max() > 1e-2
    assert s >= 0.98
    assert np.all(np.abs(ratio - 1.0) <= 0.03)


def test_glow_blocks_are_the_file_s_leaves_around_the_active_voxels(blank):
    """extract.glow_blocks: 8³ blocks aligned on the file's voxel indices, in where an active
    voxel (the density at least the clipping, an extra grid not 0) lies once grown by one voxel."""
    volumes = _mod("volumes")
    d = np.zeros((20, 20, 20), np.float32)
    d[5, 5, 5] = 1.0                    # file index (10, 10, 10): leaf [8, 16)
    d[12, 5, 5] = 0.0005                # below the clipping: inactive
    flame = np.zeros_like(d)
    flame[5, 5, 13] = 2.0               # file index (10, 10, 18): leaf [16, 24) in z
    grid = volumes.DensityGrid(density=d, index_to_object=np.eye(4), grid_name="density",
                               extras={"flame": flame}, key="k", first_index=(5, 5, 5))
    glow = _mod("extract").glow_blocks(grid, ("flame",), clipping=0.001)
    assert glow.side == (8.0, 8.0, 8.0)
    assert all((o + 5) % 8 == 0 for o in glow.origin)           # on the file's leaves
    inside = glow.contains(np.array([[5.0, 5.0, 5.0], [5.0, 5.0, 13.0], [12.0, 5.0, 5.0], [3.0, 3.0, 3.0],
                                     [2.5, 5.0, 5.0]]))
    # (3, 3, 3) is file index 8: the voxel's own leaf; (2.5, 5, 5) file 7.5, the leaf before,
    # which its growth by one voxel (file 9) does not reach
    assert list(inside) == [True, True, False, True, False]
    assert int(glow.mask.sum()) == 2
    assert _mod("extract").glow_blocks(grid, ("flame",), clipping=0.001) is glow       # kept
