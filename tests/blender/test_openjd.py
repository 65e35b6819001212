"""The Open Job Description job template farm/openjd/render_frames.yaml run by a real farm runtime
(openjd-cli's `openjd run`, the local runner of AWS Deadline Cloud's job format): the chunks'
frames equal those of one process, bit for bit; a chunk cancelled in the middle of a frame (the
task's timeout: openjd-sessions sends SIGTERM, then SIGKILL after the notify period) leaves the
frames finished before it, no file of the interrupted frame, and a failed run."""

import os
import re
import shutil
import subprocess
import sys
import time

import bpy
import numpy as np
import pytest
from blender_helpers import ROOT, SETTINGS, farm_shot, read_exr, smoke

from tfm_addon.blender import scene_builder

TEMPLATE = os.path.join(ROOT, "farm", "openjd", "render_frames.yaml")
WORKER = os.path.join(ROOT, "farm", "openjd", "render_chunk.py")
HANG_S = 300    # the longest a run may take before the test calls it hung
TIMEOUT_S = 8   # the cancelled chunk: time for Python and Blender to start and write frame 1


def _openjd():
    """The `openjd` command of this interpreter's environment (the test extra installs it)."""
    found = os.path.join(os.path.dirname(sys.executable), "openjd")
    if os.path.exists(found):
        return found
    found = shutil.which("openjd")
    if found is None:
        pytest.skip("openjd-cli is not installed (pip install openjd-cli)")
    return found


def _env():
    # The worker finds the add-on on PYTHONPATH (a farm worker has the extension installed).
    return dict(os.environ, PYTHONPATH=ROOT)


def _exr_output(scene):
    settings = scene.render.image_settings
    settings.file_format = 'OPEN_EXR'
    settings.color_depth = '32'
    settings.exr_codec = 'ZIP'


def _run(blend, out, frames, chunk_size, *more):
    """`openjd run` of the template on ``blend`` (every task of its step): (exit status, output)."""
    params = [f"BlendFile={blend}", f"OutputDir={out}", f"Frames={frames}", f"ChunkSize={chunk_size}",
              f"Python={sys.executable}", *more]
    command = [_openjd(), "run", TEMPLATE, "--step", "Render"]
    for param in params:
        command += ["--job-param", param]
    done = subprocess.run(command, env=_env(), capture_output=True, text=True, timeout=HANG_S)
    return done.returncode, done.stdout + done.stderr


def test_the_chunks_give_the_frames_of_one_process(blank, tmp_path):
    blend = farm_shot(tmp_path)

    started = time.monotonic()
    code, log = _run(blend, tmp_path / "chunks", "1-4", 2)
    print(f"openjd run, 2 chunks of 2 frames: {time.monotonic() - started:.1f} s")
    assert code == 0, log[-4000:]
    # Two tasks, each one process rendering its chunk.
    said = re.findall(r"render_chunk: frames (\d+)-(\d+) of ", log)
    assert said == [("1", "2"), ("3", "4")], log[-4000:]
    frames = re.findall(r"\tTFM frame (\d+) \(ViewLayer\) written in ", log)
    assert frames == ["1", "2", "3", "4"], log[-4000:]
    assert "Chunks run: 2" in log and "Session ended successfully" in log, log[-4000:]

    one = subprocess.run([sys.executable, WORKER, "--blend", blend, "--output",
                          str(tmp_path / "one" / "frame_####"), "--frames", "1-4"],
                         env=_env(), capture_output=True, text=True, timeout=HANG_S)
    assert one.returncode == 0, one.stdout[-2000:] + one.stderr[-2000:]

    names = [f"frame_{i:04d}.exr" for i in range(1, 5)]
    assert sorted(os.listdir(tmp_path / "chunks")) == sorted(os.listdir(tmp_path / "one")) == names
    for name in names:
        a, b = read_exr(tmp_path / "chunks" / name), read_exr(tmp_path / "one" / name)
        assert a.dtype == np.float32 and a.shape == (24, 32, 4)
        assert np.array_equal(a, b), name
    first, last = read_exr(tmp_path / "one" / names[0]), read_exr(tmp_path / "one" / names[-1])
    assert float(np.abs(first - last).max()) > 0.05


def test_a_chunk_cancelled_in_a_frame_leaves_no_part_of_it_and_fails(blank, tmp_path):
    scene_builder.build(smoke(width=256, height=192, n=24), str(tmp_path), settings=SETTINGS, samples=1)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 3
    # Frame 1 renders in about a second, frame 2 and on for far longer than the task's timeout:
    # the timeout fires in the middle of frame 2, whatever this machine's speed (keys at frames 1
    # and 2 only: no frame between them).
    for frame, samples in ((1, 1), (2, 4096)):
        scene.tfm.samples = samples
        scene.tfm.keyframe_insert("samples", frame=frame)
    _exr_output(scene)
    blend = str(tmp_path / "slow.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)

    started = time.monotonic()
    code, log = _run(blend, tmp_path / "out", "1-3", 3, f"TaskTimeout={TIMEOUT_S}")
    took = time.monotonic() - started
    print(f"openjd run, a chunk timed out after {TIMEOUT_S} s: status {code} in {took:.1f} s")
    assert code != 0, log[-4000:]
    # openjd's cancel: SIGTERM at the timeout; the process ended before the SIGKILL was due.
    assert "TIMEOUT - Runtime limit reached" in log and 'Sending signal "term"' in log, log[-4000:]
    assert "exited with code: 143" in log and 'Sending signal "kill"' not in log, log[-4000:]
    assert os.listdir(tmp_path / "out") == ["frame_0001.exr"], log[-4000:]
    image = read_exr(tmp_path / "out" / "frame_0001.exr")
    assert image.shape == (192, 256, 4) and np.isfinite(image).all()
    lines = log.splitlines()
    assert any("\tTFM frame 1 (ViewLayer) written in " in line for line in lines), log[-4000:]
    interrupted = next((line for line in lines if "\tTFM frame 2 (ViewLayer) " in line), "")
    assert " interrupted in " in interrupted, log[-4000:]
    assert interrupted.endswith("| SIGTERM; the frame is not written"), interrupted
    assert "exiting with status 143" in log, log[-4000:]
    assert "Segmentation fault" not in log and "Fatal Python error" not in log, log[-4000:]
    assert took < TIMEOUT_S + 30, took          # stopped by SIGTERM, not by the SIGKILL 30 s on
