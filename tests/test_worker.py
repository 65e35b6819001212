"""The GL worker: latest-wins slots, step-wise slot jobs, and a close() that always ends."""

import threading
import time

import pytest

from tfm_addon.engine import RenderCancelled, RenderSettings
from tfm_addon.engine.gl_context import GLContext
from tfm_addon.engine.worker import RenderWorker, WorkerClosed
from tfm_addon.scenes import smoke_scene

SETTINGS = RenderSettings(view_steps=32, light_steps=32, map_resolution=64, coefficients=4)


class Recorder:
    """A renderer stand-in for scheduling tests (no GL): records what ran, in order."""

    def __init__(self):
        self.ran = []
        self.released = False

    def release(self):
        self.released = True


def _gl_threads():
    return [t for t in threading.enumerate() if t.name == "tfm-gl"]


def _slow(tag, gate=None, checks=50):
    """A job that records its tag, then works in small steps checking for cancellation."""
    def fn(renderer, job):
        renderer.ran.append(tag)
        if gate is not None:
            gate.set()
        for _ in range(checks):
            if job.cancelled():
                renderer.ran.append(f"{tag} stopped")
                raise RenderCancelled("superseded")
            time.sleep(0.01)
        renderer.ran.append(f"{tag} done")
        return tag
    return fn


def test_latest_request_wins_and_the_one_in_between_never_runs():
    rec = Recorder()
    worker = RenderWorker(lambda: rec)
    started = threading.Event()
    first = worker.post("view", _slow("a", started))
    assert started.wait(5)
    second = worker.post("view", _slow("b"))
    third = worker.post("view", _slow("c", checks=2))
    assert third.result(10) == "c"
    with pytest.raises(RenderCancelled):
        first.result(5)
    with pytest.raises(RenderCancelled):
        second.result(5)
    assert rec.ran == ["a", "a stopped", "c", "c done"]
    assert worker.stats["dropped"] == 1 and worker.stats["superseded"] == 1
    assert worker.close(5) and rec.released


def test_generator_slot_jobs_step_between_queued_jobs():
    rec = Recorder()
    worker = RenderWorker(lambda: rec)
    gate = threading.Event()
    release = threading.Event()

    def progressive(renderer, job):
        for i in range(3):
            renderer.ran.append(f"step {i}")
            if i == 0:
                gate.set()
                release.wait(5)
            yield
        return "converged"

    job = worker.post("view", progressive)
    assert gate.wait(5)
    queued = worker.submit(lambda r, j: r.ran.append("final") or "final")
    release.set()
    assert queued.result(5) == "final" and job.result(5) == "converged"
    # The queued job ran after the step in progress, before the slot job's next step.
    assert rec.ran == ["step 0", "final", "step 1", "step 2"]
    assert worker.close(5)


def test_close_fails_queued_jobs_at_once_and_later_calls_fast():
    rec = Recorder()
    worker = RenderWorker(lambda: rec)
    started = threading.Event()
    stuck = threading.Event()
    running = worker.submit(lambda r, j: (started.set(), stuck.wait(10)))  # ignores cancellation
    assert started.wait(5)
    queued = worker.submit(lambda r, j: r.ran.append("never"))
    slot = worker.post("view", lambda r, j: r.ran.append("never either"))
    assert worker.close(timeout_s=0.05) is False  # the running job ignores cancel: not ended yet
    for job in (running, queued, slot):
        with pytest.raises(WorkerClosed, match="closed"):
            job.result(0)  # already failed: no wait at all
    with pytest.raises(WorkerClosed, match="closed"):
        worker.call(lambda r: 1)
    with pytest.raises(WorkerClosed):
        worker.post("view", lambda r, j: 1)
    stuck.set()
    assert worker.close(5) and not worker.alive and rec.released
    assert rec.ran == []


