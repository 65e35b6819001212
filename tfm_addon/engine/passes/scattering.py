"""Pass 4: per light face, the light scattered toward the camera and the solids' radiance."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .. import multiple_scattering
from ..camera import ViewPlane, camera_to_world, pixel_window
from ..gl_context import GLContext, set_matrix, set_uniforms
from ..light import PROFILE_COSINE, area_emission_far
from ..scene import Camera, Medium, RenderSettings
from .bindings import (
    MEDIUM_BOX,
    MEDIUM_EVERYWHERE,
    MEDIUM_GRID,
    MEDIUM_NONE,
    BackgroundTexture,
    MediaGPU,
    bind_light,
    bind_units,
    pass_state,
)

# How a light pass finds the transmittance from the light (the shader's LIGHT_T).
# LIGHT_T_UNIT: the light reaches the medium but its transmittance is taken as 1 ('UNSHADOWED').
LIGHT_T_TFM, LIGHT_T_MARCH, LIGHT_T_ANALYTIC, LIGHT_T_NONE, LIGHT_T_UNIT = 0, 1, 2, 3, 4

def grey_extinction(medium: Medium | None, medium_gpu: MediaGPU, tfm_sigma_t=None) -> bool:
    """Whether the extinction of every medium a light pass marches (and of the TFM it reads) is the
    same in the three channels, so that every transmittance is grey (the shader's GREY_EXTINCTION:
    one exponential per sample instead of three)."""
    coefficients = [s.medium.sigma_t for s in medium_gpu.slots if s.medium is not None]
    if medium_gpu.fog is not None:
        coefficients.append(medium_gpu.fog.sigma_t)
    if medium is not None:
        coefficients.append(medium.sigma_t)
    if tfm_sigma_t is not None:
        coefficients.append(tfm_sigma_t)
    return all(float(np.ptp(np.asarray(c, np.float64))) == 0.0 for c in coefficients)


WORLD_TAPS = 12            # a world sun's directions read per pixel on a surface in a frame of one sample ...
WORLD_TAPS_PER_FRAME = 48  # ... and at least this many over a frame's samples (3 a sample from 16 on)


def world_taps(frame_samples: int) -> int:
    """The directions a world sun's cone is read in per pixel and sample on a surface
    (shaders/world_soft.glsl): WORLD_TAPS_PER_FRAME over the frame's samples, 3 to WORLD_TAPS."""
    return int(min(WORLD_TAPS, max(3, math.ceil(WORLD_TAPS_PER_FRAME / max(int(frame_samples), 1)))))


def face_defines(frame, shadow, gobo) -> dict:
    """The light pass's FACE_KIND defines for a face: orthographic (a sun) or not, its emission
    profile, whether it has a shadow map and a gobo (each face kind compiles its own program; the
    other passes read the face from uniforms)."""
    return {"FACE_KIND": 1, "FACE_ORTHO": int(frame.ortho), "FACE_PROFILE": int(frame.profile),
            "FACE_SHADOW": int(shadow is not None), "FACE_GOBO": int(gobo is not None),
            "FACE_WORLD_SOFT": int(frame.world_spread > 0.0)}


