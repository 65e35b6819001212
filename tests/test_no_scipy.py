"""The render path without scipy (Blender bundles numpy, not scipy, and the add-on ships no scipy
wheel): AUTO's probe interpolates with numpy where scipy is missing, to the same numbers."""

import sys

import numpy as np
from scipy import ndimage

from tfm_addon.engine import RenderSettings, quality
from tfm_addon.scenes import smoke_scene


def test_numpy_trilinear_equals_scipys_map_coordinates():
    rng = np.random.default_rng(1)
    grid = np.pad(rng.random((20, 17, 9)), 1)
    coords = rng.uniform(-1.5, np.array(grid.shape)[:, None] + 0.5, size=(3, 50_000))
    coords[:, :10] = np.array(grid.shape)[:, None] - 1.0          # the last voxel centres
    coords[:, 10:20] = 0.0
    expected = ndimage.map_coordinates(grid, coords, order=1, mode="constant", cval=0.0)
    got = quality._trilinear_numpy(grid, coords)
    assert (expected == 0).mean() > 0.05                          # some points outside
    assert np.abs(got - expected).max() <= 1e-12


def test_auto_chooses_the_same_without_scipy(monkeypatch):
    scene = smoke_scene(width=40, height=24, n=24)
    quality._cache.clear()
    with_scipy = quality.auto_settings(scene, RenderSettings(quality="AUTO"))
    stats = quality.medium_stats(scene)
    quality._cache.clear()
    monkeypatch.setitem(sys.modules, "scipy", None)               # `from scipy import ...` fails
    without = quality.auto_settings(scene, RenderSettings(quality="AUTO"))
    stats2 = quality.medium_stats(scene)
    quality._cache.clear()
    assert without == with_scipy
    assert stats2.optical_depth > 0
    assert abs(stats2.optical_depth - stats.optical_depth) <= 1e-12 * stats.optical_depth
    assert stats2.light_voxels == stats.light_voxels
