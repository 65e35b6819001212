"""Fault injection on a command-line render (the farm worker farm/openjd/render_chunk.py): SIGTERM
or SIGINT at a random moment of the render ends it with 0 (every frame written) or 130 / 143, never
by a signal or a crash, and leaves only whole frames, each one the log says was written; a corrupt
(truncated) .vdb renders the rest and names the file, and fails the frame with status 1 in strict
mode."""

import os
import random
import re
import signal
import subprocess
import sys
import time

import bpy
import numpy as np
import pytest
from blender_helpers import ROOT, SETTINGS, default_sigint, moving_light_shot, read_exr, smoke

from tfm_addon.blender import scene_builder

WORKER = os.path.join(ROOT, "farm", "openjd", "render_chunk.py")
HANG_S = 120
FRAMES = 4
WIDTH, HEIGHT = 320, 240


def _text(path):
    with open(path, errors="replace") as f:
        return f.read()


def _catches_sigterm(pid):
    """Whether the process has a handler for SIGTERM (Linux: /proc/<pid>/status's SigCgt)."""
    try:
        with open(f"/proc/{pid}/status") as f:
            caught = next(line for line in f if line.startswith("SigCgt:"))
    except (OSError, StopIteration):
        return False
    return bool(int(caught.split()[1], 16) >> (signal.SIGTERM - 1) & 1)


def _render(blend, out, frames="1-4", signum=None, delay_s=0.0, **env_vars):
    """render_chunk.py on ``blend``; ``signum`` sent ``delay_s`` after the worker's first Python
    line ran (its handlers are installed: a signal during the interpreter's own start, the first
    ~0.1 s, kills any Python program). (exit status, log, seconds from the start to the end)."""
    log_path = f"{out}.log"
    env = dict(os.environ, PYTHONPATH=ROOT, **env_vars)
    started = time.monotonic()
    with open(log_path, "w") as log:
        proc = subprocess.Popen([sys.executable, WORKER, "--blend", blend, "--output",
                                 os.path.join(out, "frame_####"), "--frames", frames],
                                env=env, stdout=log, stderr=subprocess.STDOUT, preexec_fn=default_sigint)
    try:
        if signum is not None:
            while not _catches_sigterm(proc.pid) and proc.poll() is None:
                assert time.monotonic() < started + HANG_S
                time.sleep(0.002)
            time.sleep(delay_s)
            if proc.poll() is None:
                proc.send_signal(signum)
        try:
            proc.wait(HANG_S)
        except subprocess.TimeoutExpired:
            pytest.fail("the render hung:\n" + _text(log_path)[-3000:])
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc.returncode, _text(log_path), time.monotonic() - started


def _check(code, log, out, signum):
    """Exit status 0 only with every frame, else 128 + the signal; every file whole and one the
    log says was written; the number of frames written."""
    assert code >= 0, (code, log[-3000:])                      # not ended by a signal
    assert "Segmentation fault" not in log and "Fatal Python error" not in log, log[-3000:]
    assert "Traceback" not in log, log[-3000:]
    written = sorted(os.listdir(out)) if os.path.isdir(out) else []
    said = [int(n) for n in re.findall(r"^TFM frame (\d+) \(ViewLayer\) written in ", log, re.M)]
    assert written == [f"frame_{n:04d}.exr" for n in said], (written, said, log[-3000:])
    assert said == list(range(1, len(said) + 1)), said         # the frames before the stop, in order
    for name in written:
        image = read_exr(os.path.join(out, name))
        assert image.shape == (HEIGHT, WIDTH, 4) and np.isfinite(image).all(), name
        assert float(image[..., 3].max()) > 0.5, name
    if code == 0:
        assert len(written) == FRAMES, (written, log[-3000:])
    else:
        assert code == 128 + signum, (code, log[-3000:])
        assert f"exiting with status {code}" in log, log[-3000:]
    return len(written)


def test_a_signal_at_a_random_moment_leaves_whole_frames_and_a_stop_status(blank, tmp_path):
    blend = moving_light_shot(tmp_path, WIDTH, HEIGHT, samples=32, frames=FRAMES, n=16)  # ~0.7 s a frame
    code, log, whole = _render(blend, str(tmp_path / "whole"))
    assert code == 0 and _check(code, log, str(tmp_path / "whole"), None) == FRAMES, log[-3000:]
    rng = random.Random(20240607)
    seen = []
    for i in range(4):
        signum = rng.choice([signal.SIGTERM, signal.SIGINT])
        delay = rng.uniform(0.0, whole)
        out = str(tmp_path / f"run{i}")
        code, log, took = _render(blend, out, signum=signum, delay_s=delay)
        done = _check(code, log, out, signum)
        seen.append(f"{signal.Signals(signum).name} at {delay:.2f} s: status {code}, {done} frames")
    print(f"whole render {whole:.2f} s; " + "; ".join(seen))


def _corrupt_vdb_file(tmp_path):
    """The smoke scene saved with its volume reading a truncated copy of its .vdb; the .blend's
    path and the truncated file's."""
    scene_builder.build(smoke(width=32, height=24, n=16), str(tmp_path), settings=SETTINGS, samples=1)
    volume = next(ob for ob in bpy.context.scene.objects if ob.type == 'VOLUME')
    source = bpy.path.abspath(volume.data.filepath)
    with open(source, "rb") as f:
        data = f.read()
    truncated = str(tmp_path / "truncated.vdb")
    with open(truncated, "wb") as f:
        f.write(data[:len(data) // 2])
    volume.data.filepath = truncated
    blend = str(tmp_path / "corrupt.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    return blend, truncated


def test_a_truncated_vdb_renders_the_rest_and_fails_in_strict_mode(blank, tmp_path):
    blend, truncated = _corrupt_vdb_file(tmp_path)

    code, log, _ = _render(blend, str(tmp_path / "lenient"), frames="1")
    assert code == 0, log[-3000:]
    assert os.listdir(tmp_path / "lenient") == ["frame_0001.png"]   # rendered without the smoke
    said = f"Volume 'TFM Smoke': cannot read grid 'density' from '{truncated}': "
    assert said in log and "; rendering without it" in log, log[-3000:]

    code, log, _ = _render(blend, str(tmp_path / "strict"), frames="1", TFM_STRICT="1")
    assert code == 1, (code, log[-3000:])
    assert f"Strict mode: {said}" in log, log[-3000:]
    assert not os.path.exists(tmp_path / "strict") or os.listdir(tmp_path / "strict") == []


@pytest.mark.parametrize(("fault", "env", "said"), [
    ("no OpenGL", {"__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent/egl_vendor.json"},
     "no OpenGL context could be created"),
    ("memory budget", {"TFM_MEMORY_BUDGET_GB": "0.000001"}, "above the memory budget")],
    ids=["gl", "budget"])
def test_a_frame_that_cannot_render_stops_the_chunk_with_status_1(blank, tmp_path, fault, env, said):
    # The GL context failing (an EGL without a driver) and a frame above the memory budget: the
    # frame fails with its reason, nothing is written, the worker exits 1 without a traceback.
    blend = moving_light_shot(tmp_path, 64, 48, samples=4, frames=2, n=16)
    out = str(tmp_path / "out")
    code, log, _ = _render(blend, out, frames="1-2", **env)
    assert code == 1, (fault, code, log[-3000:])
    assert not os.path.exists(out) or os.listdir(out) == [], os.listdir(out)
    assert re.search(r"TFM frame 1 \(ViewLayer\) failed in .*" + re.escape(said), log), log[-3000:]
    assert "Traceback" not in log, log[-3000:]
