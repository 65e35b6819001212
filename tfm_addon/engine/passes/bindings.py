"""GPU-side state shared by the passes: the medium's textures and a light's uniforms."""

from __future__ import annotations

import numpy as np

from .. import sparse_grid
from ..boxes import nonzero_bounds
from ..gl_context import GLContext, mat4_bytes, set_matrix, set_uniforms
from ..light import LightFrame
from ..medium_grid import PreparedGrid
from ..scene import Medium
from ..sparse_grid import PreparedSparse

# Texture units of the light, map and probe passes, one table so that no two textures share a
# unit (the composite pass, a program that reads nothing else, takes its three inputs from 11-13).
UNIT = {"u_gb0": 0, "u_gb1": 1, "u_density": 2, "u_shadow": 3, "u_gobo": 4, "u_krange": 5,
        "u_coef0": 6, "u_coef1": 7, "u_coef2": 8, "u_coef3": 9, "u_attrs": 10, "u_color_grid": 11,
        "u_density1": 12, "u_density2": 13, "u_shadow_depth": 14, "u_occupancy": 15, "u_density3": 16,
        "u_glow": 17, "u_fire": 18, "u_brick_index": 19, "u_ms_fluence": 20,
        # the probe pass reads no G-buffer: its points and normals take the G-buffer's units
        "u_points": 0, "u_normals": 1}
# Uniform blocks: the solids' material table and the microfacet tables (shaders/surface.glsl).
BLOCK = {"Materials": 0, "GgxFresnel": 1, "GgxAlbedo": 2}

# The density texture's format: (moderngl dtype, numpy type); values are stored divided by the
# grid's maximum (``MediumGPU.density_scale``) so that half floats never overflow and the
# normalised integers span their range. R16 and R16F give R32F's SSIM against the numpy reference
# on every benchmark scene, R8 drops the dense smoke to 0.995 (docs/benchmark.md); R16 is the
# default: half the bytes of R32F and a sixth of R16F's conversion time in numpy.
GRID_FORMATS = {"R32F": ("f4", np.float32), "R16F": ("f2", np.float16), "R16": ("nu2", np.uint16),
                "R8": ("nu1", np.uint8)}
GRID_FORMAT = "R16"
OCCUPANCY_BLOCK = 8     # voxels per side of an occupancy cell (empty-space skipping)

MEDIUM_NONE, MEDIUM_BOX, MEDIUM_EVERYWHERE, MEDIUM_GRID = 0, 1, 2, 3
"""MEDIUM_GRID marches every medium (density grids and homogeneous boxes, several of them)."""

MAX_MEDIA = 8
"""Media one pass handles (instances of one grid count each)."""
GRID_UNITS = tuple(UNIT[name] for name in ("u_density", "u_density1", "u_density2", "u_density3"))
"""Texture units of the distinct density grids one pass reads: the units UNIT leaves free below
16 (the fewest a fragment shader has on every platform), and unit 16 where the GL has it."""
MAX_GRIDS = len(GRID_UNITS)


def has_glow_unit(gl: GLContext) -> bool:
    """Whether this GL has the texture unit of the glow blocks (u_glow, above the 16 that GL 3.3
    guarantees: a constant emission then glows over the grid's box, said in the report)."""
    return UNIT["u_glow"] < int(gl.ctx.info.get("GL_MAX_TEXTURE_IMAGE_UNITS", 16))


def has_sparse_unit(gl: GLContext) -> bool:
    """Whether this GL has the texture unit of a sparse grid's brick index (u_brick_index, above
    the 16 that GL 3.3 guarantees: without it a sparse grid is uploaded dense, at its coarse copy's
    resolution, said in the report)."""
    return UNIT["u_brick_index"] < int(gl.ctx.info.get("GL_MAX_TEXTURE_IMAGE_UNITS", 16))


def max_grids(gl: GLContext) -> int:
    """Distinct density grids one pass can read on this GL: 4, or 3 with 16 texture units."""
    units = int(gl.ctx.info.get("GL_MAX_TEXTURE_IMAGE_UNITS", 16))
    return sum(1 for u in GRID_UNITS if u < units)


