"""The world's light shadowed by the media and the solids, against Cycles (single scattering:
direct light from the environment): a smoke over a ground lit only by a uniform white world, with
the world's light from 64 directions (fewer: docs/benchmark.md; TFM_WORLD_DIRECTIONS sets it here).
Unshadowed, the same scene came out 1.028 / 1.124 of Cycles' brightness (density 1 / 10)."""

import dataclasses
import importlib
import os

import bpy
import numpy as np
import pytest
from blender_helpers import MODULE, render_passes, smoke

from tfm_addon.blender import scene_builder
from tfm_addon.engine import RenderSettings, metrics

SETTINGS = RenderSettings(view_steps=96, light_steps=64, map_resolution=192, coefficients=12)


def _against_cycles(tmp_path, cycles_samples: int):
    """The context scene rendered by TFM with the world light shadowed and unshadowed, and by
    Cycles: (SSIM, brightness) of each TFM image against Cycles, and the directions used."""
    tfm_settings = bpy.context.scene.tfm
    tfm_settings.world_light = 'SHADOWED'
    tfm_settings.world_directions = int(os.environ.get("TFM_WORLD_DIRECTIONS", "64"))
    shadowed = render_passes(tmp_path, "tfm")["Combined"]
    tfm_settings.world_light = 'UNSHADOWED'
    unshadowed = render_passes(tmp_path, "unshadowed")["Combined"]
    scene_builder.cycles_single_scattering(bpy.context.scene, samples=cycles_samples)
    cycles = render_passes(tmp_path, "cycles")["Combined"]
    assert float(cycles[..., :3].mean()) > 1e-3
    figures = [(metrics.ssim(im, cycles), metrics.brightness_ratio(im, cycles))
               for im in (shadowed, unshadowed)]
    return figures, tfm_settings.world_directions


@pytest.mark.parametrize("density", [1.0, 10.0])
def test_smoke_lit_by_a_white_world_matches_cycles(blank, tmp_path, density):
    scene = smoke(width=64, height=48, n=24, ambient=(1.0, 1.0, 1.0))
    m = scene.media[0]
    scene = dataclasses.replace(scene, lights=(), media=(dataclasses.replace(
        m, sigma_a=tuple(density * 0.1 * c / c for c in m.sigma_a),
        sigma_s=tuple(density * 0.9 * c / c for c in m.sigma_s)),))
    scene_builder.build(scene, str(tmp_path), settings=SETTINGS, samples=4)
    ((ssim, ratio), (ssim_u, ratio_u)), n = _against_cycles(tmp_path, 512)
    print(f"white world, density x{density:g}, {n} directions: SSIM {ssim:.4f}, brightness {ratio:.4f} "
          f"(unshadowed: SSIM {ssim_u:.4f}, {ratio_u:.4f})")
    assert ssim >= 0.98 and abs(ratio - 1.0) <= 0.03


def _hdri(width=64, height=32):
    """An equirectangular environment made by code: a blue sky over a dark ground and a small warm
    patch of high radiance 30 degrees up, towards -X +Y (Blender's mapping)."""
    import numpy as np

    v = (np.arange(height)[::-1] + 0.5) / height          # image rows bottom first, as Blender's
    u = (np.arange(width) + 0.5) / width
    vv, uu = np.meshgrid(v, u, indexing="ij")
    theta = np.pi * (1.0 - vv)                              # from +Z
    phi = np.pi - 2.0 * np.pi * uu
    d = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)
    rgb = np.where((d[..., 2] > 0)[..., None], [0.25, 0.45, 0.9], [0.05, 0.04, 0.03]).astype(np.float32)
    sun = np.array([-0.6, 0.6, 0.5]) / np.linalg.norm([-0.6, 0.6, 0.5])
    rgb[(d @ sun) > 0.96] = (40.0, 30.0, 20.0)
    image = bpy.data.images.new("Sky", width, height, float_buffer=True)
    rgba = np.concatenate([rgb, np.ones((height, width, 1), np.float32)], axis=-1)
    image.pixels.foreach_set(rgba.ravel())
    return image


def test_smoke_lit_by_an_hdri_matches_cycles(blank, tmp_path):
    scene = smoke(width=64, height=48, n=24, ambient=(1.0, 1.0, 1.0))
    scene = dataclasses.replace(scene, lights=())
    scene_builder.build(scene, str(tmp_path), settings=SETTINGS, samples=4)
    world = bpy.context.scene.world
    nt = world.node_tree
    bg = next(n for n in nt.nodes if n.bl_idname == 'ShaderNodeBackground')
    env = nt.nodes.new('ShaderNodeTexEnvironment')
    env.image = _hdri()
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])
    ((ssim, ratio), (ssim_u, ratio_u)), n = _against_cycles(tmp_path, 1024)
    print(f"HDRI world, {n} directions: SSIM {ssim:.4f}, brightness {ratio:.4f} "
          f"(its mean colour unshadowed: SSIM {ssim_u:.4f}, {ratio_u:.4f})")
    assert ssim >= 0.95 and abs(ratio - 1.0) <= 0.10


def test_viewport_shadows_the_world_as_the_final_render_does(blank):
    """One model of the world's light: the viewport reads the final render's setting (the world
    field carries it to the media, so a shadowed world no longer costs a march per direction)."""
    extract = importlib.import_module(MODULE + ".tfm_addon.blender.extract")
    assert extract.render_settings(blank).world_light == 'SHADOWED'
    assert extract.render_settings(blank, viewport=True).world_light == 'SHADOWED'
    blank.tfm.world_light = 'UNSHADOWED'
    assert extract.render_settings(blank, viewport=True).world_light == 'UNSHADOWED'
    assert not hasattr(blank.tfm, "world_light_viewport")


def test_world_ray_visibility_as_cycles_reads_it(blank, tmp_path):
    """World ▸ Settings ▸ Ray Visibility: Camera off hides the world behind everything, Volume
    Scatter off keeps its light from the media, Diffuse off from the surfaces; Glossy,
    Transmission and Shadow change nothing for diffuse surfaces and media (measured in Cycles 5.0;
    the conformance rows world_scatter_off and world_diffuse_off compare the images). A toggle is
    a change of the world."""
    from tfm_addon.bench import conformance

    extract = importlib.import_module(MODULE + ".tfm_addon.blender.extract")
    conformance.ROW_BY_ID["world_color"].build(str(tmp_path))
    visibility = bpy.context.scene.world.cycles_visibility

    def read():
        depsgraph = bpy.context.evaluated_depsgraph_get()
        scene = extract.extract(depsgraph).scene()
        return (scene.background, scene.world_lights_medium, scene.world_lights_surfaces), \
            extract.scene_state(depsgraph)

    everything, state = read()
    assert np.allclose(everything[0], (0.3, 0.4, 0.6)) and everything[1:] == (True, True)
    lit = everything[0]
    expected = {"camera": ((0.0, 0.0, 0.0), True, True), "scatter": (lit, False, True),
                "diffuse": (lit, True, False), "glossy": everything,
                "transmission": everything, "shadow": everything}
    for flag, seen in expected.items():
        setattr(visibility, flag, False)
        got, after = read()
        assert np.allclose(got[0], seen[0]) and got[1:] == seen[1:], flag
        changed = extract.scene_changes(state, after) & extract.Change.WORLD
        assert bool(changed) == (seen != everything), flag
        setattr(visibility, flag, True)
