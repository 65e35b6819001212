"""Render farms: frames rendered by processes on split frame ranges equal those of one process,
bit for bit (what `blender -b file.blend -s S -e E -a` on several workers must give)."""

import os
import subprocess
import sys

import bpy
import numpy as np
from blender_helpers import ROOT, SETTINGS, farm_shot, read_exr, smoke

from tfm_addon.blender import scene_builder

# One worker: Blender with the add-on enabled, rendering the animation of a saved file between
# two frames, like `blender -b file.blend -s S -e E -a` (the bpy module takes no such arguments).
WORKER = """
import sys
import bpy
import tfm_addon

tfm_addon.register()
blend, first, last, out = sys.argv[-4:]
bpy.ops.wm.open_mainfile(filepath=blend)
scene = bpy.context.scene
scene.frame_start, scene.frame_end = int(first), int(last)
scene.render.filepath = out + "/frame_####"
print("TFM samples", scene.tfm.samples, "engine", scene.render.engine)
bpy.ops.render.render(animation=True)
"""


def _worker(blend, first, last, out, **env_vars):
    """Run WORKER on ``blend`` (frames ``first``..``last`` into ``out``) with extra environment
    variables; the finished process."""
    env = dict(os.environ, PYTHONPATH=ROOT, **env_vars)
    return subprocess.run([sys.executable, "-c", WORKER, blend, str(first), str(last), str(out)],
                          env=env, capture_output=True, text=True, timeout=300)


def _farm(blend, first, last, out):
    done = _worker(blend, first, last, out)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert "TFM samples 16 engine TFM" in done.stdout      # adaptive sampling from 16 on
    return {name: read_exr(os.path.join(out, name)) for name in sorted(os.listdir(out))}


def test_split_frame_ranges_give_the_frames_of_one_process(blank, tmp_path):
    blend = farm_shot(tmp_path)

    one = _farm(blend, 1, 4, tmp_path / "one")
    split = {**_farm(blend, 1, 2, tmp_path / "a"), **_farm(blend, 3, 4, tmp_path / "b")}
    assert sorted(one) == sorted(split) == [f"frame_{i:04d}.exr" for i in range(1, 5)]
    for name in one:
        assert one[name].dtype == np.float32
        assert np.array_equal(one[name], split[name]), name
    assert float(np.abs(one["frame_0001.exr"] - one["frame_0004.exr"]).max()) > 0.05


def _smoke_file(tmp_path, name="shot.blend", samples=1):
    """A small smoke scene (a Volume object reading a .vdb next to the .blend) saved to a file;
    the Volume object and the path."""
    scene_builder.build(smoke(width=32, height=24, n=16), str(tmp_path), settings=SETTINGS, samples=samples)
    volume = next(ob for ob in bpy.context.scene.objects if ob.type == 'VOLUME')
    return volume, str(tmp_path / name)


def test_a_volume_growing_from_scale_zero_renders_every_frame(blank, tmp_path):
    volume, blend = _smoke_file(tmp_path)
    scene = bpy.context.scene
    for frame, scale in ((1, 0.0), (3, 1.0)):
        volume.scale = (scale, scale, scale)
        volume.keyframe_insert("scale", frame=frame)
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    scene.frame_set(1)

    done = _worker(blend, 1, 3, tmp_path / "out")
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert sorted(os.listdir(tmp_path / "out")) == [f"frame_{i:04d}.png" for i in (1, 2, 3)]
    said = done.stdout + done.stderr
    assert "is not rendered in this frame: its scale is zero along some axis" in said
    assert "LinAlgError" not in said


def _missing_vdb_file(tmp_path):
    """The smoke scene saved with its volume reading a relative path to a .vdb that is not there."""
    volume, blend = _smoke_file(tmp_path)
    volume.data.filepath = "//caches/gone.vdb"
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    return blend


def test_strict_mode_fails_a_missing_vdb_with_a_non_zero_exit(blank, tmp_path):
    blend = _missing_vdb_file(tmp_path)
    tried = os.path.normpath(str(tmp_path / "caches" / "gone.vdb"))

    lenient = _worker(blend, 1, 1, tmp_path / "lenient")
    assert lenient.returncode == 0, lenient.stdout[-2000:] + lenient.stderr[-2000:]
    assert os.listdir(tmp_path / "lenient") == ["frame_0001.png"]     # rendered without the smoke
    assert f"cannot read '{tried}'" in lenient.stdout + lenient.stderr   # the absolute path tried

    strict = _worker(blend, 1, 1, tmp_path / "strict", TFM_STRICT="1")
    said = strict.stdout + strict.stderr
    assert strict.returncode != 0, said[-2000:]
    assert f"Strict mode: Volume 'TFM Smoke': cannot read '{tried}'" in said
    assert not os.path.exists(tmp_path / "strict") or os.listdir(tmp_path / "strict") == []


def test_each_frame_prints_one_log_line(blank, tmp_path):
    volume, blend = _smoke_file(tmp_path)
    bpy.context.scene.frame_end = 2
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)

    done = _worker(blend, 1, 2, tmp_path / "out", TFM_EGL_DEVICE="7")
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    lines = [line for line in done.stdout.splitlines() if line.startswith("TFM frame ")]
    assert [line.split(" (")[0] for line in lines] == ["TFM frame 1", "TFM frame 2"]
    assert "TFM frame 1 (ViewLayer) written in" in lines[0]
    for line in lines:
        assert " written in " in line and "| 32x24, 1 samples | add-on 0.1.0 | GL " in line
        assert "TFM_EGL_DEVICE=7 cannot be used" in line      # a device this machine lacks
