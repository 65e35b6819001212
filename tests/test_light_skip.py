"""The TFM build's cheaper light marches, checked by what they must not change: the search for
the first and last samples with density jumps over empty occupancy cells and gives the map of the
search that fetches every step, at the grid's level 0 and level 1 (whose occupancy,
bindings.occupancy_level1, is checked against the level's trilinear density itself); the build
over the map's rectangle (passes/tfm.map_rect) gives the map built over every texel; a frame on a
grid with holes keeps the numpy reference."""

import dataclasses

import numpy as np
import pytest
from references import render_reference
from scipy import ndimage

from tfm_addon.engine import Medium, RenderSettings
from tfm_addon.engine.light import LightFrame, light_faces
from tfm_addon.engine.metrics import brightness_ratio, ssim
from tfm_addon.engine.passes import bindings
from tfm_addon.engine.passes import tfm as tfm_pass
from tfm_addon.engine.passes.bindings import OCCUPANCY_BLOCK, MediaGPU, occupancy, occupancy_level1
from tfm_addon.scenes import grid_to_world, smoke_scene


def _two_blobs(n: int = 64, radius: float = 0.15, gap: float = 0.7) -> np.ndarray:
    """Two round puffs (0 beyond ``radius`` of the side) on the spot's ray through the grid's
    centre, ``gap`` of the side apart: empty occupancy cells between them along the light's rays."""
    base = smoke_scene(width=64, height=40, n=n, with_bar=False)
    light = np.asarray(base.lights[0].matrix_world)[:3, 3]
    center = np.array([0.0, 0.0, 1.2])
    to_index = np.linalg.inv(grid_to_world((n, n, n), 2.0, tuple(center)))
    d = (center - light) / np.linalg.norm(center - light)
    idx = np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), -1).astype(np.float64)
    out = np.zeros((n, n, n), np.float32)
    for sign, weight in ((-1, 1.0), (1, 0.6)):
        c = to_index[:3, :3] @ (center + sign * gap * d) + to_index[:3, 3]
        r = np.linalg.norm(idx - c, axis=-1) / (radius * n)
        out += (weight * np.clip(1 - r * r, 0, None) ** 2).astype(np.float32)
    return out


def _scene(density: np.ndarray):
    base = smoke_scene(width=64, height=40, n=density.shape[0], with_bar=False)
    medium = Medium(sigma_a=(0.2, 0.2, 0.2), sigma_s=(3.0, 3.0, 3.0), density=density,
                    index_to_world=grid_to_world(density.shape, 2.0, (0, 0, 1.2)))
    return dataclasses.replace(base, media=(medium,))


@pytest.fixture(scope="module")
def blobs():
    return _scene(_two_blobs())


@pytest.fixture(scope="module")
def smoke():
    return smoke_scene(width=64, height=40, n=64, with_bar=False)     # no holes along its rays


def test_level1_occupancy_marks_every_cell_where_the_level_1_is_not_zero():
    """The level 1 as the GL makes it for an even side (means of 2x2x2), read trilinearly with the
    texture's edge clamp: where occupancy_level1 leaves a cell empty it is 0; the level 0's
    occupancy alone would skip non-zero level-1 density."""
    rng = np.random.default_rng(5)
    d = np.pad(_two_blobs(46, radius=0.12, gap=0.6), 1)          # padded, x, y, z: 48^3
    level1 = d.reshape(24, 2, 24, 2, 24, 2).mean(axis=(1, 3, 5))
    p = rng.uniform(0.0, d.shape[0], size=(300_000, 3))          # padded index space (voxel centres)
    value = ndimage.map_coordinates(level1, ((p + 0.5) / 2 - 0.5).T, order=1, mode="nearest")
    zyx = np.ascontiguousarray(d.transpose(2, 1, 0))
    cell = np.floor(p / OCCUPANCY_BLOCK).astype(int)
    marked1 = occupancy_level1(occupancy(zyx))[cell[:, 2], cell[:, 1], cell[:, 0]] > 0
    marked0 = occupancy(zyx)[cell[:, 2], cell[:, 1], cell[:, 0]] > 0
    assert (value[~marked1] == 0).all()
    assert (value[~marked0] > 0).sum() > 100          # what the dilation is for
    assert marked1.mean() < 0.8                       # and it leaves cells to skip (6^3 cells here)


def _build(renderer, scene, res, steps, n, *, occupancy_fill=None, monkeypatch=None):
    """The face's TFM (K range, c0.. c(n-1) per texel, (res, res, 4 * textures)) and its
    largest density integral; ``occupancy_fill`` 255 / 0 swaps the light marches' occupancy for
    one that marks every / no cell (every step fetched / every cell skipped)."""
    with renderer.gl.ctx:
        medium, _ = renderer._medium(scene, RenderSettings())
        frame = LightFrame.of(scene.lights[0])
        medium.ensure_level1(frame, steps, res)
        grid = medium.slots[0].grid
        fake = None
        if occupancy_fill is not None:
            size = grid.light_occupancy.size
            fill = bytes([occupancy_fill]) * int(np.prod(size))
            fake = renderer.gl.ctx.texture3d(size, 1, fill, dtype="f1")
            fake.filter = (renderer.gl.ctx.NEAREST, renderer.gl.ctx.NEAREST)
            monkeypatch.setattr(MediaGPU, "bind_light_occupancy",
                                lambda self, level1: fake.use(bindings.UNIT["u_occupancy"]))
        try:
            m = tfm_pass.TransmittanceMap(renderer.gl, frame, medium, None, res, steps, n, 0.5)
            maps = np.concatenate([np.frombuffer(t.read(), np.float32).reshape(res, res, 4)
                                   for t in [m.krange, *m.coef]], axis=2)
            m.release()
            alpha = tfm_pass.largest_density_integral(renderer.gl, frame, medium, res, steps)
        finally:
            if fake is not None:
                monkeypatch.undo()
                fake.release()
        return maps, alpha, grid.has_level1


