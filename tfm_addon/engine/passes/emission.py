"""GPU side of the medium's emission and colour grid: two 3D textures and their uniforms.

The textures hold the attribute grids as read (no emission constant is baked in), so changing an
emission colour, strength or tint changes uniforms only, with one exception: a medium whose
emission reads a blackbody grid, a strength grid or both (which would need five values a sample
besides its density) has its texture hold the emission those grids give, combined per voxel
(``combined``: colour x strength + tint x blackbody, less the part that reads no grid; the view
march adds it with no arithmetic of its own), and an edit of its colour, strength or tint
recomputes that combination over the voxels that can emit
(a CPU pass over the emission's box, counted in ``combines``; no grid is prepared again and no
map is built). With the attributes comes an occupancy grid of the emitting medium (R: the
density's, G: where its grids can emit), through which its march skips the cells where it
neither absorbs nor glows.

Where the emitting medium's density and the values a sample reads besides it fit in four channels
on the density's lattice, the density is packed into the same texture (``packing``), so that its
view march makes one texture fetch per sample instead of two: into the attributes' free channel
beside the combined emission of a blackbody grid, a strength grid or both (density, emission RGB),
or into the colour grid's fourth channel.
The packed density is the density texture's own values (read back from it), so both paths march
the same density.

Combining per voxel is what Cycles converges to: it looks a volume's attributes up stochastically
(one voxel drawn with the trilinear weights) and evaluates the shader on that voxel's values, so a
frame is the trilinear blend of each voxel's emission (engine/blackbody.py)."""

from __future__ import annotations

from collections import Counter

import numpy as np

from ..gl_context import GLContext, set_uniforms
from ..medium_attributes import (
    BLACKBODY,
    STRENGTH,
    PreparedAttributes,
    constant_blackbody,
    constant_emits,
    emitting_voxels,
    padded_xyz_fastest,
)
from ..scene import Medium
from .bindings import GRID_FORMATS, OCCUPANCY_BLOCK, UNIT, MediumGPU, has_glow_unit, occupancy

UNIT_ATTRS, UNIT_COLOR = UNIT["u_attrs"], UNIT["u_color_grid"]

PACKED_ATTRS_R, PACKED_COLOR_A = 1, 3
"""The march's PACKED_DENSITY define: where it reads the first medium's density (0: u_density)."""


def stored_density(grid: MediumGPU) -> np.ndarray:
    """The density texture's level 0 as float32 (padded, x fastest, z y x order), in its own
    units (density / ``grid.density_scale``): normalised integers divided by their maximum as the
    GL converts them."""
    dtype, numpy_type = GRID_FORMATS[grid.grid_format]
    nx, ny, nz = grid.grid_size
    a = np.frombuffer(grid.texture.read(alignment=1), numpy_type).reshape(nz, ny, nx)
    if np.issubdtype(numpy_type, np.integer):
        return a.astype(np.float32) / np.float32(np.iinfo(numpy_type).max)
    return a.astype(np.float32)


