"""The renderer: runs the passes for a scene and keeps what it built until it goes stale."""

from __future__ import annotations

import dataclasses
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import diffusion, environment, medium_attributes, multiple_scattering, shading, surface, world_light
from .adaptive import ActivePixels
from .camera import view_plane
from .errors import RenderCancelled
from .fire_light import content_key as fire_content_key
from .fire_light import fire_light
from .fire_light import placement as fire_placement
from .frame_plan import FacePlan, FramePlan, plan_faces, plan_frame
from .gl_context import GLContext
from .light import (
    LightFrame,
    cone_warning,
    is_dark,
    soft_extent,
    solids_may_shadow,
    why_dark,
)
from .medium_grid import grid_allowances, prepare_grid
from .output import RenderOutput
from .passes.accumulate import SampleSums
from .passes.bindings import (
    MAX_GRIDS,
    MAX_MEDIA,
    MEDIUM_BOX,
    MEDIUM_EVERYWHERE,
    MEDIUM_GRID,
    MEDIUM_NONE,
    BackgroundTexture,
    MediaGPU,
    MediumGPU,
    MediumSlot,
    gobo_texture,
    has_sparse_unit,
    max_grids,
    pass_state,
)
from .passes.emission import AttributesGPU
from .passes.fire import FireGPU, has_fire_unit
from .passes.fluence import FluenceGPU, has_fluence_units
from .passes.gbuffer import GBuffer
from .passes.probe import ARRIVING, IRRADIANCE, SCATTERED, TRANSMITTANCE, probe_light
from .passes.scattering import (
    LIGHT_T_MARCH,
    LIGHT_T_NONE,
    LIGHT_T_TFM,
    Backdrop,
    ScatteringTargets,
    run_light_pass,
)
from .passes.shadow_map import ShadowMap
from .passes.solids import SolidsBuffer, unlit_entries
from .passes.tfm import (
    TransmittanceMap,
    coefficient_textures,
    largest_density_integral,
    probe_resolution,
)
from .quality import auto_settings, light_density_integral
from .scene import Light, Medium, RenderSettings, Scene
from .sparse_grid import dense_factor, dense_means, grid_bytes, prepare_sparse


def prepare_scene(scene: Scene, settings: RenderSettings | None) -> Scene:
    """What a frame renders of ``scene``: its media's node graphs evaluated and, with
    ``world_light='SHADOWED'``, the world's light as shadowed suns. Idempotent (a prepared scene
    comes back as it is), so every sample of a frame renders the same scene object."""
    scene = shading.resolve_scene(scene)
    s = settings or RenderSettings()
    if s.world_light == "SHADOWED" and s.ambient:
        scene = world_light.with_world_light(scene, s.world_directions)
    return scene


def _media_notes(scene: Scene) -> list[str]:
    """What the renderer leaves out of the media, said once each: the emission of a medium that
    also scatters is scattered (Renderer._fluence) for the first medium marched, when a density
    grid."""
    return [f"Medium '{m.name}' emits and scatters: its own emission is not scattered by it (Cycles "
            f"lights the medium with it even with no bounces, a few per cent brighter)"
            for i, m in enumerate(scene.media) if m.has_emission and m.lights_medium and max(m.sigma_s) > 0.0
            and (i > 0 or m.density is None)]


def effective_settings(scene: Scene, settings: RenderSettings | None) -> RenderSettings:
    """The settings a frame renders with: ``quality='AUTO'`` lets quality.auto_settings choose."""
    settings = settings or RenderSettings()
    return auto_settings(scene, settings) if settings.quality == "AUTO" else settings


class _Cache:
    """GPU resources by the key of what they depend on, shared by the renderer's clients
    (viewport, final, preview...). An entry lives while the last completed frame of any client
    used it: a frame releases what neither it nor another client's last frame used, so one
    client never evicts another's maps. An entry is stored only once its build returned
    (complete); ``fresh`` holds the keys built by the frame in flight, which ``drop_fresh``
    releases when that frame fails."""

    def __init__(self):
        self.items: dict = {}
        self.used: set = set()
        self.fresh: set = set()
        self.kept: dict[str, set] = {}       # client -> keys its last completed frame used
        self.done: dict[str, set] = {}       # client -> keys its last completed, sweeping frame used

    def get(self, key, build: Callable):
        self.used.add(key)
        if key not in self.items:
            item = build()
            self.items[key] = item
            self.fresh.add(key)
            return item, True
        return self.items[key], False

    def keep(self, key):
        """The item stored under ``key``, kept by this frame as ``get`` keeps it, or None (nothing
        is built)."""
        if key not in self.items:
            return None
        self.used.add(key)
        return self.items[key]

    def drop_fresh(self) -> None:
        for key in self.fresh:
            item = self.items.pop(key, None)
            if hasattr(item, "release"):
                item.release()
        self.fresh.clear()

    def sweep(self, client: str | None = None, release: bool = True) -> None:
        """End a frame of ``client``: keep what it used, release what no client's last frame
        used. ``release=False`` adds what it used to what the client kept and releases nothing.
        ``client=None`` forgets every client (``clear``)."""
        if client is None:
            self.kept.clear()
            self.done.clear()
        elif release:
            self.kept[client] = set(self.used)
            self.done[client] = set(self.used)
        else:
            self.kept.setdefault(client, set()).update(self.used)
        self.used.clear()
        self.fresh.clear()
        if release:
            self._release_unkept()

    def cancelled(self, client: str) -> None:
        """End a cancelled frame of ``client`` (its builds are complete): keep what it used with
        what the client's last completed frame used, and release the rest, so that a run of
        cancelled frames (a drag in the viewport) holds the maps of two frames, not of every one."""
        self.kept[client] = self.done.get(client, set()) | self.used
        self.used.clear()
        self.fresh.clear()
        self._release_unkept()

    def forget(self, client: str) -> None:
        """Release what only ``client`` kept (it will render no more frames for now)."""
        self.kept.pop(client, None)
        self.done.pop(client, None)
        self._release_unkept()

    def _release_unkept(self) -> None:
        live = set().union(*self.kept.values())
        for key in list(self.items):
            if key not in live:
                item = self.items.pop(key)
                if hasattr(item, "release"):
                    item.release()

    def clear(self) -> None:
        self.used.clear()
        self.sweep()


@dataclass
class _LightPlan:
    """One face of a light, as its light pass reads it."""

    light: Light
    frame: LightFrame
    light_t: int
    shadow: ShadowMap | None
    tfm: TransmittanceMap | None
    gobo: object | None
    tfm_sigma_t: np.ndarray | None = None
    medium_shadow: bool = True      # a solid may shadow the media (light.solids_may_shadow)
    field: bool = False             # the media take its light from the world field (FacePlan.field)


