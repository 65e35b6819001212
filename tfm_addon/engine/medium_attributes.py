"""The medium's attribute grids prepared for the GPU on the density's lattice, cleaned and
downsampled as the density was: the emission-strength grid as read, and the blackbody term
evaluated per voxel (engine/blackbody.py says why), plus the colour grid."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import blackbody
from .medium_grid import downsample
from .scene import GridValue, Medium

STRENGTH, BLACKBODY = 0, 1   # channels of the scalar texture: strength grid, blackbody RGB (1-3)


@dataclass(frozen=True)
class PreparedAttributes:
    """``scalars``: (nx, ny, nz, 4) float32, channel 0 the emission-strength grid, 1-3 the
    blackbody radiance before its tint (W/(sr m^2) per metre), or None when the emission reads no
    grid; ``strength_grid``/``blackbody_grid``: which of those it holds; ``color``: (nx, ny, nz, 3)
    or None. Everything finite, on the prepared density's lattice. ``intensity_grid``: the blackbody
    intensity and temperature both read grids (and no strength grid): channel 0 holds max(b, 0), 1-3
    the term at intensity 1, to be multiplied after blending (``prepare_attributes`` says why)."""

    scalars: np.ndarray | None
    strength_grid: bool
    blackbody_grid: bool
    color: np.ndarray | None
    warnings: list[str] = field(default_factory=list)
    emission_box: tuple[tuple[float, ...], tuple[float, ...]] | None = None  # where grids emit, index space
    intensity_grid: bool = False



def uses_blackbody_grid(medium: Medium) -> bool:
    return medium.has_emission and _reads_blackbody_grid(medium)


def _reads_blackbody_grid(medium: Medium) -> bool:
    if medium.emission_grid is not None:     # per-voxel emission takes the blackbody term's place
        return True
    return (medium.blackbody_intensity.grid is not None or medium.temperature.grid is not None) and not (
        medium.blackbody_intensity.grid is None and medium.blackbody_intensity.offset <= 0.0)


def uses_strength_grid(medium: Medium) -> bool:
    return medium.has_emission and medium.emission_strength.grid is not None


def key(medium: Medium, emitting: bool = False) -> tuple:
    """What the prepared textures depend on besides the grids' content and lattice; ``emitting``:
    the key of those the medium has while it emits, whether it emits now or not (a colour, strength
    or tint at 0 keeps them: Renderer._medium_attributes)."""
    on = emitting or medium.has_emission
    bb = ((medium.blackbody_intensity, medium.temperature, medium.emission_grid)
          if on and _reads_blackbody_grid(medium) else None)
    strength = medium.emission_strength.grid if on else None
    return (strength, bb, medium.color_grid)


def _clean(a: np.ndarray, name: str, warnings: list[str]) -> np.ndarray:
    bad = ~np.isfinite(a)
    if bad.any():
        warnings.append(f"Grid '{name}' had {int(bad.sum())} NaN/infinite values; they were set to 0.")
        a = np.where(bad, np.float32(0.0), a)
    return a


def _value(medium: Medium, v: GridValue, warnings: list[str]) -> np.ndarray | float:
    if v.grid is None:
        return float(v.offset)
    g = _clean(np.asarray(medium.grids[v.grid], np.float32), v.grid, warnings)
    return v.scale * np.maximum(g.astype(np.float64), 0.0) + v.offset


def downsample_factor(medium: Medium, prepared_index_to_world: np.ndarray) -> int:
    """The factor by which the density was downsampled (1: not at all)."""
    s = np.linalg.inv(np.asarray(medium.index_to_world, np.float64)) @ np.asarray(prepared_index_to_world)
    return max(1, int(round(float(s[0, 0]))))


def _down(a: np.ndarray, factor: int) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=np.float32)
    return downsample(a, factor) if factor > 1 else a


def prepare_attributes(medium: Medium, factor: int) -> PreparedAttributes:
    """The grids ``medium`` needs besides the density, downsampled by ``factor`` like it."""
    warnings: list[str] = []
    strength, bb = uses_strength_grid(medium), uses_blackbody_grid(medium)
    intensity = (bb and medium.emission_grid is None and medium.blackbody_intensity.grid is not None
                 and medium.temperature.grid is not None)
    scalars = None
    if strength or bb:
        shape = medium.density.shape
        channels = [np.zeros(shape, np.float32) for _ in range(4)]
        if strength:
            name = medium.emission_strength.grid
            channels[STRENGTH] = _clean(np.asarray(medium.grids[name], np.float32), name, warnings)
        if bb and medium.emission_grid is not None:
            rgb = _clean(np.asarray(medium.grids[medium.emission_grid], np.float32), medium.emission_grid,
                         warnings)
            for k in range(3):
                channels[BLACKBODY + k] = rgb[..., k]
        elif bb:
            t = _value(medium, medium.temperature, warnings)
            b = _value(medium, medium.blackbody_intensity, warnings)
            t, b = np.broadcast_arrays(np.asarray(t, np.float64), np.asarray(b, np.float64))
            if t.shape != shape:
                t, b = np.broadcast_to(t, shape), np.broadcast_to(b, shape)
            if intensity and not strength:
                # Cycles draws a voxel for each attribute on its own: the term, (1 - b) K(T) + b K(T) T^4
                # where b > 0, converges to the blend of max(b, 0) times that of the term at b = 1 (the
                # blend of the other part, at most 1/T^4 of it, is left out).
                channels[STRENGTH] = np.maximum(b, 0.0).astype(np.float32)
                rgb = blackbody.radiance(t, np.ones_like(t))
            else:
                rgb = blackbody.radiance(t, b)
                if intensity:
                    warnings.append(f"The blackbody intensity grid '{medium.blackbody_intensity.grid}' "
                                    "is multiplied by the temperature's term per voxel beside an emission "
                                    "strength grid (Cycles multiplies their blends: its fire is darker).")
            for k in range(3):
                channels[BLACKBODY + k] = rgb[..., k].astype(np.float32)
        scalars = np.stack([_down(c, factor) for c in channels], axis=-1)
    color = None
    if medium.color_grid is not None:
        c = _clean(np.asarray(medium.grids[medium.color_grid], np.float32), medium.color_grid, warnings)
        color = np.stack([_down(c[..., k], factor) for k in range(3)], axis=-1)
    return PreparedAttributes(scalars, strength, bb, color, warnings, _emission_box(medium, scalars),
                              intensity and not strength)


def emitting_voxels(scalars: np.ndarray, strength_grid: bool, blackbody_grid: bool) -> np.ndarray:
    """(nx, ny, nz) bool: the voxels whose grids can emit (a strength grid above 0, a blackbody
    term not 0), whatever the strength's scale and offset (uniforms) are."""
    live = np.zeros(scalars.shape[:3], bool)
    if strength_grid:
        live |= scalars[..., STRENGTH] > 0.0
    if blackbody_grid:
        live |= np.any(scalars[..., BLACKBODY:] != 0.0, axis=-1)
    return live


