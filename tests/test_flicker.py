"""The flicker figure (tfm_addon/bench/flicker.py) on images made here: what it counts as still
and what it measures there."""

import numpy as np

from tfm_addon.bench import flicker


def _frames(n=4, moving=0.0, noise=0.0, seed=0):
    """A lit square (0.5) on black, half of it changing by ``moving`` a frame, plus noise."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        im = np.zeros((20, 20, 3), np.float32)
        im[5:15, 5:15] = 0.5
        im[5:15, 10:15] += moving * k
        im[8:11, 8:11] = 1.0                               # the white
        out.append(im + noise * rng.standard_normal(im.shape).astype(np.float32))
    return out


def test_still_pixels_are_lit_and_unchanged():
    truth = _frames(moving=0.05)
    masks = flicker.still_pixels(truth)
    assert len(masks) == 3
    for m in masks:
        assert m[7, 7] and not m[7, 12] and not m[0, 0]      # still and lit / moving / dark


def test_flicker_is_the_change_where_the_scene_is_still():
    truth = _frames(moving=0.05)
    assert flicker.flicker(truth, truth) == 0.0               # the scene's own motion is not flicker
    noisy = _frames(moving=0.05, noise=0.01, seed=3)
    f = flicker.flicker(noisy, truth)
    # the mean |difference| of two independent normals of sigma 0.01: 0.01 x 2 / sqrt(pi), white ~1
    assert 0.009 < f < 0.014, f
