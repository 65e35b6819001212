"""The speed features, checked by what they must not change: the floor method against a
numpy reference whose light transmittance is forced to 1, empty-space skipping against the
reference on a sparse grid, the occupancy grid and the tight box against the trilinear density
itself (scipy), the footprint TFM side. Timings live in ``python -m tfm_addon.bench.speed``."""

import dataclasses

import numpy as np
import pytest
from references import render_reference
from scipy import ndimage

from tfm_addon.engine import Medium, RenderSettings
from tfm_addon.engine import reference as reference_module
from tfm_addon.engine.boxes import nonzero_bounds
from tfm_addon.engine.light import LightFrame
from tfm_addon.engine.metrics import brightness_ratio, ssim
from tfm_addon.engine.passes.bindings import OCCUPANCY_BLOCK, occupancy
from tfm_addon.engine.passes.tfm import footprint_resolution, tfm_resolution
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
    return dataclasses.replace(base, media=(medium,))


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
    ref = render_reference(sparse_scene, tag="no integral toward the light", **STEPS)
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


def _numpy_light_transmittance(scene, points: np.ndarray, steps: int = 512) -> np.ndarray:
    """exp(-sigma_t * the trilinear density integrated from the spot to each point), midpoints,
    scipy's interpolation of the zero-padded grid (voxel centres at integer indices)."""
    m = scene.media[0]
    light = np.asarray(scene.lights[0].matrix_world, np.float64)[:3, 3]
    to_index = np.linalg.inv(np.asarray(m.index_to_world, np.float64))
    s = (np.arange(steps) + 0.5) / steps
    p = light + s[None, :, None] * (points - light)[:, None, :]
    idx = p @ to_index[:3, :3].T + to_index[:3, 3]
    d = ndimage.map_coordinates(np.pad(np.asarray(m.density, np.float64), 1), (idx + 1.0).reshape(-1, 3).T,
                                order=1, mode="constant").reshape(idx.shape[:2])
    length = np.linalg.norm(points - light, axis=1)
    return np.exp(-np.outer(d.mean(axis=1) * length, m.sigma_t))


def test_every_coefficient_count_reads_its_cosines_from_the_packed_map(fresh):
    """c0, c1 ride beside the K range and the rest four per texture (passes/tfm.coefficient_textures):
    each count from 2 to 16 reconstructs the transmittance the numpy march gives, more closely
    with more cosines, and a map built with 16 read with fewer gives what a map of that count gives."""
    from tfm_addon.engine import Renderer
    from tfm_addon.engine.passes.tfm import coefficient_textures

    assert [coefficient_textures(n) for n in (1, 2, 3, 6, 7, 10, 11, 14, 16)] == [0, 0, 1, 1, 2, 2, 3, 3, 4]
    scene = smoke_scene(width=40, height=24, n=32, sigma_s=(4.0, 4.0, 4.0), sigma_a=(0.4, 0.4, 0.4),
                        with_bar=False)
    rng = np.random.default_rng(1)
    idx = rng.uniform(2, 29, (3000, 3))
    points = (np.c_[idx, np.ones(len(idx))] @ np.asarray(scene.media[0].index_to_world).T)[:, :3]
    want = _numpy_light_transmittance(scene, points)
    base = RenderSettings(map_resolution=128, light_steps=128, density_weight=None)
    wide = Renderer()
    try:
        wide.light_transmittance_at(scene, dataclasses.replace(base, coefficients=16), 0, points)
        built = wide.counters["tfms"]
        errors = {}
        for n in (2, 3, 5, 6, 7, 10, 13, 16):
            settings = dataclasses.replace(base, coefficients=n)
            own = fresh.light_transmittance_at(scene, settings, 0, points)
            fresh.clear_maps()
            read = wide.light_transmittance_at(scene, settings, 0, points)
            assert float(np.abs(read - own).max()) <= 1e-5, n
            errors[n] = float(np.abs(own - want).mean())
        assert wide.counters["tfms"] == built          # every narrower count read the 16-cosine map
    finally:
        wide.release()
    counts = sorted(errors)                            # seen: 5.7e-3 at 2 cosines ... 1.9e-4 at 16
    assert all(errors[b] <= 1.01 * errors[a] for a, b in zip(counts, counts[1:], strict=False)), errors
    assert errors[16] <= 1e-3 and errors[6] <= 0.2 * errors[2] and errors[10] <= 0.6 * errors[5], errors


def test_a_grids_coarser_level_is_made_once_for_the_light_marches_that_read_it(fresh, monkeypatch):
    """The TFM build reads the grid's level 1 (2x2x2 means) where its steps and texels span two
    voxels (common.glsl grid_ray_lod): made by the first such build, not by the upload, nor again
    for a light move; a fine map (texels under two voxels) never asks for it; and the coarse
    build keeps the image against the numpy reference."""
    scene = smoke_scene(width=64, height=40, n=64, with_bar=False)
    ref = render_reference(scene, view_steps=64, light_steps=128)
    fine = RenderSettings(map_resolution=256, coefficients=6, view_steps=64, light_steps=16)
    coarse = dataclasses.replace(fine, map_resolution=24)       # ~2.4 voxels a texel, 7 a step
    img_fine = fresh.render(scene, fine).rgb
    assert fresh.counters["grid_uploads"] == 1 and fresh.counters["grid_levels"] == 0
    img = fresh.render(scene, coarse).rgb
    assert fresh.counters["grid_levels"] == 1
    m = np.array(scene.lights[0].matrix_world)
    m[0, 3] += 0.01
    fresh.render(dataclasses.replace(scene, lights=(dataclasses.replace(scene.lights[0], matrix_world=m),)),
                 coarse)
    assert fresh.counters["tfms"] == 3 and fresh.counters["grid_levels"] == 1
    assert ssim(img, ref.rgb) >= 0.995 and abs(brightness_ratio(img, ref.rgb) - 1.0) <= 0.01
    assert ssim(img_fine, ref.rgb) >= 0.995
    # Without the level the same build reads level 0: another image (the level is read), as close.
    from tfm_addon.engine import Renderer
    from tfm_addon.engine.passes.bindings import MediumGPU

    monkeypatch.setattr(MediumGPU, "ensure_level1", lambda self: False)
    other = Renderer()
    try:
        level0 = other.render(scene, coarse).rgb
    finally:
        other.release()
    assert float(np.abs(level0 - img).max()) > 1e-4 * float(img.max())
    assert abs(ssim(level0, ref.rgb) - ssim(img, ref.rgb)) <= 0.002