class Renderer:
    """Renders scenes with one OpenGL context, created on first use on the calling thread;
    every call must come from that thread (see worker.RenderWorker).

    ``counters`` counts what was built: 'grid_uploads', 'grid_levels' (a grid's coarser level
    for the light marches, made once per upload when a light first asks for it), 'shadow_maps',
    'tfms', 'gbuffers' (G-buffer
    contents drawn, one per new view; 'gbuffer_objects' counts the GL textures and framebuffers
    they were drawn into, reused across views of one size),
    'light_passes', 'renders' (maps and passes per light face), and 'faces_culled' (faces of
    point and area lights that reach neither a medium nor a visible solid: no maps, no pass);
    'pixels_shaded': pixels the light passes of a frame shaded (all of them, or the ``active``
    ones), once per frame; 'samples_reusing_plans': samples of an accumulated frame (``accumulate``)
    that used the media, solids and light plans the frame's first sample prepared; 'sums_objects':
    GL objects made for a frame's sample sums (a later frame of the same size reuses them);
    'fluences': the diffused light and the surfaces' light of a frame with volume bounces
    (engine/diffusion.py), built once per media, lights and solids, whatever the bounce count.
    A camera-only change rebuilds no light map; changing sigma_a or sigma_s of a lone medium
    rebuilds nothing on the light side (unless a fixed density weight ties the map to the
    extinction; with several media a map also depends on their relative extinction).
    """

    def __init__(self, gl: GLContext | None = None):
        self._gl = gl
        self.counters: Counter = Counter()
        self._media = _Cache()
        self._solids = _Cache()
        self._shadows = _Cache()
        self._medium_shadows = _Cache()     # light.solids_may_shadow's answers, by face and media
        self._tfms = _Cache()
        self._gobos = _Cache()
        self._gbuffers = _Cache()
        self._gbuffer_pool: dict[tuple[int, int], list[GBuffer]] = {}  # free G-buffer objects by size
        self._sums_pool: dict[tuple, list[SampleSums]] = {}            # free sample sums by size, passes
        self._targets = _Cache()
        self._attributes = _Cache()
        self._fires = _Cache()
        self._fluences = _Cache()           # diffusion.py's fields on the GPU, and their lattices
        self._backgrounds = _Cache()        # the world behind everything (passes/bindings.BackgroundTexture)
        self._caches = [self._media, self._solids, self._shadows, self._tfms, self._gobos,
                        self._gbuffers, self._targets, self._attributes, self._medium_shadows,
                        self._fires, self._fluences, self._backgrounds]
        self._frame_memos: dict[str, _FrameMemo] = {}   # per client: what the samples of its frame share

    @property
    def gl(self) -> GLContext:
        if self._gl is None:
            self._gl = GLContext()
        return self._gl

    def render(self, scene: Scene, settings: RenderSettings | None = None,
               cancel: Callable[[], bool] | None = None,
               progress: Callable[[float], None] | None = None, passes: bool = True,
               client: str = "final", sweep: bool = True, map_image_side: int | None = None,
               active: ActivePixels | None = None, accumulate=None) -> RenderOutput:
        """Render ``scene``; raises RenderCancelled when ``cancel()`` turns true between passes.
        ``passes=False`` reads back the combined image alone (the viewport's case). ``client``
        names who asks ('viewport', 'final', 'preview', ...): each client's last frame keeps its
        maps, whatever the other clients render in between. ``sweep=False`` also keeps what the
        client's previous frames kept (the viewport's coarse image must not evict the full maps).
        ``map_image_side``: the image side (pixels) a 'FOOTPRINT' TFM is capped by, default the
        camera's larger side (the coarse image passes its full image's, to reuse the full maps).
        ``active``: None, or an adaptive.ActivePixels: the light passes shade only those pixels
        (no light pass touches the others: they come out black; adaptive sampling, sampling.py).
        ``accumulate``: None, or a key naming a frame's sample sums (passes/accumulate.SampleSums,
        ``sample_sums``): the image is added into them on the GPU and nothing is read back (the
        output's ``combined`` is None, its ``passes`` empty)."""
        gl = self.gl
        gl.check_thread()
        scene = prepare_scene(scene, settings)   # node graphs evaluated here, on the render thread
        settings = effective_settings(scene, settings)
        with gl.ctx:     # current for the call, whatever other context the thread made current
            out = self._render(scene, settings, cancel, progress, passes, client, sweep, map_image_side,
                               active, accumulate)
        notes = shading.notes(scene) + _media_notes(scene) + multiple_scattering.notes(scene, settings)
        out.warnings.extend(w for w in notes if w not in out.warnings)
        return out

    def sample_sums(self, key) -> SampleSums | None:
        """The sample sums that renders with ``accumulate=key`` added into, or None."""
        return self._targets.items.get(("sums", key))

    def release_sums(self, key) -> None:
        """Release the sample sums of ``key`` (the frame is done), if any."""
        sums = self._targets.items.pop(("sums", key), None)
        if sums is not None:
            with self.gl.ctx:
                sums.release()

    def forget_client(self, client: str) -> None:
        """Release the maps that only ``client``'s last frame kept."""
        self._frame_memos.pop(client, None)
        if self._gl is not None:
            with self._gl.ctx:
                for cache in self._caches:
                    cache.forget(client)

    def _render(self, scene, settings, cancel, progress, want_passes, client, sweep=True,
                map_image_side=None, active=None, accumulate=None) -> RenderOutput:
        """One frame: its media, solids and plan (``_prepare``: memoised across the samples of an
        accumulated frame), its light maps, then its passes (``_draw``); on the way out the
        caches keep what this frame used."""
        gl = self.gl
        t_start = time.perf_counter()
        lights = [light for light in scene.lights if not is_dark(light)]
        faces_at_most = sum({"POINT": 6, "AREA": 5}.get(light.kind, 1) for light in lights)
        steps = _Steps(gl, progress, cancel, 2 + len(lights) + max(faces_at_most, 1))
        warnings: list[str] = []
        try:
            frame = self._prepare(scene, settings, lights, client, map_image_side, accumulate, active,
                                  warnings, steps)
            combined, passes = self._draw(scene, settings, frame, want_passes, accumulate, active, steps)
        except RenderCancelled:
            self._frame_memos.pop(client, None)
            # Every pass finished (ctx.finish) before the check that cancelled: what the frame
            # cached is complete, and kept for this client's next frame (which, under latest-wins
            # cancellation, likely reuses it) along with what its last completed frame used; what
            # earlier cancelled or coarse frames kept is released.
            for cache in self._caches:
                cache.cancelled(client)
            raise
        except BaseException:
            self._frame_memos.pop(client, None)
            # A pass failed midway: drop whatever this frame built, it may be partial.
            for cache in self._caches:
                cache.drop_fresh()
                cache.used.clear()
            raise
        finally:
            pass_state(gl.ctx)
        for cache in self._caches:
            cache.sweep(client, release=sweep)
        self.counters["renders"] += 1
        steps.timings["total"] = time.perf_counter() - t_start
        chosen = dict(view_steps=settings.view_steps, light_steps=settings.light_steps,
                      coefficients=settings.coefficients, tfm_side=frame.plan.tfm_side)
        return RenderOutput(combined=combined, passes=passes, warnings=_frame_notes(scene, lights, warnings),
                            timings_s=steps.timings, chosen=chosen)

    def _prepare(self, scene, settings, lights, client, map_image_side, accumulate, active, warnings,
                 steps) -> _Frame:
        """The frame's media and attributes on the GPU, its solids, its plan (frame_plan) and the
        light maps the plan asks for; a later sample of an accumulated frame takes what the first
        sample prepared. Adds the frame's warnings to ``warnings``."""
        memo = self._frame_memos.get(client)
        if (memo is not None and accumulate is not None
                and memo.frame == _frame_of(scene, settings, accumulate, client, map_image_side)):
            t0 = time.perf_counter()
            warnings += memo.warnings
            for cache, keys in zip(self._caches, memo.used, strict=True):
                cache.used.update(keys)
            self.counters["faces_culled"] += memo.state.plan.culled
            self.counters["samples_reusing_plans"] += 1
            steps.total = memo.state.plan.steps - len(lights)     # no map step
            steps.step("scene", t0)
            return memo.state
        self._frame_memos.pop(client, None)
        t0 = time.perf_counter()
        medium_gpu, medium_warnings = self._medium(scene, settings)
        warnings += medium_warnings
        # The medium that emits and reads its colour grid: the first one marched (the scene's
        # first may have been skipped: unbounded fog beside other media, an empty grid).
        medium = (medium_gpu.slots[0].medium if medium_gpu.kind == MEDIUM_GRID
                  else scene.media[0] if scene.media else None)
        attributes = self._medium_attributes(medium, medium_gpu)
        warnings += attributes.warnings if attributes is not None else []
        note = attributes.glow_note(medium) if attributes is not None and medium is not None else None
        warnings += [note] if note else []
        casters = self._solid_set(scene.shadow_casters)
        seen = self._solid_set(scene.camera_meshes, lights)
        plan = plan_frame(scene, settings, lights, medium_gpu, casts_shadows=bool(casters.vertex_count),
                          casters_bounds=casters.bounds, seen_bounds=seen.bounds,
                          map_res=self._map_resolution(settings), image_side=map_image_side,
                          accumulate=accumulate is not None, active=active is not None,
                          world_field=has_fluence_units(self.gl))
        self.counters["faces_culled"] += plan.culled
        steps.total = plan.steps
        steps.step("scene", t0)
        built = []
        for light in lights:
            t0 = time.perf_counter()
            gobo = None
            if light.gobo is not None:
                gobo, made = self._gobos.get(light.gobo_key,
                                             lambda light=light: gobo_texture(self.gl, light.gobo))
                self.counters["gobos"] += made
            built += [self._build_face(scene, settings, face, medium_gpu, casters, gobo, warnings)
                      for face in plan.faces if face.light is light]
            steps.step("light_maps", t0)
        world = [p for p in built if p.field]
        if world and all(p.shadow is not None and p.medium_shadow for p in world):
            warnings.append(f"The world's light reaches the media from {len(world)} directions with solids "
                            "in the way of each: light through an opening (a window) lights them as one "
                            "band per direction, where Cycles spreads the opening's sky over them")
        t0 = time.perf_counter()
        fluence = self._fluence(scene, settings, medium_gpu, medium, built, warnings)
        if fluence is not None:
            steps.timings["fluence"] = time.perf_counter() - t0
        frame = _Frame(plan, medium_gpu, medium, attributes, seen, built,
                       self._fire(medium, seen, warnings), fluence)
        if accumulate is not None:
            self._frame_memos[client] = _FrameMemo(
                _frame_of(scene, settings, accumulate, client, map_image_side), frame, list(warnings),
                [set(cache.used) for cache in self._caches], (scene.media, scene.lights, scene.meshes))
        return frame

    def _draw(self, scene, settings, frame: _Frame, want_passes, accumulate, active, steps):
        """The frame's G-buffer and light passes, then its image composed and read back, or added
        into the sample sums of ``accumulate`` (then (None, {}) is returned)."""
        gl = self.gl
        t0 = time.perf_counter()
        plane = view_plane(scene.camera)
        alpha_seed = settings.view_jitter or 0.0      # the sample's: surfaces of alpha below 1
        gbuffer, built = self._gbuffers.get(
            (scene.camera.key, tuple(m.key for m in scene.camera_meshes), alpha_seed,
             tuple(unlit for _, unlit in frame.seen.entries)),      # the hit flags: light linking
            lambda: self._gbuffer_for(scene.camera, plane, frame.seen, alpha_seed))
        self.counters["gbuffers"] += built
        steps.step("gbuffer", t0)

        size = (plane.width_px, plane.height_px)
        targets = self._targets.get(size, lambda: ScatteringTargets(gl, size))[0]
        lone = frame.plan.lone
        backdrop = self._backdrop(scene, settings, plane)
        compose = backdrop if lone else None
        sums = None
        if accumulate is not None:
            sums = self._targets.get(("sums", accumulate), lambda: self._new_sums(size, want_passes))[0]
            if (sums.size, sums.passes) != (size, want_passes):
                raise ValueError(f"sample sums {accumulate!r} are of another image or passes")
        if lone and sums is not None:
            sums.begin_sample()
        else:
            targets.begin(gl.ctx, clear=frame.plan.clear_targets, composing=lone)
        gbuffer.bind()
        ambient = scene.ambient if settings.ambient else (0.0, 0.0, 0.0)
        dark = (0.0, 0.0, 0.0)          # the world's Ray Visibility
        common = dict(camera=scene.camera, plane=plane, medium=frame.medium,
                      medium_gpu=frame.medium_gpu, settings=settings,
                      ambient=ambient if scene.world_lights_medium else dark,
                      ambient_surface=ambient if scene.world_lights_surfaces else dark,
                      attributes=frame.attributes, active=self._active_rects(size, active),
                      compose=compose, sums=sums if lone else None, fire=frame.fire,
                      fluence=frame.fluence)
        self.counters["pixels_shaded"] += (size[0] * size[1] if active is None
                                           else int(np.count_nonzero(active.mask)))
        if frame.plan.lightless_first:
            t0 = time.perf_counter()
            run_light_pass(gl, first=True, **common)
            self.counters["light_passes"] += 1
            steps.step("scattering", t0)
        index = {id(face): i for i, face in enumerate(frame.plan.faces)}
        for i, face in enumerate(frame.plan.passes):
            t0 = time.perf_counter()
            plan = frame.lights[index[id(face)]]
            # a field face is never first (plan_passes): its pass marches nothing
            run_light_pass(gl, first=(i == 0 and not frame.plan.lightless_first), light_t=plan.light_t,
                           tfm=plan.tfm, march=not face.field,
                           light=(plan.frame, plan.light.intensity_w_per_sr, plan.shadow, plan.gobo,
                                  (float(plan.light.lights_medium), float(plan.light.lights_surfaces),
                                   float(plan.light.media_shadow_surfaces))),
                           tfm_sigma_t=plan.tfm_sigma_t, medium_shadow=plan.medium_shadow,
                           soft=soft_extent(plan.light, plan.frame), unlit=self._unlit(plan.light, frame),
                           **common)
            self.counters["light_passes"] += 1
            steps.step("scattering", t0)
        t0 = time.perf_counter()
        if accumulate is not None:
            if not lone:
                sums.add(gl, targets, backdrop, common["active"])
            steps.timings["accumulate"] = time.perf_counter() - t0
            return None, {}
        if not lone:
            targets.compose(gl, backdrop)
        gl.finish()   # the read below then copies without waiting on the GPU
        combined = targets.read_combined()
        passes = targets.read_passes() if want_passes else {}
        steps.timings["readback"] = time.perf_counter() - t0
        return combined, passes

    def _backdrop(self, scene: Scene, settings: RenderSettings, plane) -> Backdrop:
        """What the composed image shows where no solid is seen: a constant world (black with a
        transparent film), or the environment's panorama as wide as the camera's pixels need."""
        seen = (0.0, 0.0, 0.0) if settings.film_transparent else scene.background
        image = None
        if not isinstance(seen, tuple):
            width = environment.panorama_width(scene.camera, seen)
            image, built = self._backgrounds.get(
                (seen.key, width), lambda: BackgroundTexture(self.gl, seen.panorama(width)))
            self.counters["backgrounds"] += built
            seen = (0.0, 0.0, 0.0)
        return Backdrop(settings.film_transparent, seen, image, scene.camera, plane)

    def light_transmittance_at(self, scene: Scene, settings: RenderSettings | None, light_index: int,
                               points: np.ndarray) -> np.ndarray:
        """The transmittance from ``scene.lights[light_index]`` to world ``points`` (n, 3), as the
        camera passes see it (TFM lookup, march or analytic), (n, 3) float32 per channel.
        Builds or reuses that light's maps like ``render``; for tests and diagnostics."""
        gl = self.gl
        gl.check_thread()
        scene = prepare_scene(scene, settings)
        with gl.ctx:
            return self._light_transmittance_at(scene, effective_settings(scene, settings), light_index,
                                                points)

    def _light_transmittance_at(self, scene, settings, light_index, points) -> np.ndarray:
        gl = self.gl
        medium_gpu, _ = self._medium(scene, settings)
        casters = self._solid_set(scene.shadow_casters)
        faces, culled = plan_faces(scene, settings, scene.lights[light_index], medium_gpu,
                                   casts_shadows=bool(casters.vertex_count), casters_bounds=casters.bounds,
                                   seen_bounds=None, map_res=self._map_resolution(settings))
        self.counters["faces_culled"] += culled
        plans = [self._build_face(scene, settings, face, medium_gpu, casters, None, []) for face in faces]
        pts = np.asarray(points, np.float64).reshape(-1, 3)
        out = np.ones((len(pts), 3), np.float32)
        for plan in plans:          # each point from the face it belongs to
            q = pts @ plan.frame.world_to_light[:3, :3].T + plan.frame.world_to_light[:3, 3]
            tan = np.asarray(plan.frame.tan_xy)
            mine = np.ones(len(q), bool) if plan.light.kind in ("SPOT", "SUN") else (
                (q[:, 2] < 0) & np.all(np.abs(q[:, :2]) <= -q[:, 2:3] * tan, axis=1))
            if not mine.any():
                continue
            out[mine] = probe_light(
                gl, pts[mine], TRANSMITTANCE, medium=scene.media[0] if scene.media else None,
                medium_gpu=medium_gpu, settings=settings,
                light=(plan.frame, plan.light.intensity_w_per_sr, plan.shadow, None),
                light_t=plan.light_t, tfm=plan.tfm, tfm_sigma_t=plan.tfm_sigma_t)
        for cache in self._caches:
            cache.used.clear()          # a probe keeps every map for the next render
            cache.fresh.clear()
        return out

    def _fluence(self, scene, settings, medium_gpu, medium, plans, warnings) -> FluenceGPU | None:
        """The frame's lattice fields (engine/diffusion.py) where it marches media and needs them:
        the world field where world faces light the media through it (frame_plan), the diffused
        light and surfaces' light where its bounce count asks for them, the media's emission.
        Built from the faces' maps or cached by what they depend on (the bounce count only with a
        world field: its octaves); counter 'fluences'. The viewport's coarse image
        (``settings.lattice`` False) reads the fields where built, and builds the world field
        alone where none is."""
        if medium_gpu.kind == MEDIUM_GRID:
            media = [s.medium for s in medium_gpu.slots]
            media_key = ("lattice",) + tuple(_slot_key(s) + (s.medium.key,) for s in medium_gpu.slots)
        elif medium_gpu.kind == MEDIUM_BOX and medium_gpu.fog is None:
            media = [medium]
            media_key = ("lattice", medium.key)
        else:
            return None
        # The first medium's own emission, scattered by the media (a fire lighting its smoke):
        # Cycles renders it at every bounce count, 0 included.
        emits = (medium_gpu.kind == MEDIUM_GRID and medium.has_emission and medium.lights_medium
                 and any(max(m.sigma_s) > 0.0 for m in media))
        world = [p for p in plans if p.field]
        if not plans and not emits:
            return None
        key = (media_key,
               tuple((p.light.key, p.frame.key, p.light_t, p.light.lit_media, p.field) for p in plans),
               scene.solids_key,
               tuple(m.key for m in scene.meshes if not m.holdout), self._map_resolution(settings),
               settings.light_steps, settings.coefficients, settings.density_weight, settings.tfm_filter,
               emits, multiple_scattering.for_settings(settings) if world else None)
        scattered = bool(multiple_scattering.for_settings(settings).fields or emits)
        if not (scattered or world) or not settings.lattice:
            # a frame without them keeps them for the next with; one that builds none (the
            # viewport's coarse image) reads them where they are built
            item = self._fluences.keep(key + (True,))
            self._fluences.keep(media_key)
            if not (scattered or world):
                return None
            if item is not None or not world:
                return self._fluence_read(item, medium, warnings)
            scattered = False       # the coarse image: the world field alone, cheap
        if not has_fluence_units(self.gl):
            warnings.append("This OpenGL has too few texture units for the light scattered many times, "
                            "the light the surfaces reflect into the media and the media's own emission "
                            "scattered by them: they are left out.")
            return None

        def probe(plan, points, normals=None):
            return probe_light(
                self.gl, points, IRRADIANCE if normals is not None else ARRIVING, normals,
                medium=medium, medium_gpu=medium_gpu, settings=settings,
                light=(plan.frame, plan.light.intensity_w_per_sr, plan.shadow, plan.gobo),
                light_t=plan.light_t, tfm=plan.tfm, tfm_sigma_t=plan.tfm_sigma_t)

        def arriving(points, normals):
            total = np.zeros((len(points), 3))
            for plan in plans:
                if normals is not None and plan.light.lights_surfaces:
                    total += probe(plan, points, normals)
                elif normals is None and plan.light.lights_medium and plan.light.lit_media is None:
                    total += probe(plan, points)
            return total

        octaves = multiple_scattering.for_settings(settings)

        def scattered_by(points, albedo, plans):
            """The light of ``plans`` scattered at ``points`` by media of ``albedo`` (the octaves)."""
            total = np.zeros((len(points), 3))
            for plan in plans:
                total += probe_light(
                    self.gl, points, SCATTERED, albedo, medium=medium, medium_gpu=medium_gpu,
                    settings=settings,
                    light=(plan.frame, plan.light.intensity_w_per_sr, plan.shadow, plan.gobo),
                    light_t=plan.light_t, tfm=plan.tfm, tfm_sigma_t=plan.tfm_sigma_t, octaves=octaves)
            return total

        # light linking: a light that lights some media only is scattered first by those alone
        linked = [(lambda points, plan=plan: probe(plan, points), plan.light.lit_media) for plan in plans
                  if plan.light.lights_medium and plan.light.lit_media is not None]

        def build():
            self.counters["fluences"] += 1
            lat = self._fluences.get(media_key, lambda: _Value(diffusion.lattice(media)))[0].value
            if lat is None:
                return _Value(None)
            emitted, points = _emission_light(medium) if emits and scattered else (None, 0)
            sky = (lambda points, albedo: scattered_by(points, albedo, world)) if world else None
            fields = diffusion.fluence(lat, scene.meshes, arriving, emitted, linked, world=sky,
                                       scattered=scattered)
            gpu = FluenceGPU(self.gl, fields)
            gpu.emission_points = points
            return gpu

        item = self._fluences.get(key + (scattered,), build)[0]
        self._fluences.keep(media_key)      # the lattice: for the fields of the next lights
        return self._fluence_read(item, medium, warnings)

    @staticmethod
    def _fluence_read(item, medium, warnings: list[str]) -> FluenceGPU | None:
        """The fields ``item`` (a cache entry, or None) as a frame reads them, and what it says."""
        if not isinstance(item, FluenceGPU):
            return None
        if item.emission_points:
            warnings.append(f"Medium '{medium.name}' scatters its own emission as the light of "
                            f"{item.emission_points} points of it, isotropically; solids do not shadow it")
        return item

    def _solid_set(self, meshes, lights=()) -> SolidsBuffer:
        """The vertex buffer of these meshes (the camera's and the lights' sets are one buffer
        when every mesh is in both), its material table split by what ``lights`` leave unlit
        (light linking)."""
        unlit_by = {}
        for light in lights:
            for name in light.unlit_solids:
                unlit_by[name] = unlit_by.get(name, ()) + (light.name,)
        key = tuple(m.key for m in meshes) + ((tuple(sorted(unlit_by.items())),) if unlit_by else ())
        return self._solids.get(key, lambda: SolidsBuffer(self.gl.ctx, meshes, unlit_by))[0]

    def _medium(self, scene: Scene, settings: RenderSettings) -> tuple[MediaGPU, list[str]]:
        """The frame's media on the GPU: a single homogeneous medium analytically, otherwise
        every medium marched (grids and boxes); distinct grids share the memory budget, the
        largest downsampled first; instances of one grid share its texture."""
        warnings: list[str] = []
        media = list(scene.media)
        if len(media) == 1 and media[0].is_homogeneous:
            medium = media[0]
            kind_gpu = MediumGPU(self.gl, medium, None)
            gpu = MediaGPU(kind_gpu.kind, kind_gpu, [], [])
            gpu.fog = medium if medium.box_to_world is None else None
            gpu.key = ("homogeneous", medium.density_key)
            return gpu, warnings
        # Fog without bounds (the World's Volume) beside other media: added in closed form to
        # their march and to every light's transmittance (MediaGPU.fog); a second one is added to it.
        everywhere = [m for m in media if m.is_homogeneous and m.box_to_world is None]
        media = [m for m in media if not (m.is_homogeneous and m.box_to_world is None)]
        fog = merged_fog(everywhere)
        if len(media) > MAX_MEDIA:
            warnings.append(f"At most {MAX_MEDIA} media are rendered; skipped "
                            + ", ".join(f"'{m.name}'" for m in media[MAX_MEDIA:]) + ".")
            media = media[:MAX_MEDIA]
        grids: dict[str, object] = {}
        for m in media:
            if m.density is not None and m.grid_key not in grids:
                grids[m.grid_key] = m
        most = min(MAX_GRIDS, max_grids(self.gl))
        if len(grids) > most:
            kept = set(list(grids)[:most])
            dropped = [m for m in media if m.density is not None and m.grid_key not in kept]
            warnings.append(f"At most {most} distinct density grids are rendered at once; "
                            "skipped " + ", ".join(f"'{m.name}'" for m in dropped) + ".")
            media = [m for m in media if m.density is None or m.grid_key in kept]
            grids = {k: v for k, v in grids.items() if k in kept}
        allowance, budget_note = grid_allowances(
            {k: (grid_bytes(m), m.name) for k, m in grids.items()}, settings.max_grid_bytes)
        if budget_note:
            warnings.append(budget_note)
        textures: dict[str, MediumGPU] = {}
        for k, m in grids.items():
            key = (k, allowance[k], self.gl.max_3d_texture_size, not textures)

            def build(m=m, k=k, key=key, first=not textures):
                grid, notes = self._sparse_grid(m, allowance[k], first)
                if grid is None:
                    grid = prepare_grid(m.density, np.eye(4), self.gl.max_3d_texture_size, allowance[k],
                                        m.clipping)
                notes = list(dict.fromkeys(notes + list(grid.warnings)))
                if grid.is_empty:
                    notes.append("The density grid is empty (no voxel above zero): the medium renders "
                                 "nothing.")
                self.counters["grid_uploads"] += 1
                gpu = MediumGPU(self.gl, m, grid)
                gpu.key = key
                return _Uploaded(gpu, notes)

            entry = self._media.get(key, build)[0]
            tex, notes = entry.texture, entry.notes
            warnings += [f"Medium '{m.name}': {n}" if len(grids) > 1 else n for n in notes]
            if tex.kind == MEDIUM_GRID:
                textures[k] = tex
        slots = []
        for m in media:
            if m.density is not None and m.grid_key not in textures:
                continue                       # an empty grid
            slots.append(MediumSlot(m, textures.get(m.grid_key) if m.density is not None else None))
        if not slots:
            if fog is not None:             # the other media are empty: the fog alone, analytically
                gpu = MediaGPU(MEDIUM_EVERYWHERE, MediumGPU(self.gl, fog, None), [], [])
                gpu.fog = fog
                gpu.key = ("homogeneous", fog.density_key)
                return gpu, warnings
            gpu = MediaGPU(MEDIUM_NONE, None, [], [])
            gpu.key = ("none",)
            return gpu, warnings
        others = [s.medium.name for s in slots[1:]
                  if s.medium.has_emission or s.medium.color_grid is not None]
        if others:
            warnings.append("Only the first medium's emission and colour grid are rendered; not those of "
                            + ", ".join(f"'{n}'" for n in others) + ".")
        used = [t for t in textures.values() if any(s.grid is t for s in slots)]
        gpu = MediaGPU(MEDIUM_GRID, None, slots, used)
        gpu.fog = fog
        gpu.key = tuple(_slot_key(s) for s in slots) + ((("fog", fog.key),) if fog is not None else ())
        return gpu, warnings

    def _sparse_grid(self, m: Medium, allowance: int, first: bool) -> tuple[object | None, list[str]]:
        """The medium's bricks prepared for upload where it has them and they can be used: the
        frame's first grid, no emission or colour grid, the index's texture unit, within the
        memory budget. Otherwise the grid is uploaded dense, with a report line saying why: from
        the bricks' means at the finest resolution the budget holds (``sparse_grid.dense_means``),
        or, for emission and colour grids (on the coarse copy's lattice), from the coarse copy
        (None is returned). None and no line without bricks."""
        if m.sparse is None:
            return None, []
        if m.has_emission or m.color_grid is not None:
            d = m.density.shape
            return None, [f"The sparse grid '{m.name}' is rendered at the resolution of its coarse copy "
                          f"({d[0]}x{d[1]}x{d[2]}, 1/{m.sparse.voxels_per_index:g}): it has an emission or "
                          f"colour grid, which only a dense grid carries."]
        grid = prepare_sparse(m.sparse, m.clipping)
        if not first:
            reason = "only the frame's first density grid can be sparse"
        elif not has_sparse_unit(self.gl):
            reason = "this OpenGL has too few texture units for its brick index"
        elif grid.atlas_bytes * 2 <= allowance:      # the budget counts float32 voxels
            return grid, []
        else:
            reason = (f"its {len(grid.grid.bricks)} bricks need {grid.atlas_bytes * 2 // 2**20} MiB, more "
                      f"than the {allowance // 2**20} MiB grid budget")
        f = dense_factor(grid.grid, allowance, self.gl.max_3d_texture_size)
        dense, to_fine = dense_means(grid.grid, f)
        n = "x".join(str(k) for k in dense.shape)
        prepared = prepare_grid(dense, grid.grid.index_to_medium @ to_fine, self.gl.max_3d_texture_size,
                                allowance, m.clipping)
        return prepared, [f"The sparse grid '{m.name}' is rendered dense at 1/{f} of its resolution "
                          f"({n}, the means of {f}x{f}x{f} voxels): {reason}."] + grid.warnings

    def _fire(self, medium, seen, warnings: list[str]) -> FireGPU | None:
        """The light the first marched medium's emission casts on the solids the camera sees
        (engine/fire_light.py), where its object lights surfaces; cached by what it depends on but the
        medium's placement (a moving fire's samples share it)."""
        if (medium is None or not medium.lights_surfaces or not medium.has_emission
                or not seen.vertex_count):
            return None
        if not has_fire_unit(self.gl):
            warnings.append(f"Medium '{medium.name}': its emission does not light the surfaces "
                            f"(this OpenGL has too few texture units)")
            return None
        found, built = self._fires.get(("fire", fire_content_key(medium)), lambda: _fire_gpu(self.gl, medium))
        self.counters["fire_lights"] += built
        if found is not None:
            warnings.append(f"Medium '{medium.name}' lights the surfaces from {len(found.light)} points "
                            f"of its emission; solids do not shadow that light")
        return found

    def _medium_attributes(self, medium, medium_gpu: MediaGPU) -> AttributesGPU | None:
        """The emission and colour-grid textures of ``medium`` (the first medium marched), or
        None when it has neither. Keyed by the grids, the lattice they are uploaded on and, for
        the blackbody term evaluated per voxel, the temperature and intensity; not by the
        placement, nor the emission colour, strength or tint. (Only the first medium emits or
        reads a colour grid: the others are named.) While the emission is off, the textures of the
        medium emitting are kept (and serve their colour grid), so that it comes back uploading nothing."""
        if medium is None or medium_gpu.kind == MEDIUM_NONE:
            return None
        first = medium_gpu.slots[0].grid if medium_gpu.kind == MEDIUM_GRID else None

        def key_of(emitting=False):
            # Not by the placement: moving the medium re-uploads nothing (the lattice is first.key's).
            content = (medium.grids_key if medium.source_key is None
                       else ("source", medium.source_key, tuple(sorted(medium.grids))))
            return (content, first.key, medium_attributes.key(medium, emitting))

        lit = None
        if (first is not None and not medium.has_emission
                and medium_attributes.key(medium, emitting=True)[:2] != (None, None)):
            # The emission off (a colour, strength or tint at 0): the textures it had while it
            # emitted stay, so that turning it on again uploads nothing (their colour grid serves).
            lit = self._attributes.keep(key_of(emitting=True))
        if not medium.has_emission and (medium.color_grid is None or lit is not None):
            return lit if medium.color_grid is not None else None
        if medium_gpu.kind != MEDIUM_GRID:
            return self._attributes.get(("constant",), lambda: AttributesGPU(self.gl, None))[0]
        if first is None:        # a homogeneous box marched with grids: it glows in its [-1, 1] box
            return self._attributes.get(("constant", "box"),
                                        lambda: AttributesGPU(self.gl, None, (3, 3, 3)))[0]
        key = key_of()

        def build():
            self.counters["attribute_uploads"] += 1
            factor = medium_attributes.downsample_factor(medium, medium_gpu.box_to_world)
            return AttributesGPU(self.gl, medium_attributes.prepare_attributes(medium, factor),
                                 first.grid_size, first.occupancy_cells, first)

        return self._attributes.get(key, build)[0]

    @staticmethod
    def _unlit(light, frame: _Frame) -> tuple:
        """What ``light`` does not light by its light linking: the seen solids' material table
        entries (solids.unlit_entries) and the media slots (indices)."""
        media = ()
        if light.lit_media is not None and frame.medium_gpu.kind == MEDIUM_GRID:
            media = tuple(i for i, slot in enumerate(frame.medium_gpu.slots)
                          if slot.medium.name not in light.lit_media)
        return unlit_entries(frame.seen.entries, light.name), media

    def _map_resolution(self, settings) -> int:
        """The side of the frame's shadow maps, which caps its TFMs': the settings' within the GL's
        limit."""
        return int(min(settings.map_resolution, self.gl.max_texture_size))

    def _build_face(self, scene, settings, face: FacePlan, medium_gpu, casters, gobo, warnings) -> _LightPlan:
        """The maps of a planned face (frame_plan.FacePlan), built or cached: its shadow map, the
        answer to whether it may shadow the media, its TFM (or the grid's level 1 for a march)."""
        gl = self.gl
        light, frame = face.light, face.frame
        res = self._map_resolution(settings)
        shadow = None
        if light.shadow_solids is not None:     # shadow linking: the solids that shadow this light
            casters = self._solid_set(tuple(m for m in scene.shadow_casters if m.name in light.shadow_solids))
        if face.shadow_map:
            shadow, built = self._shadows.get((light.key, frame.key, scene.solids_key, res),
                                              lambda: ShadowMap(gl, frame, casters, res))
            self.counters["shadow_maps"] += built
        boxes = medium_gpu.boxes
        medium_shadow = self._medium_shadow(light, frame, scene, shadow, casters, res,
                                            [boxes[i] for i in face.reached] or boxes,
                                            medium_gpu.kind == MEDIUM_EVERYWHERE)
        light_t, tfm, tfm_sigma = face.light_t, None, None
        if light_t == LIGHT_T_MARCH:
            self.counters["grid_levels"] += medium_gpu.ensure_level1(frame, settings.light_steps)
        elif light_t == LIGHT_T_TFM:
            tfm, tfm_sigma = self._tfm(scene, settings, light, frame, medium_gpu, shadow, face.tfm_side,
                                       list(face.reached), warnings)
            light_t = LIGHT_T_TFM if tfm is not None else LIGHT_T_NONE
        return _LightPlan(light, frame, light_t, shadow, tfm, gobo, tfm_sigma, medium_shadow, face.field)

    def _medium_shadow(self, light, frame, scene, shadow, solids, res, boxes, everywhere) -> bool:
        """Whether the face's shadow map may shadow a point of the media ``boxes``
        (light.solids_may_shadow; True for fog without bounds), cached by what the face's shadow
        map depends on and the boxes (counter 'medium_shadow_tests'). Where it may not, the light
        passes skip the lookup for the media's samples (it would be exactly 1)."""
        if shadow is None or everywhere or not boxes:
            return True
        extent = soft_extent(light, frame)      # a light's size: solids beside its centre's rays too
        key = (light.key, frame.key, scene.solids_key, res, "medium shadow", extent,
               tuple((tuple(np.round(np.asarray(b, float), 12).ravel()), tuple(lo), tuple(hi))
                     for b, lo, hi in boxes))
        flag, built = self._medium_shadows.get(key, lambda: _Value(float(
            solids_may_shadow(frame, solids.parts, boxes, res, shadow.far, extent))))
        self.counters["medium_shadow_tests"] += built
        return bool(flag.value)

    def _tfm(self, scene, settings, light, frame, medium_gpu, shadow, res, reached, warnings):
        """The face's TFM and the extinction per unit of its weighted density, or (None, None)
        when its rays meet no density. The map stores the density of the media the face reaches,
        each weighted by its mean extinction relative to the first one's (one medium: weight 1,
        so its sigma changes rebuild nothing)."""
        slots = medium_gpu.slots
        ref = slots[reached[0]].medium
        k_ref = max(float(ref.sigma_t.max()), 1e-12)
        mean_ref = max(float(ref.sigma_t.mean()), 1e-12)
        weights = [0.0] * len(slots)
        for i in reached:       # relative mean extinction: the colour error of other media balances
            weights[i] = 1.0 if i == reached[0] else float(slots[i].medium.sigma_t.mean()) / mean_ref
        chroma = {tuple(np.round(slots[i].medium.sigma_t / max(float(slots[i].medium.sigma_t.max()),
                                                                  1e-12), 3)) for i in reached}
        if len(chroma) > 1:
            who = "The world's light" if light.from_world else f"Light '{light.name}'"
            warnings.append(f"{who}: the media it reaches differ in extinction colour; "
                            f"its transmittance map uses the colour of '{ref.name}' for all.")
        n = int(min(max(settings.coefficients, 1), 16))
        if settings.density_weight is None:
            weight_key = ("auto",)
        else:
            weight_key = ("fixed", float(settings.density_weight), k_ref)
        media_key = tuple((_slot_key(slots[i]), round(weights[i], 9)) for i in reached)
        base = (light.key, frame.key, scene.solids_key, media_key, res, settings.light_steps)
        key = base + (n, weight_key)
        if key not in self._tfms.items:
            wider = [k for k in self._tfms.items
                     if k[:len(base)] == base and len(k) == len(key) and k[-1] == weight_key
                     and k[-2] > n]
            if wider:
                if base + ("alpha",) in self._tfms.items:
                    self._tfms.used.add(base + ("alpha",))    # the wider map's alpha: kept with it
                return (_FewerCoefficients(self._tfms.get(min(wider, key=lambda k: k[-2]), None)[0], n),
                        ref.sigma_t)
        # The level before the alpha probe too, which reads the build's density path.
        self.counters["grid_levels"] += medium_gpu.ensure_level1(frame, settings.light_steps, res)
        probed = 0.0
        if (settings.density_weight is None and settings.alpha_from_probe and light.kind == "SPOT"
                and len(reached) == 1 and ref.density is not None):
            probed = light_density_integral(ref, light)     # AUTO's probe: no GPU pass, no read-back
        if probed > 0.0:
            alpha_d = probed
        elif settings.density_weight is None:
            # The probe's wider texels may read the level where the map's do not: made for them too
            # (else its alpha would depend on whether another light had made the level).
            self.counters["grid_levels"] += medium_gpu.ensure_level1(frame, settings.light_steps,
                                                                     probe_resolution(res))
            alpha_d, _ = self._tfms.get(
                base + ("alpha",),
                lambda: _Value(largest_density_integral(self.gl, frame, medium_gpu, res,
                                                        settings.light_steps, weights)))
            alpha_d = alpha_d.value
            if alpha_d <= 0.0:
                return None, None
        else:
            alpha_d = max(float(settings.density_weight), 1e-6) / k_ref

        def build():
            self.counters["tfms"] += 1
            return TransmittanceMap(self.gl, frame, medium_gpu, shadow,
                                    res, settings.light_steps, n, alpha_d, weights)

        return self._tfms.get(key, build)[0], ref.sigma_t

    def _gbuffer_for(self, camera, plane, solids, alpha_seed) -> _PooledGBuffer:
        """A G-buffer drawn for ``camera``: GL objects of that size that the cache released (the
        previous sample's) are drawn into again; new ones are made only when none is free."""
        size = (plane.width_px, plane.height_px)
        free = self._gbuffer_pool.setdefault(size, [])
        if free:
            gbuffer = free.pop()
        else:
            gbuffer = GBuffer(self.gl, size)
            self.counters["gbuffer_objects"] += 1
        entry = _PooledGBuffer(gbuffer, self._gbuffer_pool)
        try:
            gbuffer.draw(self.gl, camera, plane, solids, alpha_seed)
        except BaseException:
            entry.release()
            raise
        return entry

    def _new_sums(self, size, passes) -> SampleSums:
        """A frame's sample sums: the GL objects of an earlier frame of this size, or new ones."""
        sums, new = SampleSums.take(self.gl, size, passes, self._sums_pool)
        self.counters["sums_objects"] += new
        return sums

    def _active_rects(self, size, active):
        """(vertex buffer, vertex count) of the rectangles that cover ``active``
        (adaptive.ActivePixels), or None to shade every pixel."""
        if active is None:
            return None
        if active.mask.shape != (size[1], size[0]):
            raise ValueError(f"active pixels of shape {active.mask.shape}, the image is {size[1]}x{size[0]}")
        vertices = active.vertices
        if not len(vertices):
            return None, 0
        vbo = self._targets.get(("active", active.key), lambda: self.gl.ctx.buffer(vertices.tobytes()))[0]
        return vbo, len(vertices)

    def trim_pools(self, keep_size: tuple[int, int] | None = None) -> None:
        """Release the free G-buffers and sample sums (kept for the next frame of their size) of
        every image size but ``keep_size``: a frame rendered in tiles of several sizes
        (tiles.py) would otherwise keep a set per size."""
        if self._gl is None:
            return
        with self._gl.ctx:
            for size in [k for k in self._gbuffer_pool if k != keep_size]:
                for gbuffer in self._gbuffer_pool.pop(size):
                    gbuffer.release()
            for key in [k for k in self._sums_pool if k[0] != keep_size]:
                for sums in self._sums_pool.pop(key):
                    sums.destroy()

    def clear_maps(self) -> None:
        """Drop every cached map and buffer (compiled programs stay): the next render is full."""
        self._frame_memos.clear()
        if self._gl is not None:
            with self._gl.ctx:
                for cache in self._caches:
                    cache.clear()
                for free in self._gbuffer_pool.values():
                    for gbuffer in free:
                        gbuffer.release()
                self._gbuffer_pool.clear()
                for free in self._sums_pool.values():
                    for sums in free:
                        sums.destroy()
                self._sums_pool.clear()

    def release(self) -> None:
        """Release every GPU resource and the context."""
        if self._gl is not None:
            self.clear_maps()
            self._gl.release()
            self._gl = None


