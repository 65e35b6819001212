"""Issue 8's speed features, checked by what they must not change: the floor method against a
numpy reference whose light transmittance is forced to 1, empty-space skipping against the
reference on a sparse grid, the occupancy grid and the tight box against the trilinear density
itself (scipy), the footprint TFM side. Timings live in ``python -m tfm_addon.bench.speed``."""

import dataclasses

import numpy as np
import pytest
from scipy import ndimage

from tfm_addon.engine import Medium, RenderSettings
from tfm_addon.engine import reference as reference_module
from tfm_addon.engine.light import LightFrame
from tfm_addon.engine.metrics import brightness_ratio, ssim
from tfm_addon.engine.passes.bindings import OCCUPANCY_BLOCK, nonzero_bounds, occupancy
from tfm_addon.engine.passes.tfm import footprint_resolution, tfm_resolution
from tfm_addon.engine.reference import render_reference
from tfm_addon.scenes import grid_to_world, smoke_density, smoke_scene

STEPS = dict(view_steps=96, light_steps=96)


def _sparse_grid(n: int = 48) -> np.ndarray:
    """Two small puffs in a mostly empty grid, off the occupancy cells' boundaries."""
    d = np.zeros((n, n, n), np.float32)
    puff = smoke_density(16)
    d[5:21, 9:25, 11:27] = puff
    d[n - 19:n - 3, n - 25:n - 9, n - 29:n - 13] = 0.5 * puff
    return d


def test_occupancy_marks_every_cell_where_the_trilinear_density_is_not_zero():
    rng = np.random.default_rng(3)
    d = _sparse_grid(44)
    padded = np.pad(d, 1)                     # x, y, z
    occ = occupancy(np.ascontiguousarray(padded.transpose(2, 1, 0)))     # z, y, x
    b = OCCUPANCY_BLOCK
    assert occ.shape == tuple(-(-s // b) for s in padded.shape[::-1])
    p = rng.uniform(0.0, padded.shape[0] - 1.0, size=(200_000, 3))      # padded index space
    value = ndimage.map_coordinates(padded, p.T, order=1, mode="constant", cval=0.0)
    cell = np.floor(p / b).astype(int)
    marked = occ[cell[:, 2], cell[:, 1], cell[:, 0]] > 0
    assert (value[~marked] == 0).all()        # skipping an unmarked cell skips only zeros
    assert marked.mean() < 0.6                # and the grid is sparse enough to skip something


def test_tight_box_holds_all_the_density():
    d = _sparse_grid(44)
    lo, hi = nonzero_bounds(d)
    nz = np.argwhere(d > 0)
    assert np.allclose(lo, nz.min(axis=0) - 1) and np.allclose(hi, nz.max(axis=0) + 1)
    lo, hi = nonzero_bounds(np.zeros((4, 4, 4), np.float32))
    assert all(a >= b for a, b in zip(lo, hi, strict=True))       # an empty box


@pytest.fixture(scope="module")
def sparse_scene():
    base = smoke_scene(width=80, height=48, n=48)
    d = _sparse_grid(48)
    medium = Medium(sigma_a=(0.2, 0.2, 0.2), sigma_s=(3.0, 3.0, 3.0), density=d,
                    index_to_world=grid_to_world(d.shape, 2.0, (0, 0, 1.2)))
    return dataclasses.replace(base, medium=medium)


def test_skipping_and_tight_bounds_keep_the_image_on_a_sparse_grid(renderer, sparse_scene):
    ref = render_reference(sparse_scene, **STEPS)
    for method in ("TFM", "BRUTE_FORCE"):
        out = renderer.render(sparse_scene, RenderSettings(method=method, map_resolution=128, **STEPS))
        assert ssim(out.rgb, ref.rgb) >= 0.99, method
        assert abs(brightness_ratio(out.rgb, ref.rgb) - 1) <= 0.02, method


def test_unshadowed_is_the_frame_with_light_transmittance_one(renderer, sparse_scene, monkeypatch):
    renderer.clear_maps()
    before = renderer.counters["tfms"]
    out = renderer.render(sparse_scene, RenderSettings(method="UNSHADOWED", map_resolution=128, **STEPS))
    assert renderer.counters["tfms"] == before, "the floor builds no TFM"
    shadowed = renderer.render(sparse_scene, RenderSettings(map_resolution=128, **STEPS))
    assert out.passes["scattering"].sum() > 1.1 * shadowed.passes["scattering"].sum()
    # The reference with every integral toward the light set to 0 (the solids still shadow).
    monkeypatch.setattr(reference_module._Field, "integral_to",
                        lambda self, points, light: np.zeros(len(points)))
    ref = render_reference(sparse_scene, **STEPS)
    assert ssim(out.rgb, ref.rgb) >= 0.99
    assert abs(brightness_ratio(out.rgb, ref.rgb) - 1) <= 0.02
    assert ssim(out.passes["scattering"], ref.passes["scattering"]) >= 0.99
    assert abs(brightness_ratio(out.passes["scattering"], ref.passes["scattering"]) - 1) <= 0.02
    # the shadowed frame is not that reference: the comparison can fail
    assert brightness_ratio(shadowed.passes["scattering"], ref.passes["scattering"]) < 0.93


def test_footprint_side_follows_the_light_distance(renderer, sparse_scene):
    with renderer.gl.ctx:
        medium_gpu, _ = renderer._medium(sparse_scene, RenderSettings())
        light = sparse_scene.lights[0]
        near = LightFrame.of(light)
        far_m = np.array(light.matrix_world)
        far_m[:3, 3] = far_m[:3, 3] + 3.0 * (far_m[:3, 3] - np.array([0.0, 0.0, 1.2]))
        far = LightFrame.of(dataclasses.replace(light, matrix_world=far_m))
        n_near = footprint_resolution(near, medium_gpu, 4096)
        n_far = footprint_resolution(far, medium_gpu, 4096)
        settings = RenderSettings(tfm_resolution="FOOTPRINT", map_resolution=512)
        capped = tfm_resolution(settings, far, medium_gpu, 512, image_side=80)
    assert 64 <= n_near < n_far <= 4096      # farther light: smaller texels needed, more of them
    assert capped == min(n_far, 80)