class ScatteringTargets:
    """Three RGBA32F textures the size of the pixel window that the light passes add into:
    scattered light, solids' radiance (before the medium in front of them), view transmittance;
    and the combined image made from them."""

    def __init__(self, gl: GLContext, size: tuple[int, int]):
        ctx = gl.ctx
        self.size = size
        self.textures = [ctx.texture(size, 4, dtype="f4") for _ in range(3)]
        self.fbo = ctx.framebuffer(self.textures)
        self.combined = ctx.texture(size, 4, dtype="f4")
        self.combined_fbo = ctx.framebuffer([self.combined])
        self.composing_fbo = ctx.framebuffer([*self.textures, self.combined])
        self.flipped = False        # the combined image's rows: top row first (compose) or not

    def begin(self, ctx, clear: bool = True, composing: bool = False) -> None:
        """Bind the targets for the light passes; ``clear``: zero them first (needed only where a
        pixel that the first pass does not draw is read: the first pass writes, the others add);
        ``composing``: a lone pass that writes the combined image too (run_light_pass's
        ``compose``), bottom row first."""
        self.flipped = composing
        (self.composing_fbo if composing else self.fbo).use()
        pass_state(ctx, blend=True)
        if clear:
            self.fbo.clear(0, 0, 0, 0)

    def compose(self, gl: GLContext, backdrop: Backdrop) -> None:
        """Write the combined image (blending off), the world behind everything from ``backdrop``."""
        pass_state(gl.ctx)
        self.flipped = False
        self.combined_fbo.use()
        gl.draw_fullscreen(self.composite_program(gl, backdrop, {"TOP_ROW_FIRST": 1}))

    def composite_program(self, gl: GLContext, backdrop: Backdrop, defines=None):
        """composite.frag with ``defines``, reading these targets (and the bound G-buffer)."""
        prog = gl.program("fullscreen.vert", "composite.frag", {**(defines or {}), **backdrop.defines()})
        for unit, (name, tex) in enumerate(zip(("u_scatter", "u_surface", "u_transmittance"),
                                               self.textures, strict=True), start=11):
            tex.use(unit)
            prog[name].value = unit
        prog["u_gb1"].value = 1
        backdrop.bind(prog)
        return prog

    def read_combined(self) -> np.ndarray:
        """(h, w, 4) float32, top row first (``compose`` writes the rows in that order and they
        are read straight into a new array; a composing pass writes them bottom row first)."""
        w, h = self.size
        out = np.empty((h, w, 4), np.float32)
        self.combined.read_into(out)
        return np.ascontiguousarray(out[::-1]) if self.flipped else out

    def read_passes(self) -> dict[str, np.ndarray]:
        """The passes as (h, w, 3) float32 arrays, top row first."""
        w, h = self.size
        scatter, surface, transmittance = (
            np.frombuffer(t.read(), dtype=np.float32).reshape(h, w, 4)[::-1, :, :3] for t in self.textures)
        return {"scattering": np.ascontiguousarray(scatter),
                "surfaces": np.ascontiguousarray(surface * transmittance),
                "transmittance": np.ascontiguousarray(transmittance)}

    def release(self) -> None:
        self.fbo.release()
        self.combined_fbo.release()
        self.composing_fbo.release()
        for t in [*self.textures, self.combined]:
            t.release()


@dataclasses.dataclass(frozen=True)
class Backdrop:
    """What a composed pixel shows behind the medium where no solid is seen: nothing (a
    transparent film), a constant world (``world``, RGB) or the world by direction (``image``, a
    BackgroundTexture, seen through the camera's view plane)."""

    film_transparent: bool
    world: tuple[float, float, float]
    image: BackgroundTexture | None
    camera: Camera
    plane: ViewPlane

    def defines(self) -> dict[str, int]:
        return {"BACKGROUND_IMAGE": 1} if self.image is not None else {}

    def bind(self, prog) -> None:
        set_uniforms(prog, u_film_transparent=int(bool(self.film_transparent)),
                     u_world=tuple(float(c) for c in self.world))
        if self.image is not None:
            camera_uniforms(prog, self.camera, self.plane)
            self.image.bind(prog)


def camera_uniforms(prog, camera: Camera, plane: ViewPlane) -> None:
    set_matrix(prog, "u_camera_to_world", camera_to_world(camera))
    set_uniforms(prog, u_plane0=(plane.x0, plane.y0), u_pixel_size=plane.pixel_size,
                 u_ortho=int(plane.ortho), u_clip=(camera.clip_start, camera.clip_end),
                 u_window_origin=tuple(float(v) for v in pixel_window(camera)[:2]))