@dataclass
class _Frame:
    """What a frame prepared for its passes: its plan, its media and the first marched medium
    with its attributes (emission, colour grid), the solids the camera sees, and each planned
    face with its maps (``lights``)."""

    plan: FramePlan
    medium_gpu: MediaGPU
    medium: Medium | None
    attributes: AttributesGPU | None
    seen: SolidsBuffer
    lights: list[_LightPlan]
    fire: FireGPU | None = None
    fluence: FluenceGPU | None = None


def _emission_light(medium) -> tuple[Callable | None, int]:
    """``medium``'s emission as diffusion.fluence's ``emitted`` (its fluence, or with normals its
    irradiance, at world points) and the count of points it is taken from (None, 0: it emits
    nothing there)."""
    light = fire_light(medium)
    if light is None:
        return None, 0
    rotation, _, offset = fire_placement(medium)

    def emitted(points, normals, softening):
        if normals is None:
            return light.fluence(points, rotation, offset, softening)
        return light.irradiance(points, normals, rotation, offset)

    return emitted, len(light)


def _fire_gpu(gl, medium) -> FireGPU | None:
    light = fire_light(medium)
    return None if light is None else FireGPU(gl, light)


@dataclass
class _FrameMemo:
    """What the first sample of an accumulated frame prepared (``state``), its warnings and the
    cache keys it used (each later sample marks them used again); ``frame`` (_frame_of) says
    which frame, ``held`` keeps the scene parts whose ids it holds."""

    frame: tuple
    state: _Frame
    warnings: list
    used: list
    held: tuple


