"""GPU side of the medium's emission and colour grid: two 3D textures and their uniforms.

The textures hold the attribute grids as read (no emission constant is baked in), so changing an
emission colour, strength, intensity, tint or temperature scale changes uniforms only. With the
attributes comes an occupancy grid of the emitting medium (R: the density's, G: where its grids
can emit), through which its march skips the cells where it neither absorbs nor glows."""

from __future__ import annotations

import numpy as np

from ..gl_context import GLContext, set_uniforms
from ..medium_attributes import (
    PreparedAttributes,
    constant_blackbody,
    constant_emits,
    emitting_voxels,
    padded_xyz_fastest,
)
from ..scene import Medium
from .bindings import OCCUPANCY_BLOCK, UNIT, occupancy

UNIT_ATTRS, UNIT_COLOR = UNIT["u_attrs"], UNIT["u_color_grid"]


class AttributesGPU:
    """The attribute grids of one medium as textures (a 1-voxel texture when there are none)."""

    def __init__(self, gl: GLContext, prepared: PreparedAttributes | None,
                 grid_size: tuple[int, ...] | None = None, density_cells: np.ndarray | None = None):
        """``grid_size``: the padded density texture's size, whose index box [-1, n] bounds a
        constant emission in a grid (as the reference's march does); ``density_cells``: that
        grid's occupancy (bindings.occupancy), the R channel of the emitting medium's."""
        ctx = gl.ctx
        self.strength_grid = prepared is not None and prepared.strength_grid
        self.blackbody_grid = prepared is not None and prepared.blackbody_grid
        self.warnings = list(prepared.warnings) if prepared is not None else []
        scalars = prepared.scalars if prepared is not None else None
        self.reads_grid = scalars is not None
        if scalars is None:
            self.attrs_size = (1, 1, 1)
            data = np.zeros((1, 1, 1, 4), np.float32)
        else:
            data = padded_xyz_fastest(scalars)
            self.attrs_size = tuple(int(n) + 2 for n in scalars.shape[:3])
        self.attrs = ctx.texture3d(self.attrs_size, 4, data.tobytes(), dtype="f4")
        # A constant part of the emission glows in the grid's box (or everywhere: no grid).
        self.grid_box = (((-1.0, -1.0, -1.0), tuple(float(n) - 2.0 for n in grid_size))
                         if grid_size is not None else ((-2.0, -2.0, -2.0), (1e30, 1e30, 1e30)))
        self.grids_box = prepared.emission_box if prepared is not None else None
        self.cells = None       # R: the density's occupancy, G: where the grids may emit
        if scalars is not None:
            live = emitting_voxels(scalars, self.strength_grid, self.blackbody_grid)
            glow = occupancy(padded_xyz_fastest(live[..., None].astype(np.uint8))[..., 0], OCCUPANCY_BLOCK)
            if density_cells is None:
                density_cells = np.full_like(glow, 255)
            if glow.shape != density_cells.shape:       # not the density's lattice: may glow anywhere
                glow = np.full_like(density_cells, 255)
            cells = np.ascontiguousarray(np.stack([density_cells, glow], axis=-1))
            self.cells = ctx.texture3d(cells.shape[2::-1], 2, cells.tobytes(), dtype="f1")
            self.cells.filter = (ctx.NEAREST, ctx.NEAREST)
            self.cells.repeat_x = self.cells.repeat_y = self.cells.repeat_z = False
        self.color = None
        if prepared is not None and prepared.color is not None:
            size = tuple(int(n) + 2 for n in prepared.color.shape[:3])
            self.color = ctx.texture3d(size, 3, padded_xyz_fastest(prepared.color).tobytes(), dtype="f4")
        for tex in (self.attrs, self.color):
            if tex is not None:
                tex.filter = (ctx.LINEAR, ctx.LINEAR)
                tex.repeat_x = tex.repeat_y = tex.repeat_z = False

    def emission_box(self, medium: Medium) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Index-space box outside which ``medium`` (these grids' medium) emits nothing: the
        grids' emitting voxels, or the whole grid box where a constant part glows."""
        if self.grids_box is None or constant_emits(medium):
            return self.grid_box
        return self.grids_box

    def program_kind(self, medium: Medium) -> int:
        """The march's EMISSION define for ``medium``: 1 a constant (reads no grid), 2 grids, 3 grids
        and a constant part (which the skipped samples add)."""
        if not self.reads_grid:
            return 1
        return 3 if constant_emits(medium) else 2

    def bind(self, prog, medium: Medium, emits: bool = True) -> None:
        """The uniforms and textures of ``medium``'s emission (``emits``: the program adds it,
        and skips the cells where it neither absorbs nor glows through these cells) and colour
        grid."""
        self.attrs.use(UNIT_ATTRS)
        v = medium.emission_strength
        strength = ((float(v.scale), float(v.offset), 0.0) if self.strength_grid
                    else (0.0, float(v.offset), -1.0))
        lo, hi = self.emission_box(medium)
        set_uniforms(prog, u_attrs=UNIT_ATTRS, u_attrs_size=tuple(float(n) for n in self.attrs_size),
                     u_emission_color=tuple(float(c) for c in medium.emission_color),
                     u_strength=strength, u_bb_grid=int(self.blackbody_grid),
                     u_bb_const=constant_blackbody(medium),
                     u_bb_tint=tuple(float(c) for c in medium.blackbody_tint),
                     u_emit_lo=lo, u_emit_hi=hi)
        if emits and self.cells is not None:
            self.cells.use(UNIT["u_occupancy"])
        if self.color is not None:
            self.color.use(UNIT_COLOR)
            set_uniforms(prog, u_color_grid=UNIT_COLOR)

    def release(self) -> None:
        for tex in (self.attrs, self.color, self.cells):
            if tex is not None:
                tex.release()
