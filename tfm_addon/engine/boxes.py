"""Axis-aligned boxes in numpy: where lines cross a box, and the tightest box of a grid's
non-zero voxels. Shared by the renderer (passes/bindings.py), the AUTO rule (quality.py) and the
numpy reference (reference.py); nothing here touches GL."""

from __future__ import annotations

import numpy as np


def slab(o: np.ndarray, d: np.ndarray, lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """Parameter interval [t_in, t_out] of the lines o + t d (..., 3) inside the box
    lo <= x <= hi (empty where t_in >= t_out); a line parallel to an axis is inside that axis's
    slab for every t where its origin is, else for none."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        ta = (lo - o) * inv
        tb = (hi - o) * inv
    t_near = np.minimum(ta, tb)
    t_far = np.maximum(ta, tb)
    parallel = d == 0
    inside = (o >= lo) & (o <= hi)
    t_near = np.where(parallel, np.where(inside, -np.inf, np.inf), t_near)
    t_far = np.where(parallel, np.where(inside, np.inf, -np.inf), t_far)
    return t_near.max(axis=-1), t_far.min(axis=-1)


def nonzero_bounds(grid: np.ndarray) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(lo, hi) in index space of the tightest box outside which the trilinear values of the
    (nx, ny, nz) ``grid`` are 0: one voxel beyond the first and last non-zero voxel centres on
    each axis (lo = hi where none is). ``grid``: the values, or a boolean mask of the non-zero
    ones. Each axis's occupancy comes from one projection of the mask (two reductions over the
    grid, not three)."""
    mask = grid if grid.dtype == bool else grid > 0
    yz = mask.any(axis=0)
    occupied = (mask.any(axis=(1, 2)), yz.any(axis=1), yz.any(axis=0))
    lo, hi = [], []
    for axis in range(3):
        nz = np.flatnonzero(occupied[axis])
        first, last = (int(nz[0]), int(nz[-1])) if nz.size else (1, -1)     # empty: lo = hi
        lo.append(float(first - 1))
        hi.append(float(last + 1))
    return tuple(lo), tuple(hi)
