"""A big, mostly empty density grid held as bricks: only its non-empty 8³ cells, each with the
voxels that trilinear reads inside it need.

The lattice is the padded one the dense texture holds (a zero voxel around the grid, padded
voxel p = index + 1). Cell c covers padded positions [8 c, 8 c + 8) on each axis; trilinear
there reads padded voxels 8 c .. 8 c + 8, so a brick stores those 9³ voxels (the cell's 8³ and
an apron of one voxel on its upper side, which is the next cell's first voxel). A cell whose 9³
voxels are all 0 has no brick: its density is 0 everywhere, and it is exactly an empty cell of
the dense path's occupancy grid (passes/bindings.occupancy, 8³ cells), so that the same
structure skips empty space. The GPU holds the bricks in an atlas 3D texture of 9³ slots and an
index texture of the slot of each cell (passes/bindings.MediumGPU, shaders/common.glsl
``sparse_density``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .medium_grid import clean_density

CELL = 8                 # voxels a side of a cell (= bindings.OCCUPANCY_BLOCK)
SLOT = CELL + 1          # voxels a side of a brick: the cell and its upper apron


@dataclass(frozen=True, eq=False)
class SparseGrid:
    """A density grid of ``shape`` (nx, ny, nz) voxels as bricks: ``cells`` (n, 3) int32, the
    padded lattice's cell of each brick; ``bricks`` (n, 9, 9, 9) float32 in x, y, z order, the
    padded voxels 8 c .. 8 c + 8 of its cell; ``index_to_medium``: this grid's index (voxel
    centres at integers) to the index space of the medium's ``density`` (identity when that is
    the same grid; a coarser copy's otherwise)."""

    shape: tuple[int, int, int]
    cells: np.ndarray
    bricks: np.ndarray
    index_to_medium: np.ndarray = field(default_factory=lambda: np.eye(4))

    @property
    def cell_shape(self) -> tuple[int, int, int]:
        """Cells a side of the padded lattice (x, y, z)."""
        return cell_shape(self.shape)

    @property
    def voxels_per_index(self) -> float:
        """This grid's voxels per unit of the medium's index space (the coarse copy's factor)."""
        return float(1.0 / np.linalg.norm(np.asarray(self.index_to_medium)[:3, 0]))


def grid_bytes(medium) -> int:
    """The bytes a medium's density counts against the grid budget (float32 voxels, as
    medium_grid.prepare_grid counts them): its bricks' where it has them."""
    if medium.sparse is not None:
        return len(medium.sparse.bricks) * SLOT ** 3 * 4
    return medium.density.size * 4