@pytest.mark.parametrize("lod", [0, 1])
def test_the_builds_jumps_over_empty_cells_change_no_map(fresh, blobs, smoke, monkeypatch, lod):
    """The build's search for the ray's first and last samples with density jumps over empty
    occupancy cells: every coefficient and K range of the map (and the alpha pass) equals the
    build whose occupancy marks every cell (every step fetched), on a grid with holes along the
    light's rays and on one without, at level 0 (a fine map) and level 1 (a coarse one). The jumps
    do happen (an occupancy that marks no cell changes the maps of rays with density)."""
    res, steps = (128, 64) if lod == 0 else (24, 16)
    for name, scene in (("blobs", blobs), ("smoke", smoke)):
        for n in (2, 6, 8):
            skip, a_skip, level = _build(fresh, scene, res, steps, n)
            every, a_every, _ = _build(fresh, scene, res, steps, n, occupancy_fill=255,
                                       monkeypatch=monkeypatch)
            assert level == (lod == 1), (name, n)
            scale = np.ones(every.shape[-1])       # K range relative to the largest, coefficients (c0 <= 1)
            scale[:2] = float(np.abs(every[..., :2]).max())
            assert float(np.abs(skip[..., :2] - every[..., :2]).max()) == 0.0, (name, n, lod)  # same K ranges
            assert float((np.abs(skip - every) / scale).max()) <= 1e-5, (name, n, lod)
            assert abs(a_skip - a_every) <= 1e-5 * a_every
            if name == "blobs":
                wrong, _, _ = _build(fresh, scene, res, steps, n, occupancy_fill=0, monkeypatch=monkeypatch)
                assert float((np.abs(wrong - every) / scale).max()) > 1e-3, (n, lod)     # the jumps are taken


def test_a_frame_on_a_grid_with_holes_keeps_the_reference(fresh, blobs):
    """The TFM and the brute force on the grid with holes, against the numpy reference (the
    thresholds of test_speed's sparse grid)."""
    steps = dict(view_steps=96, light_steps=96)
    ref = render_reference(blobs, **steps)
    for method in ("TFM", "BRUTE_FORCE"):
        out = fresh.render(blobs, RenderSettings(method=method, map_resolution=128, **steps))
        assert ssim(out.rgb, ref.rgb) >= 0.99, method
        assert abs(brightness_ratio(out.rgb, ref.rgb) - 1) <= 0.02, method


def test_the_map_rectangle_holds_every_texel_whose_ray_meets_the_medium(fresh, blobs, monkeypatch):
    """map_rect, for a spot and a point light's cube faces: the map built over the rectangle alone
    equals the map built over every texel, bit for bit (outside it: F = 1, K range 0), and the
    rectangle is smaller than the map where the medium's box covers part of the face (a face
    with a box corner behind its origin is built whole). The map over every texel is built with
    map_rect answering None (the whole map)."""
    point = dataclasses.replace(blobs.lights[0], kind="POINT")
    areas = []
    with fresh.gl.ctx:
        medium, _ = fresh._medium(blobs, RenderSettings())
        for light in (blobs.lights[0], point):
            for frame in light_faces(light, medium.boxes):
                maps = {}
                for use_rect in (False, True):
                    if not use_rect:
                        monkeypatch.setattr(tfm_pass, "map_rect", lambda *args: None)
                    m = tfm_pass.TransmittanceMap(fresh.gl, frame, medium, None, 96, 48, 6, 0.5)
                    maps[use_rect] = np.concatenate([np.frombuffer(t.read(), np.float32).reshape(96, 96, 4)
                                                     for t in [m.krange, *m.coef]], axis=2)
                    rect = m.rect
                    m.release()
                    monkeypatch.undo()
                assert np.array_equal(maps[True], maps[False])
                met = maps[False][..., 1] > maps[False][..., 0]
                if rect is None:
                    continue
                x0, y0, w, h = rect
                inside = np.zeros_like(met)
                inside[y0:y0 + h, x0:x0 + w] = True
                assert not (met & ~inside).any()
                areas.append((w * h / 96 ** 2, met.any()))
    assert len(areas) >= 2 and all(hit for _, hit in areas), areas    # the spot and a cube face or more
    assert areas[0][0] < 0.6 and min(a for a, _ in areas) < 0.1, areas   # seen: 0.57 (the spot), 0.08
