"""The fields of engine/diffusion.py on the GPU: two RGB 3D textures over its lattice, read by the
first light pass (the shader's MS_GRID, shaders/scatter.frag)."""

from __future__ import annotations

import numpy as np

from ..diffusion import Fluence
from ..gl_context import GLContext, set_matrix, set_uniforms
from .bindings import UNIT


def has_fluence_units(gl: GLContext) -> bool:
    """Whether this GL has the two texture units of the fields (above the 16 that GL 3.3 guarantees)."""
    return UNIT["u_ms_diffused"] < int(gl.ctx.info.get("GL_MAX_TEXTURE_IMAGE_UNITS", 16))


class FluenceGPU:
    """The surfaces' light and the diffused light, linear between cell centres and 0 outside the
    lattice (the shader tests the bounds)."""

    def __init__(self, gl: GLContext, fluence: Fluence):
        lat = fluence.lattice
        self.iterations = fluence.iterations
        self.textures = []
        for field in (fluence.surface, fluence.diffused):
            # x fastest: the (nx, ny, nz, 3) array transposed to (nz, ny, nx, 3)
            data = np.ascontiguousarray(np.transpose(field, (2, 1, 0, 3)), np.float32)
            tex = gl.ctx.texture3d(lat.shape, 3, data.tobytes(), dtype="f4")
            tex.repeat_x = tex.repeat_y = tex.repeat_z = False
            self.textures.append(tex)
        world_to_cell = np.linalg.inv(lat.cell_to_world())
        to_tc = np.diag([*(1.0 / np.asarray(lat.shape, np.float64)), 1.0])
        to_tc[:3, 3] = 0.5 / np.asarray(lat.shape, np.float64)
        self.world_to_tc = to_tc @ world_to_cell

    def bind(self, prog, weights: tuple[float, float]) -> None:
        """The fields and their weights: (the surfaces' light, the diffused light)."""
        for name, tex in zip(("u_ms_surface", "u_ms_diffused"), self.textures, strict=True):
            tex.use(UNIT[name])
            set_uniforms(prog, **{name: UNIT[name]})
        set_matrix(prog, "u_world_to_ms", self.world_to_tc)
        set_uniforms(prog, u_ms_weight=tuple(float(w) for w in weights))

    def release(self) -> None:
        for tex in self.textures:
            tex.release()
