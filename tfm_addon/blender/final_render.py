"""Final renders (F12, animations, command line) and material previews.

Reads the scene, renders its antialiasing samples on the GL thread while this thread (the one
Blender called the engine on) forwards progress and cancel, writes Combined and the three passes
into Blender's render result, and reports problems to the user; nothing raises into Blender.
"""

from __future__ import annotations

import dataclasses
import math
import os
import signal
import sys
import threading
import time
import traceback

import numpy as np

from ..engine import caches
from ..engine.errors import RenderCancelled, RendererError
from ..engine.sampling import auto_samples
from .camera import border_window
from .extract import extract
from .motion import read_motion
from .render_worker import close_worker, get_worker

# Blender pass name -> RenderOutput pass name.
PASSES = (("Scattering", "scattering"), ("Surfaces", "surfaces"), ("Transmittance", "transmittance"))

# What the last final render told the user: (level, message) pairs, for scripts and tests.
last_messages: list[tuple[str, str]] = []
# Seconds per stage of the last final render, as the renderer measured them.
last_timings: dict[str, float] = {}
# Scene name -> what Auto chose for that scene's last final render (RenderOutput.chosen), shown
# under Render Properties ▸ Volumes.
auto_choices: dict[str, dict] = {}
last_samples = [0]   # the antialiasing samples of the last frame (the log line)
# Warnings already given in a material preview: each is reported once per session, since Blender
# renders the same preview scene again for every material and shape.
_preview_reported: set[str] = set()


def _forget_renders() -> None:
    """What the last renders left for the interface goes with the add-on's memos (unregister)."""
    last_messages.clear()
    last_timings.clear()
    auto_choices.clear()
    _preview_reported.clear()
    last_samples[0] = 0


caches.REGISTRY.on_clear(_forget_renders)

# Voxels along a mesh medium's longest side in a preview (its shapes span ~100 px of 128).
PREVIEW_VOLUME_RESOLUTION = 64

STRICT_ENV = "TFM_STRICT"      # 1: every scene renders in strict mode (scene.tfm.strict)
STRICT_EXIT_CODE = 1           # command-line Blender's exit status when strict mode fails a frame
# Report lines that say a frame would render without something it needs (a missing or
# unreadable file or grid): errors in strict mode. A grid with no active voxels is content.
MISSING_MARKERS = ("rendering without it",)
NOT_MISSING = ("has no active voxels",)
# Report lines that name a documented approximation (docs/multiple_scattering.md, docs/blender.md:
# what it does and how far it is from Cycles) or say how the scene is lit as Cycles lights it: Info.
# Every other line the engine says is a setting, node or file not read or read in part: Warning (a
# farm's strict mode fails the task on it).
APPROXIMATION_MARKERS = ("multiple scattering approximated by",
                         "The scene has no light of its own: the world lights it alone")


# A command-line frame running longer than this many seconds prints its progress on stdout, at most
# once a second, as a farm manager reads it ("Fra:<frame> ... Sample <k>/<n>", the form of Cycles'
# lines that Deadline's Blender adaptor and Flamenco parse). TFM_PROGRESS_AFTER_S overrides it.
PROGRESS_AFTER_S = 2.0
PROGRESS_EVERY_S = 1.0


def progress_line(frame: int, layer: str, done: int, samples: int, seconds: float) -> str:
    """A farm-readable progress line: done of ``samples`` samples of the frame (across its tiles)."""
    return f"Fra:{frame} | TFM | {layer} | Time:{seconds:.1f} s | Sample {done}/{samples}"


BUDGET_ENV = "TFM_MEMORY_BUDGET_GB"   # GiB; overrides scene.tfm.memory_budget_gb
GIB = 1024 ** 3
# Bytes a pixel of a final render takes at its peak beyond Blender's render result, measured with
# python -m tfm_addon.bench.frame_memory (docs/benchmark.md, "A final render's memory per pixel")
# and rounded up: the renderer's GL images (G-buffer, scattering targets, the samples' sums: host
# memory on a software GL, the GPU's on a graphics card), the means read back, one pass copied
# into Blender at a time.
ENGINE_BYTES_PER_PIXEL = 340


