"""Stopping a final render: SIGINT (Ctrl+C) and SIGTERM (a farm's cancel) sent to a command-line
render stop the GL work, leave the frames finished before them and no file of the interrupted
frame (nor a part of a tiled one), and exit with 130 / 143, never crashing; in the same process a
cancelled render (Esc: the engine's test_break) or an interrupted wait is followed by a render
that works; the handlers are replaced only while background Blender renders."""

import importlib
import os
import signal
import subprocess
import sys
import time

import bpy
import numpy as np
import pytest
from blender_helpers import (
    MODULE,
    ROOT,
    SETTINGS,
    FakeEngine,
    default_sigint,
    moving_light_shot,
    read_exr,
    render_passes,
    smoke,
)

from tfm_addon.blender import scene_builder

HANG_S = 120    # the longest a stopping render may take before the test calls it hung

# A render farm's worker: the add-on registered from the repository, the saved file's animation
# rendered into ``out``; every write into Blender's render result (each tile of a tiled frame)
# says so on stdout, for the test to send its signal in the middle of a tiled frame.
WORKER = """
import os
import sys

import bpy
import tfm_addon

tfm_addon.register()
from tfm_addon.blender import final_render

blend, out = sys.argv[-2:]
bpy.ops.wm.open_mainfile(filepath=blend)
scene = bpy.context.scene
scene.render.filepath = os.path.join(out, "frame_####")
print("TFM test: tiles", final_render.tiling(scene, scene.render.resolution_x,
                                             scene.render.resolution_y, 3)[0], flush=True)
write_result = final_render.write_result


def traced(*args, **kwargs):
    written = write_result(*args, **kwargs)
    print("TFM test: result written", flush=True)
    return written


final_render.write_result = traced
bpy.ops.render.render(animation=True)
print("TFM test: the render returned", flush=True)
"""
WRITTEN = "TFM test: result written"


def _final_render():
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.final_render")


def _interrupt(blend, out, signum, delay_s=0.0, writes_after_first=0, **env_vars):
    """Render ``blend``'s animation in a Blender process and send it ``signum`` ``delay_s`` after
    the first frame's file exists (and ``writes_after_first`` more writes into the render result
    were said); (return code, log, seconds from the signal to the process's end)."""
    log_path = f"{out}.log"
    env = dict(os.environ, PYTHONPATH=ROOT, **env_vars)
    with open(log_path, "w") as log:
        proc = subprocess.Popen([sys.executable, "-c", WORKER, blend, str(out)], env=env,
                                stdout=log, stderr=subprocess.STDOUT, preexec_fn=default_sigint)
    try:
        deadline = time.monotonic() + HANG_S
        first = os.path.join(out, "frame_0001.exr")

        def wait(ready):
            while not ready():
                assert proc.poll() is None, "the render ended before the signal:\n" + _text(log_path)
                assert time.monotonic() < deadline, "no first frame:\n" + _text(log_path)
                time.sleep(0.01)

        wait(lambda: os.path.exists(first))
        writes = _text(log_path).count(WRITTEN) + writes_after_first
        wait(lambda: _text(log_path).count(WRITTEN) >= writes)
        time.sleep(delay_s)
        sent = time.monotonic()
        proc.send_signal(signum)
        try:
            proc.wait(HANG_S)
        except subprocess.TimeoutExpired:
            pytest.fail(f"the render did not stop within {HANG_S} s of the signal:\n" + _text(log_path))
        stopped = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc.returncode, _text(log_path), stopped


def _text(path):
    with open(path, errors="replace") as f:
        return f.read()


def _check_stopped(code, log, out, signum, width, height, frames):
    """The process exited with 128 + ``signum`` (no crash); the frames before the interrupted one
    are there and whole, the interrupted one is not: the number of frames written."""
    name = signal.Signals(signum).name
    assert code == 128 + signum, (code, log[-3000:])           # not -11 (SIGSEGV) nor -6 (SIGABRT)
    assert "Segmentation fault" not in log and "Fatal Python error" not in log, log[-3000:]
    written = sorted(os.listdir(out))
    done = len(written)
    assert 1 <= done < frames and written == [f"frame_{i:04d}.exr" for i in range(1, done + 1)], written
    for file in written:
        image = read_exr(os.path.join(out, file))
        assert image.shape == (height, width, 4) and np.isfinite(image).all(), file
        assert float(image[..., 3].max()) > 0.5, file
    line = next((x for x in log.splitlines() if x.startswith(f"TFM frame {done + 1} (ViewLayer) ")), "")
    assert " interrupted in " in line and line.endswith(f"| {name}; the frame is not written"), log[-3000:]
    assert f"render stopped by {name}" in log and f"exiting with status {128 + signum}" in log
    assert "TFM test: the render returned" not in log        # the process ended in the render job
    return done


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_stops_an_animation_between_frames_written_whole(blank, tmp_path, signum):
    blend = moving_light_shot(tmp_path, 512, 384, samples=16)                # about 1 s a frame on llvmpipe
    code, log, stopped = _interrupt(blend, tmp_path / "out", signum, delay_s=0.3)   # in frame 2
    print(f"{signal.Signals(signum).name}: stopped {stopped:.2f} s after the signal")
    _check_stopped(code, log, tmp_path / "out", signum, 512, 384, frames=4)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_in_a_tiled_frame_writes_no_part_of_it(blank, tmp_path, signum):
    final_render = _final_render()
    blend = moving_light_shot(tmp_path, 320, 240, samples=8, frames=3)
    # Room for the render result and 64-pixel tiles with their aprons: 5 x 4 tiles a frame.
    budget = final_render.result_bytes(320, 240, 3) + final_render.ENGINE_BYTES_PER_PIXEL * 96 ** 2
    code, log, stopped = _interrupt(blend, tmp_path / "out", signum, writes_after_first=3,
                                    **{final_render.BUDGET_ENV: str(budget / 1024 ** 3)})
    print(f"{signal.Signals(signum).name}: stopped {stopped:.2f} s after the signal")
    assert "TFM test: tiles 64" in log, log[-3000:]
    # Sent after three tiles of frame 2 were written into Blender's result: frame 2 is not saved.
    assert _check_stopped(code, log, tmp_path / "out", signum, 320, 240, frames=3) == 1


