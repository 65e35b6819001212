"""GPU-side state shared by the passes: the medium's textures and a light's uniforms."""

from __future__ import annotations

import numpy as np

from ..gl_context import GLContext, set_matrix, set_uniforms
from ..light import LightFrame
from ..medium_grid import PreparedGrid
from ..scene import Medium

# Texture units of the light, map and probe passes, one table so that no two textures share a
# unit (the composite pass, a program that reads nothing else, takes its three inputs from 11-13).
UNIT = {"u_gb0": 0, "u_gb1": 1, "u_density": 2, "u_shadow": 3, "u_gobo": 4, "u_krange": 5,
        "u_coef0": 6, "u_coef1": 7, "u_coef2": 8, "u_coef3": 9, "u_attrs": 10, "u_color_grid": 11,
        "u_points": 12, "u_shadow_depth": 14, "u_occupancy": 15}

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
        if name in prog:
            prog[name].value = unit


class MediumGPU:
    """The medium's bounds as an oriented box and, for a grid, its padded 3D texture."""

    def __init__(self, gl: GLContext, medium: Medium | None, grid: PreparedGrid | None,
                 grid_format: str | None = None):
        grid_format = grid_format or GRID_FORMAT
        self.texture = None
        self.density_scale = 1.0
        self.occupancy = None
        if medium is None or (grid is not None and grid.is_empty):
            self.kind = MEDIUM_NONE
            world_to_box, lo, hi = np.eye(4), (0, 0, 0), (0, 0, 0)
        elif grid is not None:
            self.kind = MEDIUM_GRID
            n = grid.density.shape
            world_to_box = np.linalg.inv(grid.index_to_world)
            lo, hi = nonzero_bounds(grid.density)
            data = grid.padded_xyz_fastest()
            self.grid_size = (n[0] + 2, n[1] + 2, n[2] + 2)
            self.grid_format = grid_format
            dtype, numpy_type = GRID_FORMATS[grid_format]
            self.density_scale = max(grid.max_value, 1e-30)      # stored: density / scale
            if np.issubdtype(numpy_type, np.integer):     # normalised: round to the nearest step
                top = np.float32(np.iinfo(numpy_type).max / self.density_scale)
                stored = data * top + np.float32(0.5)
            else:
                stored = data * np.float32(1.0 / self.density_scale)
            self.texture = gl.ctx.texture3d(self.grid_size, 1, stored.astype(numpy_type).tobytes(),
                                            dtype=dtype)
            self.texture.filter = (gl.ctx.LINEAR, gl.ctx.LINEAR)
            self.texture.repeat_x = self.texture.repeat_y = self.texture.repeat_z = False
            occ = occupancy(data)
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

    def bind(self, prog) -> None:
        set_matrix(prog, "u_world_to_box", self.world_to_box)
        set_uniforms(prog, u_box_lo=self.lo, u_box_hi=self.hi)
        if self.texture is not None:
            set_uniforms(prog, u_grid_size=tuple(float(x) for x in self.grid_size),
                         u_occupancy_block=float(OCCUPANCY_BLOCK), u_density_scale=self.density_scale)
            self.texture.use(UNIT["u_density"])
            self.occupancy.use(UNIT["u_occupancy"])

    def release(self) -> None:
        for t in (self.texture, self.occupancy):
            if t is not None:
                t.release()


def nonzero_bounds(density: np.ndarray) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(lo, hi) in index space of the tightest box outside which the trilinear density is 0:
    one voxel beyond the first and last non-zero voxel centres on each axis."""
    lo, hi = [], []
    for axis in range(3):
        other = tuple(a for a in range(3) if a != axis)
        nz = np.flatnonzero(np.any(density > 0, axis=other))
        first, last = (int(nz[0]), int(nz[-1])) if nz.size else (1, -1)     # empty: lo = hi
        lo.append(float(first - 1))
        hi.append(float(last + 1))
    return tuple(lo), tuple(hi)


def occupancy(padded_zyx: np.ndarray, block: int = OCCUPANCY_BLOCK) -> np.ndarray:
    """255 where a cell of block^3 padded voxels may hold non-zero trilinear density, else 0, in
    the layout of ``padded_zyx`` (x fastest). Cell c covers padded positions [c b, (c + 1) b) on
    each axis, whose trilinear value reads voxels c b .. (c + 1) b: the max is over those."""
    d = padded_zyx > 0
    d[:, :, :-1] |= d[:, :, 1:]   # voxel j may touch positions in the cell of j and of j - 1
    d[:, :-1, :] |= d[:, 1:, :]
    d[:-1, :, :] |= d[1:, :, :]
    for axis in range(3):
        d = np.logical_or.reduceat(d, np.arange(0, d.shape[axis], block), axis=axis)
    return np.ascontiguousarray(d.astype(np.uint8) * 255)


def bind_light(prog, frame: LightFrame, intensity, map_res: int, shadow, gobo) -> None:
    """A light's uniforms; ``shadow`` is a ShadowMap or None, ``gobo`` a texture or None."""
    set_matrix(prog, "u_world_to_light", frame.world_to_light)
    set_uniforms(prog, u_light_pos=tuple(frame.position), u_intensity=tuple(float(x) for x in intensity),
                 u_cos_half=frame.cos_half, u_spot_smooth=frame.spot_smooth,
                 u_tan_half=tuple(float(t) for t in frame.tan_xy),
                 u_cone_scale=tuple(float(s) for s in frame.cone_scale),
                 u_map_res=float(map_res), u_has_shadow=int(shadow is not None),
                 u_has_gobo=int(gobo is not None))
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