class _Steps:
    """A frame's progress and cancel checks: each ``step`` waits for the GL, adds the time since
    ``t0`` to ``timings[name]``, reports done / ``total`` and raises RenderCancelled when
    ``cancel()`` turns true."""

    def __init__(self, gl: GLContext, progress, cancel, total: int):
        self.gl, self.progress, self.cancel, self.total = gl, progress, cancel, total
        self.done = 0
        self.timings: dict[str, float] = {}

    def step(self, name: str, t0: float) -> None:
        self.gl.finish()   # lets the host's threads run while the pass completes
        self.timings[name] = self.timings.get(name, 0.0) + time.perf_counter() - t0
        self.done += 1
        if self.progress is not None:
            self.progress(min(self.done / self.total, 1.0))
        if self.cancel is not None and self.cancel():
            raise RenderCancelled("The render was cancelled.")


def _frame_of(scene: Scene, settings: RenderSettings, accumulate, client: str, map_image_side) -> tuple:
    """What the samples of one frame (``accumulate``, sampling.iter_samples) share: the scene's
    media, lights and meshes by identity (a sample replaces only the camera, whose jitter no map
    depends on; _FrameMemo.held keeps the ids theirs), the image size and the settings but for the
    view-march jitter."""
    return (accumulate, client, map_image_side, tuple(map(id, scene.media)), tuple(map(id, scene.lights)),
            tuple(map(id, scene.meshes)), scene.camera.width_px, scene.camera.height_px,
            dataclasses.replace(settings, view_jitter=None))


