"""Preparing a density grid for the GPU: cleaning bad values, fitting it in the limits."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class PreparedGrid:
    """A density grid ready to upload: ``density`` (nx, ny, nz) float32, finite and >= 0;
    ``index_to_world`` for it (changed when the grid was downsampled); ``max_value``."""

    density: np.ndarray
    index_to_world: np.ndarray
    max_value: float
    warnings: list[str] = field(default_factory=list)

    @property
    def is_empty(self) -> bool:
        return self.density.size == 0 or self.max_value <= 0.0

    def padded_xyz_fastest(self) -> np.ndarray:
        """The grid with a layer of zeros around it, x varying fastest (OpenGL's order)."""
        padded = np.pad(self.density, 1)
        return np.ascontiguousarray(padded.transpose(2, 1, 0))


def clean_density(density: np.ndarray, clipping: float = 0.0) -> tuple[np.ndarray, list[str]]:
    """The grid every consumer reads (upload, AUTO statistics, bounds): float32 with NaN, infinite
    and negative values set to 0, one warning per kind found; and values below ``clipping``
    (Cycles' volume.render.clipping, density units) set to 0 without a warning (Blender's
    documented behaviour: lower densities are empty space)."""
    d = np.asarray(density, dtype=np.float32)
    warnings = []
    finite = np.isfinite(d)
    if finite.all() and (d.size == 0 or float(d.min()) >= 0.0) and clipping <= 0.0:
        return d, warnings
    kinds = (("NaN", np.isnan(d)), ("infinite", np.isinf(d)), ("negative", finite & (d < 0)))
    for name, mask in kinds:
        count = int(np.count_nonzero(mask))
        if count:
            warnings.append(f"The density grid has {count} {name} voxel{'s' if count > 1 else ''}; "
                            "rendered as 0.")
    keep = finite & (d >= max(float(clipping), 0.0)) & (d > 0)
    return np.where(keep, d, np.float32(0.0)), warnings


def prepare_grid(density: np.ndarray, index_to_world: np.ndarray, max_side: int,
                 max_bytes: int, clipping: float = 0.0) -> PreparedGrid:
    """Clean a grid (``clean_density``) and downsample it until it fits ``max_side`` voxels per
    axis (padding included) and ``max_bytes`` of float32; each change adds a warning."""
    d, warnings = clean_density(density, clipping)
    m = np.asarray(index_to_world, dtype=np.float64)
    if d.size:
        side_factor = max(math.ceil(n / (max_side - 2)) for n in d.shape)
        byte_factor = math.ceil((d.size * 4 / max(max_bytes, 1)) ** (1.0 / 3.0))
        f = max(side_factor, byte_factor, 1)
        if f > 1:
            old_shape = d.shape
            d = downsample(d, f)
            s = np.diag([f, f, f, 1.0])
            s[:3, 3] = (f - 1) / 2.0
            m = m @ s
            warnings.append(
                f"The density grid {old_shape[0]}x{old_shape[1]}x{old_shape[2]} exceeds the GPU limit "
                f"({max_side} voxels a side, {max_bytes // 2**20} MiB); it was downsampled by {f} to "
                f"{d.shape[0]}x{d.shape[1]}x{d.shape[2]}.")
    max_value = float(d.max()) if d.size else 0.0
    return PreparedGrid(np.ascontiguousarray(d), m, max_value, warnings)


def downsample(d: np.ndarray, f: int) -> np.ndarray:
    """Mean over f^3 blocks; the last partial block of each axis repeats its edge values."""
    pad = [(0, (-n) % f) for n in d.shape]
    p = np.pad(d, pad, mode="edge")
    nx, ny, nz = (n // f for n in p.shape)
    return p.reshape(nx, f, ny, f, nz, f).mean(axis=(1, 3, 5), dtype=np.float64).astype(np.float32)


def grid_allowances(grids: dict, max_bytes: int) -> tuple[dict, str | None]:
    """Byte allowances of several grids sharing one budget: ``grids`` maps a key to (bytes,
    name). While the total exceeds ``max_bytes`` the largest allowance is cut by 8 (a factor 2
    per axis), so the largest grid is downsampled first. Returns the allowances and a warning
    naming the grids that were cut (None when everything fits)."""
    allowance = {k: int(b) for k, (b, _) in grids.items()}
    cut = []
    total = sum(allowance.values())
    while allowance and total > max_bytes:
        k = max(allowance, key=lambda key: allowance[key])
        if allowance[k] <= 8 * 4:
            break
        allowance[k] //= 8
        if grids[k][1] not in cut:
            cut.append(grids[k][1])
        total = sum(allowance.values())
    if not cut or len(grids) < 2:
        return {k: (max_bytes if len(grids) < 2 else a) for k, a in allowance.items()}, None
    return allowance, (f"The media's grids need {sum(b for b, _ in grids.values()) // 2**20} MiB together, "
                       f"more than the {max_bytes // 2**20} MiB budget: downsampled largest first: "
                       + ", ".join(f"'{n}'" for n in cut) + ".")