def _interrupted_then_rendered(tmp_path, tiled, on_break):
    """The smoke scene rendered, then a render stopped at its second check (``on_break``), then
    rendered again: (first, engine of the stopped render, again)."""
    final_render = _final_render()
    scene_builder.build(smoke(width=160, height=120, n=16), str(tmp_path), settings=SETTINGS, samples=4)
    scene = bpy.context.scene
    if tiled:       # 3 x 2 tiles of 64 pixels
        scene.tfm.memory_budget_gb = (final_render.result_bytes(160, 120, 3)
                                      + final_render.ENGINE_BYTES_PER_PIXEL * 96 ** 2) / 1024 ** 3
        assert final_render.tiling(scene, 160, 120, 3) == (64, None)
    first = render_passes(tmp_path, "first")
    engine = FakeEngine(160, 120, break_at=2, on_break=on_break)
    final_render.render(engine, bpy.context.evaluated_depsgraph_get())
    assert engine.checks >= 2
    engine.messages = list(final_render.last_messages)
    again = render_passes(tmp_path, "again")
    return first, engine, again


def _same(a, b):
    for name, image in a.items():
        error = float(np.abs(b[name] - image).max() / max(float(np.abs(image).max()), 1e-6))
        assert error < 1e-4, (name, error)


@pytest.mark.parametrize("tiled", [False, True])
def test_a_cancelled_render_is_followed_by_one_that_works(blank, tmp_path, tiled):
    first, engine, again = _interrupted_then_rendered(tmp_path, tiled, on_break=lambda: True)
    assert engine.errors == [] and ('INFO', "cancelled") in engine.messages
    assert engine.results == 0          # no tile was finished before the second check
    _same(first, again)


def test_an_interrupted_wait_reports_an_error_and_the_next_render_works(blank, tmp_path):
    # Ctrl+C where Python's own handler runs (no guard): KeyboardInterrupt in the wait. The GL
    # job is cancelled and waited for, the frame fails with an error (Blender then writes
    # nothing of it) instead of the exception reaching Blender (which would write the frame).
    def interrupt():
        raise KeyboardInterrupt

    first, engine, again = _interrupted_then_rendered(tmp_path, tiled=False, on_break=interrupt)
    assert engine.errors == ["TFM: interrupted by SIGINT (KeyboardInterrupt); frame 1 is not written"]
    assert engine.results == 0
    _same(first, again)


@pytest.fixture
def python_sigint():
    """SIGINT handled as in a plain Python process (a pytest-xdist worker ignores it)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def test_the_stop_signals_are_taken_only_while_background_blender_renders(blank, tmp_path, monkeypatch,
                                                                          python_sigint):
    final_render = _final_render()
    ours = final_render._on_stop_signal
    stops = (signal.SIGINT, signal.SIGTERM)
    before = {s: signal.getsignal(s) for s in stops}
    assert callable(before[signal.SIGINT]) and ours not in before.values()
    scene_builder.build(smoke(width=32, height=24, n=16), str(tmp_path), settings=SETTINGS, samples=1)
    during = {}

    def render_post(*args):      # after the frame, before Blender ends the render job
        during.update({s: signal.getsignal(s) for s in stops})

    bpy.app.handlers.render_post.append(render_post)
    try:
        render_passes(tmp_path)
    finally:
        bpy.app.handlers.render_post.remove(render_post)
    assert during == {s: ours for s in stops}
    assert {s: signal.getsignal(s) for s in stops} == before      # given back when the job ended
    for handlers in (bpy.app.handlers.render_complete, bpy.app.handlers.render_cancel):
        assert final_render._render_job_ended not in handlers

    # Blender's interface (not background): never.
    monkeypatch.setattr(final_render, "_background", lambda: False)
    assert final_render.guard_signals() is False
    assert {s: signal.getsignal(s) for s in stops} == before

    # An ignored signal stays ignored.
    monkeypatch.setattr(final_render, "_background", lambda: True)
    previous = signal.signal(signal.SIGTERM, signal.SIG_IGN)
    try:
        assert final_render.guard_signals() is True
        assert signal.getsignal(signal.SIGINT) is ours and signal.getsignal(signal.SIGTERM) == signal.SIG_IGN
        final_render.unguard_signals()
        assert signal.getsignal(signal.SIGINT) == before[signal.SIGINT]
    finally:
        signal.signal(signal.SIGTERM, previous)
