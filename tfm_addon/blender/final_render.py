"""Final renders (F12, animations, command line) and material previews.

Reads the scene, renders its antialiasing samples on the GL thread while this thread (the one
Blender called the engine on) forwards progress and cancel, writes Combined and the three passes
into Blender's render result, and reports problems to the user; nothing raises into Blender.
"""

from __future__ import annotations

import dataclasses
import traceback

import numpy as np

from ..engine.errors import RenderCancelled, RendererError
from ..engine.sampling import AUTO_SAMPLES
from .camera import border_window
from .extract import extract
from .render_worker import get_worker

# Blender pass name -> RenderOutput pass name.
PASSES = (("Scattering", "scattering"), ("Surfaces", "surfaces"), ("Transmittance", "transmittance"))

# What the last final render told the user: (level, message) pairs, for scripts and tests.
last_messages: list[tuple[str, str]] = []
# Seconds per stage of the last final render, as the renderer measured them.
last_timings: dict[str, float] = {}
# Warnings already given in a material preview: each is reported once per session, since Blender
# renders the same preview scene again for every material and shape.
_preview_reported: set[str] = set()

# Voxels along a mesh medium's longest side in a preview (its shapes span ~100 px of 128).
PREVIEW_VOLUME_RESOLUTION = 64


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


def sample_count(scene) -> int:
    """Antialiasing samples of a final render: scene.tfm.samples, or AUTO_SAMPLES for 0."""
    return int(scene.tfm.samples) or AUTO_SAMPLES


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
    if level == 'WARNING':
        if message in _job["told"]:
            return                     # said earlier in this render job
        _job["told"].add(message)
    last_messages.append((level, message))
    if level == 'ERROR':
        engine.error_set(message)
    engine.report({level}, message)


def _warn(engine, message: str, preview: bool) -> None:
    """A warning for the user; in a material preview, once per session (and on the console)."""
    if preview:
        if message in _preview_reported:
            return
        _preview_reported.add(message)
        print(f"TFM material preview: {message}")
    _tell(engine, 'WARNING', message)


def auto_line(chosen: dict) -> str:
    """The report line saying what Auto chose for the frame."""
    side = chosen.get("tfm_side", 0)
    maps = f", transmittance maps up to {side}x{side}" if side else ""
    return (f"Auto quality: {chosen['view_steps']} view steps, {chosen['light_steps']} light steps, "
            f"{chosen['coefficients']} coefficients{maps}")


def render(engine, depsgraph) -> None:
    """RenderEngine.render: one frame of one view layer."""
    last_messages.clear()
    last_timings.clear()
    scene = depsgraph.scene
    _start_frame(scene.name, scene.frame_current, depsgraph.view_layer.name)
    width, height = engine.resolution_x, engine.resolution_y
    window = border_window(scene.render, width, height)
    preview = engine.is_preview
    try:
        extraction = extract(depsgraph, camera_object=engine.camera_override,
                             size=(width, height), window=window,
                             volume_resolution=PREVIEW_VOLUME_RESOLUTION if preview else None)
        if extraction.camera is None:
            _tell(engine, 'ERROR', "The scene has no camera to render from")
            return
        for message in extraction.all_warnings:
            _warn(engine, message, preview)
        settings = extraction.settings
        if preview:
            settings = preview_settings(settings, width, height)
        samples = 1 if preview else sample_count(scene)
        engine.update_stats("", "TFM: rendering" if samples == 1 else f"TFM: sample 1/{samples}")
        shown = [0]

        def progress(fraction):  # on Blender's render thread, like test_break
            engine.update_progress(fraction)
            k = min(int(fraction * samples) + 1, samples)
            if samples > 1 and k != shown[0]:
                shown[0] = k
                engine.update_stats("", f"TFM: sample {k}/{samples}")

        output = get_worker().render(extraction.scene(), settings,
                                     cancel=engine.test_break, progress=progress, samples=samples,
                                     client="preview" if preview else "final")
    except RenderCancelled:
        last_messages.append(('INFO', "cancelled"))
        return
    except RendererError as ex:
        _tell(engine, 'ERROR', str(ex))
        return
    except Exception as ex:
        traceback.print_exc()
        _tell(engine, 'ERROR', f"TFM render failed: {type(ex).__name__}: {ex}")
        return
    for message in output.warnings:
        if message not in extraction.all_warnings:
            _warn(engine, message, preview)
    last_timings.update(output.timings_s)
    if settings.quality == 'AUTO' and output.chosen and not preview:
        _tell(engine, 'INFO', auto_line(output.chosen))
    write_result(engine, output, depsgraph.view_layer.name, width, height,
                 passes=enabled_passes(depsgraph.view_layer))


def write_result(engine, output, layer_name: str, width: int, height: int, passes=PASSES) -> None:
    """Copy a RenderOutput (top row first) into Blender's render result (bottom row first):
    Combined and ``passes`` (pairs of Blender and RenderOutput pass names)."""
    for name, _ in passes:
        engine.add_pass(name, 3, "RGB", layer=layer_name)
    result = engine.begin_result(0, 0, width, height, layer=layer_name)
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
            render_pass.rect = np.ascontiguousarray(image[::-1].reshape(h * w, c), dtype=np.float32)
    except Exception as ex:
        engine.end_result(result, cancel=True)
        _tell(engine, 'ERROR', f"TFM could not write the render result: {ex}")
        return
    engine.end_result(result)
