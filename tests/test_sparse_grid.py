"""A sparse grid (engine/sparse_grid.py: only its non-empty 8³ cells, as 9³ bricks in an atlas
with an index of their slots) renders what the dense grid renders, and its bricks round-trip:
numpy against the dense array, and the renderer's image against the dense path's."""

import dataclasses

import numpy as np

from tfm_addon import scenes
from tfm_addon.engine import RenderSettings
from tfm_addon.engine import sparse_grid as sg
from tfm_addon.engine.boxes import nonzero_bounds
from tfm_addon.engine.passes import bindings


def _blobs(n: int = 64, count: int = 6, seed: int = 2) -> np.ndarray:
    """Scattered round blobs (a smooth falloff to 0 at their rim), the rest 0."""
    rng = np.random.default_rng(seed)
    x, y, z = np.meshgrid(*(np.arange(n, dtype=np.float32),) * 3, indexing="ij")
    d = np.zeros((n, n, n), np.float32)
    for c in rng.uniform(8, n - 8, size=(count, 3)):
        r = rng.uniform(4, 8)
        r2 = ((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2) / r ** 2
        d = np.maximum(d, np.clip(1 - r2, 0, None) * 6)
    return d


def test_bricks_round_trip_and_hold_the_voxels_across_their_borders():
    rng = np.random.default_rng(1)
    d = np.zeros((37, 20, 45), np.float32)        # sides that are not multiples of 8
    d[rng.integers(0, 37, 40), rng.integers(0, 20, 40), rng.integers(0, 45, 40)] = rng.random(40) + 0.1
    d[7, 7, 7] = d[0, 0, 0] = d[36, 19, 44] = 2.0   # a voxel in a cell's apron, the grid's corners
    grid = sg.from_dense(d)
    assert np.array_equal(sg.dense_from_bricks(grid), d)
    padded = np.pad(d, ((1, 8), (1, 8), (1, 8)))
    cs = grid.cell_shape
    # Every brick holds the padded voxels 8c .. 8c + 8: its upper apron is the next cell's first.
    for (cx, cy, cz), brick in zip(grid.cells, grid.bricks, strict=True):
        assert np.array_equal(brick, padded[8 * cx:8 * cx + 9, 8 * cy:8 * cy + 9, 8 * cz:8 * cz + 9])
    # A cell has a brick exactly where the dense path's occupancy marks it (the same skipping).
    occ = bindings.occupancy(np.ascontiguousarray(np.pad(d, 1).transpose(2, 1, 0)))
    mask = np.zeros(cs[::-1], bool)
    mask[grid.cells[:, 2], grid.cells[:, 1], grid.cells[:, 0]] = True
    assert np.array_equal(mask, occ > 0)
    # Voxel (7, 7, 7) is padded 8: in cell 1's interior and cell 0's apron, so both have bricks.
    assert {(0, 0, 0), (1, 1, 1)} <= {tuple(c) for c in grid.cells}
    assert sg.prepare_sparse(grid).bounds == nonzero_bounds(d)


def test_atlas_and_index_give_each_cell_its_brick():
    d = _blobs(40, count=3)
    grid = sg.from_dense(d)
    layout = sg.atlas_layout(len(grid.bricks), 64)          # a small atlas: several rows of slots
    atlas = sg.pack_atlas(grid.bricks, layout, lambda v: v.astype(np.float32))
    index = sg.index_cells(grid.cells, grid.shape, layout)
    assert atlas.shape == tuple(9 * a for a in layout[::-1])
    padded = np.pad(d, ((1, 8), (1, 8), (1, 8)))
    cs = grid.cell_shape
    found = 0
    for cx in range(cs[0]):
        for cy in range(cs[1]):
            for cz in range(cs[2]):
                sx, sy, sz, present = index[cz, cy, cx]
                block = padded[8 * cx:8 * cx + 9, 8 * cy:8 * cy + 9, 8 * cz:8 * cz + 9]
                if not present:
                    assert not block.any()
                    continue
                found += 1
                brick = atlas[9 * sz:9 * sz + 9, 9 * sy:9 * sy + 9, 9 * sx:9 * sx + 9].transpose(2, 1, 0)
                assert np.array_equal(brick, block)
    assert found == len(grid.bricks) > 8


def test_coarse_copy_is_the_means_of_the_cells():
    d = _blobs(48, count=4)
    collector = sg.BrickCollector(d.shape)
    for cx, slab in enumerate(sg.dense_slabs(d)):
        collector.add(cx, slab)
    grid, coarse, coarse_to_fine = collector.finish()
    padded = np.pad(d, ((1, 8), (1, 8), (1, 8)))[:8 * 7, :8 * 7, :8 * 7]
    assert np.allclose(coarse, padded.reshape(7, 8, 7, 8, 7, 8).mean(axis=(1, 3, 5)), atol=1e-6)
    assert grid.voxels_per_index == 8.0
    # The coarse voxel (1, 2, 3) is the mean of padded voxels 8..15 on x: index 7..14, centre 10.5.
    assert np.allclose(coarse_to_fine @ [1, 2, 3, 1], [10.5, 18.5, 26.5, 1])


def test_sparse_path_renders_the_dense_image(renderer):
    """64³ scattered blobs, a spot light with its TFM and the bar's shadow, rendered from the
    dense texture and from the bricks: the same image within 1e-5 of its peak per pixel (the GL's
    filtering weights differ in the last bits between a 66³ texture and the atlas)."""
    base = scenes.smoke_scene(width=96, height=64, n=16)
    d = _blobs()
    dense = dataclasses.replace(base.media[0], density=d, name="blobs",
                                index_to_world=scenes.grid_to_world(d.shape, 2.0, (0, 0, 1.2)))
    sparse = dataclasses.replace(dense, sparse=sg.from_dense(d))
    settings = RenderSettings(view_steps=96, light_steps=96, map_resolution=128, coefficients=8)
    a = renderer.render(dataclasses.replace(base, media=(dense,)), settings)
    b = renderer.render(dataclasses.replace(base, media=(sparse,)), settings)
    assert not any("sparse" in w for w in b.warnings)
    ia, ib = a.combined[..., :3], b.combined[..., :3]
    peak = float(ia.max())
    diff = np.abs(ia - ib)
    print(f"peak {peak:.4f}, largest difference {diff.max():.2e}, mean {diff.mean():.2e}")
    assert peak > 0.05
    assert float(diff.max()) <= 1e-5 * peak
    # The bricks beside their coarse copy (the medium's density at 1/8, as read from a .vdb): the
    # renderer uploads the bricks and places them through index_to_medium.
    collector = sg.BrickCollector(d.shape)
    for cx, slab in enumerate(sg.dense_slabs(d)):
        collector.add(cx, slab)
    bricks, coarse, coarse_to_fine = collector.finish()
    read = dataclasses.replace(dense, density=coarse, sparse=bricks,
                               index_to_world=dense.index_to_world @ coarse_to_fine)
    e = renderer.render(dataclasses.replace(base, media=(read,)), settings).combined[..., :3]
    assert float(np.abs(ia - e).max()) <= 1e-5 * peak
    # It can fail: the grid moved by one voxel renders another image.
    moved = dataclasses.replace(sparse, sparse=sg.from_dense(np.roll(d, 1, axis=0)))
    c = renderer.render(dataclasses.replace(base, media=(moved,)), settings).combined[..., :3]
    assert float(np.abs(ia - c).max()) > 1e-2 * peak


def test_sparse_grid_with_an_emission_grid_falls_back_with_a_report_line(renderer):
    base = scenes.fire_scene(width=48, height=32, n=16)
    m = base.media[0]
    fire = dataclasses.replace(m, sparse=sg.from_dense(m.density))
    out = renderer.render(dataclasses.replace(base, media=(fire,)), RenderSettings(view_steps=32))
    assert [w for w in out.warnings if "sparse grid" in w and "emission" in w]


def test_bricks_are_cleaned_as_the_dense_grid_is():
    d = np.zeros((20, 20, 20), np.float32)
    d[7, 3, 3] = np.nan             # in cell 1's interior and cell 0's apron: counted once
    d[15, 15, 15] = -2.0            # alone in its cells: their bricks are dropped
    d[3, 3, 3] = 1.0
    prepared = sg.prepare_sparse(sg.from_dense(d))
    assert prepared.warnings == ["The density grid has 1 NaN voxel; rendered as 0.",
                                 "The density grid has 1 negative voxel; rendered as 0."]
    assert np.array_equal(sg.dense_from_bricks(prepared.grid), np.where(d == 1.0, d, 0))
    assert len(prepared.grid.bricks) == 1 and prepared.bounds == nonzero_bounds(np.where(d == 1.0, d, 0))


def test_dense_means_of_the_bricks_are_the_block_means_of_the_padded_grid():
    d = _blobs(40, count=3)
    grid = sg.from_dense(d)
    padded = np.zeros(tuple(8 * c for c in grid.cell_shape), np.float32)
    padded[1:41, 1:41, 1:41] = d
    for f in (2, 4):
        means, to_fine = sg.dense_means(grid, f)
        n = padded.shape[0] // f
        assert np.allclose(means, padded.reshape(n, f, n, f, n, f).mean(axis=(1, 3, 5)), atol=1e-6)
        # block i's centre: index f i - 1 + (f - 1) / 2
        assert np.allclose(to_fine @ [1, 2, 3, 1], [f - 1 + (f - 1) / 2, 2 * f - 1 + (f - 1) / 2,
                                                    3 * f - 1 + (f - 1) / 2, 1])
    assert sg.dense_factor(grid, 48 ** 3 * 4, 2048) == 1 and sg.dense_factor(grid, 48 ** 3 * 4 - 1, 2048) == 2


def test_a_sparse_grid_over_the_budget_renders_dense_at_the_finest_resolution_that_fits(renderer):
    base = scenes.smoke_scene(width=64, height=40, n=16)
    d = _blobs()
    dense = dataclasses.replace(base.media[0], density=d, name="blobs",
                                index_to_world=scenes.grid_to_world(d.shape, 2.0, (0, 0, 1.2)))
    sparse = dataclasses.replace(dense, sparse=sg.from_dense(d))
    grid = sparse.sparse
    budget = 190_000      # under the bricks' 69 x 9³ float32 (201 204 B), above the 36³ half lattice's
    assert 36 ** 3 * 4 < budget < len(grid.bricks) * 9 ** 3 * 4
    settings = RenderSettings(view_steps=64, light_steps=64, map_resolution=128, coefficients=8,
                              max_grid_bytes=budget)
    out = renderer.render(dataclasses.replace(base, media=(sparse,)), settings)
    said = [w for w in out.warnings if "sparse grid 'blobs'" in w]
    assert len(said) == 1 and "dense at 1/2 of its resolution (36x36x36" in said[0], out.warnings
    full = renderer.render(dataclasses.replace(base, media=(dense,)),
                           dataclasses.replace(settings, max_grid_bytes=2 ** 30)).combined[..., :3]
    from tfm_addon.engine.metrics import ssim
    s = ssim(out.combined[..., :3], full)
    print(f"SSIM against the full resolution {s:.4f}")
    assert 0.9 < s < 0.99999        # the same blobs at half their resolution
