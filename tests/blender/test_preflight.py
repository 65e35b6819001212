"""The pre-flight check a render farm runs on a worker before rendering a .blend
(docs/blender.md, "Render farms"): the documented command-line expression exits non-zero, naming
the absolute path tried, when a file is missing or the add-on is not enabled; the check finds every
file a frame range reads (volume sequences by Blender's own frame rule, fluid caches, images)."""

import os
import shutil
import subprocess
import sys

import bpy
from blender_helpers import ROOT, SETTINGS, smoke

from tfm_addon.blender import scene_builder

# What docs/blender.md tells a farm to run (Blender's --python-exit-code 2 made explicit: the
# bpy module takes no command-line arguments).
EXPRESSION = ("import bpy; assert hasattr(bpy.types, 'TFM_OT_preflight'), "
              "'the TFM add-on is not enabled'; bpy.ops.tfm.preflight()")
WORKER = """
import sys
import bpy
import tfm_addon

blend, enable = sys.argv[-2:]
if enable == "1":
    tfm_addon.register()
bpy.ops.wm.open_mainfile(filepath=blend)
print("engine as read:", bpy.context.scene.render.engine)
try:
    exec(EXPRESSION)
except Exception as ex:
    print("Error:", ex)
    sys.exit(2)
"""


def _preflight_process(blend, enable=True):
    env = dict(os.environ, PYTHONPATH=ROOT)
    code = f"EXPRESSION = {EXPRESSION!r}\n" + WORKER
    return subprocess.run([sys.executable, "-c", code, blend, "1" if enable else "0"], env=env,
                          capture_output=True, text=True, timeout=120)


def _smoke_file(tmp_path):
    scene_builder.build(smoke(width=32, height=24, n=16), str(tmp_path), settings=SETTINGS)
    volume = next(ob for ob in bpy.context.scene.objects if ob.type == 'VOLUME')
    return volume, str(tmp_path / "shot.blend")


def test_a_worker_without_a_file_or_the_add_on_exits_non_zero(blank, tmp_path, addon):
    volume, blend = _smoke_file(tmp_path)
    good = addon.blender.preflight.check(bpy.context.scene)
    assert good.problems == [], good.problems
    assert any(n.startswith("OpenGL ") for n in good.notes), good.notes    # vendor / renderer named
    assert good.lines()[-1] == "TFM preflight: OK"

    volume.data.filepath = "//caches/gone.vdb"
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    tried = os.path.normpath(str(tmp_path / "caches" / "gone.vdb"))
    done = _preflight_process(blend)
    said = done.stdout + done.stderr
    assert done.returncode == 2, said[-2000:]
    assert f"PROBLEM: Volume 'TFM Smoke': '{tried}' not found" in said
    assert "TFM preflight: OpenGL " in said

    bare = _preflight_process(blend, enable=False)      # Blender would render it with EEVEE
    said = bare.stdout + bare.stderr
    assert bare.returncode == 2, said[-2000:]
    assert "the TFM add-on is not enabled" in said
    assert "engine as read: BLENDER_EEVEE" in said


def test_every_file_of_the_frame_range_is_checked(blank, tmp_path, addon):
    preflight = addon.blender.preflight
    volume, _ = _smoke_file(tmp_path)
    scene = bpy.context.scene
    first = str(tmp_path / "seq_0001.vdb")
    for n in (1, 2, 4):                                  # frame 3 of the sequence is missing
        shutil.copy(volume.data.filepath, str(tmp_path / f"seq_{n:04d}.vdb"))
    data = volume.data
    data.filepath = first
    data.is_sequence = True
    data.frame_start, data.frame_duration, data.frame_offset = 1, 4, 0

    # Blender's own frame rule, compared with the evaluated volume's frame, for every mode.
    for mode in ('CLIP', 'EXTEND', 'REPEAT', 'PING_PONG'):
        data.sequence_mode = mode
        for frame in (-2, 0, 1, 3, 4, 5, 7, 9):
            scene.frame_set(frame)
            evaluated = volume.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.grids.frame
            ours = preflight.sequence_file_frame(frame, 1, 4, 0, mode)
            assert (2**31 - 1 if ours is None else ours) == evaluated, (mode, frame)

    data.sequence_mode = 'CLIP'
    scene.frame_start, scene.frame_end = 1, 2
    scene.frame_set(1)
    assert preflight.check(scene, gl=False).problems == []
    scene.frame_end = 4
    found = preflight.check(scene, gl=False).problems
    assert found == [f"Volume 'TFM Smoke': 1 of the 4 files the frames 1-4 read are missing, the first "
                     f"'{os.path.normpath(str(tmp_path / 'seq_0003.vdb'))}'"]

    # A fluid domain baked for frames 1-4 with frame 2's data missing, an image that is not there,
    # and another render engine.
    cache = os.path.normpath(str(tmp_path / "cache"))
    domain = scene_builder.fluid_domain("Domain", (-1, -1, -1), (1, 1, 1), 16, cache)
    # A final render reads it; the viewport depsgraph of this process never evaluates Mantaflow
    # (it aborts bpy as a module when its domain is freed).
    domain.modifiers["Fluid"].show_viewport = False
    settings = domain.modifiers["Fluid"].domain_settings
    settings.cache_frame_start, settings.cache_frame_end = 1, 4
    for n in (1, 3, 4):
        scene_builder.write_fluid_cache_frame(cache, n, {"density": smoke(n=8).media[0].density}, 0.1)
    image = bpy.data.images.new("Gobo", 4, 4)
    image.source = 'FILE'
    image.filepath = "//textures/gobo.png"
    image.use_fake_user = True
    scene.render.engine = 'CYCLES'
    found = preflight.check(scene, gl=False).problems
    assert sorted(found) == sorted([
        "Scene 'Scene' renders with CYCLES, not TFM (Render Properties > Render Engine)",
        f"Volume 'TFM Smoke': 1 of the 4 files the frames 1-4 read are missing, the first "
        f"'{os.path.join(str(tmp_path), 'seq_0003.vdb')}'",
        f"Fluid domain 'Domain': 1 cache files of the frames 1-4 are missing in '{cache}', the first "
        f"'{os.path.join(cache, 'data', 'fluid_data_0002.vdb')}'",
        f"Image 'Gobo': file '//textures/gobo.png' not found at "
        f"'{os.path.normpath(bpy.path.abspath('//textures/gobo.png'))}'; rendering without it: Cycles' "
        f"missing-texture pink (1, 0, 1) instead",     # the renderer's form (blender/files.py)
    ]), found
