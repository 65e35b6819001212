"""A pass that evaluates a light face at given points as the light passes see it: the transmittance
from the light (diagnostics, tests), the light arriving at points of the media or the irradiance of
surfaces (the fields of engine/diffusion.py)."""

from __future__ import annotations

import numpy as np

from .. import multiple_scattering
from ..gl_context import GLContext, set_uniforms
from ..scene import Medium, RenderSettings
from .bindings import MEDIUM_GRID, UNIT, MediaGPU, bind_light, bind_units, pass_state

POINTS_UNIT = UNIT["u_points"]
NORMALS_UNIT = UNIT["u_normals"]
ROW = 4096                          # points per row of the probe's image
TRANSMITTANCE, ARRIVING, IRRADIANCE, SCATTERED = 0, 1, 2, 3


def probe_light(
    gl: GLContext,
    points: np.ndarray,
    what: int,
    normals: np.ndarray | None = None,
    *,
    medium: Medium | None,
    medium_gpu: MediaGPU,
    settings: RenderSettings,
    light,
    light_t: int,
    tfm,
    tfm_sigma_t=None,
    octaves=None,
) -> np.ndarray:
    """(n, 3) float32 per channel at world ``points`` (n, 3): ``what`` is TRANSMITTANCE from the
    light, the light ARRIVING (past the solids and media), or the IRRADIANCE of surfaces of unit
    ``normals`` (n, 3) there; ``light`` is (frame, intensity, ShadowMap or None, gobo or None).
    SCATTERED: the light that media of albedo ``normals`` (n, 3) scatter there, times 4 pi, by
    ``octaves`` (multiple_scattering.Octaves, None: single scattering; their slab term left out)."""
    n = len(points)
    w = max(1, min(n, ROW))
    h = -(-n // w)

    def image(values):
        a = np.zeros((w * h, 3), np.float32)
        a[:n] = np.asarray(values, np.float32).reshape(-1, 3)
        tex = gl.ctx.texture((w, h), 3, a.tobytes(), dtype="f4")
        tex.filter = (gl.ctx.NEAREST, gl.ctx.NEAREST)
        return tex

    src = image(points)
    nrm = image(normals) if normals is not None else None
    dst = gl.ctx.texture((w, h), 4, dtype="f4")
    fbo = gl.ctx.framebuffer([dst])
    fbo.use()
    pass_state(gl.ctx)
    defines = {"MEDIUM": medium_gpu.kind, "LIGHT_T": light_t, "PROBE": what}
    if what == SCATTERED and octaves is not None and octaves.count > 1:
        defines["OCTAVES"] = octaves.count
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
    if "OCTAVES" in defines:
        multiple_scattering.bind(prog, octaves)
    src.use(POINTS_UNIT)
    set_uniforms(prog, u_points=POINTS_UNIT)
    if nrm is not None:
        nrm.use(NORMALS_UNIT)
        set_uniforms(prog, u_normals=NORMALS_UNIT)
    gl.draw_fullscreen(prog)
    out = np.frombuffer(dst.read(), dtype=np.float32).reshape(w * h, 4)[:n, :3].copy()
    for obj in (fbo, dst, src, nrm):
        if obj is not None:
            obj.release()
    return out