def cell_shape(shape) -> tuple[int, int, int]:
    """Cells a side of a grid of ``shape`` voxels on its padded lattice (= the occupancy grid's)."""
    return tuple(-(-(int(n) + 2) // CELL) for n in shape)


def slab_shape(shape) -> tuple[int, int, int]:
    """The padded voxels one slab of ``BrickCollector.add`` holds: a row of cells along x."""
    cs = cell_shape(shape)
    return (SLOT, CELL * cs[1] + 1, CELL * cs[2] + 1)


class BrickCollector:
    """Bricks gathered a row of cells at a time (a slab of 9 padded x planes), so that the grid
    is never held dense: memory grows with the non-empty bricks only. Also gathers the means of
    each cell's 8³ voxels, the coarse copy (1/8 resolution) of the grid for whoever reads the
    medium's ``density`` (statistics, bounds)."""

    def __init__(self, shape, expected: int = 0):
        """``expected``: bricks to make room for at first (it grows as needed)."""
        self.shape = tuple(int(n) for n in shape)
        self.cs = cell_shape(self.shape)
        self.coarse = np.zeros(self.cs, np.float32)
        self._store = np.empty((int(expected), SLOT, SLOT, SLOT), np.float32)
        self._cell_store = np.empty((int(expected), 3), np.int32)
        self._count = 0

    @property
    def count(self) -> int:
        """Bricks gathered so far."""
        return self._count

    def add(self, cx: int, slab: np.ndarray, cy0: int = 0) -> None:
        """``slab``: (9, 8 m + 1, 8 cz + 1) padded voxels from (8 cx, 8 cy0, 0): the cells cy0 ..
        cy0 + m - 1 of a row (all of them: ``slab_shape``)."""
        slab = np.ascontiguousarray(slab, dtype=np.float32)
        cy, cz = (slab.shape[1] - 1) // CELL, self.cs[2]
        plane = slab[0] != 0                        # (8 cy + 1, 8 cz + 1): any of the 9 planes
        for k in range(1, SLOT):                    # (NaN counts: the renderer cleans it, said once)
            np.logical_or(plane, slab[k] != 0, out=plane)
        rows = plane[:-1].reshape(cy, CELL, -1).any(axis=1) | plane[CELL::CELL]     # (cy, 8 cz + 1)
        present = rows[:, :-1].reshape(cy, cz, CELL).any(axis=2) | rows[:, CELL::CELL]
        js, ks = np.nonzero(present)
        if js.size == 0:
            return
        sx, sy, sz = slab.strides
        windows = np.lib.stride_tricks.as_strided(
            slab, shape=(cy, cz, SLOT, SLOT, SLOT), strides=(CELL * sy, CELL * sz, sx, sy, sz))
        n0, n1 = self._count, self._count + len(js)
        if n1 > len(self._store):                   # grown by half: no list of pieces to join
            grown = np.empty((max(n1, len(self._store) * 3 // 2 + 64), SLOT, SLOT, SLOT), np.float32)
            grown[:n0] = self._store[:n0]
            self._store = grown
            self._cell_store = np.resize(self._cell_store, (len(grown), 3))
        bricks = self._store[n0:n1]
        bricks[...] = windows[js, ks]               # only the non-empty bricks
        self.coarse[cx, cy0 + js, ks] = bricks[:, :CELL, :CELL, :CELL].mean(axis=(1, 2, 3), dtype=np.float64)
        self._cell_store[n0:n1] = np.stack([np.full_like(js, cx), cy0 + js, ks], axis=1)
        self._count = n1

    def finish(self) -> tuple[SparseGrid, np.ndarray, np.ndarray]:
        """The grid's bricks, its coarse copy (cx, cy, cz) float32 and the coarse copy's index to
        this grid's index (a cell's centre: index 8 c + 2.5); the SparseGrid's
        ``index_to_medium`` maps into the coarse copy's index space."""
        n = self._count
        bricks = self._store[:n]
        if n < len(self._store) * 3 // 4:          # much room left unused: not kept
            bricks = bricks.copy()
        cells = self._cell_store[:n].copy()
        coarse_to_fine = np.diag([float(CELL)] * 3 + [1.0])
        coarse_to_fine[:3, 3] = CELL / 2 - 1.5
        grid = SparseGrid(self.shape, cells, bricks, np.linalg.inv(coarse_to_fine))
        return grid, self.coarse, coarse_to_fine


def from_dense(density: np.ndarray) -> SparseGrid:
    """The bricks of a dense (nx, ny, nz) grid, ``index_to_medium`` the identity (tests, and a
    dense grid too big for the memory budget)."""
    d = np.asarray(density, np.float32)
    collector = BrickCollector(d.shape)
    for cx, slab in enumerate(dense_slabs(d)):
        collector.add(cx, slab)
    grid = collector.finish()[0]
    return SparseGrid(grid.shape, grid.cells, grid.bricks)


def dense_slabs(d: np.ndarray):
    """The slabs of ``BrickCollector.add`` cut from a dense grid."""
    shape = slab_shape(d.shape)
    for cx in range(cell_shape(d.shape)[0]):
        slab = np.zeros(shape, np.float32)
        x0 = CELL * cx - 1                          # the slab's first padded plane, as an index
        a, b = max(x0, 0), min(x0 + SLOT, d.shape[0])
        if b > a:
            slab[a - x0:b - x0, 1:1 + d.shape[1], 1:1 + d.shape[2]] = d[a:b]
        yield slab


@dataclass(frozen=True, eq=False)
class PreparedSparse:
    """A sparse grid ready to upload: the bricks cleaned as ``medium_grid.clean_density`` cleans a
    dense grid (the bricks left all 0 dropped), its ``max_value`` and non-zero ``bounds`` (lo, hi)
    in its index space, as ``boxes.nonzero_bounds`` gives them for the dense grid."""

    grid: SparseGrid
    max_value: float
    bounds: tuple
    warnings: list[str] = field(default_factory=list)

    @property
    def is_empty(self) -> bool:
        return len(self.grid.bricks) == 0 or self.max_value <= 0.0

    @property
    def atlas_bytes(self) -> int:
        return len(self.grid.bricks) * SLOT ** 3 * 2


def prepare_sparse(grid: SparseGrid, clipping: float = 0.0) -> PreparedSparse:
    """Clean the bricks (NaN, infinite, negative values and values below ``clipping`` set to 0;
    the warnings count each voxel once, in its own cell) and find the bounds."""
    bricks, warnings = clean_density(grid.bricks, clipping)
    cells = grid.cells
    if bricks is not grid.bricks:                   # values were cleaned: some bricks may be empty now
        if warnings:
            _, warnings = clean_density(grid.bricks[:, :CELL, :CELL, :CELL], clipping)
        keep = bricks.reshape(len(bricks), -1).max(axis=1, initial=0.0) > 0
        bricks, cells = bricks[keep], cells[keep]
    cleaned = SparseGrid(grid.shape, cells, bricks, grid.index_to_medium)
    max_value = float(bricks.max()) if len(bricks) else 0.0
    return PreparedSparse(cleaned, max_value, brick_bounds(cells, bricks), warnings)


def brick_bounds(cells: np.ndarray, bricks: np.ndarray) -> tuple[tuple, tuple]:
    """``boxes.nonzero_bounds`` of the grid the bricks hold: one voxel beyond the first and last
    non-zero voxel centres on each axis (index space; lo = hi where none is). A cell's own voxels
    lie below the next cell's, so each end is found in the outermost layer of cells holding a
    non-zero voxel of their own (not only in their apron)."""
    lo, hi = [], []
    for axis in range(3):
        others = tuple(a for a in (1, 2, 3) if a != axis + 1)
        ends = []
        for layers in (np.unique(cells[:, axis]), np.unique(cells[:, axis])[::-1]):
            for layer in layers:
                pick = np.flatnonzero(cells[:, axis] == layer)
                along = (bricks[pick, :CELL, :CELL, :CELL] > 0).any(axis=others)      # (n, 8)
                if along.any():
                    where = np.flatnonzero(along.any(axis=0))
                    ends.append(CELL * int(layer) - 1 + int(where[0] if not ends else where[-1]))
                    break
        if len(ends) < 2:
            return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        lo.append(float(ends[0] - 1))
        hi.append(float(ends[1] + 1))
    return tuple(lo), tuple(hi)


def atlas_layout(count: int, max_side: int) -> tuple[int, int, int]:
    """Slots along x, y, z of an atlas for ``count`` bricks, at most ``max_side`` voxels a side."""
    per_axis = max(1, min(max_side // SLOT, 255))      # the index texture holds 8-bit slots
    ax = min(per_axis, max(1, math.ceil(count ** (1.0 / 3.0))))
    ay = min(per_axis, max(1, math.ceil(math.sqrt(count / ax))))
    az = max(1, math.ceil(count / (ax * ay)))
    if az > per_axis:
        raise ValueError(f"{count} bricks do not fit a {max_side}³ atlas")
    return ax, ay, az


def pack_atlas(bricks: np.ndarray, layout, to_stored) -> np.ndarray:
    """The atlas texture's voxels (z, y, x order, x fastest): brick k in slot (k mod ax,
    k // ax mod ay, k // (ax ay)); ``to_stored`` turns float32 values into the stored type
    (bindings.stored_values), a chunk of bricks at a time."""
    ax, ay, az = layout
    probe = to_stored(np.zeros(1, np.float32))
    atlas = np.zeros((az, SLOT, ay, SLOT, ax, SLOT), probe.dtype)
    view = atlas.transpose(4, 2, 0, 5, 3, 1)          # (sx, sy, sz, x, y, z)
    k = np.arange(len(bricks))
    sx, sy, sz = k % ax, (k // ax) % ay, k // (ax * ay)
    chunk = 8192
    for a in range(0, len(bricks), chunk):
        b = min(a + chunk, len(bricks))
        view[sx[a:b], sy[a:b], sz[a:b]] = to_stored(bricks[a:b])
    return atlas.reshape(az * SLOT, ay * SLOT, ax * SLOT)


def index_cells(cells: np.ndarray, shape, layout) -> np.ndarray:
    """The index texture's texels (z, y, x order, RGBA8UI): each cell's slot (x, y, z) and 1 in
    alpha where it has a brick, else 0."""
    cs = cell_shape(shape)
    ax, ay, _ = layout
    out = np.zeros((cs[2], cs[1], cs[0], 4), np.uint8)
    k = np.arange(len(cells))
    out[cells[:, 2], cells[:, 1], cells[:, 0]] = np.stack(
        [k % ax, (k // ax) % ay, k // (ax * ay), np.ones_like(k)], axis=1).astype(np.uint8)
    return out


def dense_factor(grid: SparseGrid, max_bytes: int, max_side: int) -> int:
    """The smallest f of 1, 2, 4, 8 whose ``dense_means`` fits ``max_bytes`` of float32 and
    ``max_side`` voxels a side (padding included); 8 when none does."""
    sides = np.asarray(grid.cell_shape, np.float64) * CELL
    for f in (1, 2, 4):
        if np.prod(sides / f) * 4 <= max_bytes and sides.max() / f + 2 <= max_side:
            return f
    return CELL


def dense_means(grid: SparseGrid, f: int) -> tuple[np.ndarray, np.ndarray]:
    """The grid dense at 1/``f`` of its resolution (f divides 8): the means of f³ blocks of the
    padded lattice (block i covers padded voxels f i .. f i + f - 1), from the bricks, never from
    a full-resolution copy; with the blocks' index to this grid's index (a block's centre)."""
    k = CELL // f
    cs = grid.cell_shape
    out = np.zeros(tuple(c * k for c in cs), np.float32)
    view = out.reshape(cs[0], k, cs[1], k, cs[2], k).transpose(0, 2, 4, 1, 3, 5)     # (cx, cy, cz, k, k, k)
    cells = grid.cells
    for a in range(0, len(cells), 8192):
        b = grid.bricks[a:a + 8192, :CELL, :CELL, :CELL]
        means = b.reshape(len(b), k, f, k, f, k, f).mean(axis=(2, 4, 6), dtype=np.float64)
        view[cells[a:a + 8192, 0], cells[a:a + 8192, 1], cells[a:a + 8192, 2]] = means
    to_fine = np.diag([float(f)] * 3 + [1.0])
    to_fine[:3, 3] = (f - 1) / 2 - 1.0
    return out, to_fine


def dense_from_bricks(grid: SparseGrid) -> np.ndarray:
    """The dense (nx, ny, nz) grid the bricks stand for (tests; small grids only)."""
    cs = grid.cell_shape
    padded = np.zeros(tuple(CELL * c + 1 for c in cs), np.float32)
    for (cx, cy, cz), brick in zip(grid.cells, grid.bricks, strict=True):
        padded[CELL * cx:CELL * cx + SLOT, CELL * cy:CELL * cy + SLOT, CELL * cz:CELL * cz + SLOT] = brick
    nx, ny, nz = grid.shape
    return padded[1:1 + nx, 1:1 + ny, 1:1 + nz].copy()
