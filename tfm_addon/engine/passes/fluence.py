"""The fields of engine/diffusion.py on the GPU: their sum, weighed by the frame's bounce count
(the world's light and the media's emission whole at every count), as one RGB 3D texture over
the lattice, read by the first light pass (the shader's MS_GRID, shaders/scatter.frag). A new
bounce count writes the texture again from the fields kept here; it solves nothing (but where
the world field holds the world's light through the octaves of that count: Renderer._fluence)."""

from __future__ import annotations

import numpy as np

from ..diffusion import Fluence
from ..gl_context import GLContext, set_matrix, set_uniforms
from .bindings import UNIT


def has_fluence_units(gl: GLContext) -> bool:
    """Whether this GL has the texture unit of the fields (above the 16 that GL 3.3 guarantees)."""
    return UNIT["u_ms_fluence"] < int(gl.ctx.info.get("GL_MAX_TEXTURE_IMAGE_UNITS", 16))


class FluenceGPU:
    """surface * the surfaces' light + grid * the diffused light + the media's own emission and
    the world's light (whole at every bounce count: Cycles scatters them with none) + emission *
    its diffused light, linear between cell centres and 0 outside the lattice (the shader tests
    the bounds). ``scattered``: the diffused light was solved for (it then stands for the octaves'
    slab term)."""

    def __init__(self, gl: GLContext, fluence: Fluence):
        lat = fluence.lattice
        # x fastest: each (nx, ny, nz, 3) field transposed to (nz, ny, nx, 3)
        self._fields = [np.ascontiguousarray(np.transpose(f, (2, 1, 0, 3)), np.float32)
                        for f in (fluence.surface, fluence.diffused, fluence.emission_diffused,
                                  fluence.emission + fluence.world)]
        self.scattered = fluence.scattered
        self.texture = gl.ctx.texture3d(lat.shape, 3, dtype="f2")
        self.texture.repeat_x = self.texture.repeat_y = self.texture.repeat_z = False
        self.weights = None
        self.emission_points = 0        # the points the media's emission was taken from (renderer)
        world_to_cell = np.linalg.inv(lat.cell_to_world())
        to_tc = np.diag([*(1.0 / np.asarray(lat.shape, np.float64)), 1.0])
        to_tc[:3, 3] = 0.5 / np.asarray(lat.shape, np.float64)
        self.world_to_tc = to_tc @ world_to_cell

    def bind(self, prog, weights: tuple[float, float, float]) -> None:
        """The fields weighed by ``weights`` (the surfaces' light, the diffused light, the
        emission's diffused light)."""
        weights = tuple(float(w) for w in weights)
        if weights != self.weights:
            total = sum(w * f for w, f in zip(weights, self._fields[:3], strict=True)) + self._fields[3]
            self.texture.write(np.minimum(total, 65000.0).astype(np.float16).tobytes())
            self.weights = weights
        self.texture.use(UNIT["u_ms_fluence"])
        set_uniforms(prog, u_ms_fluence=UNIT["u_ms_fluence"])
        set_matrix(prog, "u_world_to_ms", self.world_to_tc)

    def release(self) -> None:
        self.texture.release()
