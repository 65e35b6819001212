"""Pass 1: distance from a light face to the nearest solid, per map texel."""

from __future__ import annotations

import numpy as np

from ..gl_context import GLContext, set_matrix, set_uniforms
from ..light import LightFrame
from .bindings import BLOCK, bind_units, pass_state
from .solids import POSITION_HIT, SolidsBuffer


def _box_corners(lo, hi) -> np.ndarray:
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


class ShadowMap:
    """An R32F texture of distances in metres (1e30 where no solid is seen), and the same as a
    depth texture (distance / ``far``) that the light passes sample with hardware comparison;
    ``near``: the nearest caster's distance (its bounds'), metres."""

    def __init__(self, gl: GLContext, frame: LightFrame, solids: SolidsBuffer, resolution: int):
        ctx = gl.ctx
        self.texture = ctx.texture((resolution, resolution), 1, dtype="f4")
        self.texture.filter = (ctx.NEAREST, ctx.NEAREST)
        self.depth = ctx.depth_texture((resolution, resolution))
        self.depth.compare_func = "<="
        self.depth.filter = (ctx.LINEAR, ctx.LINEAR)
        self.depth.repeat_x = self.depth.repeat_y = False
        fbo = ctx.framebuffer([self.texture], self.depth)
        fbo.use()
        pass_state(ctx, depth_test=True)
        fbo.clear(1e30, 0, 0, 0, depth=1.0)
        lo, hi = solids.bounds
        box = _box_corners(lo, hi)
        if frame.ortho:
            far = frame.far * 1.01
        else:
            far = float(np.linalg.norm(box - frame.position, axis=1).max()) * 1.01
        far = far if far > 0.0 else 1.0         # scale-free: near and far follow the scene
        near = far * 1e-5
        self.far = far
        # The nearest caster's distance from the face's origin (a sun: its depth below the face's
        # plane), each mesh's bounds, metres: how far a soft shadow's blocker search reaches.
        pos = frame.position
        if frame.ortho:
            axis, top = frame.world_to_light[2, :3], frame.world_to_light[2, 3]
            depths = [-float(np.max(_box_corners(a, b) @ axis + top)) for a, b, _ in solids.parts]
        else:
            depths = [float(np.linalg.norm(np.maximum(np.maximum(a - pos, pos - b), 0.0)))
                      for a, b, _ in solids.parts]
        self.near = max(min(depths, default=far), far * 1e-3)
        prog = gl.program("shadow_map.vert", "shadow_map.frag")
        set_matrix(prog, "u_light_clip", frame.clip_matrix(near, far))
        set_matrix(prog, "u_world_to_light", frame.world_to_light)
        set_uniforms(prog, u_light_pos=tuple(frame.position), u_shadow_far=far, u_face_ortho=int(frame.ortho))
        bind_units(prog)
        solids.materials.bind_to_uniform_block(BLOCK["Materials"])
        vao = ctx.vertex_array(prog, [(solids.vbo, POSITION_HIT, "in_position", "in_hit")])
        vao.render(vertices=solids.vertex_count)
        pass_state(ctx)
        vao.release()
        fbo.release()

    def release(self) -> None:
        self.texture.release()
        self.depth.release()
