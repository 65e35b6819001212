"""Pass 3: the transmittance function map of one light face (METHOD.md section 3)."""

from __future__ import annotations

import math

import numpy as np

from ..gl_context import GLContext, set_uniforms
from ..light import LightFrame
from .bindings import UNIT, MediaGPU, bind_light, bind_units, pass_state

MAX_COEFFICIENTS = 16
COEF_DTYPE = "f4"      # "f2" (half floats) gives the same SSIM on every bench scene, no faster on llvmpipe
TEXELS_PER_VOXEL = 1.0          # the 'FOOTPRINT' resolution rule (docs/benchmark.md): sharp densities
SMOOTH_TEXELS_PER_VOXEL = 1 / 3  # ... and smooth ones (quality.footprint_texels_per_voxel)
MIN_FOOTPRINT_RESOLUTION = 64


def footprint_resolution(frame: LightFrame, medium, cap: int,
                         texels_per_voxel: float = TEXELS_PER_VOXEL) -> int:
    """The TFM side, texels, for ``tfm_resolution='FOOTPRINT'``: ``texels_per_voxel`` map texels per
    voxel where the medium's non-zero box comes nearest to the light (the map's texels grow
    with distance, so farther voxels get more), a multiple of 16 in
    [MIN_FOOTPRINT_RESOLUTION, cap]; ``cap`` when the light is inside that box."""
    w2b, b2w = medium.world_to_box, medium.box_to_world
    p = w2b[:3, :3] @ frame.position + w2b[:3, 3]
    q = np.clip(p, medium.lo, medium.hi)
    distance = float(np.linalg.norm(b2w[:3, :3] @ (q - p)))
    voxel = float(np.linalg.norm(b2w[:3, :3], axis=0).min())
    if distance <= 0.0 or voxel <= 0.0:
        return int(cap)
    texels = texels_per_voxel * 2.0 * frame.tan_half * distance / voxel
    return int(min(cap, max(MIN_FOOTPRINT_RESOLUTION, 16 * math.ceil(texels / 16))))


def tfm_resolution(settings, frame: LightFrame, medium, map_res: int,
                   image_side: int | None = None, texels_per_voxel: float = TEXELS_PER_VOXEL) -> int:
    """The TFM side for ``settings.tfm_resolution`` (RenderSettings), at most ``map_res``;
    'FOOTPRINT' also at most ``image_side`` (the image's larger side, pixels): a map finer than
    the image is not seen where the medium fits in the frame."""
    r = settings.tfm_resolution
    if r is None:
        return int(map_res)
    if r == "FOOTPRINT":
        cap = map_res if image_side is None else min(map_res, max(int(image_side),
                                                                  MIN_FOOTPRINT_RESOLUTION))
        return footprint_resolution(frame, medium, cap, texels_per_voxel)
    return int(min(max(int(r), 1), map_res))


def coefficient_textures(coefficients: int) -> int:
    """Textures of coefficients beside the K range texture for ``coefficients`` cosines: c0, c1 sit
    in the K range's z, w, then four per texture (2: none, 3-6: one, 7-10: two, ...), so that a
    lookup fetches 1 + this many texels."""
    return max(0, math.ceil((int(coefficients) - 2) / 4))


def map_rect(frame: LightFrame, medium: MediaGPU, resolution: int) -> tuple[int, int, int, int] | None:
    """(x, y, width, height), texels, of a rectangle of the face's map holding every texel whose
    light ray may meet one of the media's boxes (tfm_build.frag marches nothing elsewhere: a
    texel there is F = 1, K range 0); width 0 when no ray meets one; None when the rectangle is
    the whole map (a box behind or around a perspective face's origin). The texels whose centres
    fall in the boxes' projected corners' bounding rectangle, and one more on every side."""
    res = int(resolution)
    lo_uv, hi_uv = np.full(2, np.inf), np.full(2, -np.inf)
    tan = np.asarray(frame.tan_xy, np.float64)
    w2l = np.asarray(frame.world_to_light, np.float64)
    for box_to_world, lo, hi in medium.boxes:
        if any(a >= b for a, b in zip(lo, hi, strict=True)):
            continue                     # an empty box: no ray meets it
        corners = np.array(np.meshgrid(*zip(lo, hi, strict=True), indexing="ij")).reshape(3, -1)
        world = np.asarray(box_to_world, np.float64)[:3, :3] @ corners + np.asarray(box_to_world)[:3, 3:4]
        q = w2l[:3, :3] @ world + w2l[:3, 3:4]
        if frame.ortho:
            uv = 0.5 + 0.5 * q[:2] / tan[:, None]
        else:
            if not (q[2] < 0.0).all():
                return None
            uv = 0.5 + 0.5 * q[:2] / (-q[2] * tan[:, None])
        lo_uv, hi_uv = np.minimum(lo_uv, uv.min(axis=1)), np.maximum(hi_uv, uv.max(axis=1))
    if not np.isfinite(lo_uv).all():
        return (0, 0, 0, 0)
    first = np.clip(np.ceil(lo_uv * res - 0.5) - 1, 0, res)       # texel centres (i + 0.5) / res
    last = np.clip(np.floor(hi_uv * res - 0.5) + 1, -1, res - 1)
    x0, y0 = int(first[0]), int(first[1])
    w, h = max(int(last[0]) - x0 + 1, 0), max(int(last[1]) - y0 + 1, 0)
    if (x0, y0, w, h) == (0, 0, res, res):
        return None
    return (x0, y0, w, h) if w and h else (0, 0, 0, 0)