def frame_estimate(width: int, height: int, passes: int) -> int:
    """Bytes a final render of ``width`` x ``height`` with ``passes`` of the three passes needs
    at its peak: the renderer's share and Blender's render result (float32 RGBA plus RGB per
    pass). Measured 369 bytes a pixel in all at 1024² and 2048² with the three passes; this
    gives 392."""
    return int(width) * int(height) * (ENGINE_BYTES_PER_PIXEL + 4 * (4 + 3 * passes))


def memory_budget(scene) -> tuple[int | None, str]:
    """(bytes, where the figure comes from) a final render may use; None: no budget known."""
    raw = os.environ.get(BUDGET_ENV, "").strip()
    if raw:
        try:
            if float(raw) > 0:
                return int(float(raw) * GIB), BUDGET_ENV
        except ValueError:
            pass
    gb = float(getattr(getattr(scene, "tfm", None), "memory_budget_gb", 0.0) or 0.0)
    if gb > 0:
        return int(gb * GIB), "Render Properties > Performance > Memory Limit"
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return None, ""
    return total // 2, "half of this machine's memory"


MIN_TILE = 64        # pixels a side: a frame whose render result leaves no room for such tiles is refused
MAX_TILE = 2048      # pixels a side of the largest tile


def result_bytes(width: int, height: int, passes: int) -> int:
    """Blender's render result: float32 RGBA Combined and RGB per pass."""
    return int(width) * int(height) * 4 * (4 + 3 * passes)