def _emission_box(medium: Medium, scalars: np.ndarray | None):
    """Index-space bounds of the voxels whose grids can emit, one voxel wider (the trilinear
    support); None when the emission reads no grid. A constant part of the emission (a strength
    offset, a blackbody term without grid) glows in the whole grid box besides: passes/emission
    widens the box to it when it binds, since that part is a uniform."""
    if scalars is None:
        return None
    live = emitting_voxels(scalars, uses_strength_grid(medium), uses_blackbody_grid(medium))
    if not live.any():
        return ((0.0, 0.0, 0.0), (-1.0, -1.0, -1.0))
    idx = np.argwhere(live)
    return (tuple(float(x) - 1.0 for x in idx.min(axis=0)), tuple(float(x) + 1.0 for x in idx.max(axis=0)))


def constant_emits(medium: Medium) -> bool:
    """Whether a constant part of the emission glows wherever the medium is: a strength offset
    above 0 with a colour, or a blackbody term that reads no grid."""
    glows = medium.emission_strength.offset > 0.0 and any(c != 0.0 for c in medium.emission_color)
    burns = any(c != 0.0 for c in medium.blackbody_tint) and any(c != 0.0 for c in constant_blackbody(medium))
    return medium.has_emission and (glows or burns)


def constant_blackbody(medium: Medium) -> tuple[float, float, float]:
    """The blackbody term before the tint when it reads no grid."""
    if not medium.has_emission or uses_blackbody_grid(medium):
        return (0.0, 0.0, 0.0)
    rgb = blackbody.radiance(np.asarray(medium.temperature.offset), medium.blackbody_intensity.offset)
    return tuple(float(x) for x in np.asarray(rgb).reshape(3))


def padded_xyz_fastest(a: np.ndarray) -> np.ndarray:
    """An (nx, ny, nz, c) grid with a layer of zeros around it, x varying fastest (OpenGL's order)."""
    padded = np.pad(a, ((1, 1), (1, 1), (1, 1), (0, 0)))
    return np.ascontiguousarray(padded.transpose(2, 1, 0, 3))
