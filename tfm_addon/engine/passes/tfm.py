"""Pass 3: the transmittance function map of one light face (METHOD.md section 3)."""

from __future__ import annotations

import math

import numpy as np

from ..gl_context import GLContext, set_uniforms
from ..light import LightFrame
from .bindings import MediaGPU, bind_light, bind_units, pass_state

MAX_COEFFICIENTS = 16


def largest_density_integral(gl: GLContext, frame: LightFrame, medium: MediaGPU, resolution: int,
                             light_steps: int, weights=None) -> float:
    """The largest integral of the weighted density (metres at unit density) along the face's
    rays, marched on a coarse map that ignores the solids."""
    ctx = gl.ctx
    res = max(16, resolution // 4)
    tex = ctx.texture((res, res), 4, dtype="f4")
    fbo = ctx.framebuffer([tex])
    fbo.use()
    pass_state(ctx)
    prog = gl.program("fullscreen.vert", "tfm_build.frag", {"OPTICAL_DEPTH_ONLY": 1, "N_COEFF": 1,
                                                            "N_TARGETS": 1, **medium.defines()})
    bind_units(prog)
    medium.bind(prog, weights)
    bind_light(prog, frame, (0, 0, 0), res, None, None)
    set_uniforms(prog, u_light_steps=int(light_steps), u_inv_alpha=1.0)
    gl.draw_fullscreen(prog)
    tau = np.frombuffer(tex.read(), dtype=np.float32).reshape(-1, 4)[:, 0]
    fbo.release()
    tex.release()
    return float(tau.max()) if tau.size else 0.0


class TransmittanceMap:
    """K_in/K_out (metres from the light) and ceil(n / 4) RGBA32F textures of DCT coefficients of
    F(x) = exp(-tau_D(x) / alpha_D), so that T = F ** (alpha_D * sigma_t) per channel."""

    def __init__(self, gl: GLContext, frame: LightFrame, medium: MediaGPU, shadow, resolution: int,
                 light_steps: int, coefficients: int, alpha_d: float, weights=None):
        ctx = gl.ctx
        n = int(min(max(coefficients, 1), MAX_COEFFICIENTS))
        self.coefficients = n
        self.alpha_d = float(alpha_d)
        targets = math.ceil(n / 4)
        size = (resolution, resolution)
        self.krange = ctx.texture(size, 4, dtype="f4")
        self.coef = [ctx.texture(size, 4, dtype="f4") for _ in range(targets)]
        for t in [self.krange, *self.coef]:
            t.filter = (ctx.LINEAR, ctx.LINEAR)      # texelFetch ignores it; 'LINEAR' lookups use it
            t.repeat_x = t.repeat_y = False
        fbo = ctx.framebuffer([self.krange, *self.coef])
        fbo.use()
        pass_state(ctx)
        prog = gl.program("fullscreen.vert", "tfm_build.frag", {"N_COEFF": n, "N_TARGETS": targets,
                                                                **medium.defines()})
        bind_units(prog)
        medium.bind(prog, weights)
        bind_light(prog, frame, (0, 0, 0), resolution, shadow, None)
        set_uniforms(prog, u_light_steps=int(light_steps), u_inv_alpha=1.0 / self.alpha_d)
        gl.draw_fullscreen(prog)
        fbo.release()

    def defines(self, tfm_filter: str) -> dict[str, int]:
        return {"N_COEFF": self.coefficients, "N_TARGETS": len(self.coef),
                "TFM_FILTER": int(tfm_filter == "LINEAR")}

    def bind(self, prog, sigma_t) -> None:
        """``sigma_t``: the extinction per unit of the map's weighted density, per channel."""
        self.krange.use(5)
        for i, t in enumerate(self.coef):
            t.use(6 + i)
        set_uniforms(prog, u_tfm_exponent=tuple(float(self.alpha_d * s) for s in sigma_t))

    def release(self) -> None:
        for t in [self.krange, *self.coef]:
            t.release()
