"""Textured surfaces: the base colour, roughness and metallic of each pixel where the G-buffer sees
a surface whose input is a node graph (Image Texture on UVs, procedural textures on Generated or
Object coordinates, the colour nodes after them), evaluated on the CPU by
``shading.evaluate_value`` at that pixel's point and written into the G-buffer.

Each antialiasing sample evaluates its own pixels' points, so a texture is point-sampled per
sample and its edges are antialiased by the samples, as in Cycles. The cost is one read-back of
the G-buffer and the graph's numpy evaluation per textured pixel and sample (docs/benchmark.md).
"""

from __future__ import annotations

import numpy as np

from .. import shading
from ..camera import clip_matrix
from ..gl_context import GLContext, set_matrix
from ..scene import Camera
from .bindings import pass_state
from .solids import COORDS_FORMAT, SolidsBuffer


def pack_rough_metal(rough, metal) -> np.ndarray:
    """Roughness and metallic in one float, as gbuffer_pack.glsl packs them."""
    q = np.floor(np.clip(np.stack([rough, metal]), 0.0, 1.0) * 4095.0 + 0.5)
    return (q[0] + 4096.0 * q[1]).astype(np.float32)


class SurfaceTextures:
    """The targets of the texture-coordinate pass of one G-buffer (its size and depth buffer)."""

    def __init__(self, gl: GLContext, size: tuple[int, int], depth):
        ctx = gl.ctx
        self.object_u = ctx.texture(size, 4, dtype="f4")
        self.v = ctx.texture(size, 4, dtype="f4")
        self.fbo = ctx.framebuffer([self.object_u, self.v], depth)
        self._vao = None
        self._vao_solids = None

    def apply(self, gl: GLContext, camera: Camera, solids: SolidsBuffer, albedo_distance,
              normal_hit) -> None:
        """Draw the textured surfaces' coordinates over the G-buffer's depth, evaluate their
        textured inputs per pixel and write them into ``albedo_distance`` (base colour) and
        ``normal_hit`` (roughness and metallic, packed as gbuffer_pack.glsl packs them)."""
        ctx = gl.ctx
        prog = gl.program("surface_coords.vert", "surface_coords.frag")
        set_matrix(prog, "u_camera_clip", clip_matrix(camera))
        if self._vao_solids is not solids:
            if self._vao is not None:
                self._vao.release()
            self._vao = ctx.vertex_array(prog, [(solids.coords_vbo, COORDS_FORMAT, "in_position",
                                                 "in_object", "in_uv")])
            self._vao_solids = solids
        self.fbo.use()
        self.fbo.clear(0, 0, 0, 0)
        pass_state(ctx, depth_test=True)
        ctx.depth_func = "<="
        self.fbo.depth_mask = False
        self._vao.render(vertices=solids.coords_count)
        self.fbo.depth_mask = True
        ctx.depth_func = "<"
        pass_state(ctx)
        w, h = albedo_distance.size
        normal = np.frombuffer(normal_hit.read(), np.float32).reshape(h, w, 4).copy()
        flags = normal[..., 3]
        object_u = np.frombuffer(self.object_u.read(), np.float32).reshape(h, w, 4)
        v = np.frombuffer(self.v.read(), np.float32).reshape(h, w, 4)[..., 0]
        base = np.frombuffer(albedo_distance.read(), np.float32).reshape(h, w, 4).copy()
        packed = False
        for k, surface in solids.textured:
            mask = np.abs(flags - (1.0 + 2.0 * k)) < 0.5
            n = int(np.count_nonzero(mask))
            if n == 0:
                continue
            position = object_u[mask][:, :3].astype(np.float64)
            uv = np.stack([object_u[mask][:, 3], v[mask]], -1).astype(np.float64)
            at = {"n": n, "position": position, "uv": uv}
            if surface.base_texture is not None:
                base[mask, :3] = np.maximum(shading.evaluate_value(surface.base_texture, "RGBA", **at), 0.0)
            if surface.roughness_texture is not None or surface.metallic_texture is not None:
                rough, metal = (np.full(n, constant) if graph is None
                                else shading.evaluate_value(graph, "VALUE", **at)
                                for graph, constant in ((surface.roughness_texture, surface.roughness),
                                                        (surface.metallic_texture, surface.metallic)))
                normal[mask, 2] = pack_rough_metal(rough, metal)
                packed = True
        albedo_distance.write(base.tobytes())
        if packed:
            normal_hit.write(normal.tobytes())

    def release(self) -> None:
        if self._vao is not None:
            self._vao.release()
            self._vao, self._vao_solids = None, None
        self.fbo.release()
        self.object_u.release()
        self.v.release()
