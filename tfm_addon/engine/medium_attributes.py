"""The medium's attribute grids (emission strength, blackbody intensity, temperature, colour)
prepared for the GPU on the density's lattice, cleaned and downsampled as the density was."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .medium_grid import downsample
from .scene import Medium


@dataclass(frozen=True)
class PreparedAttributes:
    """``scalars``: (nx, ny, nz, 4) float32 holding the scalar grids the emission reads, channel
    ``channels[name]``, or None when the emission reads no grid; ``color``: (nx, ny, nz, 3) or
    None. Both finite, on the prepared density's lattice."""

    scalars: np.ndarray | None
    channels: dict[str, int]
    color: np.ndarray | None
    warnings: list[str] = field(default_factory=list)


def scalar_names(medium: Medium) -> tuple[str, ...]:
    """The scalar grids the emission reads, in channel order (at most four)."""
    names: list[str] = []
    if medium.has_emission:
        for value in (medium.emission_strength, medium.blackbody_intensity, medium.temperature):
            if value.grid is not None and value.grid not in names:
                names.append(value.grid)
    return tuple(names[:4])


def _clean(a: np.ndarray, name: str, warnings: list[str]) -> np.ndarray:
    bad = ~np.isfinite(a)
    if bad.any():
        warnings.append(f"Grid '{name}' had {int(bad.sum())} NaN/infinite values; they were set to 0.")
        a = np.where(bad, np.float32(0.0), a)
    return a


def downsample_factor(medium: Medium, prepared_index_to_world: np.ndarray) -> int:
    """The factor by which the density was downsampled (1: not at all)."""
    s = np.linalg.inv(np.asarray(medium.index_to_world, np.float64)) @ np.asarray(prepared_index_to_world)
    return max(1, int(round(float(s[0, 0]))))


def prepare_attributes(medium: Medium, factor: int) -> PreparedAttributes:
    """The grids ``medium`` needs besides the density, downsampled by ``factor`` like it."""
    warnings: list[str] = []
    names = scalar_names(medium)
    scalars = None
    if names:
        channels = []
        for name in names:
            a = _clean(np.asarray(medium.grids[name], np.float32), name, warnings)
            channels.append(downsample(a, factor) if factor > 1 else a)
        shape = channels[0].shape
        scalars = np.zeros((*shape, 4), np.float32)
        for i, a in enumerate(channels):
            scalars[..., i] = a
    color = None
    if medium.color_grid is not None:
        c = _clean(np.asarray(medium.grids[medium.color_grid], np.float32), medium.color_grid, warnings)
        if factor > 1:
            c = np.stack([downsample(np.ascontiguousarray(c[..., k]), factor) for k in range(3)], axis=-1)
        color = np.ascontiguousarray(c)
    return PreparedAttributes(scalars, {n: i for i, n in enumerate(names)}, color, warnings)


def padded_xyz_fastest(a: np.ndarray) -> np.ndarray:
    """An (nx, ny, nz, c) grid with a layer of zeros around it, x varying fastest (OpenGL's order)."""
    padded = np.pad(a, ((1, 1), (1, 1), (1, 1), (0, 0)))
    return np.ascontiguousarray(padded.transpose(2, 1, 0, 3))
