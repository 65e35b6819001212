"""GPU-side state shared by the passes: the medium's textures and a light's uniforms."""

from __future__ import annotations

import numpy as np

from ..gl_context import GLContext, set_matrix, set_uniforms
from ..light import LightFrame
from ..medium_grid import PreparedGrid
from ..scene import Medium

# Texture units, fixed for every program.
UNIT = {"u_gb0": 0, "u_gb1": 1, "u_density": 2, "u_shadow": 3, "u_gobo": 4, "u_krange": 5,
        "u_coef0": 6, "u_coef1": 7, "u_coef2": 8, "u_coef3": 9, "u_shadow_depth": 14}

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

    def __init__(self, gl: GLContext, medium: Medium | None, grid: PreparedGrid | None):
        self.texture = None
        if medium is None or (grid is not None and grid.is_empty):
            self.kind = MEDIUM_NONE
            world_to_box, lo, hi = np.eye(4), (0, 0, 0), (0, 0, 0)
        elif grid is not None:
            self.kind = MEDIUM_GRID
            n = grid.density.shape
            world_to_box = np.linalg.inv(grid.index_to_world)
            lo, hi = (-1, -1, -1), tuple(float(x) for x in n)
            data = grid.padded_xyz_fastest()
            self.grid_size = (n[0] + 2, n[1] + 2, n[2] + 2)
            self.texture = gl.ctx.texture3d(self.grid_size, 1, data.tobytes(), dtype="f4")
            self.texture.filter = (gl.ctx.LINEAR, gl.ctx.LINEAR)
            self.texture.repeat_x = self.texture.repeat_y = self.texture.repeat_z = False
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
            set_uniforms(prog, u_grid_size=tuple(float(x) for x in self.grid_size))
            self.texture.use(UNIT["u_density"])

    def release(self) -> None:
        if self.texture is not None:
            self.texture.release()


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