def tiling(scene, width: int, height: int, passes: int) -> tuple[int | None, str | None]:
    """How a final render fits the memory budget: (None, None) the whole frame at once; (side,
    None) in tiles of at most ``side`` pixels a side (the renderer's memory then follows the tile:
    ENGINE_BYTES_PER_PIXEL of the tile with its apron); (None, message) refused: Blender's render
    result alone leaves no room for a MIN_TILE tile."""
    from ..engine.tiles import TILE_APRON

    budget, source = memory_budget(scene)
    if budget is None or frame_estimate(width, height, passes) <= budget:
        return None, None
    left = budget - result_bytes(width, height, passes)
    side = int(math.isqrt(max(left, 0) // ENGINE_BYTES_PER_PIXEL)) - 2 * TILE_APRON
    if side >= MIN_TILE:
        return min(side, MAX_TILE), None
    need = result_bytes(width, height, passes) + ENGINE_BYTES_PER_PIXEL * (MIN_TILE + 2 * TILE_APRON) ** 2
    return None, (f"The frame is {width}x{height} ({width * height / 1e6:.1f} megapixels): TFM would "
                  f"need about {need / GIB:.2f} GiB to render it even in tiles (Blender's render result "
                  f"alone takes {result_bytes(width, height, passes) / GIB:.2f} GiB), above the memory "
                  f"budget of {budget / GIB:.2f} GiB ({source}). Nothing was rendered: lower the "
                  f"resolution, turn off passes, or raise the limit (Memory Limit, or {BUDGET_ENV})")


def strict_mode(scene) -> bool:
    """Strict mode: TFM_STRICT=1 (or true/yes/on) in the environment, or the scene's setting."""
    if os.environ.get(STRICT_ENV, "").strip().lower() in ("1", "true", "yes", "on"):
        return True
    return bool(getattr(getattr(scene, "tfm", None), "strict", False))


def _cancelled(engine) -> bool:
    """Whether the frame's GL work should stop: a stop signal, or Blender's break (Esc)."""
    return bool(stop_requested()) or bool(engine.test_break())


def severity(message: str) -> str:
    """'INFO' for a documented approximation, else 'WARNING' (see APPROXIMATION_MARKERS)."""
    return 'INFO' if any(m in message for m in APPROXIMATION_MARKERS) else 'WARNING'


def missing_data(message: str) -> bool:
    """True when the report line says the frame renders without something it needs."""
    return any(m in message for m in MISSING_MARKERS) and not any(m in message for m in NOT_MISSING)


def _background() -> bool:
    import bpy

    return bool(bpy.app.background)


def exit_process(code: int) -> None:
    """End command-line Blender at once with ``code`` (strict mode, a stop signal; tests replace
    it): Python's and C's buffered output is flushed, nothing else runs (no teardown)."""
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        import ctypes

        ctypes.CDLL(None).fflush(None)    # Blender's own lines (C stdio), e.g. the last 'Saved:'
    except (OSError, AttributeError, TypeError):
        pass
    os._exit(code)


# ---------------------------------------------------------------- stop signals
# SIGINT (Ctrl+C) and SIGTERM (a render farm's cancel) while background Blender renders: the
# handler only records the signal; the frame's GL job sees it at its next check (between passes)
# and stops, the frame reports an error so that Blender neither writes it nor renders the next
# one, and when Blender ends the render job (its render_cancel / render_complete handlers) the
# process exits with 128 + the signal's number. A second signal exits at once.
STOP_SIGNALS = ("SIGINT", "SIGTERM")
_stop: dict = {"signal": None, "previous": {}}


def stop_exit_code(signum: int) -> int:
    """The exit status of a process stopped by ``signum`` (the shells' convention: 130, 143)."""
    return 128 + int(signum)


def stop_requested() -> str | None:
    """The name of the stop signal received during this render job (None: none)."""
    signum = _stop["signal"]
    return None if signum is None else signal.Signals(signum).name


def _on_stop_signal(signum, frame) -> None:
    # On the main thread between two bytecodes, possibly inside a lock or a write of the waiting
    # code: set a flag, write with os.write, take no lock.
    if _stop["signal"] is not None:
        os.write(2, f"TFM: a second stop signal ({signal.Signals(signum).name}): exiting at once "
                    f"with status {stop_exit_code(_stop['signal'])}\n".encode())
        os._exit(stop_exit_code(_stop["signal"]))
    _stop["signal"] = signum
    os.write(2, f"TFM: {signal.Signals(signum).name} received: stopping the render; the frame "
                f"being rendered is not written\n".encode())


def guard_signals() -> bool:
    """Called as a final render starts (RenderEngine.render): in background Blender, on the main
    thread, SIGINT and SIGTERM only ask the render to stop (``stop_requested``) until Blender ends
    the render job; then the previous handlers come back. A signal that is ignored, or handled
    outside Python (Blender's own Ctrl+C break in the ``blender`` executable), is left alone, as is
    any signal in Blender's interface. True while guarded."""
    if _stop["previous"]:
        return True
    if not _background() or threading.current_thread() is not threading.main_thread():
        return False
    import bpy

    for name in STOP_SIGNALS:
        signum = getattr(signal, name, None)
        current = None if signum is None else signal.getsignal(signum)
        if not (callable(current) or (current == signal.SIG_DFL and name == "SIGTERM")):
            continue
        try:
            _stop["previous"][signum] = signal.signal(signum, _on_stop_signal)
        except (ValueError, OSError):
            pass
    if _stop["previous"]:
        bpy.app.handlers.render_complete.append(_render_job_ended)
        bpy.app.handlers.render_cancel.append(_render_job_ended)
    return bool(_stop["previous"])


def unguard_signals() -> None:
    """Put back the handlers ``guard_signals`` replaced and forget its Blender handlers."""
    import bpy

    for handlers in (bpy.app.handlers.render_complete, bpy.app.handlers.render_cancel):
        while _render_job_ended in handlers:
            handlers.remove(_render_job_ended)
    previous, _stop["previous"] = _stop["previous"], {}
    for signum, handler in previous.items():
        signal.signal(signum, handler)


def _render_job_ended(*args) -> None:
    """Blender's render_complete / render_cancel: the handlers come back; after a stop signal
    (every frame finished before it was written by now) the process exits."""
    unguard_signals()
    if _stop["signal"] is not None:
        exit_stopped()


def exit_stopped() -> None:
    """End the process after a stop signal: the GL thread ends (its job was cancelled) and
    releases its context, then the process exits with 128 + the signal's number."""
    signum = _stop["signal"]
    code = stop_exit_code(signum)
    print(f"TFM: render stopped by {signal.Signals(signum).name}: frames finished before it are "
          f"written, the interrupted one is not; exiting with status {code}", file=sys.stderr, flush=True)
    close_worker()
    exit_process(code)


_addon_version = caches.memo("final_render.version", 1)


def addon_version() -> str:
    """The extension's version from its blender_manifest.toml ('unknown' without one), read once."""
    return _addon_version.made("version", _read_version)


def _read_version() -> str:
    version = "unknown"
    manifest = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(
        os.path.abspath(__file__)))), "blender_manifest.toml")
    try:
        import tomllib

        with open(manifest, "rb") as f:
            version = str(tomllib.load(f).get("version", version))
    except (OSError, ValueError, ImportError):
        pass
    return version