def run_light_pass(gl: GLContext, *, camera: Camera, plane: ViewPlane, medium: Medium | None,
                   medium_gpu: MediaGPU, settings: RenderSettings, ambient, first: bool,
                   light=None, light_t: int = LIGHT_T_NONE, tfm=None, tfm_sigma_t=None,
                   attributes=None, active=None, compose=None, sums=None,
                   medium_shadow: bool = True, ambient_surface=None, soft=None, fire=None,
                   unlit=((0, 0, 0, 0), ()), fluence=None, march: bool = True) -> None:
    """Add one pass into the bound ScatteringTargets. ``light`` is (face, intensity, ShadowMap
    or None, gobo texture or None[, (weight on the media, weight on the surfaces)]) or None for the
    ambient-only first pass (``ambient``: the world radiance the media scatter on the first pass,
    ``ambient_surface`` the one the surfaces reflect, default ``ambient``); ``tfm_sigma_t`` the
    extinction per unit of the TFM's weighted density (default: ``medium``'s). ``attributes``
    (emission.AttributesGPU or None): the first medium's emission, added by the first pass, and
    colour grid. ``active``: None (every pixel), or (vertex buffer, count) of rectangles in window
    pixels: only the pixels they cover are shaded (adaptive sampling; the others keep the targets'
    zeros). ``compose``: None, or the Backdrop of a lone first pass that writes the
    combined image too (the targets bound with ``begin(composing=True)``), or with ``sums``
    (accumulate.SampleSums, bound by ``begin_sample``) adds the sample into them instead.
    ``medium_shadow`` False: no solid shadows a point of the media from this face
    (light.solids_may_shadow), their samples skip the shadow map. ``soft``: the light's size
    across the face (light.soft_extent) or None: soft shadows from its shadow map and TFM. ``fire``
    (passes/fire.FireGPU or None): the emitting medium's light on the solids, added by the first pass.
    ``unlit`` (light linking): the material table entries the light does not light (solids.
    unlit_entries' bits) and the media slots it does not light (their indices). ``fluence``
    (passes/fluence.FluenceGPU or None): the diffused light and the surfaces' light, scattered by
    the first pass's media samples; the octaves' slab diffusion term is then left out where it
    holds the diffused light. ``march`` False: a later pass lights the surfaces alone (the world
    field carries the face's light to the media: frame_plan.FacePlan.field)."""
    medium_kind = medium_gpu.kind
    if light is not None and (light_t == LIGHT_T_NONE or not march) and not first:
        medium_kind = MEDIUM_NONE          # this pass's light never reaches the medium
    emits = attributes is not None and first and medium_kind != MEDIUM_NONE and medium.has_emission
    colored = attributes is not None and attributes.color is not None and medium_kind == MEDIUM_GRID
    defines = {"MEDIUM": medium_kind, "LIGHT_T": light_t, "FIRST_PASS": int(first),
               "HAS_LIGHT": int(light is not None),
               "PROJECTIVE": int(settings.sampling == "PROJECTIVE"),
               "EMISSION": attributes.program_kind(medium) if emits else 0, "COLOR_GRID": int(colored),
               "PACKED_DENSITY": attributes.packing(medium, medium_gpu, emits, colored)
               if attributes is not None else 0,
               "EMISSION_GRIDS": attributes.grids_read() if emits else 0,
               "GREY_EXTINCTION": int(grey_extinction(medium, medium_gpu, tfm_sigma_t))}
    if emits and medium_kind == MEDIUM_GRID and attributes.glow_blocks(medium) is not None:
        defines["GLOW_BLOCKS"] = 1      # the constant emission glows in these blocks only
    if active is not None:
        defines["RECTS"] = 1
    if fire is not None and first:
        defines["FIRE_LIGHT"] = 1
    octaves = multiple_scattering.for_settings(settings)
    if fluence is not None and first and medium_kind in (MEDIUM_GRID, MEDIUM_BOX):
        defines["MS_GRID"] = 1
    if fluence is not None and fluence.scattered:
        octaves = dataclasses.replace(octaves, k=0.0)       # the diffused field stands for it
    if light is not None:
        defines.update(face_defines(light[0], light[2], light[3]))
        if light[2] is not None and not medium_shadow:
            defines["MEDIUM_SHADOW"] = 0
        if soft is not None:
            defines["SOFT_SHADOW"] = 1
            defines["AREA_SPREAD"] = int(soft.area_spread[1] > 0.0)
            defines["SOFT_ROUND"] = int(soft.round)
            if light[0].profile == PROFILE_COSINE and not defines["AREA_SPREAD"]:
                defines["AREA_FAR"] = int(area_emission_far(
                    soft, light[0].position, medium_gpu.boxes, None if light[2] is None else light[2].near,
                    medium_gpu.kind == MEDIUM_EVERYWHERE or medium_gpu.fog is not None))
    if compose is not None and sums is not None:
        defines.update(SUMS=1, PASSES=int(sums.passes))
    elif compose is not None:
        defines["COMPOSE"] = 1
    if tfm is not None:
        defines.update(tfm.defines(settings.tfm_filter))
    if medium_kind == MEDIUM_GRID:
        defines.update(medium_gpu.defines())
    if light is not None and medium_kind != MEDIUM_NONE and octaves.count > 1:
        defines["OCTAVES"] = octaves.count
        if octaves.k > 0.0:
            defines["SLAB"] = 1         # the slab diffusion term (no lattice's fields stand for it)
    prog = gl.program("fullscreen.vert", "scatter.frag", defines)
    # The first pass writes the targets ScatteringTargets.begin bound, the others add into them.
    pass_state(gl.ctx, blend=not first or sums is not None)
    bind_units(prog)
    camera_uniforms(prog, camera, plane)
    medium_gpu.bind(prog)
    if medium is not None:
        set_uniforms(prog, u_sigma_s=tuple(float(x) for x in medium.sigma_s),
                     u_sigma_t=tuple(float(x) for x in medium.sigma_t), u_g=float(medium.anisotropy))
    surface_ambient = ambient if ambient_surface is None else ambient_surface
    set_uniforms(prog, u_ambient=tuple(float(x) for x in ambient),
                 u_ambient_surface=tuple(float(x) for x in surface_ambient),
                 u_view_steps=int(settings.view_steps), u_light_steps=int(settings.light_steps),
                 u_view_jitter=-1.0 if settings.view_jitter is None else float(settings.view_jitter))
    if light is not None:
        frame, intensity, shadow, gobo = light[:4]
        bind_light(prog, frame, intensity, settings.map_resolution, shadow, gobo)
        if defines.get("FACE_WORLD_SOFT"):
            set_uniforms(prog, u_world_taps=world_taps(settings.frame_samples))
        set_uniforms(prog, u_light_targets=tuple(light[4]) if len(light) > 4 else (1.0, 1.0, 1.0),
                     u_unlit_entries=tuple(unlit[0]))
        slots = prog.get("u_med_unlit", None)
        if slots is not None:
            values = [float(i in unlit[1]) for i in range(slots.array_length)]
            slots.value = values if len(values) > 1 else values[0]
        if defines.get("SOFT_SHADOW"):
            set_uniforms(prog, u_soft_extent=soft.extent,
                         u_area_u=soft.area_u, u_area_v=soft.area_v, u_area_spread=soft.area_spread,
                         u_soft_near=0.0 if shadow is None else shadow.near,
                         u_soft_seed=0.0 if settings.view_jitter is None else float(settings.view_jitter))
    if "OCTAVES" in defines:
        multiple_scattering.bind(prog, octaves)
    if tfm is not None:
        tfm.bind(prog, medium.sigma_t if tfm_sigma_t is None else tfm_sigma_t)
    if emits or colored:
        attributes.bind(prog, medium, emits)
    if fire is not None and first:
        fire.bind(prog, medium)
    if defines.get("MS_GRID"):
        fluence.bind(prog, (octaves.surface, octaves.grid, octaves.emission))
    if compose is not None:
        compose.bind(prog)
    if active is None:
        gl.draw_fullscreen(prog)
    elif active[1]:
        set_uniforms(prog, u_window=(float(plane.width_px), float(plane.height_px)))
        gl.draw_rects(prog, *active)
