"""A .vdb whose active box holds more voxels than a grid is read into (volumes.MAX_READ_VOXELS) is
read at a lower resolution, slab by slab, as the means of f x f x f voxels on the same world box,
and the render report says so: never a dense copy at full size."""

import importlib
import time

import bpy
import numpy as np
from blender_helpers import MODULE, SETTINGS, render_passes, smoke

from tfm_addon.blender import scene_builder
from tfm_addon.engine import metrics


def test_a_grid_above_the_read_limit_is_read_as_block_means(blank, tmp_path, monkeypatch):
    volumes = importlib.import_module(f"{MODULE}.tfm_addon.blender.volumes")
    caches = importlib.import_module(f"{MODULE}.tfm_addon.engine.caches")
    final_render = importlib.import_module(f"{MODULE}.tfm_addon.blender.final_render")
    made = scene_builder.build(smoke(width=64, height=48, n=40), str(tmp_path), settings=SETTINGS)
    full = render_passes(tmp_path, "full")["Combined"]
    volumes.grid_cache.clear()
    volume = made["medium"].evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    grid, _ = volumes.grid_cache.read(volume, "density", "Smoke", generated=False)
    dense, to_object = np.asarray(grid.density), grid.index_to_object

    monkeypatch.setattr(volumes, "MAX_READ_VOXELS", 20 ** 3)
    monkeypatch.setattr(volumes, "SLAB_BYTES", 4096)            # several slabs a plane
    volumes.grid_cache.clear()
    small, warnings = volumes.grid_cache.read(volume, "density", "Smoke", generated=False)
    f = volumes.read_factor(dense.shape, 20 ** 3)
    assert f == 2 and small.density.shape == tuple(-(-n // 2) for n in dense.shape)
    padded = np.pad(dense, [(0, -n % 2) for n in dense.shape])
    means = padded.reshape(padded.shape[0] // 2, 2, padded.shape[1] // 2, 2, padded.shape[2] // 2, 2).mean(
        axis=(1, 3, 5))
    assert np.allclose(small.density, means, atol=1e-6)
    # Array index i of the halved grid sits at the centre of full-resolution voxels 2i and 2i + 1.
    centre = to_object @ np.array([2 * 3 + 0.5, 2 * 5 + 0.5, 2 * 7 + 0.5, 1.0])
    assert np.allclose(small.index_to_object @ np.array([3, 5, 7, 1.0]), centre)
    shape = "x".join(map(str, dense.shape))
    assert any(f"the grids' active box is {shape} voxels" in w and "read at 1/2 resolution" in w
               for w in warnings), warnings

    caches.REGISTRY.clear()       # the grids read again
    halved = render_passes(tmp_path, "halved")["Combined"]
    said = [m for _, m in final_render.last_messages]
    assert any("read at 1/2 resolution" in m for m in said), said
    ssim = metrics.ssim(halved, full)
    assert 0.95 < ssim < 0.9999, ssim       # the same smoke at half its resolution


def _write_blobs(vdb, path: str) -> str:
    """Three round blobs of smoke in a 50³ box (voxels of 5 cm), the rest inactive."""
    x, y, z = np.meshgrid(*(np.arange(50, dtype=np.float32),) * 3, indexing="ij")
    d = np.zeros((50, 50, 50), np.float32)
    for c in ((10, 12, 30), (38, 20, 9), (25, 40, 40)):
        r2 = ((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2) / 36.0
        d = np.maximum(d, np.clip(1.0 - r2, 0.0, None) * 4.0)
    grid = vdb.FloatGrid()
    grid.name = "density"
    grid.transform = vdb.createLinearTransform(voxelSize=0.05)
    grid.copyFromArray(d, ijk=(3, -7, 11), tolerance=0.0)
    vdb.write(path, grids=[grid])
    return path


def test_the_viewport_reads_a_big_file_in_the_background(blank, tmp_path, monkeypatch):
    """In the viewport a big .vdb (thresholds lowered for the test) is read by a process of its
    own: the first update leaves the volume out and says so, without reading; once read, an
    update takes the sparse grid from the cache."""
    volumes = importlib.import_module(f"{MODULE}.tfm_addon.blender.volumes")
    viewport = importlib.import_module(f"{MODULE}.tfm_addon.blender.viewport")
    Change = importlib.import_module(f"{MODULE}.tfm_addon.blender.changes").Change
    from tfm_addon.blender.openvdb_module import import_openvdb

    made = scene_builder.build(smoke(width=48, height=36), str(tmp_path), settings=SETTINGS)
    made["medium"].data.filepath = _write_blobs(import_openvdb(), str(tmp_path / "blobs.vdb"))
    monkeypatch.setattr(volumes, "BACKGROUND_READ_BYTES", 0)
    monkeypatch.setattr(volumes, "MAX_READ_VOXELS", 60_000)
    volumes.grid_cache.clear()
    session = viewport.ViewportSession()
    session.update(bpy.context.evaluated_depsgraph_get())
    assert not session.extraction.scene(session.extraction.camera).media
    assert any("is being read" in w and "in the background" in w for w in session.warnings), session.warnings
    end = time.monotonic() + 60
    while volumes.grid_cache.reading and time.monotonic() < end:
        time.sleep(0.05)
    made["medium"].data.update_tag()            # the add-on's timer does it once the read is done
    session.update(bpy.context.evaluated_depsgraph_get(), Change.MEDIUM)
    (medium,) = session.extraction.scene(session.extraction.camera).media
    assert medium.sparse is not None and len(medium.sparse.bricks) > 0
    assert not any("being read" in w for w in session.warnings), session.warnings
    session.close()


def test_a_big_mostly_empty_grid_is_read_as_bricks_at_full_resolution(tmp_path, monkeypatch):
    """Above the read limit, a density whose active voxels fill at most SPARSE_MAX_FILL of its box
    is read as bricks (volumes.read_sparse), slab by slab: they hold exactly the full-resolution
    voxels, placed as the dense read places them, beside their 1/8 coarse copy."""
    from tfm_addon.blender import volumes
    from tfm_addon.blender.openvdb_module import import_openvdb
    from tfm_addon.engine import sparse_grid

    vdb = import_openvdb()
    path = _write_blobs(vdb, str(tmp_path / "blobs.vdb"))

    full = volumes.read_grid_set(vdb, path, "density", (), "Blobs", [], "k")
    limit = 60_000       # below the box (about 41³), above the bricks
    monkeypatch.setattr(volumes, "COPY_VOXELS", 4000)       # a row of cells copied in parts
    read = volumes.read_grid_set(vdb, path, "density", (), "Blobs", [], "k", limit, sparse=True)
    bricks = read.sparse
    assert bricks is not None and 0 < len(bricks.bricks) * 9 ** 3 <= limit < full.density.size
    assert np.array_equal(sparse_grid.dense_from_bricks(bricks), full.density)
    # Brick index i sits where the full read's index i does; the coarse copy is 1/8 of it.
    fine = np.array([5.0, 9.0, 13.0, 1.0])
    assert np.allclose(read.index_to_object @ bricks.index_to_medium @ fine, full.index_to_object @ fine)
    assert read.density.shape == sparse_grid.cell_shape(full.density.shape)
    # The viewport's read, in a process of its own, gives the same grids back, after a preview:
    # the voxels at 8 c + 3 of the box, placed where they are.
    previews = []
    other = volumes.read_in_process(path, "density", "Blobs", (), "k", limit, True, previews.append)
    (preview,) = previews
    assert np.array_equal(preview.density, full.density[3::8, 3::8, 3::8])
    assert np.allclose(preview.index_to_object @ [1, 2, 0, 1], full.index_to_object @ [11, 19, 3, 1])
    assert np.array_equal(other.sparse.bricks, bricks.bricks) and np.array_equal(other.density, read.density)
    assert np.array_equal(other.index_to_object, read.index_to_object)
    assert other.first_index == read.first_index
    # Not asked for (another grid read, an emitting material): read dense at 1/2, as before.
    halved = volumes.read_grid_set(vdb, path, "density", (), "Blobs", [], "k", limit)
    assert halved.sparse is None and halved.density.shape == tuple(-(-n // 2) for n in full.density.shape)
