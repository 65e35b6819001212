"""The packed emission density, the TFM build over the map's rectangle with its level-1
occupancy, and the Sobol antialiasing: each test fails without its fix, against a
computation that does not share the code under test (the same march through every occupancy
cell, a map built without the history the bug depends on)."""

import dataclasses

import numpy as np
import pytest

from tfm_addon.engine import Renderer, RenderSettings
from tfm_addon.engine.light import light_faces
from tfm_addon.engine.passes import bindings
from tfm_addon.engine.passes import tfm as tfm_pass
from tfm_addon.engine.passes.bindings import MediaGPU
from tfm_addon.scenes import grid_to_world, smoke_scene


def _sheared_blobs(shear: float = 3.0):
    """Two puffs in a 64^3 grid placed with a shear (a volume parented to a rotated, non-uniformly
    scaled object), lit by a sun whose rays run along the direction in which a metre crosses the
    most voxels (3.3 times what the columns of the placement suggest)."""
    n = 64
    idx = np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), -1).astype(np.float64)
    density = np.zeros((n, n, n), np.float32)
    for c, w in (((20, 24, 32), 1.0), ((44, 40, 30), 0.6)):
        r = np.linalg.norm(idx - np.asarray(c), axis=-1) / 9.0
        density += (w * np.clip(1 - r * r, 0, None) ** 2).astype(np.float32)
    base = smoke_scene(width=64, height=40, n=16, with_bar=False)
    shear_m = np.eye(4)
    shear_m[0, 1] = shear
    to_world = grid_to_world(density.shape, 2.0, (0, 0, 1.2)) @ shear_m
    medium = dataclasses.replace(base.media[0], density=density, index_to_world=to_world)
    _, _, vt = np.linalg.svd(np.linalg.inv(shear_m[:3, :3]))
    d = vt[0] / np.linalg.norm(vt[0])           # world direction of the light's rays
    z = -d
    x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, np.cross(z, x), z, to_world[:3, 3] - 5.0 * d
    sun = dataclasses.replace(base.lights[0], kind="SUN", matrix_world=m)
    return dataclasses.replace(base, media=(medium,), lights=(sun,))


def _map(gl, scene, res: int, steps: int, level_before: bool, every_cell: bool = False) -> np.ndarray:
    """The sun's TFM (K range and coefficients per texel) as the renderer builds it (the level 1
    made when the face may read it), by a new renderer; ``level_before``: another light made the
    grid's level 1 first; ``every_cell``: the light march's occupancy marks every cell."""
    r = Renderer(gl=gl)
    fake = None
    try:
        with gl.ctx:
            medium, _ = r._medium(scene, RenderSettings())
            frame = light_faces(scene.lights[0], medium.boxes)[0]
            grid = medium.slots[0].grid
            if level_before:
                grid.ensure_level1()
            medium.ensure_level1(frame, steps, res)
            original = MediaGPU.bind_light_occupancy
            if every_cell:
                size = grid.light_occupancy.size
                fake = gl.ctx.texture3d(size, 1, bytes([255]) * int(np.prod(size)), dtype="f1")
                fake.filter = (gl.ctx.NEAREST, gl.ctx.NEAREST)
                MediaGPU.bind_light_occupancy = lambda self, level1: fake.use(bindings.UNIT["u_occupancy"])
            try:
                m = tfm_pass.TransmittanceMap(gl, frame, medium, None, res, steps, 6, 0.5)
            finally:
                MediaGPU.bind_light_occupancy = original
            out = np.concatenate([np.frombuffer(t.read(), np.float32).reshape(res, res, 4)
                                  for t in [m.krange, *m.coef]], axis=2)
            m.release()
            return out
    finally:
        if fake is not None:
            fake.release()
        r.clear_maps()


@pytest.mark.parametrize("res", [16, 32])
def test_a_sheared_grid_map_does_not_depend_on_another_lights_level(fresh, res):
    """bindings.MediaGPU.may_read_level1 bounds the voxels a map texel spans by the placement's
    columns; a sheared placement crosses more voxels a metre along other directions (its smallest
    singular value), so the build's rays read level 1 where it said they could not: the level was
    not made (a fresh renderer's map reads level 0) unless another light had made it, and then the
    build skipped by the level 0's occupancy, which misses the level 1's density (seen: K ranges
    0.41-0.47 m short, coefficients 4e-4-2e-3 off). Fixed: the smallest singular value."""
    scene = _sheared_blobs()
    steps = 16
    alone = _map(fresh.gl, scene, res, steps, level_before=False)
    after = _map(fresh.gl, scene, res, steps, level_before=True)
    every = _map(fresh.gl, scene, res, steps, level_before=True, every_cell=True)
    met = every[..., 1] > every[..., 0]
    assert met.mean() > 0.05
    k_scale = float(np.abs(every[..., :2]).max())
    assert float(np.abs(after[..., :2] - every[..., :2]).max()) <= 1e-6 * k_scale      # exact skips
    assert float(np.abs(after[..., 2:] - every[..., 2:]).max()) <= 1e-6
    assert float(np.abs(alone - after).max()) <= 1e-6 * max(k_scale, 1.0)          # no history


def test_the_alpha_probe_does_not_depend_on_another_lights_level(fresh):
    """The alpha pass (passes/tfm.largest_density_integral) marches texels four times wider than
    its map's, so it may read level 1 where the map may not: the level was made only for the
    map's texels, so a fresh renderer's probe read level 0 and, once another light had made the
    level, level 1, and the frame changed with what had been rendered before it (seen: alpha 4-5 %
    apart at map sides 64 and 96, the two-puff grid, 16 light steps). Fixed: the level is made
    for the probe's texels too. The frame of a fresh renderer equals the frame rendered after the
    grid's level 1 was made."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from test_light_skip import _scene, _two_blobs

    scene = _scene(_two_blobs())
    settings = RenderSettings(map_resolution=64, light_steps=16, view_steps=48, coefficients=4)
    outs, alphas = [], []
    for level_before in (False, True):
        r = Renderer(gl=fresh.gl)
        try:
            if level_before:
                with fresh.gl.ctx:
                    medium, _ = r._medium(scene, settings)
                    medium.slots[0].grid.ensure_level1()
            outs.append(r.render(scene, settings).combined[..., :3])
            alphas.append([v.value for k, v in r._tfms.items.items() if k[-1] == "alpha"])
        finally:
            r.clear_maps()
    assert len(alphas[0]) == 1 and alphas[0][0] > 0.0
    assert alphas[0] == alphas[1]
    assert float(np.abs(outs[0] - outs[1]).max()) <= 1e-6 * float(outs[1].max())