_gl_description = caches.memo("final_render.gl description", 1)    # the worker's GL, by its id


def gl_description(worker) -> str:
    """'vendor / renderer (version)' of the worker's GL context, asked once per worker."""
    key = id(worker)
    text = _gl_description.get(key)
    if text is None:
        try:
            text = worker.call(lambda r: r.gl.describe(), timeout_s=60.0)
        except Exception as ex:  # no OpenGL: the log says why (and asks again next frame)
            return f"unavailable ({type(ex).__name__}: {ex})"
        _gl_description.put(key, text)
    return text


def log_frame(scene, layer: str, width: int, height: int, samples: int, seconds: float,
              status: str, worker) -> str:
    """The one line per final-render frame on stdout (render farm logs): frame, view layer, size,
    samples, time, outcome, add-on version and GL."""
    gl = gl_description(worker)
    outcome, _, why = status.partition(": ")
    line = (f"TFM frame {scene.frame_current} ({layer}) {outcome} in {seconds:.2f} s | "
            f"{width}x{height}, {samples} samples | add-on {addon_version()} | GL {gl}"
            + (f" | {why}" if why else ""))
    print(line, flush=True)
    return line


def preview_settings(settings, width: int, height: int):
    """The quality for a material preview of ``width`` x ``height`` pixels: steps and maps sized
    for the image (a 128 px preview marches 64 steps and builds 128 px maps), whatever the
    scene's TFM panel says (the preview scene has the add-on's defaults)."""
    side = max(width, height)
    res = int(min(512, max(64, 2 ** round(np.log2(max(side, 1))))))
    steps = int(min(128, max(32, side // 2)))
    return dataclasses.replace(settings, quality='CUSTOM', view_steps=steps, light_steps=steps,
                               map_resolution=res, coefficients=8, density_weight=None,
                               tfm_filter='LINEAR', method='TFM', ambient=True)


def enabled_passes(view_layer) -> tuple[tuple[str, str], ...]:
    """The PASSES entries the view layer's Passes panel turns on (all of them without one)."""
    settings = getattr(view_layer, "tfm", None)
    if settings is None:
        return PASSES
    return tuple((blender_name, name) for blender_name, name in PASSES
                 if getattr(settings, f"use_pass_{name}", True))


def sample_count(scene, camera=None, meshes=()) -> int:
    """Antialiasing samples of a final render: scene.tfm.samples, or for 0 the automatic count
    (sampling.auto_samples: AUTO_SAMPLES, more for ``camera``'s depth of field and for surfaces
    of ``meshes`` with alpha below 1)."""
    return int(scene.tfm.samples) or auto_samples(camera, meshes)


def register_passes(engine, scene, view_layer) -> None:
    """Declare the passes this engine writes (for the compositor and the image editor)."""
    engine.register_pass(scene, view_layer, "Combined", 4, "RGBA", 'COLOR')
    for name, _ in enabled_passes(view_layer):
        engine.register_pass(scene, view_layer, name, 3, "RGB", 'COLOR')


# What the current render job (a still, or the frames of an animation) already said: a warning
# is reported once per job, not once per frame. A job ends when a frame is rendered again (or an
# earlier one), or another scene renders.
_job: dict = {"scene": None, "frame": None, "layers": set(), "told": set()}


def _start_frame(scene_name: str, frame: int, layer: str) -> None:
    j = _job
    if (j["scene"] != scene_name or j["frame"] is None or frame < j["frame"]
            or (frame == j["frame"] and layer in j["layers"])):
        j.update(scene=scene_name, frame=frame, layers=set(), told=set())
    if frame != j["frame"]:
        j.update(frame=frame, layers=set())
    j["layers"].add(layer)


def _tell(engine, level: str, message: str) -> None:
    if level in ('WARNING', 'INFO'):
        if message in _job["told"]:
            return                     # said earlier in this render job (a frame range)
        _job["told"].add(message)
    last_messages.append((level, message))
    if level == 'ERROR':
        engine.error_set(message)
    engine.report({level}, message)


def _warn(engine, message: str, preview: bool) -> None:
    """A report line for the user, at its ``severity``; in a material preview, once per session
    (and on the console)."""
    if preview:
        if message in _preview_reported:
            return
        _preview_reported.add(message)
        print(f"TFM material preview: {message}")
    _tell(engine, severity(message), message)


def auto_fields(chosen: dict) -> list[tuple[str, str]]:
    """What Auto chose (RenderOutput.chosen) as (setting, value) pairs, named as the panels name
    the settings."""
    fields = [("Steps", str(chosen["view_steps"])), ("Shadow Steps", str(chosen["light_steps"])),
              ("Coefficients", str(chosen["coefficients"]))]
    side = chosen.get("tfm_side", 0)
    if side:
        fields.append(("Volume Shadow Maps", f"up to {side}x{side}"))
    return fields


def auto_line(chosen: dict) -> str:
    """The report line saying what Auto chose for the frame."""
    return "Auto quality: " + ", ".join(f"{name} {value}" for name, value in auto_fields(chosen))


def render(engine, depsgraph) -> None:
    """RenderEngine.render: one frame of one view layer. A final render prints one log line
    (``log_frame``); in strict mode a frame that would render without something it needs is an
    error, and command-line Blender exits with STRICT_EXIT_CODE. A stop signal (``guard_signals``)
    or a KeyboardInterrupt stops the frame's GL job and fails the frame with an error: Blender
    writes nothing of it and renders no further frame."""
    last_messages.clear()
    last_timings.clear()
    last_samples[0] = 0
    if engine.is_preview:
        _render(engine, depsgraph, strict=False)
        return
    scene = depsgraph.scene
    strict = strict_mode(scene)
    start = time.perf_counter()
    width, height = engine.resolution_x, engine.resolution_y
    interrupted = stop_requested()
    try:
        status = "cancelled" if interrupted else _render(engine, depsgraph, strict)
    except KeyboardInterrupt:      # Ctrl+C in a script with Python's own handler: the GL job
        status = "cancelled"       # was cancelled and has stopped (wait_for)
        interrupted = "SIGINT (KeyboardInterrupt)"
    interrupted = interrupted or stop_requested()
    if interrupted and status != "written":
        # An error, not a cancel: Blender then neither writes this frame (nor any result of it,
        # tiles included) nor renders the next one. Raising instead would not do: Blender prints
        # the exception, writes the frame as it stands and goes on with the animation.
        _tell(engine, 'ERROR', f"TFM: interrupted by {interrupted}; frame {scene.frame_current} "
                               f"is not written")
        status = f"interrupted: {interrupted}; the frame is not written"
    log_frame(scene, depsgraph.view_layer.name, width, height, last_samples[0] or sample_count(scene),
              time.perf_counter() - start, status, get_worker())
    if strict and status.startswith("failed") and _background():
        print(f"TFM strict mode: frame {scene.frame_current} failed ({status[len('failed: '):]}); "
              f"exiting with status {STRICT_EXIT_CODE}", file=sys.stderr, flush=True)
        exit_process(STRICT_EXIT_CODE)


def _render(engine, depsgraph, strict: bool) -> str:
    """One frame; returns its outcome for the log: 'written', 'cancelled' or 'failed: why'."""
    scene = depsgraph.scene
    _start_frame(scene.name, scene.frame_current, depsgraph.view_layer.name)
    width, height = engine.resolution_x, engine.resolution_y
    window = border_window(scene.render, width, height)
    preview = engine.is_preview
    tile = None
    if not preview:       # before anything the size of the frame is allocated
        tile, refusal = tiling(scene, width, height, len(enabled_passes(depsgraph.view_layer)))
        if refusal is not None:
            return _fail(engine, refusal)
    try:
        extraction = extract(depsgraph, camera_object=engine.camera_override,
                             size=(width, height), window=window,
                             volume_resolution=PREVIEW_VOLUME_RESOLUTION if preview else None)
        if extraction.camera is None:
            return _fail(engine, "The scene has no camera to render from")
        missing = [m for m in extraction.all_warnings if missing_data(m)] if strict else []
        for message in extraction.all_warnings:
            if message not in missing:
                _warn(engine, message, preview)
        if missing:
            return _fail(engine, "Strict mode: " + "; ".join(
                m.split("; rendering without it")[0] for m in missing))
        settings = extraction.settings
        if preview:
            settings = preview_settings(settings, width, height)
        samples = 1 if preview else sample_count(scene, extraction.camera, extraction.meshes)
        last_samples[0] = samples
        engine.update_stats("", "TFM: rendering" if samples == 1 else f"TFM: sample 1/{samples}")
        shown = [0]
        started, logged = time.perf_counter(), [0.0]
        log_after = float(os.environ.get("TFM_PROGRESS_AFTER_S", PROGRESS_AFTER_S))
        log = _background() and not preview

        def progress(fraction):  # on Blender's render thread, like test_break
            engine.update_progress(fraction)
            k = min(int(fraction * samples) + 1, samples)
            if samples > 1 and k != shown[0]:
                shown[0] = k
                engine.update_stats("", f"TFM: sample {k}/{samples}")
            now = time.perf_counter() - started
            if log and now >= log_after and (not logged[0] or now - logged[0] >= PROGRESS_EVERY_S):
                logged[0] = now
                done = min(int(fraction * samples), samples)
                print(progress_line(scene.frame_current, depsgraph.view_layer.name, done, samples, now),
                      flush=True)

        scene_to_render = extraction.scene()
        if not preview:     # motion blur: matrices across the shutter (blender/motion.py)
            motion, notes = read_motion(engine, depsgraph, scene_to_render,
                                        engine.camera_override or depsgraph.scene.camera)
            for message in notes:
                _warn(engine, message, preview)
            scene_to_render = dataclasses.replace(scene_to_render, motion=motion)
        if stop_requested():
            raise RenderCancelled("stopped by a signal before the frame's GL work")
        if tile is None:
            output = get_worker().render(scene_to_render, settings, cancel=lambda: _cancelled(engine),
                                         progress=progress, samples=samples,
                                         client="preview" if preview else "final")
        else:
            output = _render_tiles(engine, scene_to_render, settings, samples, tile,
                                   depsgraph.view_layer, progress)
    except RenderCancelled:
        last_messages.append(('INFO', "cancelled"))
        return "cancelled"
    except RendererError as ex:
        return _fail(engine, str(ex))
    except Exception as ex:
        traceback.print_exc()
        return _fail(engine, f"TFM render failed: {type(ex).__name__}: {ex}")
    for message in output.warnings:
        if message not in extraction.all_warnings:
            _warn(engine, message, preview)
    last_timings.update(output.timings_s)
    if settings.quality == 'AUTO' and output.chosen and not preview:
        auto_choices[scene.name] = dict(output.chosen)
        _tell(engine, 'INFO', auto_line(output.chosen))
    written = tile is not None or write_result(engine, output, depsgraph.view_layer.name, width, height,
                                               passes=enabled_passes(depsgraph.view_layer))
    return "written" if written else "failed: the render result could not be written"


def _render_tiles(engine, scene, settings, samples: int, side: int, view_layer, progress):
    """A frame too large for the memory budget, rendered in tiles of ``side`` pixels
    (engine/tiles.py), each written into Blender's result as it is done; the frame's warnings,
    timings and chosen settings."""
    from ..engine.camera import pixel_window
    from ..engine.tiles import render_tiled

    passes = enabled_passes(view_layer)
    worker = get_worker()

    def cancel():
        return _cancelled(engine)

    def render_tile(tile_scene, tile_settings, until, whites, with_passes):
        if cancel():     # before the next tile's GL work; its tiles written so far are not saved
            raise RenderCancelled("The frame was cancelled between two tiles.")
        size = pixel_window(tile_scene.camera)[2:]
        worker.call(lambda r: r.trim_pools(size), timeout_s=60.0)    # one tile size's GL images
        return worker.render(tile_scene, tile_settings, cancel=cancel, samples=samples,
                             passes=with_passes, until=until, whites=whites)

    def write(tile, out):
        x0, y0, w, h = tile.core
        if not write_result(engine, out, view_layer.name, w, h, passes=passes, x=x0, y=y0):
            raise RendererError("the render result could not be written")

    return render_tiled(render_tile, scene, settings, samples, side, write, passes=bool(passes),
                        progress=progress)


def _fail(engine, message: str) -> str:
    _tell(engine, 'ERROR', message)
    return f"failed: {message}"


def write_result(engine, output, layer_name: str, width: int, height: int, passes=PASSES,
                 x: int = 0, y: int = 0) -> bool:
    """Copy a RenderOutput (top row first) into Blender's render result (bottom row first), at
    pixel (``x``, ``y``) from its lower-left corner (a tile): Combined and ``passes`` (pairs of
    Blender and RenderOutput pass names). False when it could not (reported)."""
    for name, _ in passes:
        engine.add_pass(name, 3, "RGB", layer=layer_name)
    result = engine.begin_result(x, y, width, height, layer=layer_name)
    try:
        layer = result.layers[0]
        images = {"Combined": output.combined}
        for blender_name, name in passes:
            images[blender_name] = output.passes[name]
        for render_pass in layer.passes:
            image = images.get(render_pass.name)
            if image is None:
                continue
            h, w, c = image.shape
            if h * w != len(render_pass.rect) or c != render_pass.channels:
                raise RendererError(
                    f"pass '{render_pass.name}' is {w}x{h}x{c}, Blender expects "
                    f"{len(render_pass.rect)} pixels of {render_pass.channels} channels")
            # Bottom row first; foreach_set copies the float32 buffer straight in (assigning
            # ``rect`` would build a Python object per pixel: seconds and ~100 bytes a pixel).
            render_pass.rect.foreach_set(np.ascontiguousarray(image[::-1], dtype=np.float32).reshape(-1))
    except Exception as ex:
        engine.end_result(result, cancel=True)
        _tell(engine, 'ERROR', f"TFM could not write the render result: {ex}")
        return False
    engine.end_result(result)
    return True