class _FewerCoefficients:
    """A TFM read with its first ``n`` coefficients (the shader masks the rest of the last
    texture it reads)."""

    def __init__(self, tfm: TransmittanceMap, n: int):
        self.tfm, self.coefficients = tfm, n

    def defines(self, tfm_filter: str) -> dict[str, int]:
        return {**self.tfm.defines(tfm_filter), "N_COEFF": self.coefficients,
                "N_TARGETS": coefficient_textures(self.coefficients)}

    def bind(self, prog, sigma_t) -> None:
        self.tfm.bind(prog, sigma_t)


class _PooledGBuffer:
    """A cached G-buffer whose release hands its GL objects back to the renderer's pool (at most
    GBUFFER_POOL free per size) for the next view's contents, instead of freeing them."""

    def __init__(self, gbuffer: GBuffer, pool: dict):
        self.gbuffer, self._pool = gbuffer, pool

    def bind(self) -> None:
        self.gbuffer.bind()

    def release(self) -> None:
        free = self._pool.setdefault(self.gbuffer.size, [])
        if len(free) < GBUFFER_POOL:
            free.append(self.gbuffer)
        else:
            self.gbuffer.release()


GBUFFER_POOL = 2


@dataclass
class _Uploaded:
    """A grid's texture and the notes its preparation raised (unpacks as that pair)."""

    texture: MediumGPU
    notes: list

    def __iter__(self):
        return iter((self.texture, self.notes))

    def release(self) -> None:
        self.texture.release()