class AttributesGPU:
    """The attribute grids of one medium as textures (a 1-voxel texture when there are none)."""

    def __init__(self, gl: GLContext, prepared: PreparedAttributes | None,
                 grid_size: tuple[int, ...] | None = None, density_cells: np.ndarray | None = None,
                 density: MediumGPU | None = None):
        """``grid_size``: the padded density texture's size, whose index box [-1, n] bounds a
        constant emission in a grid (as the reference's march does); ``density_cells``: that
        grid's occupancy (bindings.occupancy), the R channel of the emitting medium's;
        ``density``: that grid's texture, packed beside the attributes where they fit (None: not
        packed)."""
        ctx = gl.ctx
        self._gl = gl
        self._glow = None                   # (mask, texture) of the glow blocks (_glow_texture)
        self.strength_grid = prepared is not None and prepared.strength_grid
        self.blackbody_grid = prepared is not None and prepared.blackbody_grid
        self.warnings = list(prepared.warnings) if prepared is not None else []
        scalars = prepared.scalars if prepared is not None else None
        self.reads_grid = scalars is not None
        # The blackbody intensity's blend times that of the term at intensity 1: not combinable.
        self.intensity_grid = prepared is not None and prepared.intensity_grid
        # Grids: the texture holds (density or 0, emission RGB) combined per voxel (combine).
        self.combined = bool((self.blackbody_grid or self.strength_grid) and not self.intensity_grid)
        self.combines = 0                   # how often the combined emission was computed
        self._combined_for = None           # the uniforms it was computed for
        color = prepared.color if prepared is not None else None
        # Where the density is packed: the colour grid's 4th channel, else the attributes' free one.
        self.packed = 0
        self.packed_passes: Counter = Counter()     # passes per PACKED_DENSITY value (packing)
        self.density_grid = density
        lattice = tuple(grid_size) if grid_size is not None else None
        if density is not None and density.texture is not None:
            if color is not None and tuple(int(n) + 2 for n in color.shape[:3]) == lattice:
                self.packed = PACKED_COLOR_A
            elif (scalars is not None and self.combined
                  and tuple(int(n) + 2 for n in scalars.shape[:3]) == lattice):
                self.packed = PACKED_ATTRS_R
        stored = stored_density(density) if self.packed else None
        if scalars is None:
            self.attrs_size = (1, 1, 1)
            data = np.zeros((1, 1, 1, 4), np.float32)
        else:
            data = padded_xyz_fastest(scalars)
            self.attrs_size = tuple(int(n) + 2 for n in scalars.shape[:3])
            if self.combined:
                self._keep_sources(data, prepared.emission_box)
            if self.packed == PACKED_ATTRS_R:         # density, the combined emission
                data[..., 0] = stored
            if self.combined and self._block is not None:
                self._block[..., 0] = data[self._box + (0,)]
        self.attrs = ctx.texture3d(self.attrs_size, data.shape[-1], np.ascontiguousarray(data).tobytes(),
                                   dtype="f4")
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
        if color is not None:
            size = tuple(int(n) + 2 for n in color.shape[:3])
            data = padded_xyz_fastest(color)
            if self.packed == PACKED_COLOR_A:         # colour RGB, density
                data = np.concatenate([data, stored[..., None]], axis=-1)
            self.color = ctx.texture3d(size, data.shape[-1], np.ascontiguousarray(data).tobytes(), dtype="f4")
        for tex in (self.attrs, self.color):
            if tex is not None:
                tex.filter = (ctx.LINEAR, ctx.LINEAR)
                tex.repeat_x = tex.repeat_y = tex.repeat_z = False

    def emission_box(self, medium: Medium) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Index-space box outside which ``medium`` (these grids' medium) emits nothing: the
        grids' emitting voxels, or the whole grid box where a constant part glows."""
        if self.glow_blocks(medium) is not None:
            lo, hi = medium.glow.box        # where Cycles' volume mesh is (scene.Medium.glow)
            if self.grids_box is not None:  # which holds the grids' emitting voxels: made sure of
                lo = tuple(min(a, b) for a, b in zip(lo, self.grids_box[0], strict=True))
                hi = tuple(max(a, b) for a, b in zip(hi, self.grids_box[1], strict=True))
            return lo, hi
        if self.grids_box is None or constant_emits(medium):
            return self.grid_box
        return self.grids_box

    def program_kind(self, medium: Medium) -> int:
        """The march's EMISSION define for ``medium``: 1 a constant (reads no grid), 2 grids, 3 grids
        and a constant part (which the skipped samples add)."""
        if not self.reads_grid:
            return 1
        return 3 if constant_emits(medium) else 2

    def grids_read(self) -> int:
        """The march's EMISSION_GRIDS define: 4 the emission of a strength grid, a blackbody grid or
        both, combined per voxel in gba, 8 a blackbody intensity grid in r times the blackbody term
        in gba, 0 no grid."""
        if self.combined:
            return 4
        if self.intensity_grid:
            return 8        # the intensity in r times the blackbody term in gba, each blended
        return 0

    def _keep_sources(self, data: np.ndarray, box) -> None:
        """Keep, for ``combine``, the strength and blackbody grids over the texels of the index box
        ``box`` (the voxels that can emit, one wider), and zero them in ``data`` (the padded texture,
        z, y, x order): the combined emission is written at the first bind."""
        n = self.attrs_size
        lo, hi = box
        a = [min(max(int(np.floor(lo[k])) + 1, 0), n[k]) for k in range(3)]
        b = [min(max(int(np.ceil(hi[k])) + 2, a[k]), n[k]) for k in range(3)]
        self._box = (slice(a[2], b[2]), slice(a[1], b[1]), slice(a[0], b[0]))
        self._viewport = (a[0], a[1], a[2], b[0] - a[0], b[1] - a[1], b[2] - a[2])
        self._block = None
        if all(b[k] > a[k] for k in range(3)):
            region = data[self._box]
            self._strength = np.ascontiguousarray(np.maximum(region[..., STRENGTH], 0.0))
            self._blackbody = [np.ascontiguousarray(region[..., BLACKBODY + k]) for k in range(3)]
            self._block = np.zeros(region.shape, np.float32)    # R: the packed density (or 0)
            self._scratch = (np.empty_like(self._strength), np.empty_like(self._strength),
                             np.empty_like(self._strength))
        data[..., STRENGTH:] = 0.0

    def combine(self, medium: Medium) -> None:
        """Make the texture's gba ``medium``'s combined emission, per voxel (where it reads a
        strength or a blackbody grid): colour x (max(scale x strength + offset, 0) - max(offset, 0))
        + tint x blackbody.
        The part that reads no grid, colour x max(offset, 0), stays a uniform, so that the voxels
        that cannot emit hold 0 whatever the uniforms are and only the emission's box is
        recomputed and written. Nothing is done when the uniforms are those of the last call."""
        v = medium.emission_strength
        color = tuple(float(c) for c in medium.emission_color)
        tint = tuple(float(c) for c in medium.blackbody_tint)
        key = (color, float(v.scale), float(v.offset), tint)
        if not self.combined or key == self._combined_for:
            return
        if self._block is not None:
            glow, part, term = self._scratch
            np.multiply(self._strength, np.float32(v.scale), out=glow)
            glow += np.float32(v.offset)
            np.maximum(glow, 0.0, out=glow)
            glow -= np.float32(max(float(v.offset), 0.0))
            for k in range(3):
                np.multiply(self._blackbody[k], np.float32(tint[k]), out=term)
                np.multiply(glow, np.float32(color[k]), out=part)
                term += part
                self._block[..., BLACKBODY + k] = term
            self.attrs.write(self._block, viewport=self._viewport)
        self._combined_for = key
        self.combines += 1

    def packing(self, medium: Medium, medium_gpu, emits: bool, colored: bool) -> int:
        """The march's PACKED_DENSITY define for a pass over ``medium_gpu`` (``emits``: the pass
        adds ``medium``'s emission; ``colored``: it reads the colour grid): where the first
        medium's density is read, 0 (its own texture) unless the texture read anyway holds it."""
        where = self._packing(medium, medium_gpu, emits, colored)
        self.packed_passes[where] += 1
        return where

    def _packing(self, medium: Medium, medium_gpu, emits: bool, colored: bool) -> int:
        if not self.packed or not medium_gpu.slots or medium_gpu.slots[0].grid is not self.density_grid:
            return 0
        if not medium_gpu.grids or medium_gpu.grids[0] is not self.density_grid:
            return 0        # the packed density stands for grid slot 0 (u_density)
        if self.packed == PACKED_COLOR_A:
            return self.packed if colored else 0
        return self.packed if emits and self.program_kind(medium) >= 2 else 0

    def bind(self, prog, medium: Medium, emits: bool = True) -> None:
        """The uniforms and textures of ``medium``'s emission (``emits``: the program adds it,
        and skips the cells where it neither absorbs nor glows through these cells) and colour
        grid."""
        self.attrs.use(UNIT_ATTRS)
        v = medium.emission_strength
        color = np.asarray(medium.emission_color, np.float64)
        tint = np.asarray(medium.blackbody_tint, np.float64)
        # The parts that read no grid (a constant strength, a blackbody term without grid), summed.
        const = tint * np.asarray(constant_blackbody(medium), np.float64)
        if not self.strength_grid or self.combined:
            const = const + color * max(float(v.offset), 0.0)
        self.combine(medium)
        lo, hi = self.emission_box(medium)
        set_uniforms(prog, u_attrs=UNIT_ATTRS, u_attrs_size=tuple(float(n) for n in self.attrs_size),
                     u_emission_const=tuple(float(c) for c in const),
                     u_bb_tint=tuple(float(c) for c in tint),
                     u_emit_lo=lo, u_emit_hi=hi)
        if emits and self.cells is not None:
            self.cells.use(UNIT["u_occupancy"])
        glow = self.glow_blocks(medium)
        if emits and glow is not None:
            self._glow_texture(glow).use(UNIT["u_glow"])
            set_uniforms(prog, u_glow=UNIT["u_glow"], u_glow_origin=glow.origin, u_glow_side=glow.side)
        if self.color is not None:
            self.color.use(UNIT_COLOR)
            set_uniforms(prog, u_color_grid=UNIT_COLOR)

    def glow_blocks(self, medium: Medium):
        """The blocks outside which ``medium``'s constant emission does not glow (the march's
        GLOW_BLOCKS), or None: where it has them and such a part, and the GL the unit for them
        (bindings.has_glow_unit; without it the grid's box, ``glow_note``)."""
        return medium.glow if self._glows(medium) and has_glow_unit(self._gl) else None

    def glow_note(self, medium: Medium) -> str | None:
        """The report's line where ``medium`` has glow blocks this GL cannot read."""
        if not self._glows(medium) or has_glow_unit(self._gl):
            return None
        return (f"'{medium.name}': its constant emission glows over the grid's box, not over the "
                f"blocks where Cycles puts the volume (this GL has too few texture units)")

    @staticmethod
    def _glows(medium: Medium) -> bool:
        return medium.glow is not None and constant_emits(medium)

    def _glow_texture(self, glow):
        """The blocks as an R8 texture (nearest), made again only when the mask changes (a new
        Medium each depsgraph update brings blocks of the same content)."""
        m = np.ascontiguousarray(glow.mask.transpose(2, 1, 0), dtype=np.uint8) * np.uint8(255)
        key = (glow.mask.shape, m.tobytes())
        if self._glow is None or self._glow[0] != key:
            if self._glow is not None:
                self._glow[1].release()
            tex = self._gl.ctx.texture3d(glow.mask.shape, 1, key[1], dtype="f1")
            tex.filter = (self._gl.ctx.NEAREST, self._gl.ctx.NEAREST)
            tex.repeat_x = tex.repeat_y = tex.repeat_z = False
            self._glow = (key, tex)
        return self._glow[1]

    def release(self) -> None:
        for tex in (self.attrs, self.color, self.cells):
            if tex is not None:
                tex.release()
        if self._glow is not None:
            self._glow[1].release()
            self._glow = None