def test_close_during_a_render_ends_the_thread_and_releases_the_context():
    scene = smoke_scene(width=48, height=32, n=32)
    live, threads = GLContext.live, len(_gl_threads())
    worker = RenderWorker()
    worker.render(scene, SETTINGS)  # the context exists, programs compiled
    assert GLContext.live == live + 1
    started = threading.Event()

    def forever(renderer, job):  # renders until cancelled (the renderer checks between passes)
        started.set()
        while True:
            renderer.render(scene, SETTINGS, cancel=job.cancelled)

    waiting = worker.submit(forever)
    assert started.wait(10)
    assert worker.close(timeout_s=10.0)
    with pytest.raises(WorkerClosed):
        waiting.result(0)
    with pytest.raises(WorkerClosed):
        worker.render(scene, SETTINGS)
    assert not worker.alive
    assert GLContext.live == live and len(_gl_threads()) == threads


def test_render_calls_progress_and_cancel_on_the_calling_thread():
    scene = smoke_scene(width=48, height=32, n=32)
    worker = RenderWorker()
    seen = set()
    progress = []

    def on_progress(fraction):
        seen.add(threading.get_ident())
        progress.append(fraction)

    def cancel():
        seen.add(threading.get_ident())
        return False

    out = worker.render(scene, SETTINGS, cancel=cancel, progress=on_progress)
    assert out.combined.max() > 0
    assert seen == {threading.get_ident()}
    assert progress == sorted(progress) and progress[-1] == 1.0

    calls = []

    def cancel_at_once():
        calls.append(1)
        return True

    with pytest.raises(RenderCancelled):
        worker.render(scene, SETTINGS, cancel=cancel_at_once)
    assert worker.counters["renders"] == 1  # the cancelled frame never finished
    assert worker.close(10)



def test_waiting_for_a_pass_lets_other_python_threads_run(renderer):
    """moderngl keeps the GIL in its calls; the renderer's waits (GLContext.finish) must not, or
    the host's UI thread stops for a whole pass. A thread that wakes every 0.5 ms counts its
    wake-ups while the GL thread waits for queued passes."""
    import dataclasses

    from tfm_addon.engine.camera import view_plane
    from tfm_addon.engine.passes.scattering import ScatteringTargets, run_light_pass

    scene = smoke_scene(width=320, height=180, n=32)
    heavy = dataclasses.replace(SETTINGS, view_steps=200)
    renderer.render(scene, heavy)  # compiles and builds everything once
    gl = renderer.gl
    wakeups = [0]
    stop = threading.Event()

    def tick():
        while not stop.is_set():
            time.sleep(0.0005)
            wakeups[0] += 1

    thread = threading.Thread(target=tick)
    with gl.ctx:
        targets = ScatteringTargets(gl, (320, 180))
        medium_gpu, _ = renderer._medium(scene, heavy)
        plane = view_plane(scene.camera)
        thread.start()
        targets.begin(gl.ctx)
        for _ in range(4):  # queued, not waited for
            run_light_pass(gl, camera=scene.camera, plane=plane, medium=scene.media[0], medium_gpu=medium_gpu,
                           settings=heavy, ambient=(0.1, 0.1, 0.1), first=True)
        before = wakeups[0]
        t0 = time.perf_counter()
        gl.finish()
        waited = time.perf_counter() - t0
        during = wakeups[0] - before
        stop.set()
        thread.join()
        gl.ctx.disable(gl.ctx.BLEND)
        targets.release()
    if waited < 0.02:
        pytest.skip(f"the GPU finished the passes in {waited * 1000:.1f} ms: nothing to wait for")
    # Held GIL: no wake-up at all during the wait. Released: one per 0.5 ms or so (fewer on busy cores).
    assert during >= 5, (during, waited)


def test_an_interrupted_waiter_cancels_its_job():
    # Ctrl+C in a script raises KeyboardInterrupt in the thread waiting for a render: the GL
    # job must stop at its next check, not finish a frame nobody will read.
    worker = RenderWorker(renderer_factory=Recorder)
    recorder = worker.call(lambda r: r)
    gate = threading.Event()
    job = worker.submit(_slow("frame", gate, checks=500))     # 5 s if never cancelled
    assert gate.wait(5)

    def interrupt(fraction):
        raise KeyboardInterrupt

    from tfm_addon.engine.worker import wait_for
    job.set_progress(0.5)
    with pytest.raises(KeyboardInterrupt):
        wait_for(job, progress=interrupt)
    assert job.cancelled()
    assert worker.call(lambda r: "next", timeout_s=2) == "next"   # the thread is free again
    assert recorder.ran == ["frame", "frame stopped"]
    assert worker.close(5)
