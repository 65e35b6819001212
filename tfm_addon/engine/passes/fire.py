"""The light an emitting medium casts on the solids (engine/fire_light.py) on the GPU: its points
as uniform arrays and their transmittance maps as one texture, read by the first light pass
(the shader's FIRE_LIGHT, shaders/fire_light.glsl)."""

from __future__ import annotations

import numpy as np

from ..fire_light import DIRECTIONS, MAX_POINTS, FireLight, placement
from ..gl_context import GLContext, set_uniforms
from ..scene import Medium
from .bindings import UNIT


def has_fire_unit(gl: GLContext) -> bool:
    """Whether this GL has the texture unit of the maps (above the 16 that GL 3.3 guarantees)."""
    return UNIT["u_fire"] < int(gl.ctx.info.get("GL_MAX_TEXTURE_IMAGE_UNITS", 16))


class FireGPU:
    """One medium's points and maps, cached by the renderer by fire_light.content_key (not the
    placement: ``bind`` places them where the medium is)."""

    def __init__(self, gl: GLContext, light: FireLight):
        self.light = light
        atlas = light.atlas
        self.texture = gl.ctx.texture((atlas.shape[1], atlas.shape[0]), 3, atlas.tobytes(), dtype="f4")
        self.texture.repeat_x = self.texture.repeat_y = False
        power = np.zeros((MAX_POINTS, 4), np.float32)
        power[:len(light), :3] = light.intensity
        self._power = power.tobytes()

    def bind(self, prog, medium: Medium) -> None:
        """The maps and the points placed where ``medium`` is now."""
        light, n = self.light, len(self.light)
        rotation, _, offset = placement(medium)
        pos = np.zeros((MAX_POINTS, 4), np.float32)
        pos[:n, :3], pos[:n, 3] = light.positions @ rotation.T + offset, light.softening
        self._pos = pos.tobytes()
        self.texture.use(UNIT["u_fire"])
        set_uniforms(prog, u_fire=UNIT["u_fire"], u_fire_count=n,
                     u_fire_atlas=(float(n * DIRECTIONS), float(DIRECTIONS)))
        if prog.get("u_fire_to_local", None) is not None:
            prog["u_fire_to_local"].write(np.asarray(rotation, np.float32).tobytes())   # R^T, column-major
        for name, data in (("u_fire_pos", self._pos), ("u_fire_power", self._power)):
            if prog.get(name, None) is not None:
                prog[name].write(data)

    def release(self) -> None:
        self.texture.release()
