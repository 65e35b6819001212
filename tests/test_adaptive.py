"""Adaptive sampling (engine/adaptive.py): the light passes shade exactly the active pixels, the
converged pixels stop early without raising the error against a supersampled image, and the
viewport, two processes and the final render still agree."""

import dataclasses
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from tfm_addon.engine import RenderSettings
from tfm_addon.engine.adaptive import ADAPTIVE_FIRST_SAMPLES, ADAPTIVE_MIN_SAMPLES, TILE, active_pixels
from tfm_addon.engine.progressive import ProgressiveView
from tfm_addon.engine.sampling import (
    MANY_SAMPLES,
    MANY_SAMPLES_COEFFICIENTS,
    Accumulator,
    frame_settings,
    iter_samples,
    render_samples,
)
from tfm_addon.engine.worker import RenderWorker
from tfm_addon.scenes import smoke_scene

SETTINGS = RenderSettings(view_steps=32, light_steps=32, map_resolution=64, coefficients=4)
ROOT = Path(__file__).resolve().parents[1]


def test_the_light_passes_shade_exactly_the_active_blocks(renderer):
    h, w = 23, 37                       # neither a multiple of the block side
    scene = smoke_scene(width=w, height=h, n=32)
    mask = np.random.default_rng(3).random((h, w)) < 0.04
    active = active_pixels(mask)
    assert active.mask[mask].all() and 0.0 < active.fraction < 0.8
    blocks = active.mask[::-1]          # counted from the lower-left corner, as GL does
    for y in range(0, h, TILE):
        for x in range(0, w, TILE):
            block = blocks[y:y + TILE, x:x + TILE]
            assert block.all() or not block.any()
    full = renderer.render(scene, SETTINGS)
    before = renderer.counters["pixels_shaded"]
    part = renderer.render(scene, SETTINGS, active=active)
    assert renderer.counters["pixels_shaded"] - before == int(active.mask.sum())
    assert np.array_equal(part.combined[active.mask], full.combined[active.mask])
    assert not part.combined[~active.mask][:, :3].any()
    for name, image in full.passes.items():
        assert np.array_equal(part.passes[name][active.mask], image[active.mask]), name


def test_adaptive_sampling_keeps_the_error_for_a_fraction_of_the_pixels(fresh):
    # Against the 8x8 supersampled, box-filtered view (midpoint march): 32 adaptive samples leave
    # the mean error of 32 samples everywhere (within 10 %), while the pixels that stopped after
    # the first 2 or 8 samples make the light passes shade under 60 % of the pixels (the smoke fills
    # a third of this small image, in whole blocks).
    big = smoke_scene(width=48 * 8, height=32 * 8, n=32)
    reference = fresh.render(big, SETTINGS).combined.reshape(32, 8, 48, 8, 4).mean(axis=(1, 3))
    scene = smoke_scene(width=48, height=32, n=32)

    def run(threshold):
        before = fresh.counters["pixels_shaded"]
        acc = Accumulator()
        for _ in iter_samples(fresh, scene, SETTINGS, 32, accumulator=acc, adaptive_threshold=threshold):
            pass
        error = float(np.abs(acc.output.combined - reference).mean())
        return error, fresh.counters["pixels_shaded"] - before, acc

    uniform, uniform_pixels, _ = run(None)
    adaptive, adaptive_pixels, acc = run(0.01)
    eight = float(np.abs(render_samples(fresh, scene, SETTINGS, ADAPTIVE_MIN_SAMPLES).combined
                         - reference).mean())
    assert uniform_pixels == 32 * 48 * 32
    print("mean error: adaptive", adaptive, "uniform", uniform, "8 samples", eight)
    assert adaptive <= 1.1 * uniform and adaptive < 0.8 * eight, (adaptive, uniform, eight)
    assert adaptive_pixels == int(acc.pixel_samples.sum())
    assert adaptive_pixels < 0.6 * uniform_pixels, adaptive_pixels / uniform_pixels
    counts = {int(c): int((acc.pixel_samples == c).sum()) for c in np.unique(acc.pixel_samples)}
    assert set(counts) == {ADAPTIVE_FIRST_SAMPLES, ADAPTIVE_MIN_SAMPLES, 32}, counts
    assert np.array_equal(acc.pixel_samples == 32, acc.active.mask)
    # The pixels that stopped first are flat: black background and unlit ground in this view.
    assert float(np.abs(acc.output.combined[acc.pixel_samples == ADAPTIVE_FIRST_SAMPLES, :3]).max()) < 1e-3


