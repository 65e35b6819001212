"""The film against Cycles (single scattering, BLENDER.md settings), 160x90: a transparent film
composited over grey, and an opaque film with a coloured world seen behind the smoke."""

import importlib
import time

import bpy
import numpy as np
from blender_helpers import MODULE, render_passes, smoke

from tfm_addon.blender import scene_builder
from tfm_addon.engine import RenderSettings, metrics

SETTINGS = RenderSettings(view_steps=128, light_steps=128, map_resolution=256, coefficients=16)
CYCLES_SAMPLES = 256
GREY = 0.18
WORLD = (0.25, 0.35, 0.6)


def _over_grey(image):
    return image[..., :3] + (1.0 - image[..., 3:4]) * GREY


def _renders(tmp_path, transparent: bool):
    scene = bpy.context.scene
    # No ground: its far edge, a horizon across the frame, would test anti-aliasing instead.
    scene_builder.build(smoke(width=160, height=90, n=32, with_ground=False), str(tmp_path),
                        settings=SETTINGS)
    if not transparent:
        world = scene.world
        world.node_tree.nodes["Background"].inputs["Color"].default_value = (*WORLD, 1.0)
        # The world is seen, it lights nothing: TFM's ambient off, Cycles' world rays off.
        scene.tfm.ambient = False
        v = world.cycles_visibility
        v.diffuse = v.glossy = v.transmission = v.scatter = False
    scene.render.film_transparent = transparent
    tfm = render_passes(tmp_path, "tfm")["Combined"]
    scene_builder.cycles_single_scattering(scene, samples=CYCLES_SAMPLES)
    scene.render.film_transparent = transparent
    t0 = time.perf_counter()
    cycles = render_passes(tmp_path, "cycles")["Combined"]
    return tfm, cycles, time.perf_counter() - t0


def test_transparent_film_over_grey_matches_cycles(blank, tmp_path):
    tfm, cycles, seconds = _renders(tmp_path, True)
    sky = cycles[..., 3] < 0.01
    assert sky.mean() > 0.2 and (tfm[..., 3][sky] < 0.02).all()
    a, b = _over_grey(tfm), _over_grey(cycles)
    ssim = metrics.ssim(a, b)
    print(f"transparent film over grey: SSIM {ssim:.4f}, brightness ratio "
          f"{metrics.brightness_ratio(a, b):.4f} (Cycles {CYCLES_SAMPLES} spp, {seconds:.1f} s)")
    assert ssim >= 0.98
    assert abs(np.mean(tfm[..., 3]) - np.mean(cycles[..., 3])) < 0.01


def test_opaque_film_shows_the_world_like_cycles(blank, tmp_path):
    tfm, cycles, seconds = _renders(tmp_path, False)
    assert (tfm[..., 3] == 1.0).all() and (cycles[..., 3] > 0.999).all()
    ssim = metrics.ssim(tfm[..., :3], cycles[..., :3])
    ratio = metrics.brightness_ratio(tfm[..., :3], cycles[..., :3])
    print(f"opaque film, coloured world: SSIM {ssim:.4f}, brightness ratio {ratio:.4f} "
          f"(Cycles {CYCLES_SAMPLES} spp, {seconds:.1f} s)")
    assert ssim >= 0.98 and abs(ratio - 1.0) < 0.03
    top = tfm[0, :, :3]                       # the top row sees the world past the smoke
    np.testing.assert_allclose(top.mean(axis=0), WORLD, rtol=0.02)


def test_viewport_follows_the_film(blank, tmp_path):
    """The viewport draws the combined image: opaque film, the world and alpha 1; transparent,
    the sky's alpha 0 (a settings change re-reads the film)."""
    changes = importlib.import_module(MODULE + ".tfm_addon.blender.changes")
    scene = bpy.context.scene
    scene_builder.build(smoke(width=64, height=36, n=32, with_ground=False), str(tmp_path), settings=SETTINGS)
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (*WORLD, 1.0)
    scene.render.film_transparent = False
    session = importlib.import_module(MODULE + ".tfm_addon.blender.viewport").ViewportSession()
    session.update(bpy.context.evaluated_depsgraph_get())
    camera = session.extraction.camera
    opaque = session.render(camera).combined
    assert (opaque[..., 3] == 1.0).all()
    np.testing.assert_allclose(opaque[0, :, :3].mean(axis=0), WORLD, rtol=0.02)
    scene.render.film_transparent = True
    session.update(bpy.context.evaluated_depsgraph_get(), changes.Change.SETTINGS)
    clear = session.render(camera).combined
    assert (clear[0, :, 3] == 0.0).all() and (clear[0, :, :3] == 0.0).all()
