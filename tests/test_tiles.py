"""A frame rendered in tiles (engine/tiles.py) equals the frame rendered whole: the tiles cover the
image once, share the light maps, and with adaptive sampling make the whole frame's decisions."""

import dataclasses

import numpy as np

from tfm_addon import scenes
from tfm_addon.engine import RenderSettings
from tfm_addon.engine.camera import pixel_window
from tfm_addon.engine.sampling import render_samples
from tfm_addon.engine.tiles import plan_tiles, render_tiled

SETTINGS = RenderSettings(view_steps=16, light_steps=32, map_resolution=64, coefficients=4)


def _tiled(renderer, scene, settings, samples, side):
    _, _, w, h = pixel_window(scene.camera)
    images = {"combined": np.full((h, w, 4), np.nan, np.float32)}
    written = []

    def render_tile(s, st, until, whites, passes):
        return render_samples(renderer, s, st, samples, passes=passes, until=until, whites=whites)

    def write(tile, out):
        x0, y0, tw, th = tile.core
        top = h - (y0 + th)
        for name, image in {"combined": out.combined, **out.passes}.items():
            target = images.setdefault(name, np.full((h, w, image.shape[2]), np.nan, np.float32))
            assert np.isnan(target[top:top + th, x0:x0 + tw]).all()       # each pixel written once
            target[top:top + th, x0:x0 + tw] = image
        written.append(tile)

    before = dict(renderer.counters)
    summary = render_tiled(render_tile, scene, settings, samples, side, write)
    tfms = renderer.counters["tfms"] - before["tfms"]
    return images, written, summary, tfms


def _peak_error(a, b):
    return float(np.abs(a - b).max() / np.abs(b).max())


def test_tiles_cover_the_window_once_on_block_boundaries():
    camera = scenes.smoke_scene(width=70, height=45).camera
    tiles = plan_tiles(camera, 30)
    cover = np.zeros((45, 70), int)
    for t in tiles:
        x0, y0, w, h = t.core
        assert x0 % 4 == 0 and y0 % 4 == 0 and w <= 28 and h <= 28
        cover[y0:y0 + h, x0:x0 + w] += 1
        wx, wy, ww, wh = t.window
        assert wx <= x0 and wy <= y0 and wx + ww >= x0 + w and wy + wh >= y0 + h and wx % 4 == 0
    assert (cover == 1).all()


def test_a_frame_in_tiles_equals_the_whole_frame(renderer):
    scene = scenes.smoke_scene(width=64, height=48, n=32)
    for samples in (3, 16):                                  # 16: adaptive sampling
        whole = render_samples(renderer, scene, SETTINGS, samples)
        images, written, summary, tfms = _tiled(renderer, scene, SETTINGS, samples, side=24)
        assert len(written) == 6
        assert tfms <= 1                            # the maps are built once, for every tile
        assert not np.isnan(images["combined"]).any()
        # Rays of a tile start from another window corner: float rounding only.
        assert _peak_error(images["combined"], whole.combined) < 2e-3, samples
        for name, image in whole.passes.items():
            assert _peak_error(images[name], image) < 2e-3, (samples, name)
        assert summary.chosen["view_steps"] == whole.chosen["view_steps"]


def test_a_bordered_frame_in_tiles_equals_its_border(renderer):
    scene = scenes.smoke_scene(width=64, height=48, n=32)
    scene = dataclasses.replace(scene, camera=dataclasses.replace(
        scene.camera, border=(0.2 + 1e-3 / 64, 0.1 + 1e-3 / 48, 0.9 - 1e-3 / 64, 0.8 - 1e-3 / 48)))
    whole = render_samples(renderer, scene, SETTINGS, 4)
    images, written, _, _ = _tiled(renderer, scene, SETTINGS, 4, side=20)
    assert images["combined"].shape == whole.combined.shape
    assert _peak_error(images["combined"], whole.combined) < 2e-3
