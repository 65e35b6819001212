"""AUTO's scene statistics (tfm_addon.engine.quality) made cheaper without changing what they
compute: the grid summary (non-zero bounds and sharpness from one mask, the sharpness from
per-axis neighbour differences over the non-zero box) and the light probe's sample points built in
place. The old code path is kept here, plain numpy, and patched in to compare: the statistics and
the settings AUTO chooses must be equal on several scenes (pure numpy). And a frame of samples
under AUTO takes its automatic alpha from that probe, like a single AUTO render (one GL test)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tfm_addon import scenes
from tfm_addon.engine import RenderSettings, quality
from tfm_addon.engine.boxes import nonzero_bounds, slab
from tfm_addon.engine.medium_grid import clean_density, downsample
from tfm_addon.engine.scene import Light


def _old_sharpness(density: np.ndarray) -> float:
    """The sharpness as computed before: six gathers per sampled non-zero voxel."""
    d = np.asarray(density)
    top = float(d.max()) if d.size else 0.0
    if top <= 0.0 or min(d.shape) < 3:
        return 0.0
    nonzero = np.flatnonzero(d.reshape(-1) > 0)
    if len(nonzero) > quality._SHARPNESS_SAMPLES:
        nonzero = np.random.default_rng(0).choice(nonzero, quality._SHARPNESS_SAMPLES, replace=False)
    idx = np.clip(np.array(np.unravel_index(nonzero, d.shape)).T, 1, np.array(d.shape) - 2)
    centre = d[tuple(idx.T)]
    jump = np.zeros(len(idx), dtype=np.float32)
    for axis in range(3):
        step = np.zeros(3, dtype=np.int64)
        step[axis] = 1
        for sign in (1, -1):
            jump = np.maximum(jump, np.abs(d[tuple((idx + sign * step).T)] - centre))
    return float(np.percentile(jump, 99)) / top


def _old_grid_summary(m):
    density, _ = clean_density(m.density, m.clipping)
    f = max(1, math.ceil(max(density.shape) / quality._COARSE_SIDE))
    coarse = np.pad(downsample(density, f) if f > 1 else density, 1)
    return coarse, f, _old_sharpness(density), nonzero_bounds(density)


def _old_light_part(m, light, grid):
    """The light probe as computed before (the points through a (rays, steps, 3) array)."""
    from scipy import ndimage

    to_local, lo, hi, _ = quality._bounds_of(m)
    if to_local is None:
        return 0.0, 0.0
    o_w, d_w = quality._face_rays(light, m, quality._LIGHT_RAYS)
    o = o_w @ to_local[:3, :3].T + to_local[:3, 3]
    d = d_w @ to_local[:3, :3].T
    t0, t1 = slab(o, d, lo, hi)
    t0 = np.maximum(t0, 0.0)
    hit = t1 > t0
    if not hit.any():
        return 0.0, 0.0
    o_h, d_h, t0, t1 = o[hit], d[hit], t0[hit], t1[hit]
    chord = (t1 - t0) * np.linalg.norm(d_h, axis=1)
    if grid is None:
        return float((t1 - t0).max()), float(chord.max())
    coarse, f = grid[:2]
    steps = int(min(512, max(16, math.ceil(2.0 * chord.max() / f))))
    s = (np.arange(steps) + 0.5) / steps
    t = t0[:, None] + s[None, :] * (t1 - t0)[:, None]
    p = o_h[:, None, :] + t[:, :, None] * d_h[:, None, :]
    c = (p - (f - 1) / 2.0) / f + 1.0
    dens = ndimage.map_coordinates(coarse, c.reshape(-1, 3).T, order=1, mode="constant",
                                   cval=0.0).reshape(p.shape[:2])
    tau = float((dens.sum(axis=1) * (t1 - t0) / steps).max())
    nonzero = dens > 0
    if not nonzero.any():
        return tau, 0.0
    first = np.where(nonzero.any(axis=1), nonzero.argmax(axis=1), steps)
    last = np.where(nonzero.any(axis=1), steps - 1 - nonzero[:, ::-1].argmax(axis=1), -1)
    span = np.clip(last - first + 1, 0, None) / steps * chord
    return tau, float(span.max())


def _with_density(scene, density):
    return dataclasses.replace(scene, media=(dataclasses.replace(scene.media[0], density=density),))


def _scenes():
    smoke = scenes.smoke_scene(64, 36, 48)
    rng = np.random.default_rng(5)
    border = np.asarray(scenes.smoke_density(40), np.float32).copy()
    border[0] = border[-1] = 0.3                     # non-zero voxels on the grid's border faces
    dense = (rng.random((70, 66, 62)) + 0.05).astype(np.float32)      # > 200k non-zero: the sample
    point = Light(kind="POINT", matrix_world=scenes.translate_scale((0.5, -3.0, 2.0), 1.0),
                  power_w=800.0, name="Point")
    sun = Light(kind="SUN", matrix_world=scenes.look_at((2.0, -2.0, 4.0), (0.0, 0.0, 0.0)),
                power_w=3.0, name="Sun")
    return {
        "smoke 48^3": smoke,
        "smoke clipped": dataclasses.replace(
            smoke, media=(dataclasses.replace(smoke.media[0], clipping=0.2),)),
        "paper smoke 80^3 (coarse factor 2)": scenes.paper_smoke_scene(64, 36, 80),
        "dense smoke": scenes.dense_smoke_scene(64, 36, 32, thickness=30.0),
        "demo plume": scenes.demo_scene(64, 36, 40),
        "border voxels, point light": dataclasses.replace(_with_density(smoke, border), lights=(point,)),
        "dense random 70x66x62, sun": dataclasses.replace(_with_density(smoke, dense), lights=(sun,)),
        "block": _with_density(smoke, np.pad(np.ones((20, 30, 10), np.float32), 6)),
        "homogeneous box": scenes.homogeneous_box_scene(64, 36),
    }


@pytest.mark.parametrize("name", list(_scenes()))
def test_auto_statistics_and_settings_equal_the_old_code_path(name, monkeypatch):
    scene = _scenes()[name]
    base = RenderSettings(quality="AUTO", map_resolution=128)
    quality._cache.clear()
    new_stats, new_settings = quality.medium_stats(scene), quality.auto_settings(scene, base)
    new_texels = quality.footprint_texels_per_voxel(scene.media[0])
    if scene.media[0].density is not None:
        density, _ = clean_density(scene.media[0].density, scene.media[0].clipping)
        assert quality.sharpness(density) == _old_sharpness(density)       # the defaults, no mask
    with monkeypatch.context() as patch:
        patch.setattr(quality, "_grid_summary", _old_grid_summary)
        patch.setattr(quality, "_light_part", _old_light_part)
        quality._cache.clear()
        old_stats, old_settings = quality.medium_stats(scene), quality.auto_settings(scene, base)
        old_texels = quality.footprint_texels_per_voxel(scene.media[0])
    quality._cache.clear()
    assert new_stats == old_stats           # exactly: the same floating-point operations
    assert new_settings == old_settings and new_texels == old_texels
    assert new_stats.optical_depth > 0.0 or scene.media[0].density is None


def test_sharpness_reads_the_non_zero_box_like_the_whole_grid():
    """Random smooth grids cut at random levels, some with empty slabs and border voxels: the
    box-cut neighbour differences give the old gathers' value bit for bit."""
    from scipy import ndimage

    for seed in range(12):
        rng = np.random.default_rng(seed)
        shape = tuple(int(n) for n in rng.integers(3, 30, 3))
        d = ndimage.gaussian_filter(rng.random(shape), rng.uniform(0.3, 3.0)).astype(np.float32)
        d = np.where(d > np.quantile(d, rng.uniform(0.2, 0.97)), d, 0.0).astype(np.float32)
        if seed % 3 == 0:
            d[int(rng.integers(0, shape[0]))] = 0.0
        assert quality.sharpness(d) == _old_sharpness(d), seed
        idx = np.argwhere(d > 0)        # one voxel beyond the first and last non-zero ones
        want = (tuple(float(v) for v in idx.min(axis=0) - 1), tuple(float(v) for v in idx.max(axis=0) + 1))
        assert nonzero_bounds(d > 0) == nonzero_bounds(d) == want, seed


