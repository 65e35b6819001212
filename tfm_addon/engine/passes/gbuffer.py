"""Pass 2: the solids seen from the camera (albedo, distance, normal)."""

from __future__ import annotations

from ..camera import ViewPlane, camera_to_world, clip_matrix
from ..gl_context import GLContext, set_matrix, set_uniforms
from ..scene import Camera
from ..surface import table_blocks
from .bindings import BLOCK, UNIT, bind_units, pass_state
from .solids import FORMAT, SolidsBuffer
from .surface_textures import SurfaceTextures


class GBuffer:
    """Two RGBA32F textures the size of the pixel window: (base colour, distance along the view
    ray in metres) and (world normal as two octahedral floats, roughness and metallic packed in
    one, the hit flag: 1 + 2 k where a surface of material k of the solids' table is seen, 2 where
    a holdout is seen; shaders/gbuffer_pack.glsl), with their
    framebuffer and depth buffer. A surface of alpha below 1 is drawn at that fraction of the
    pixels and samples (shaders/gbuffer.frag). ``draw`` re-renders the contents for a view into the same GL
    objects, so that samples that only move the camera (antialiasing jitter) allocate nothing."""

    def __init__(self, gl: GLContext, size: tuple[int, int]):
        ctx = gl.ctx
        self.size = (int(size[0]), int(size[1]))
        self.albedo_distance = ctx.texture(self.size, 4, dtype="f4")
        self.normal_hit = ctx.texture(self.size, 4, dtype="f4")
        for t in (self.albedo_distance, self.normal_hit):
            t.filter = (ctx.NEAREST, ctx.NEAREST)
        self.depth = ctx.depth_renderbuffer(self.size)
        self.fbo = ctx.framebuffer([self.albedo_distance, self.normal_hit], self.depth)
        self._vao = None
        self._vao_solids = None   # the SolidsBuffer the vertex array reads (held: compared by identity)
        self._solids = None       # the SolidsBuffer drawn: its material table is bound with the textures
        self._tables = [ctx.buffer(b) for b in table_blocks()]
        self._textures = None     # SurfaceTextures, made for the first textured solids drawn

    def draw(self, gl: GLContext, camera: Camera, plane: ViewPlane, solids: SolidsBuffer,
             alpha_seed: float = 0.0) -> None:
        """Render ``solids`` seen by ``camera`` (``plane`` its pixel window, of this size);
        ``alpha_seed`` in [0, 1), the sample's: which pixels a surface of alpha below 1 covers."""
        ctx = gl.ctx
        self.fbo.use()
        pass_state(ctx, depth_test=True)
        self.fbo.clear(0, 0, 0, 0, depth=1.0)
        self._solids = solids
        if solids.vertex_count:
            prog = gl.program("gbuffer.vert", "gbuffer.frag")
            c2w = camera_to_world(camera)
            set_matrix(prog, "u_camera_clip", clip_matrix(camera))
            set_uniforms(prog, u_camera_pos=tuple(c2w[:3, 3]), u_camera_forward=tuple(-c2w[:3, 2]),
                         u_ortho=int(plane.ortho), u_alpha_seed=float(alpha_seed))
            bind_units(prog)
            solids.materials.bind_to_uniform_block(BLOCK["Materials"])
            if self._vao_solids is not solids:
                if self._vao is not None:
                    self._vao.release()
                self._vao = ctx.vertex_array(prog, [(solids.vbo, FORMAT, "in_position", "in_normal",
                                                     "in_albedo", "in_hit", "in_rough_metal")])
                self._vao_solids = solids
            self._vao.render(vertices=solids.vertex_count)
        pass_state(ctx)
        if solids.textured and solids.coords_count:
            if self._textures is None:
                self._textures = SurfaceTextures(gl, self.size, self.depth)
            self._textures.apply(gl, camera, solids, self.albedo_distance, self.normal_hit)

    def bind(self) -> None:
        self.albedo_distance.use(UNIT["u_gb0"])
        self.normal_hit.use(UNIT["u_gb1"])
        if self._solids is not None:
            self._solids.materials.bind_to_uniform_block(BLOCK["Materials"])
        self._tables[0].bind_to_uniform_block(BLOCK["GgxFresnel"])
        self._tables[1].bind_to_uniform_block(BLOCK["GgxAlbedo"])

    def release(self) -> None:
        if self._vao is not None:
            self._vao.release()
            self._vao, self._vao_solids = None, None
        self._solids = None
        if self._textures is not None:
            self._textures.release()
        for b in self._tables:
            b.release()
        self.fbo.release()
        self.depth.release()
        self.albedo_distance.release()
        self.normal_hit.release()
