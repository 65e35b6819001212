"""The renderer: runs the passes for a scene and keeps what it built until it goes stale."""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .camera import view_plane
from .errors import RenderCancelled
from .gl_context import GLContext
from .light import LightFrame, cone_meets_box, is_dark
from .medium_grid import prepare_grid
from .output import RenderOutput
from .passes.bindings import MEDIUM_GRID, MediumGPU, gobo_texture
from .passes.gbuffer import GBuffer
from .passes.probe import probe_light_transmittance
from .passes.scattering import (
    LIGHT_T_ANALYTIC,
    LIGHT_T_MARCH,
    LIGHT_T_NONE,
    LIGHT_T_TFM,
    ScatteringTargets,
    run_light_pass,
)
from .passes.shadow_map import ShadowMap
from .passes.solids import SolidsBuffer
from .passes.tfm import TransmittanceMap, largest_density_integral
from .quality import auto_settings
from .scene import RenderSettings, Scene, SpotLight


def effective_settings(scene: Scene, settings: RenderSettings | None) -> RenderSettings:
    """The settings a frame renders with: ``quality='AUTO'`` lets quality.auto_settings choose."""
    settings = settings or RenderSettings()
    return auto_settings(scene, settings) if settings.quality == "AUTO" else settings


class _Cache:
    """GPU resources by the key of what they depend on; what a frame did not use is released."""

    def __init__(self):
        self.items: dict = {}
        self.used: set = set()

    def get(self, key, build: Callable):
        self.used.add(key)
        if key not in self.items:
            self.items[key] = build()
            return self.items[key], True
        return self.items[key], False

    def sweep(self) -> None:
        for key in list(self.items):
            if key not in self.used:
                item = self.items.pop(key)
                if hasattr(item, "release"):
                    item.release()
        self.used.clear()

    def clear(self) -> None:
        self.used.clear()
        self.sweep()


@dataclass
class _LightPlan:
    light: SpotLight
    frame: LightFrame
    light_t: int
    shadow: ShadowMap | None
    tfm: TransmittanceMap | None
    gobo: object | None