def test_a_sampled_auto_frame_takes_alpha_from_the_probe_not_a_gpu_pass():
    """iter_samples renders with the frame's settings, whose quality reads 'CUSTOM': they carry
    ``alpha_from_probe``, so the spot's alpha is the probe's density integral (no alpha pass
    cached), and the frame equals one rendered with that alpha as a fixed density weight."""
    from tfm_addon.engine import Renderer
    from tfm_addon.engine.sampling import frame_settings, render_samples

    scene = scenes.smoke_scene(40, 24, 24)
    auto = RenderSettings(quality="AUTO", map_resolution=64)
    chosen = frame_settings(scene, auto, 4)
    assert chosen.quality == "CUSTOM" and chosen.alpha_from_probe and chosen.density_weight is None
    probed = quality.light_density_integral(scene.media[0], scene.lights[0])
    fixed = dataclasses.replace(chosen, alpha_from_probe=False,
                                density_weight=probed * float(scene.media[0].sigma_t.max()))
    renderer = Renderer()
    try:
        image = render_samples(renderer, scene, auto, 4, passes=False).combined
        assert sum(1 for k in renderer._tfms.items if k[-1] == "alpha") == 0
        want = render_samples(renderer, scene, fixed, 4, passes=False).combined
        gpu = render_samples(renderer, scene, dataclasses.replace(chosen, alpha_from_probe=False), 4,
                             passes=False).combined
        assert sum(1 for k in renderer._tfms.items if k[-1] == "alpha") == 1      # the GPU pass's
    finally:
        renderer.release()
    assert float(np.abs(image - want).max()) <= 1e-5 * float(want.max())
    assert float(np.abs(gpu - want).max()) <= 0.05 * float(want.max())     # nearly the same alpha
