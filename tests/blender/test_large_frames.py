"""A frame larger than the memory budget allows at once renders in tiles through
bpy.ops.render.render (final_render.tiling, engine/tiles.py) and equals the frame rendered whole."""

import importlib

import bpy
import numpy as np
from blender_helpers import MODULE, SETTINGS, render_passes, smoke

from tfm_addon.blender import scene_builder


def test_a_frame_above_the_budget_renders_in_tiles_equal_to_the_whole(blank, tmp_path, monkeypatch):
    final_render = importlib.import_module(f"{MODULE}.tfm_addon.blender.final_render")
    monkeypatch.delenv(final_render.BUDGET_ENV, raising=False)
    scene_builder.build(smoke(width=160, height=120, n=24), str(tmp_path), settings=SETTINGS, samples=16)
    scene = bpy.context.scene
    scene.tfm.memory_budget_gb = 64.0
    whole = render_passes(tmp_path, "whole")
    assert final_render.tiling(scene, 160, 120, 3) == (None, None)

    # Room for the render result and 64-pixel tiles (with their aprons): 3 x 2 tiles.
    budget = final_render.result_bytes(160, 120, 3) + final_render.ENGINE_BYTES_PER_PIXEL * 100 ** 2
    scene.tfm.memory_budget_gb = budget / 1024 ** 3
    assert final_render.tiling(scene, 160, 120, 3) == (68, None)
    renders = final_render.get_worker().counters["renders"]
    tiled = render_passes(tmp_path, "tiled")
    # Six tiles, three stages (adaptive sampling's two decisions, then the frame's 16 samples).
    assert final_render.get_worker().counters["renders"] - renders > 16 * 6
    for name, image in whole.items():
        error = float(np.abs(tiled[name] - image).max() / np.abs(image).max())
        assert error < 2e-3, (name, error)


def test_a_render_border_in_tiles_equals_the_border_rendered_whole(blank, tmp_path, monkeypatch):
    final_render = importlib.import_module(f"{MODULE}.tfm_addon.blender.final_render")
    monkeypatch.delenv(final_render.BUDGET_ENV, raising=False)
    scene_builder.build(smoke(width=160, height=120, n=24), str(tmp_path), settings=SETTINGS, samples=4)
    scene = bpy.context.scene
    render = scene.render
    render.use_border = True
    render.border_min_x, render.border_max_x, render.border_min_y, render.border_max_y = 0.1, 0.85, 0.2, 0.9
    scene.tfm.memory_budget_gb = 64.0
    whole = render_passes(tmp_path, "whole")
    scene.tfm.memory_budget_gb = (final_render.result_bytes(160, 120, 3)
                                  + final_render.ENGINE_BYTES_PER_PIXEL * 100 ** 2) / 1024 ** 3
    tiled = render_passes(tmp_path, "tiled")
    assert tiled["Combined"].shape == whole["Combined"].shape
    for name, image in whole.items():
        error = float(np.abs(tiled[name] - image).max() / np.abs(image).max())
        assert error < 2e-3, (name, error)
