"""GPU side of the medium's emission and colour grid: two 3D textures and their uniforms.

The textures hold the attribute grids as read (no emission constant is baked in), so changing an
emission colour, strength, intensity, tint or temperature scale changes uniforms only."""

from __future__ import annotations

import numpy as np

from ..gl_context import GLContext, set_uniforms
from ..medium_attributes import PreparedAttributes, constant_blackbody, padded_xyz_fastest
from ..scene import Medium
from .bindings import UNIT

UNIT_ATTRS, UNIT_COLOR = UNIT["u_attrs"], UNIT["u_color_grid"]


class AttributesGPU:
    """The attribute grids of one medium as textures (a 1-voxel texture when there are none)."""

    def __init__(self, gl: GLContext, prepared: PreparedAttributes | None,
                 grid_size: tuple[int, ...] | None = None):
        """``grid_size``: the padded density texture's size, whose index box [-1, n] bounds a
        constant emission in a grid (as the reference's march does)."""
        ctx = gl.ctx
        self.strength_grid = prepared is not None and prepared.strength_grid
        self.blackbody_grid = prepared is not None and prepared.blackbody_grid
        self.warnings = list(prepared.warnings) if prepared is not None else []
        scalars = prepared.scalars if prepared is not None else None
        if scalars is None:
            self.attrs_size = (1, 1, 1)
            data = np.zeros((1, 1, 1, 4), np.float32)
        else:
            data = padded_xyz_fastest(scalars)
            self.attrs_size = tuple(int(n) + 2 for n in scalars.shape[:3])
        self.attrs = ctx.texture3d(self.attrs_size, 4, data.tobytes(), dtype="f4")
        box = prepared.emission_box if prepared is not None else None
        if box is None and grid_size is not None:
            box = ((-1.0, -1.0, -1.0), tuple(float(n) - 2.0 for n in grid_size))
        self.emission_box = box or ((-2.0, -2.0, -2.0), (1e30, 1e30, 1e30))
        self.color = None
        if prepared is not None and prepared.color is not None:
            size = tuple(int(n) + 2 for n in prepared.color.shape[:3])
            self.color = ctx.texture3d(size, 3, padded_xyz_fastest(prepared.color).tobytes(), dtype="f4")
        for tex in (self.attrs, self.color):
            if tex is not None:
                tex.filter = (ctx.LINEAR, ctx.LINEAR)
                tex.repeat_x = tex.repeat_y = tex.repeat_z = False

    def bind(self, prog, medium: Medium) -> None:
        self.attrs.use(UNIT_ATTRS)
        v = medium.emission_strength
        strength = ((float(v.scale), float(v.offset), 0.0) if self.strength_grid
                    else (0.0, float(v.offset), -1.0))
        set_uniforms(prog, u_attrs=UNIT_ATTRS, u_attrs_size=tuple(float(n) for n in self.attrs_size),
                     u_emission_color=tuple(float(c) for c in medium.emission_color),
                     u_strength=strength, u_bb_grid=int(self.blackbody_grid),
                     u_bb_const=constant_blackbody(medium),
                     u_bb_tint=tuple(float(c) for c in medium.blackbody_tint),
                     u_emit_lo=self.emission_box[0], u_emit_hi=self.emission_box[1])
        if self.color is not None:
            self.color.use(UNIT_COLOR)
            set_uniforms(prog, u_color_grid=UNIT_COLOR)

    def release(self) -> None:
        for tex in (self.attrs, self.color):
            if tex is not None:
                tex.release()
