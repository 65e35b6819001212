"""A diagnostic pass: the transmittance from a light at given points, as the light passes see it."""

from __future__ import annotations

import numpy as np

from ..gl_context import GLContext, set_uniforms
from ..scene import Medium, RenderSettings
from .bindings import MEDIUM_GRID, UNIT, MediaGPU, bind_light, bind_units, pass_state

POINTS_UNIT = UNIT["u_points"]


def probe_light_transmittance(
    gl: GLContext,
    points: np.ndarray,
    *,
    medium: Medium | None,
    medium_gpu: MediaGPU,
    settings: RenderSettings,
    light,
    light_t: int,
    tfm,
    tfm_sigma_t=None,
) -> np.ndarray:
    """(n, 3) float32 transmittance per channel from the light to world ``points`` (n, 3);
    ``light`` is (frame, intensity, ShadowMap or None, gobo or None)."""
    pts = np.ascontiguousarray(np.asarray(points, dtype=np.float32).reshape(-1, 3))
    n = len(pts)
    src = gl.ctx.texture((n, 1), 3, pts.tobytes(), dtype="f4")
    src.filter = (gl.ctx.NEAREST, gl.ctx.NEAREST)
    dst = gl.ctx.texture((n, 1), 4, dtype="f4")
    fbo = gl.ctx.framebuffer([dst])
    fbo.use()
    pass_state(gl.ctx)
    defines = {"MEDIUM": medium_gpu.kind, "LIGHT_T": light_t}
    if medium_gpu.kind == MEDIUM_GRID:
        defines.update(medium_gpu.defines())
    if tfm is not None:
        defines.update(tfm.defines(settings.tfm_filter))
    prog = gl.program("fullscreen.vert", "probe.frag", defines)
    bind_units(prog)
    medium_gpu.bind(prog)
    frame, intensity, shadow, gobo = light
    bind_light(prog, frame, intensity, settings.map_resolution, shadow, gobo)
    if medium is not None:
        set_uniforms(
            prog, u_sigma_t=tuple(float(x) for x in medium.sigma_t), u_light_steps=int(settings.light_steps)
        )
    if tfm is not None:
        tfm.bind(prog, medium.sigma_t if tfm_sigma_t is None else tfm_sigma_t)
    src.use(POINTS_UNIT)
    set_uniforms(prog, u_points=POINTS_UNIT)
    gl.draw_fullscreen(prog)
    out = np.frombuffer(dst.read(), dtype=np.float32).reshape(n, 4)[:, :3].copy()
    for obj in (fbo, dst, src):
        obj.release()
    return out