def test_a_frame_whose_pixels_have_all_converged_ends_there(fresh):
    """A frame decides its sample count from its samples: where the first decision stops every
    pixel (a flat world, nothing else), the frame ends after its first samples."""
    scene = dataclasses.replace(smoke_scene(width=48, height=32, n=16), media=(), meshes=(), lights=(),
                                ambient=(0.2, 0.2, 0.2))
    acc = Accumulator()
    opaque = dataclasses.replace(SETTINGS, film_transparent=False)      # the world seen: 0.2 grey
    for _ in iter_samples(fresh, scene, opaque, 32, accumulator=acc):
        pass
    assert acc.count == ADAPTIVE_FIRST_SAMPLES and not acc.active.mask.any()
    assert np.allclose(acc.output.combined, (0.2, 0.2, 0.2, 1.0), atol=1e-6)
    # the smoke goes on to every sample where it has not converged
    acc = Accumulator()
    for _ in iter_samples(fresh, smoke_scene(width=48, height=32, n=16), SETTINGS, 16, accumulator=acc):
        pass
    assert acc.count == 16


def test_the_converged_viewport_equals_the_adaptive_final_render():
    worker = RenderWorker()
    try:
        view = ProgressiveView(worker)
        scene = smoke_scene(width=48, height=32, n=32)
        samples = 2 * ADAPTIVE_MIN_SAMPLES + 2
        view.request("A", scene, SETTINGS, samples)
        for _ in range(6000):
            frame = view.frame()
            if frame is not None and frame.samples == samples and view.state == "idle":
                break
            time.sleep(0.01)
        assert frame.samples == samples and frame.stage == "accumulating"
        before = worker.call(lambda r: r.counters["pixels_shaded"])
        final = worker.call(lambda r: render_samples(r, scene, SETTINGS, samples, passes=False))
        shaded = worker.call(lambda r: r.counters["pixels_shaded"]) - before
        assert shaded < 0.8 * samples * 48 * 32        # the adaptive part ran
        assert float(np.abs(frame.image - final.combined).max()) <= 1e-4
    finally:
        assert worker.close(10)


_OTHER_PROCESS = """
import sys
import numpy as np
from tfm_addon.engine import Renderer, RenderSettings
from tfm_addon.engine.sampling import render_samples
from tfm_addon.scenes import smoke_scene
settings = RenderSettings(view_steps=32, light_steps=32, map_resolution=64, coefficients=4)
scene = smoke_scene(width=48, height=32, n=32)
np.save(sys.argv[1], render_samples(Renderer(), scene, settings, 20).combined)
"""