def draw_in_rect(gl: GLContext, prog, fbo, rect, clear_targets) -> None:
    """Draw ``prog`` over ``fbo`` within ``rect`` (map_rect; None: all of it), the rest of each
    target cleared first to its value in ``clear_targets`` ((texture, rgba) pairs)."""
    if rect is not None:
        for tex, rgba in clear_targets:
            target = gl.ctx.framebuffer([tex])
            target.clear(*rgba)
            target.release()
        fbo.viewport = rect           # gl_FragCoord stays in the map's texels
    fbo.use()
    if rect is None or (rect[2] and rect[3]):
        gl.draw_fullscreen(prog)


def probe_resolution(resolution: int) -> int:
    """The side of largest_density_integral's coarse map for a map of side ``resolution``: its
    texels are wider, so its march may read the grid's level 1 where the map's may not."""
    return max(16, int(resolution) // 4)


def largest_density_integral(gl: GLContext, frame: LightFrame, medium: MediaGPU, resolution: int,
                             light_steps: int, weights=None) -> float:
    """The largest integral of the weighted density (metres at unit density) along the face's
    rays, marched on a coarse map (probe_resolution) that ignores the solids."""
    ctx = gl.ctx
    res = probe_resolution(resolution)
    tex = ctx.texture((res, res), 4, dtype="f4")
    fbo = ctx.framebuffer([tex])
    pass_state(ctx)
    prog = gl.program("fullscreen.vert", "tfm_build.frag", {"OPTICAL_DEPTH_ONLY": 1, "N_COEFF": 1,
                                                            "N_TARGETS": 1, **medium.defines()})
    bind_units(prog)
    medium.bind(prog, weights)
    medium.bind_light_occupancy(medium.may_read_level1(frame, light_steps, res))
    bind_light(prog, frame, (0, 0, 0), res, None, None)
    set_uniforms(prog, u_light_steps=int(light_steps), u_inv_alpha=1.0)
    draw_in_rect(gl, prog, fbo, map_rect(frame, medium, res),
                 [(tex, (0.0, 0.0, 0.0, 1.0))])
    gl.finish()  # wait with the GIL released; the read then only copies
    tau = np.frombuffer(tex.read(), dtype=np.float32).reshape(-1, 4)[:, 0]
    fbo.release()
    tex.release()
    return float(tau.max()) if tau.size else 0.0


class TransmittanceMap:
    """An RGBA32F texture of K_in, K_out (metres from the light) and the first two DCT coefficients
    of F(x) = exp(-tau_D(x) / alpha_D), so that T = F ** (alpha_D * sigma_t) per channel, and
    ``coefficient_textures(n)`` RGBA32F textures of the others, four each."""

    def __init__(self, gl: GLContext, frame: LightFrame, medium: MediaGPU, shadow, resolution: int,
                 light_steps: int, coefficients: int, alpha_d: float, weights=None):
        ctx = gl.ctx
        n = int(min(max(coefficients, 1), MAX_COEFFICIENTS))
        self.coefficients = n
        self.alpha_d = float(alpha_d)
        targets = coefficient_textures(n)
        size = (resolution, resolution)
        self.krange = ctx.texture(size, 4, dtype="f4")
        self.coef = [ctx.texture(size, 4, dtype=COEF_DTYPE) for _ in range(targets)]
        for t in [self.krange, *self.coef]:
            t.filter = (ctx.LINEAR, ctx.LINEAR)      # texelFetch ignores it; 'LINEAR' lookups use it
            t.repeat_x = t.repeat_y = False
        fbo = ctx.framebuffer([self.krange, *self.coef])
        pass_state(ctx)
        prog = gl.program("fullscreen.vert", "tfm_build.frag", {"N_COEFF": n, "N_TARGETS": targets,
                                                                **medium.defines()})
        bind_units(prog)
        medium.bind(prog, weights)
        medium.bind_light_occupancy(medium.may_read_level1(frame, light_steps, resolution))
        bind_light(prog, frame, (0, 0, 0), resolution, shadow, None)
        set_uniforms(prog, u_light_steps=int(light_steps), u_inv_alpha=1.0 / self.alpha_d)
        self.rect = map_rect(frame, medium, resolution)
        draw_in_rect(gl, prog, fbo, self.rect, [(self.krange, (0.0, 0.0, 1.0, 0.0))]
                     + [(t, (0.0, 0.0, 0.0, 0.0)) for t in self.coef])
        fbo.release()

    def defines(self, tfm_filter: str) -> dict[str, int]:
        return {"N_COEFF": self.coefficients, "N_TARGETS": len(self.coef),
                "TFM_FILTER": int(tfm_filter == "LINEAR")}

    def bind(self, prog, sigma_t) -> None:
        """``sigma_t``: the extinction per unit of the map's weighted density, per channel."""
        self.krange.use(UNIT["u_krange"])
        for i, t in enumerate(self.coef):
            t.use(UNIT[f"u_coef{i}"])
        set_uniforms(prog, u_tfm_exponent=tuple(float(self.alpha_d * s) for s in sigma_t))

    def release(self) -> None:
        for t in [self.krange, *self.coef]:
            t.release()