def pass_state(ctx, *, depth_test: bool = False, blend: bool = False) -> None:
    """Set every fixed-function state a pass depends on, whatever the previous pass (or a
    cancelled frame) left: blending (additive when on), depth test, face culling."""
    ctx.disable(ctx.CULL_FACE)
    if depth_test:
        ctx.enable(ctx.DEPTH_TEST)
    else:
        ctx.disable(ctx.DEPTH_TEST)
    if blend:
        ctx.enable(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE
        ctx.blend_equation = ctx.FUNC_ADD
    else:
        ctx.disable(ctx.BLEND)


def bind_units(prog) -> None:
    for name, unit in UNIT.items():
        if prog.get(name, None) is not None:   # a dict look-up (`in` walks every member)
            prog[name].value = unit
    for name, binding in BLOCK.items():
        if prog.get(name, None) is not None:
            prog[name].binding = binding


class MediumGPU:
    """One medium's bounds as an oriented box and, for a grid, its padded 3D texture. A grid's
    texture is made from ``grid`` (prepared with the identity placement): ``index_scale`` maps
    the texture's index space to the medium's own (a downsampled grid), so instances of one
    grid share the texture, each with its own ``index_to_world``."""

    sparse = False
    brick_index = None

    def __init__(self, gl: GLContext, medium: Medium | None, grid: PreparedGrid | PreparedSparse | None,
                 grid_format: str | None = None):
        grid_format = grid_format or GRID_FORMAT
        self.texture = None
        self.index_scale = np.eye(4)
        self.density_scale = 1.0
        self.occupancy = None
        if isinstance(grid, PreparedSparse) and not grid.is_empty:
            self.kind = MEDIUM_GRID
            self._upload_sparse(gl, grid)
            world_to_box = np.linalg.inv(np.asarray(medium.index_to_world) @ self.index_scale)
            lo, hi = grid.bounds
        elif medium is None or (grid is not None and grid.is_empty):
            self.kind = MEDIUM_NONE
            world_to_box, lo, hi = np.eye(4), (0, 0, 0), (0, 0, 0)
        elif grid is not None:
            self.kind = MEDIUM_GRID
            n = grid.density.shape
            self.index_scale = np.asarray(grid.index_to_world, np.float64)
            world_to_box = np.linalg.inv(np.asarray(medium.index_to_world) @ self.index_scale)
            lo, hi = nonzero_bounds(grid.density)
            self.grid_size = (n[0] + 2, n[1] + 2, n[2] + 2)
            self.grid_format = grid_format
            dtype, numpy_type = GRID_FORMATS[grid_format]
            self.density_scale = max(grid.max_value, 1e-30)      # stored: density / scale
            stored = stored_grid(grid.density, numpy_type, self.density_scale)
            self.texture = gl.ctx.texture3d(self.grid_size, 1, stored, dtype=dtype)
            self.texture.repeat_x = self.texture.repeat_y = self.texture.repeat_z = False
            self.texture.filter = (gl.ctx.LINEAR, gl.ctx.LINEAR)     # level 1: see ensure_level1
            self._gl = gl
            occ = self.occupancy_cells = occupancy(stored)     # a voxel stored as 0 is empty
            self.occupancy_size = occ.shape[::-1]
            self.occupancy = gl.ctx.texture3d(self.occupancy_size, 1, occ.tobytes(), dtype="f1")
            self.occupancy.filter = (gl.ctx.NEAREST, gl.ctx.NEAREST)
            self.occupancy.repeat_x = self.occupancy.repeat_y = self.occupancy.repeat_z = False
        elif medium.box_to_world is not None:
            self.kind = MEDIUM_BOX
            world_to_box, lo, hi = np.linalg.inv(medium.box_to_world), (-1, -1, -1), (1, 1, 1)
        else:
            self.kind = MEDIUM_EVERYWHERE
            world_to_box, lo, hi = np.eye(4), (0, 0, 0), (0, 0, 0)
        self.world_to_box = world_to_box
        self.box_to_world = np.linalg.inv(world_to_box)
        self.lo, self.hi = tuple(float(x) for x in lo), tuple(float(x) for x in hi)

    def _upload_sparse(self, gl: GLContext, grid: PreparedSparse) -> None:
        """The atlas of the bricks (R16, density / its maximum, as a dense grid's texture), the
        index of their slots per cell and the occupancy of those cells (sparse_grid.py)."""
        g = grid.grid
        self.sparse = True
        self._gl = gl
        self.grid_format = "R16"
        self.index_scale = np.asarray(g.index_to_medium, np.float64)
        self.grid_size = tuple(int(n) + 2 for n in g.shape)
        self.density_scale = max(grid.max_value, 1e-30)
        layout = sparse_grid.atlas_layout(len(g.bricks), gl.max_3d_texture_size)
        atlas = sparse_grid.pack_atlas(g.bricks, layout,
                                       lambda v: stored_values(v, np.uint16, self.density_scale))
        self.atlas_size = atlas.shape[::-1]
        self.texture = gl.texture3d_r16(atlas)         # the host's thread runs meanwhile
        self.texture.repeat_x = self.texture.repeat_y = self.texture.repeat_z = False
        self.texture.filter = (gl.ctx.LINEAR, gl.ctx.LINEAR)
        del atlas
        index = sparse_grid.index_cells(g.cells, g.shape, layout)
        self.brick_index = gl.ctx.texture3d(index.shape[2::-1], 4, index, dtype="u1")
        self.brick_index.filter = (gl.ctx.NEAREST, gl.ctx.NEAREST)
        occ = self.occupancy_cells = np.ascontiguousarray(index[..., 3] * np.uint8(255))
        self.occupancy_size = occ.shape[::-1]
        self.occupancy = gl.ctx.texture3d(self.occupancy_size, 1, occ.tobytes(), dtype="f1")
        self.occupancy.filter = (gl.ctx.NEAREST, gl.ctx.NEAREST)
        self.occupancy.repeat_x = self.occupancy.repeat_y = self.occupancy.repeat_z = False

    def bind_sparse(self, prog) -> None:
        """A sparse grid's index and sizes (it reads as grid slot 0)."""
        if self.sparse:
            set_uniforms(prog, u_sparse_size=tuple(float(x) for x in self.grid_size),
                         u_atlas_size=tuple(float(x) for x in self.atlas_size))
            self.brick_index.use(UNIT["u_brick_index"])

    has_level1 = False

    def ensure_level1(self) -> bool:
        """Give the grid's texture its level 1 (the means of 2x2x2 voxels, made by the GL) for
        the light marches whose steps and map texels span two voxels (common.glsl grid_ray_lod;
        every other read asks for level 0). Made once, when a light first asks for it, not with
        every upload. Until then a read of level 1 reads level 0. True when made now. A texture
        with an odd side gets no level: the GL resamples an odd axis linearly rather than
        averaging pairs of voxels (Mesa: [1, 4, 9, 16, 25] -> [3.25, 18.25]), which brightened a
        voxel-scale pattern on a 63^3 grid by 5 %; its light marches read level 0."""
        if (self.texture is None or self.sparse or self.has_level1
                or any(int(s) % 2 for s in self.grid_size)):
            return False
        self._gl.build_level1(self.texture)       # the GIL released meanwhile
        self.texture.filter = (self._gl.ctx.LINEAR_MIPMAP_NEAREST, self._gl.ctx.LINEAR)
        self.has_level1 = True
        # The level's occupancy from the level 0's cells (their small texture read back).
        size = self.occupancy.size
        occ0 = np.frombuffer(self.occupancy.read(alignment=1), dtype=np.uint8).reshape(size[::-1])
        occ = occupancy_level1(occ0)
        self.occupancy1 = self._gl.ctx.texture3d(occ.shape[::-1], 1, occ.tobytes(), dtype="f1")
        self.occupancy1.filter = (self._gl.ctx.NEAREST, self._gl.ctx.NEAREST)
        self.occupancy1.repeat_x = self.occupancy1.repeat_y = self.occupancy1.repeat_z = False
        return True

    occupancy1 = None

    @property
    def light_occupancy(self):
        """The occupancy the light marches skip by: conservative for every level they may read
        (``occupancy1`` once the level 1 exists, else the level 0's ``occupancy``)."""
        return self.occupancy1 if self.occupancy1 is not None else self.occupancy

    def bind(self, prog) -> None:
        set_matrix(prog, "u_world_to_box", self.world_to_box)
        set_uniforms(prog, u_box_lo=self.lo, u_box_hi=self.hi)
        if self.texture is not None:
            set_uniforms(prog, u_grid_size=tuple(float(x) for x in self.grid_size),
                         u_occupancy_block=float(OCCUPANCY_BLOCK), u_density_scale=self.density_scale)
            self.texture.use(UNIT["u_density"])
            self.occupancy.use(UNIT["u_occupancy"])
            self.bind_sparse(prog)

    def release(self) -> None:
        for t in (self.texture, self.occupancy, self.occupancy1, self.brick_index):
            if t is not None:
                t.release()


def stored_grid(density: np.ndarray, numpy_type, scale: float) -> np.ndarray:
    """The (nx, ny, nz) grid as its texture holds it: padded by a zero voxel on every side, x
    fastest, divided by ``scale`` (a normalised integer type: rounded to the nearest step): scaled
    and converted in the grid's own order, then transposed in the stored type."""
    nx, ny, nz = density.shape
    out = np.zeros((nx + 2, ny + 2, nz + 2), numpy_type)
    out[1:-1, 1:-1, 1:-1] = stored_values(density, numpy_type, scale)
    return np.ascontiguousarray(out.transpose(2, 1, 0))


def stored_values(density: np.ndarray, numpy_type, scale: float) -> np.ndarray:
    """Densities as a grid texture stores them: divided by ``scale``, a normalised integer type
    rounded to the nearest step (the float values; the caller's array converts them)."""
    if np.issubdtype(numpy_type, np.integer):
        values = density * np.float32(np.iinfo(numpy_type).max / scale)
        values += np.float32(0.5)
        return values.astype(numpy_type)
    return (density * np.float32(1.0 / scale)).astype(numpy_type)


def occupancy(padded_zyx: np.ndarray, block: int = OCCUPANCY_BLOCK, below: int = 0,
              above: int = 1) -> np.ndarray:
    """255 where a cell of block^3 padded voxels may hold non-zero trilinear density, else 0, in
    the layout of ``padded_zyx`` (x fastest). Cell c covers padded positions [c b, (c + 1) b) on
    each axis, whose trilinear value reads voxels c b .. (c + 1) b: the OR is over those, one
    axis at a time on the already reduced array (a box filter is separable). ``below`` and
    ``above`` widen the voxels read to c b - below .. (c + 1) b - 1 + above (occupancy_level1)."""
    d = padded_zyx > 0
    for axis in range(3):
        n = d.shape[axis]
        starts = np.arange(0, n, block)
        cells = np.logical_or.reduceat(d, starts, axis=axis)
        head = [slice(None)] * 3
        for k in range(1, above + 1):            # the first voxels of the next cell
            if len(starts) > 1:
                voxels = np.minimum(starts[1:] + k - 1, n - 1)
                head[axis] = slice(0, len(starts) - 1)
                cells[tuple(head)] |= np.take(d, voxels, axis=axis)
        for k in range(1, below + 1):            # and the last voxels of the previous one
            if len(starts) > 1:
                head[axis] = slice(1, len(starts))
                cells[tuple(head)] |= np.take(d, starts[1:] - k, axis=axis)
        d = cells
    return np.ascontiguousarray(d.astype(np.uint8) * 255)


def occupancy_level1(occupancy0: np.ndarray) -> np.ndarray:
    """``occupancy`` for the reads of the level 1 (the 2x2x2 means of an even-sided texture),
    from the level 0's occupancy cells: trilinear between the level's voxels at a padded position
    p of cell c (in [c b, (c + 1) b), b even) reads level-1 voxels floor((p - 0.5) / 2) and the
    next, the means of level-0 voxels c b - 2 .. (c + 1) b + 1, which cells c - 1 .. c + 1 of the
    level 0 cover (b >= 2): each cell ORed with its 26 neighbours. Conservative, and made from
    the small cell grid (no read-back of the level)."""
    d = np.asarray(occupancy0) > 0
    for axis in range(3):
        out = d.copy()
        lo = [slice(None)] * 3
        hi = [slice(None)] * 3
        lo[axis], hi[axis] = slice(0, -1), slice(1, None)
        out[tuple(lo)] |= d[tuple(hi)]
        out[tuple(hi)] |= d[tuple(lo)]
        d = out
    return np.ascontiguousarray(d.astype(np.uint8) * 255)


class MediumSlot:
    """One medium of a frame as the marching shaders see it: its box (index space of its grid,
    or the [-1, 1] cube), the grid texture it reads (None: density 1 in the box), its
    coefficients per unit density and its weight in the lights' TFMs."""

    def __init__(self, medium: Medium, grid: MediumGPU | None):
        self.medium, self.grid = medium, grid
        if grid is not None:
            to_world = np.asarray(medium.index_to_world) @ grid.index_scale
            self.lo, self.hi = grid.lo, grid.hi          # the density's non-zero bounds
        else:
            to_world = np.asarray(medium.box_to_world)
            self.lo, self.hi = (-1.0, -1.0, -1.0), (1.0, 1.0, 1.0)
        self.box_to_world = to_world
        self.world_to_box = np.linalg.inv(to_world)


def smallest_stretch(a: np.ndarray) -> float:
    """The fewest metres a unit of index space spans in any direction (the smallest singular value
    of the 3x3 ``a``): a metre crosses at most 1 / it voxels, the most common.glsl grid_ray_lod
    can count along a ray. The columns' lengths where they are orthogonal (a rotation and a
    scale, to Blender's float32: cosines under 1e-5, whose error in it is of that order); a
    sheared placement's columns overstate it (LAPACK there only)."""
    a = np.asarray(a, dtype=np.float64)
    g = a.T @ a
    d = np.sqrt(np.diag(g))
    off = np.abs(g - np.diag(np.diag(g)))
    if (off <= 1e-5 * np.outer(d, d)).all():
        return float(d.min())
    return float(np.linalg.svd(a, compute_uv=False).min())


class MediaGPU:
    """The media of a frame. ``kind``: MEDIUM_NONE, the analytic MEDIUM_BOX or
    MEDIUM_EVERYWHERE for a single homogeneous medium (``first``), or MEDIUM_GRID: every medium
    in ``slots`` marched, their distinct grids in ``grids`` (at most MAX_GRIDS). ``fog``: the
    homogeneous fog without bounds (the World's Volume), or None: MEDIUM_EVERYWHERE's medium, or
    with MEDIUM_GRID the fog overlapping the slots' media, which the shaders add in closed form
    (WORLD_FOG, shaders/homogeneous.glsl)."""

    fog: Medium | None = None

    def __init__(self, kind: int, first: MediumGPU | None, slots: list[MediumSlot],
                 grids: list[MediumGPU]):
        self.kind, self.first, self.slots, self.grids = kind, first, slots, grids
        src = first if first is not None else None
        if kind == MEDIUM_GRID:
            s0 = slots[0]
            self.world_to_box, self.box_to_world, self.lo, self.hi = (
                s0.world_to_box, s0.box_to_world, s0.lo, s0.hi)
        elif src is not None:
            self.world_to_box, self.box_to_world, self.lo, self.hi = (
                src.world_to_box, src.box_to_world, src.lo, src.hi)
        else:
            self.world_to_box = self.box_to_world = np.eye(4)
            self.lo = self.hi = (0.0, 0.0, 0.0)
        self.key = None

    @property
    def boxes(self) -> list[tuple[np.ndarray, tuple, tuple]]:
        """(box_to_world, lo, hi) of every marched medium (or the analytic box)."""
        if self.kind == MEDIUM_GRID:
            return [(s.box_to_world, s.lo, s.hi) for s in self.slots]
        if self.kind == MEDIUM_BOX:
            return [(self.box_to_world, self.lo, self.hi)]
        return []

    def ensure_level1(self, frame: LightFrame, light_steps: int, resolution: int | None = None) -> bool:
        """Make the lone grid's level 1 (``MediumGPU.ensure_level1``) when a light march of the
        face ``frame`` with ``light_steps`` steps may read it: its longest step through the
        grid's non-zero box and (a TFM of side ``resolution``; None: the brute force's march, no
        texels) the map's widest texel where a ray can enter the box (at its corner farthest from
        the light) both span two voxels. The shader decides per ray; this only spares the level
        where no ray wants it (a ray that wants it must find it, or a map would depend on whether
        another light had made the level before)."""
        return self.may_read_level1(frame, light_steps, resolution) and self.slots[0].grid.ensure_level1()

    def may_read_level1(self, frame: LightFrame, light_steps: int, resolution: int | None = None) -> bool:
        """Whether a light march of ``frame`` (``ensure_level1``'s arguments) may read the lone
        grid's level 1."""
        if self.kind != MEDIUM_GRID or len(self.slots) != 1 or self.slots[0].grid is None:
            return False
        slot = self.slots[0]
        lo, hi = np.asarray(slot.lo), np.asarray(slot.hi)
        step = float(np.linalg.norm(hi - lo)) / max(int(light_steps), 1)      # voxels
        texel = np.inf
        if resolution is not None:
            w2b = slot.world_to_box
            p = w2b[:3, :3] @ np.asarray(frame.position, float) + w2b[:3, 3]
            corners = np.array(np.meshgrid(*zip(lo, hi, strict=True), indexing="ij")).reshape(3, -1)
            distance = float(np.linalg.norm(slot.box_to_world[:3, :3] @ (corners - p[:, None]), axis=0).max())
            voxel = smallest_stretch(slot.box_to_world[:3, :3])
            reach = 1.0 if frame.ortho else distance
            texel = 2.0 * min(frame.tan_xy) * reach / max(int(resolution), 1) / max(voxel, 1e-30)
        return min(step, texel) >= 2.0

    def bind_light_occupancy(self, level1: bool) -> None:
        """Bind, in u_occupancy's place, the lone grid's occupancy for a TFM build that may
        (``level1``) or may not read the level 1 (the build reads no other occupancy): the level
        0's skips more where only level 0 is read."""
        grid = self.slots[0].grid if self.kind == MEDIUM_GRID and self.slots else None
        if grid is not None:
            (grid.light_occupancy if level1 else grid.occupancy).use(UNIT["u_occupancy"])

    def defines(self) -> dict:
        """The media's count, grid count and grid slot per medium, compiled into the program
        (the shaders' loops over media unroll to fixed texture reads)."""
        if self.kind != MEDIUM_GRID:
            return {}
        fog = {"WORLD_FOG": 1} if self.fog is not None else {}
        if self.grids and self.grids[0].sparse:
            fog["SPARSE_GRID"] = 1
        index = {id(g): i for i, g in enumerate(self.grids)}
        slots = [index[id(s.grid)] if s.grid is not None else -1 for s in self.slots]
        slots += [-1] * (MAX_MEDIA - len(slots))
        return {"N_MEDIA": len(self.slots), "N_GRIDS": max(len(self.grids), 1),
                "MEDIA_SLOTS": "int[{}]({})".format(MAX_MEDIA, ", ".join(str(s) for s in slots)), **fog}

    def bind(self, prog, weights=None) -> None:
        """Bind the textures and the per-medium uniforms; ``weights``: the TFM weight of each
        slot (default 1)."""
        set_matrix(prog, "u_world_to_box", self.world_to_box)
        set_uniforms(prog, u_box_lo=tuple(self.lo), u_box_hi=tuple(self.hi))
        if self.kind != MEDIUM_GRID:
            return
        if self.fog is not None:
            set_uniforms(prog, u_fog_sigma_t=tuple(float(x) for x in self.fog.sigma_t),
                         u_fog_sigma_s=tuple(float(x) for x in self.fog.sigma_s),
                         u_fog_g=float(self.fog.anisotropy))
        n = MAX_MEDIA
        slots = self.slots
        pad = n - len(slots)
        mats = [s.world_to_box for s in slots] + [np.eye(4)] * pad
        if prog.get("u_med_to_box", None) is not None:
            u = prog["u_med_to_box"]
            u.write(b"".join(mat4_bytes(m) for m in mats[:u.array_length]))
        weights = [1.0] * len(slots) if weights is None else list(weights)

        def vec(values, fill):
            return [tuple(float(x) for x in v) for v in values] + [fill] * pad

        _set_arrays(
            prog,
            u_med_lo=vec([s.lo for s in slots], (0.0, 0.0, 0.0)),
            u_med_hi=vec([s.hi for s in slots], (-1.0, -1.0, -1.0)),
            u_med_sigma_t=vec([s.medium.sigma_t for s in slots], (0.0, 0.0, 0.0)),
            u_med_sigma_s=vec([s.medium.sigma_s for s in slots], (0.0, 0.0, 0.0)),
            u_med_g=[float(s.medium.anisotropy) for s in slots] + [0.0] * pad,
            u_med_weight=[float(w) for w in weights] + [0.0] * pad,
        )
        first = slots[0].grid
        if first is not None:    # the first medium's lattice: its colour grid, empty-space skipping
            set_uniforms(prog, u_grid_size=tuple(float(x) for x in first.grid_size),
                         u_density_scale=first.density_scale, u_occupancy_block=float(OCCUPANCY_BLOCK))
            first.occupancy.use(UNIT["u_occupancy"])
        sizes = [tuple(float(x) for x in g.grid_size) for g in self.grids]
        sizes += [(1.0, 1.0, 1.0)] * (MAX_GRIDS - len(sizes))
        scales = [float(g.density_scale) for g in self.grids] + [1.0] * (MAX_GRIDS - len(self.grids))
        _set_arrays(prog, u_grid_sizes=sizes, u_grid_scales=scales)
        for g, unit in zip(self.grids, GRID_UNITS, strict=False):
            g.texture.use(unit)
        if self.grids:
            self.grids[0].bind_sparse(prog)

    def release(self) -> None:
        pass


def _set_arrays(prog, **values) -> None:
    """Set uniform arrays the program uses, as long as the compiler kept them."""
    for name, value in values.items():
        if prog.get(name, None) is not None:
            u = prog[name]
            v = value[:u.array_length]
            u.value = v if u.array_length > 1 else v[0]


def bind_light(prog, frame: LightFrame, intensity, map_res: int, shadow, gobo) -> None:
    """A light face's uniforms; ``shadow`` is a ShadowMap or None, ``gobo`` a texture or None."""
    set_matrix(prog, "u_world_to_light", frame.world_to_light)
    rect = frame.shadow_rect or (0.0, 0.0, 1.0, 1.0)
    set_uniforms(prog, u_light_pos=tuple(frame.position), u_intensity=tuple(float(x) for x in intensity),
                 u_cos_half=frame.cos_half, u_spot_smooth=frame.spot_smooth,
                 u_tan_half=tuple(float(t) for t in frame.tan_xy),
                 u_face_ortho=int(frame.ortho), u_profile=int(frame.profile),
                 u_emit_axis=tuple(float(a) for a in frame.emit_axis),
                 u_shadow_rect=tuple(float(x) for x in rect),
                 u_cone_scale=tuple(float(s) for s in frame.cone_scale),
                 u_map_res=float(map_res), u_has_shadow=int(shadow is not None),
                 u_has_gobo=int(gobo is not None), u_world_spread=float(frame.world_spread),
                 u_occluder_depth=float(frame.occluder_depth))
    if shadow is not None:
        shadow.texture.use(UNIT["u_shadow"])
        shadow.depth.use(UNIT["u_shadow_depth"])
        set_uniforms(prog, u_shadow_far=shadow.far)
    if gobo is not None:
        gobo.use(UNIT["u_gobo"])


def gobo_texture(gl: GLContext, image: np.ndarray):
    """An (h, w, 3) image, top row first, as a linear-filtered texture (row 0 at t = 0)."""
    h, w = image.shape[:2]
    tex = gl.ctx.texture((w, h), 3, np.ascontiguousarray(image, dtype=np.float32).tobytes(), dtype="f4")
    tex.filter = (gl.ctx.LINEAR, gl.ctx.LINEAR)
    tex.repeat_x = tex.repeat_y = False
    return tex


BACKGROUND_UNIT = 14    # the composite pass's background (its inputs take 11-13; it reads no other)


class BackgroundTexture:
    """The world seen behind everything where it varies with the direction, read by the composite
    pass (shaders/background.glsl) in each pixel's direction: an equirectangular panorama
    (environment.Environment.panorama), top row first, with its mipmaps."""

    def __init__(self, gl: GLContext, image: np.ndarray):
        h, w = image.shape[:2]
        rows = np.ascontiguousarray(np.asarray(image, np.float32)[::-1, :, :3])     # v = 0: the bottom row
        tex = gl.ctx.texture((w, h), 3, rows.tobytes(), dtype="f4")
        tex.build_mipmaps()
        tex.filter = (gl.ctx.LINEAR_MIPMAP_LINEAR, gl.ctx.LINEAR)
        tex.repeat_x, tex.repeat_y = True, False
        self.texture = tex

    def bind(self, prog) -> None:
        self.texture.use(BACKGROUND_UNIT)
        prog["u_background"].value = BACKGROUND_UNIT

    def release(self) -> None:
        self.texture.release()