def test_another_process_renders_the_same_adaptive_frame_bit_for_bit(renderer, tmp_path):
    out = tmp_path / "frame.npy"
    done = subprocess.run([sys.executable, "-c", _OTHER_PROCESS, str(out)], cwd=ROOT, capture_output=True,
                          text=True, timeout=300, env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert done.returncode == 0, done.stderr[-2000:]
    here = render_samples(renderer, smoke_scene(width=48, height=32, n=32), SETTINGS, 20).combined
    assert np.array_equal(np.load(out), here)


def test_auto_takes_more_coefficients_for_many_samples():
    scene = smoke_scene(width=48, height=32, n=32)
    auto = RenderSettings(quality="AUTO", map_resolution=64)
    few = frame_settings(scene, auto, MANY_SAMPLES - 1)
    many = frame_settings(scene, auto, MANY_SAMPLES)
    assert few.coefficients < MANY_SAMPLES_COEFFICIENTS       # AUTO's own choice on this thin smoke
    assert many.coefficients == MANY_SAMPLES_COEFFICIENTS
    assert dataclasses.replace(many, coefficients=few.coefficients, view_steps=few.view_steps,
                               frame_samples=few.frame_samples) == few
    assert (few.frame_samples, many.frame_samples) == (MANY_SAMPLES - 1, MANY_SAMPLES)
    custom = frame_settings(scene, SETTINGS, MANY_SAMPLES)     # CUSTOM keeps the user's choice
    assert custom.coefficients == SETTINGS.coefficients



def test_a_sample_reads_its_light_targets_only_where_its_first_pass_wrote(fresh, monkeypatch):
    # A sample of an accumulated frame does not clear the light passes' targets: the first pass
    # writes the pixels (blending off), the others add. Garbage put in the targets before every
    # sample must not reach the frame: it equals the frame of targets cleared before every sample,
    # under adaptive sampling (rectangles) and with a point light (several passes a sample).
    from tfm_addon.engine.passes.scattering import ScatteringTargets
    from tfm_addon.engine.scene import Light

    scene = smoke_scene(width=40, height=24, n=32)
    point = Light(kind="POINT", matrix_world=np.array(
        [[1, 0, 0, 1.5], [0, 1, 0, -1.0], [0, 0, 1, 2.5], [0, 0, 0, 1]], float), power_w=800.0)
    scene = dataclasses.replace(scene, lights=(*scene.lights, point))
    samples = 2 * ADAPTIVE_MIN_SAMPLES
    begin = ScatteringTargets.begin
    cleared = []

    def frame():
        acc = Accumulator()
        for _ in iter_samples(fresh, scene, SETTINGS, samples, passes=True, accumulator=acc):
            pass
        return acc

    def cleared_begin(self, ctx, clear=True, composing=False):
        cleared.append(clear)
        begin(self, ctx, True, composing)

    def poisoned_begin(self, ctx, clear=True, composing=False):
        self.fbo.use()
        self.fbo.clear(1e3, -1e3, 1e3, 1e3)
        begin(self, ctx, clear, composing)

    monkeypatch.setattr(ScatteringTargets, "begin", cleared_begin)
    full = frame()
    assert cleared == [False] * samples          # the renderer clears none of them itself
    assert full.active is not None and 0.0 < full.active.fraction < 0.9
    assert fresh.counters["light_passes"] >= 2 * samples
    fresh.clear_maps()
    monkeypatch.setattr(ScatteringTargets, "begin", poisoned_begin)
    part = frame()
    assert np.array_equal(part.active.mask, full.active.mask)
    assert np.abs(part.output.combined - full.output.combined).max() <= 1e-6
    for name, image in full.output.passes.items():
        assert np.abs(part.output.passes[name] - image).max() <= 1e-6, name


def test_rectangle_sets_drawn_in_turn_each_shade_their_own_pixels(renderer):
    # draw_rects keeps the vertex arrays of recent (program, rectangles) pairs (RECT_ARRAYS): sets
    # drawn in turn, more of them than it keeps and then the first ones again, each shade exactly
    # their blocks (a vertex array of another set, or of a released buffer, would not).
    from tfm_addon.engine.gl_context import RECT_ARRAYS

    h, w = 24, 40
    scene = smoke_scene(width=w, height=h, n=32)
    full = renderer.render(scene, SETTINGS, passes=False).combined
    rng = np.random.default_rng(5)
    sets = [active_pixels(rng.random((h, w)) < 0.03) for _ in range(RECT_ARRAYS + 2)]
    for active in sets + sets[:3]:
        part = renderer.render(scene, SETTINGS, passes=False, active=active).combined
        assert np.array_equal(part[active.mask], full[active.mask])
        assert not part[~active.mask][:, :3].any()
    assert len(renderer.gl._rects) <= RECT_ARRAYS