class Renderer:
    """Renders scenes with one OpenGL context, created on first use on the calling thread;
    every call must come from that thread (see worker.RenderWorker).

    ``counters`` counts what was built: 'grid_uploads', 'shadow_maps', 'tfms', 'gbuffers',
    'light_passes', 'renders'. A camera-only change rebuilds no light map; changing sigma_a or
    sigma_s rebuilds nothing on the light side (unless a fixed density weight ties the map to
    the extinction).
    """

    def __init__(self, gl: GLContext | None = None):
        self._gl = gl
        self.counters: Counter = Counter()
        self._media = _Cache()
        self._solids = _Cache()
        self._shadows = _Cache()
        self._tfms = _Cache()
        self._gobos = _Cache()
        self._gbuffers = _Cache()
        self._targets = _Cache()
        self._caches = [self._media, self._solids, self._shadows, self._tfms, self._gobos,
                        self._gbuffers, self._targets]

    @property
    def gl(self) -> GLContext:
        if self._gl is None:
            self._gl = GLContext()
        return self._gl

    def render(self, scene: Scene, settings: RenderSettings | None = None,
               cancel: Callable[[], bool] | None = None,
               progress: Callable[[float], None] | None = None, passes: bool = True,
               sweep: bool = True) -> RenderOutput:
        """Render ``scene``; raises RenderCancelled when ``cancel()`` turns true between passes.
        ``passes=False`` reads back the combined image alone (the viewport's case).
        ``sweep=False`` keeps what this frame did not use (a preview frame between two full ones:
        the viewport's coarse image must not evict the full maps)."""
        gl = self.gl
        gl.check_thread()
        settings = effective_settings(scene, settings)
        with gl.ctx:     # current for the call, whatever other context the thread made current
            return self._render(scene, settings, cancel, progress, passes, sweep)

    def _render(self, scene, settings, cancel, progress, want_passes, sweep=True) -> RenderOutput:
        gl = self.gl
        t_start = time.perf_counter()
        timings: dict[str, float] = {}
        warnings: list[str] = []
        lights = [light for light in scene.lights if not is_dark(light)]
        steps = 2 + len(lights) + max(len(lights), 1)   # scene, maps per light, G-buffer, passes
        done = [0]

        def step(name: str, t0: float) -> None:
            gl.finish()   # lets the host's threads run while the pass completes
            timings[name] = timings.get(name, 0.0) + time.perf_counter() - t0
            done[0] += 1
            if progress is not None:
                progress(min(done[0] / steps, 1.0))
            if cancel is not None and cancel():
                raise RenderCancelled("The render was cancelled.")

        try:
            t0 = time.perf_counter()
            medium_gpu, medium_warnings = self._medium(scene, settings)
            warnings += medium_warnings
            solids = self._solids.get(tuple(m.key for m in scene.meshes),
                                      lambda: SolidsBuffer(gl.ctx, scene.meshes))[0]
            step("scene", t0)

            plans = []
            for light in lights:
                t0 = time.perf_counter()
                plans.append(self._plan_light(scene, settings, light, medium_gpu, solids))
                step("light_maps", t0)

            t0 = time.perf_counter()
            plane = view_plane(scene.camera)
            gbuffer, built = self._gbuffers.get(
                (scene.camera.key, tuple(m.key for m in scene.meshes)),
                lambda: GBuffer(gl, scene.camera, plane, solids))
            self.counters["gbuffers"] += built
            step("gbuffer", t0)

            size = (plane.width_px, plane.height_px)
            targets = self._targets.get(size, lambda: ScatteringTargets(gl, size))[0]
            targets.begin(gl.ctx)
            gbuffer.bind()
            ambient = scene.ambient if settings.ambient else (0.0, 0.0, 0.0)
            common = dict(camera=scene.camera, plane=plane, medium=scene.medium,
                          medium_gpu=medium_gpu, settings=settings, ambient=ambient)
            if not plans:
                t0 = time.perf_counter()
                run_light_pass(gl, first=True, **common)
                self.counters["light_passes"] += 1
                step("scattering", t0)
            for i, plan in enumerate(plans):
                t0 = time.perf_counter()
                run_light_pass(gl, first=(i == 0), light_t=plan.light_t, tfm=plan.tfm,
                               light=(plan.frame, plan.light.intensity_w_per_sr,
                                      plan.shadow, plan.gobo),
                               **common)
                self.counters["light_passes"] += 1
                step("scattering", t0)
            t0 = time.perf_counter()
            targets.compose(gl)
            gl.finish()   # the read below then copies without waiting on the GPU
            combined = targets.read_combined()
            passes = targets.read_passes() if want_passes else {}
            timings["readback"] = time.perf_counter() - t0
        except BaseException:
            for cache in self._caches:
                cache.used.clear()
            raise
        for cache in self._caches:
            if sweep:
                cache.sweep()
            else:
                cache.used.clear()
        self.counters["renders"] += 1
        timings["total"] = time.perf_counter() - t_start
        if not scene.lights:
            warnings.append("The scene has no spot light: only surfaces and ambient light are "
                            "rendered, and the medium scatters no light beam.")
        elif not lights:
            warnings.append("Every spot light has zero power, colour or cone angle: no light beam.")
        return RenderOutput(combined=combined, passes=passes, warnings=warnings, timings_s=timings)

    def light_transmittance_at(self, scene: Scene, settings: RenderSettings | None, light_index: int,
                               points: np.ndarray) -> np.ndarray:
        """The transmittance from ``scene.lights[light_index]`` to world ``points`` (n, 3), as the
        camera passes see it (TFM lookup, march or analytic), (n, 3) float32 per channel.
        Builds or reuses that light's maps like ``render``; for tests and diagnostics."""
        gl = self.gl
        gl.check_thread()
        with gl.ctx:
            return self._light_transmittance_at(scene, effective_settings(scene, settings), light_index,
                                                points)

    def _light_transmittance_at(self, scene, settings, light_index, points) -> np.ndarray:
        gl = self.gl
        medium_gpu, _ = self._medium(scene, settings)
        solids = self._solids.get(tuple(m.key for m in scene.meshes),
                                  lambda: SolidsBuffer(gl.ctx, scene.meshes))[0]
        plan = self._plan_light(scene, settings, scene.lights[light_index], medium_gpu, solids)
        out = probe_light_transmittance(
            gl, points, medium=scene.medium, medium_gpu=medium_gpu, settings=settings,
            light=(plan.frame, plan.light.intensity_w_per_sr, plan.shadow,
                   None), light_t=plan.light_t, tfm=plan.tfm)
        for cache in self._caches:
            cache.used.clear()          # a probe keeps every map for the next render
        return out

    def _medium(self, scene: Scene, settings: RenderSettings) -> tuple[MediumGPU, list[str]]:
        medium = scene.medium
        if medium is None or medium.is_homogeneous:
            key = ("homogeneous", None if medium is None else medium.density_key)
            return self._media.get(key, lambda: (MediumGPU(self.gl, medium, None), []))[0]

        def build():
            grid = prepare_grid(medium.density, medium.index_to_world, self.gl.max_3d_texture_size,
                                settings.max_grid_bytes)
            warnings = list(grid.warnings)
            if grid.is_empty:
                warnings.append("The density grid is empty: only the surfaces are rendered.")
            self.counters["grid_uploads"] += 1
            return MediumGPU(self.gl, medium, grid), warnings

        return self._media.get((medium.density_key, settings.max_grid_bytes), build)[0]

    def _plan_light(self, scene, settings, light, medium_gpu, solids) -> _LightPlan:
        gl = self.gl
        frame = LightFrame.of(light)
        res = int(min(settings.map_resolution, gl.max_texture_size))
        shadow = None
        if solids.vertex_count:
            shadow, built = self._shadows.get((light.key, scene.solids_key, res),
                                              lambda: ShadowMap(gl, frame, solids, res))
            self.counters["shadow_maps"] += built
        gobo = None
        if light.gobo is not None:
            gobo = self._gobos.get(light.key, lambda: gobo_texture(gl, light.gobo))[0]

        medium = scene.medium
        light_t, tfm = LIGHT_T_NONE, None
        if medium_gpu.kind == MEDIUM_GRID:
            reaches = cone_meets_box(frame, medium_gpu.box_to_world, medium_gpu.lo, medium_gpu.hi)
            if reaches and light.use_tfm:
                if settings.method == "BRUTE_FORCE":
                    light_t = LIGHT_T_MARCH
                else:
                    tfm = self._tfm(scene, settings, light, frame, medium_gpu, shadow, res)
                    light_t = LIGHT_T_TFM if tfm is not None else LIGHT_T_NONE
        elif medium is not None and medium_gpu.kind != 0:
            light_t = LIGHT_T_ANALYTIC
        return _LightPlan(light, frame, light_t, shadow, tfm, gobo)

    def _tfm(self, scene, settings, light, frame, medium_gpu, shadow, res):
        """The light's TFM, or None when its rays meet no density."""
        medium = scene.medium
        n = int(min(max(settings.coefficients, 1), 16))
        if settings.density_weight is None:
            weight_key = ("auto",)
        else:
            weight_key = ("fixed", float(settings.density_weight), float(medium.sigma_t.max()))
        base = (light.key, scene.solids_key, medium.density_key, res, settings.light_steps)
        key = base + (n, weight_key)
        if settings.density_weight is None:
            alpha_d, _ = self._tfms.get(
                base + ("alpha",),
                lambda: _Value(largest_density_integral(self.gl, frame, medium_gpu, res,
                                                        settings.light_steps)))
            alpha_d = alpha_d.value
            if alpha_d <= 0.0:
                return None
        else:
            alpha_d = max(float(settings.density_weight), 1e-6) / max(float(medium.sigma_t.max()), 1e-12)

        def build():
            self.counters["tfms"] += 1
            return TransmittanceMap(self.gl, frame, medium_gpu, shadow,
                                    res, settings.light_steps, n, alpha_d)

        return self._tfms.get(key, build)[0]

    def clear_maps(self) -> None:
        """Drop every cached map and buffer (compiled programs stay): the next render is full."""
        if self._gl is not None:
            with self._gl.ctx:
                for cache in self._caches:
                    cache.clear()

    def release(self) -> None:
        """Release every GPU resource and the context."""
        if self._gl is not None:
            self.clear_maps()
            self._gl.release()
            self._gl = None


@dataclass
class _Value:
    value: float

    def release(self) -> None:
        pass