@dataclass
class _Value:
    value: object

    def release(self) -> None:
        pass


def _slot_key(slot: MediumSlot) -> tuple:
    """What a marched medium's share of a map depends on: its grid texture and placement."""
    grid = None if slot.grid is None else slot.grid.key
    return (grid, tuple(np.round(slot.world_to_box, 12).ravel()))


def _frame_notes(scene: Scene, lights, warnings: list[str]) -> list[str]:
    """The render report: the frame's ``warnings`` once each, then what the lights say (none
    lit, approximations, cones past the maps' reach)."""
    warnings = list(warnings) + surface.table_note(scene.camera_meshes)
    world = [light for light in scene.lights if light.from_world]
    if world and len(world) == len(scene.lights):
        warnings.append(f"The scene has no light of its own: the world lights it alone, from {len(world)} "
                        f"directions (World ▸ Lighting: Shadowed), each casting the soft shadow of its "
                        f"share of the sky on surfaces")
    elif not scene.lights:
        lit_by = ("surfaces, ambient light and the media's emission"
                  if any(m.has_emission for m in scene.media) else "surfaces and ambient light")
        warnings.append(f"The scene has no spot light (nor any other light): only {lit_by} are rendered, "
                        f"and the medium scatters no light beam.")
    elif not [light for light in lights if not light.from_world]:
        dark = [light for light in scene.lights if not light.from_world]
        warnings.append("No light lights the scene (" + "; ".join(
            f"'{light.name or light.kind.title()}' has {why_dark(light)}" for light in dark)
            + "): no light beam.")
    warnings = list(dict.fromkeys(warnings))       # once each, however many faces said it
    return warnings + [w for w in map(cone_warning, lights) if w]


def merged_fog(fogs) -> Medium | None:
    """Fogs without bounds as one (their coefficients add up, the phase is the sigma_s mixture of
    their lobes, as where media overlap), or None."""
    if len(fogs) <= 1:
        return fogs[0] if fogs else None
    sigma_s = np.sum([f.sigma_s for f in fogs], axis=0)
    weights = [float(np.mean(f.sigma_s)) for f in fogs]
    g = sum(w * f.anisotropy for w, f in zip(weights, fogs, strict=True)) / max(sum(weights), 1e-30)
    return Medium(sigma_a=tuple(float(x) for x in np.sum([f.sigma_a for f in fogs], axis=0)),
                  sigma_s=tuple(float(x) for x in sigma_s), anisotropy=float(g),
                  name=" + ".join(f.name for f in fogs))
