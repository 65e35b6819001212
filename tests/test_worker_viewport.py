"""The progressive viewport image on the GL worker: latest wins, superseded frames are never
shown, maps are built once per change, and the converged image is the final render's."""

import dataclasses
import threading

import numpy as np

from tfm_addon.engine import RenderSettings, progressive
from tfm_addon.engine.progressive import ProgressiveView
from tfm_addon.engine.sampling import render_samples
from tfm_addon.engine.worker import RenderWorker
from tfm_addon.scenes import look_at, smoke_scene

SETTINGS = RenderSettings(view_steps=32, light_steps=32, map_resolution=64, coefficients=4)
MAPS128 = dataclasses.replace(SETTINGS, map_resolution=128)  # coarse maps: 64


class RecordingView(ProgressiveView):
    """Records every frame the GL thread offers, shown or dropped."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.offered = []
        self.on_offer = None

    def _publish(self, generation, *args):
        if self.on_offer is not None:
            self.on_offer(generation)
        shown = super()._publish(generation, *args)
        self.offered.append((generation, shown))
        return shown


def _wait_converged(view, generation, timeout_s=60.0):
    done = threading.Event()
    for _ in range(int(timeout_s / 0.01)):
        frame = view.frame()
        if frame is not None and frame.generation == generation and view.state == "idle":
            return frame
        done.wait(0.01)
    raise AssertionError(f"not converged: {view.state}, {view.counters}")


def _counts(worker):
    return dict(worker.counters)


def test_superseded_frames_are_dropped_without_being_shown():
    worker = RenderWorker()
    view = RecordingView(worker)
    scene = smoke_scene(width=64, height=40, n=32)
    moved = dataclasses.replace(scene, camera=dataclasses.replace(
        scene.camera, matrix_world=look_at((0.5, -6.0, 2.0), (0, 0, 1.0))))

    # A: the new request arrives while A's first frame is finishing: that frame is dropped.
    def supersede(generation):
        if generation == 1:
            view.on_offer = None
            view.request("B", moved, SETTINGS, 4)

    view.on_offer = supersede
    view.request("A", scene, SETTINGS, 4)
    frame = _wait_converged(view, 2)
    assert view.offered[0] == (1, False)
    assert all(shown for gen, shown in view.offered if gen == 2)
    assert not any(shown for gen, shown in view.offered if gen == 1)
    assert view.counters["dropped"] >= 1 and frame.samples == 4

    # C waits in the slot behind a busy worker and D replaces it: C never runs at all.
    gate = threading.Event()
    busy = worker.submit(lambda r, j: gate.wait(10))
    view.request("C", scene, SETTINGS, 4)
    view.request("D", moved, SETTINGS, 2)
    gate.set()
    busy.result(10)
    _wait_converged(view, 4)
    assert [gen for gen, _ in view.offered if gen == 3] == []
    assert worker.stats["dropped"] >= 1
    # The same request again posts nothing.
    assert view.request("D", moved, SETTINGS, 2) is False
    assert worker.close(10)


def test_coarse_then_full_then_samples_with_maps_built_once_per_change():
    worker = RenderWorker()
    view = RecordingView(worker)
    scene = smoke_scene(width=64, height=40, n=32)
    view.request(1, scene, MAPS128, 6)
    _wait_converged(view, 1)
    assert view.counters["coarse"] == 1 and view.counters["samples"] == 6

    # Orbit the camera: no light map rebuilt while it refines to 6 samples.
    before = _counts(worker)
    orbit = dataclasses.replace(scene, camera=dataclasses.replace(
        scene.camera, matrix_world=look_at((2.0, -5.5, 2.0), (0, 0, 1.0))))
    gate = threading.Event()
    busy = worker.submit(lambda r, j: gate.wait(10))
    view.request(2, orbit, MAPS128, 6)
    assert view.status == "Rendering"                    # same maps: none to build
    gate.set()
    busy.result(10)
    frame = _wait_converged(view, 2)
    after = _counts(worker)
    assert all(after[k] == before[k] for k in ("tfms", "shadow_maps", "grid_uploads"))
    assert after["gbuffers"] - before["gbuffers"] >= 6

    # Move the light: its maps are rebuilt once for the coarse image (quarter side, half the
    # light steps) and once for the full one, not once per refinement step.
    light = scene.lights[0]
    lit = dataclasses.replace(orbit, lights=(dataclasses.replace(
        light, matrix_world=look_at((-2.0, -1.5, 4.5), (0, 0, 1.0))),))
    before, coarse = after, view.counters["coarse"]
    gate = threading.Event()
    busy = worker.submit(lambda r, j: gate.wait(10))     # hold the GL thread: the header first
    view.request(3, lit, MAPS128, 6)
    assert view.status == "Building maps" and view.state == "coarse"
    gate.set()
    busy.result(10)
    relit = _wait_converged(view, 3)
    after = _counts(worker)
    assert view.counters["coarse"] == coarse + 1
    assert after["tfms"] - before["tfms"] == 2 and after["shadow_maps"] - before["shadow_maps"] == 2
    assert float(np.abs(relit.image - frame.image).max()) > 0.01

    # More coefficients: new TFMs (coarse and full); the full shadow map is still valid and the
    # coarse frame in between does not evict it (only the coarse image's own one is built).
    before = after
    view.request(4, lit, dataclasses.replace(MAPS128, coefficients=8), 6)
    _wait_converged(view, 4)
    after = _counts(worker)
    assert after["tfms"] - before["tfms"] == 2 and after["shadow_maps"] - before["shadow_maps"] == 1

    # Converged: the viewport's image is the final render of that view at that sample count.
    assert view.status == "Sample 6/6" and relit.samples == 6 and relit.stage == "accumulating"
    final = worker.call(lambda r: render_samples(r, lit, MAPS128, 6, passes=False))
    assert float(np.abs(relit.image - final.combined).max()) <= 1e-4
    assert relit.image.shape == final.combined.shape
    assert worker.close(10)


def test_a_failing_render_is_named_in_the_status_and_the_view_goes_idle():
    class Broken:
        def render(self, *args, **kwargs):
            raise ValueError("boom")

        def release(self):
            pass

    worker = RenderWorker(Broken)
    view = ProgressiveView(worker)
    view.request(1, smoke_scene(width=32, height=24, n=16), SETTINGS, 4)
    job = view._job
    assert job.wait(10)
    assert view.status == "viewport failed: ValueError: boom" and view.state == "idle"
    assert view.frame() is None
    assert worker.close(5)


def test_coarse_image_reuses_the_full_footprint_tfm(monkeypatch):
    """Orbiting the camera builds no map: the coarse image (a quarter of the side) caps a
    'FOOTPRINT' TFM by the full image's side, so it reads the full image's TFM (it built its own
    at every camera move, and the full frame then released it)."""
    monkeypatch.setattr(progressive, "COARSE_BELOW_S", 0.0)      # always a coarse image first
    worker = RenderWorker()
    view = ProgressiveView(worker)
    settings = dataclasses.replace(SETTINGS, map_resolution=256, tfm_resolution="FOOTPRINT")
    scene = smoke_scene(width=256, height=144, n=128)
    view.request(1, scene, settings, 1)
    _wait_converged(view, 1)
    before = _counts(worker)
    for i in range(2):
        orbit = dataclasses.replace(scene, camera=dataclasses.replace(
            scene.camera, matrix_world=look_at((2.0 + i, -5.5, 2.0), (0, 0, 1.0))))
        view.request(2 + i, orbit, settings, 1)
        _wait_converged(view, 2 + i)
    after = _counts(worker)
    assert view.counters["coarse"] == 3
    assert after["tfms"] - before["tfms"] == 0
    assert worker.close(10)


def test_a_light_move_builds_the_multiple_scattering_fields_once_for_the_full_image():
    """With volume bounces the lattice's fields are built from the full maps: the coarse image
    after a light move (quarter-side maps) leaves them out, so that it comes quickly; the full
    image builds them once, and the refinement steps reuse them."""
    worker = RenderWorker()
    view = RecordingView(worker)
    scene = smoke_scene(width=48, height=32, n=24)
    bounces = dataclasses.replace(MAPS128, volume_bounces=16)
    view.request(1, scene, bounces, 3)
    first = _wait_converged(view, 1)
    assert worker.counters["fluences"] == 1
    light = scene.lights[0]
    lit = dataclasses.replace(scene, lights=(dataclasses.replace(
        light, matrix_world=look_at((-2.0, -1.5, 4.5), (0, 0, 1.0))),))
    coarse = view.counters["coarse"]
    view.request(2, lit, bounces, 3)
    relit = _wait_converged(view, 2)
    assert view.counters["coarse"] == coarse + 1
    assert worker.counters["fluences"] == 2
    assert float(np.abs(relit.image - first.image).max()) > 0.01
    # the converged image is the final render's, fields included
    final = worker.call(lambda r: render_samples(r, lit, bounces, 3, passes=False))
    assert float(np.abs(relit.image - final.combined).max()) <= 1e-4
    assert worker.close(10)
