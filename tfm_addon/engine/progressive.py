"""The viewport's progressive image: a small state machine fed by a latest-wins request slot.

States: 'idle' (nothing asked, or the last request converged), 'coarse' (a reduced-resolution
first image is computing), 'full' (the pixel-centre image at full resolution), 'accumulating'
(jittered samples folded into a running mean, up to the requested count). A request whose key
differs from the current one supersedes it: the GL thread drops the old job (or stops it between
passes) and starts over at 'coarse'. Hosts call ``request`` and ``frame`` from their UI thread
and never wait; the GL thread publishes frames, and a frame of a superseded request is dropped,
never shown. No Blender here: the host polls ``take_redraw`` and redraws.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from dataclasses import dataclass

import numpy as np

from .errors import RenderCancelled
from .renderer import prepare_scene
from .sampling import Accumulator, frame_settings, iter_samples
from .scene import RenderSettings, Scene
from .worker import RenderWorker, WorkerClosed

SLOT = "viewport"           # the default worker slot and renderer cache client (one per view:
CLIENT = SLOT               # views sharing a slot would supersede each other's requests)
COARSE_SCALE = 0.25        # side of the coarse image relative to the full one
COARSE_BELOW_S = 0.05      # skip the coarse image when the last full image took less than this


@dataclass(frozen=True)
class Frame:
    """A finished viewport image: ``image`` (h, w, 4) float32 premultiplied RGBA, top row first;
    ``stage`` 'coarse', 'full' or 'accumulating'; ``samples`` folded into it of ``target``."""

    image: np.ndarray
    generation: int
    stage: str
    samples: int
    target: int
    warnings: tuple[str, ...] = ()
    seconds_since_request: float = 0.0
    pixels: np.ndarray | None = None   # ready to upload: bottom row first, finite, contiguous


def upload_pixels(image: np.ndarray) -> np.ndarray:
    """``image`` (top row first) as a GPU texture wants it: bottom row first, float32, contiguous,
    NaN as 0 and infinities clamped to the half-float range (done off the host's UI thread)."""
    return np.ascontiguousarray(np.nan_to_num(image[::-1], nan=0.0, posinf=6.0e4, neginf=-6.0e4),
                                dtype=np.float32)


def coarse_settings(settings: RenderSettings, rebuild_maps: bool) -> RenderSettings:
    """The coarse image's settings: half the view steps; when the maps must be rebuilt anyway,
    maps of a quarter side with half the light steps (the full maps follow once, for the full
    image). When they need no rebuild, the cached full maps. The lattice fields of multiple
    scattering only where already built (the full image builds them, once, from the full maps)."""
    coarse = dataclasses.replace(settings, view_steps=max(8, settings.view_steps // 2), lattice=False)
    if rebuild_maps:
        coarse = dataclasses.replace(coarse, map_resolution=max(64, settings.map_resolution // 4),
                                     light_steps=max(8, settings.light_steps // 2))
    return coarse


def _scene_maps_key(scene: Scene, settings: RenderSettings):
    """What the light maps depend on in the scene (read on the host's thread: "Building maps")."""
    return (tuple(light.key for light in scene.lights), tuple(m.density_key for m in scene.media),
            scene.solids_key, settings.map_resolution)


def _maps_key(scene: Scene, settings: RenderSettings):
    """What the light maps of a frame depend on, with the settings the quality rule chose."""
    return _scene_maps_key(scene, settings) + (settings.light_steps, settings.coefficients,
                                               settings.density_weight)


class ProgressiveView:
    """One viewport's progressive image. ``counters``: 'requests', 'published', 'dropped'
    (frames of superseded requests, finished but never shown), 'coarse', 'samples'. ``slot``:
    the worker slot, and the renderer cache client, of this view alone."""

    def __init__(self, worker: RenderWorker, slot: str = SLOT, coarse_scale: float = COARSE_SCALE):
        self.worker = worker
        self.slot = slot
        self.client = slot
        self.coarse_scale = coarse_scale
        self._lock = threading.Lock()
        self._generation = 0
        self._key = None
        self._job = None
        self._frame: Frame | None = None
        self._redraw = False
        self._state = "idle"
        self._status = ""
        self._error: str | None = None
        self._maps_key = None
        self._last_full_s: float | None = None
        self.counters = {"requests": 0, "published": 0, "dropped": 0, "coarse": 0, "samples": 0}

    # ------------------------------------------------------------------ host (UI thread) side
    def request(self, key, scene: Scene, settings: RenderSettings, samples: int) -> bool:
        """Ask for ``scene`` rendered progressively up to ``samples``; ``key`` names everything the
        image depends on. The same key as the current request does nothing (it keeps refining or
        stays converged). Returns True when a new request was posted. Never waits."""
        key = (key, int(samples))
        with self._lock:
            if key == self._key:
                return False
            self._key = key
            self._generation += 1
            generation = self._generation
            self._state = "coarse"
            known = self._maps_key is not None and self._maps_key[:4] == _scene_maps_key(scene, settings)
            self._status = "Rendering" if known else "Building maps"
            self._error = None
            self.counters["requests"] += 1
        t0 = time.perf_counter()

        def job(renderer, job):
            return self._refine(renderer, job, generation, t0, scene, settings, max(int(samples), 1))

        try:
            self._job = self.worker.post(self.slot, job)
        except WorkerClosed as ex:
            with self._lock:
                self._error, self._state = str(ex), "idle"
        return True

    def frame(self) -> Frame | None:
        """The newest finished frame (of the current request, or the previous one's while the
        current one computes)."""
        with self._lock:
            return self._frame

    def take_redraw(self) -> bool:
        """True once per newly published frame (the host then asks for a redraw)."""
        with self._lock:
            new, self._redraw = self._redraw, False
            return new

    @property
    def state(self) -> str:
        return self._state

    @property
    def status(self) -> str:
        """One line for the viewport header: the error, or what is computing, or the last warning."""
        with self._lock:
            if self._error:
                return self._error
            frame = self._frame
            if self._state == "idle" and frame is not None and frame.generation == self._generation:
                if frame.warnings:
                    return frame.warnings[-1]
                return f"Sample {frame.samples}/{frame.target}"
            return self._status

    def cancel(self) -> None:
        """Stop refining (the frame shown stays)."""
        with self._lock:
            self._key = None
            self._generation += 1
            self._state = "idle"
        if self._job is not None:
            self._job.cancel()

    # ------------------------------------------------------------------ GL thread side
    def _publish(self, generation: int, t0: float, image: np.ndarray, stage: str, samples: int,
                 target: int, warnings) -> bool:
        pixels = upload_pixels(image) if generation == self._generation else None
        with self._lock:
            if generation != self._generation:
                self.counters["dropped"] += 1
                return False
            self._frame = Frame(image, generation, stage, samples, target, tuple(warnings),
                                time.perf_counter() - t0, pixels)
            self._redraw = True
            self.counters["published"] += 1
            converged = samples >= target and stage != "coarse"
            self._state = "idle" if converged else ("full" if stage == "coarse" else "accumulating")
            self._status = "Rendering" if stage == "coarse" else f"Sample {min(samples + 1, target)}/{target}"
            return True

    def _refine(self, renderer, job, generation, t0, scene, settings, target):
        """The generator the worker steps: coarse image, full image, then samples 2..target."""
        try:
            scene = prepare_scene(scene, settings)     # node graphs evaluated on the render thread
            settings = frame_settings(scene, settings, target)
            maps_key = _maps_key(scene, settings)
            w, h = scene.camera.width_px, scene.camera.height_px
            cw, ch = max(1, round(w * self.coarse_scale)), max(1, round(h * self.coarse_scale))
            slow = self._last_full_s is None or self._last_full_s >= COARSE_BELOW_S
            rebuild = maps_key != self._maps_key
            if (slow or rebuild) and (cw, ch) != (w, h):
                small = dataclasses.replace(scene, camera=dataclasses.replace(
                    scene.camera, width_px=cw, height_px=ch))
                out = renderer.render(small, coarse_settings(settings, rebuild), job.cancelled, None, False,
                                      client=self.client, sweep=False,
                                      map_image_side=None if rebuild else max(w, h))
                self.counters["coarse"] += 1
                self._publish(generation, t0, out.combined, "coarse", 0, target, out.warnings)
                yield
            t_full = time.perf_counter()
            for k, acc in enumerate(iter_samples(renderer, scene, settings, target, job.cancelled,
                                                 passes=False, accumulator=Accumulator(),
                                                 client=self.client)):
                if k == 0:
                    self._last_full_s = time.perf_counter() - t_full
                    self._maps_key = maps_key
                self.counters["samples"] += 1
                mean = acc.output
                self._publish(generation, t0, mean.combined.copy(), "full" if k == 0 else "accumulating",
                              acc.count, target, mean.warnings)
                yield
        except RenderCancelled:
            raise
        except Exception as ex:
            with self._lock:
                if generation == self._generation:
                    self._error = f"viewport failed: {type(ex).__name__}: {ex}"
                    self._state = "idle"
            raise
