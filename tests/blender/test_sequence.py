"""A .vdb frame sequence rendered as a render farm renders it: a saved .blend, a fresh Blender
process started from the command line, ``render(animation=True)``."""

import glob
import importlib
import os
import subprocess
import sys
import textwrap

import bpy
import numpy as np
from blender_helpers import MODULE, ROOT, SETTINGS, read_passes, render_passes, smoke

from tfm_addon import scenes
from tfm_addon.blender import scene_builder


def _centroid_x(image):
    weight = image.sum(axis=2)
    return float((weight * np.arange(image.shape[1])[None, :]).sum() / weight.sum())


def test_three_frame_sequence_renders_three_frames_from_the_command_line(blank, tmp_path):
    scene = scenes.smoke_scene(width=64, height=48, n=32)
    made = scene_builder.build(scene, str(tmp_path), settings=SETTINGS)
    # Three frames of the puff drifting along +x by 4 voxels a frame.
    density = scene.media[0].density
    for frame in (1, 2, 3):
        shifted = np.zeros_like(density)
        shifted[4 * frame:] = density[:density.shape[0] - 4 * frame]
        scene_builder.write_vdb(str(tmp_path / f"smoke_{frame:04d}.vdb"), shifted, voxel_size_m=2.0 / 32)
    volume = made["medium"].data
    volume.filepath = str(tmp_path / "smoke_0001.vdb")
    volume.is_sequence = True
    volume.frame_start, volume.frame_duration, volume.sequence_mode = 1, 3, 'CLIP'
    b = bpy.context.scene
    b.frame_start, b.frame_end = 1, 3
    b.render.filepath = str(tmp_path / "frames" / "frame_")
    b.render.image_settings.media_type = 'MULTI_LAYER_IMAGE'
    b.render.image_settings.file_format = 'OPEN_EXR_MULTILAYER'
    b.render.image_settings.color_depth = '32'
    blend = str(tmp_path / "sequence.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)

    script = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {ROOT!r})
        import bpy, tfm_addon
        tfm_addon.register()
        bpy.ops.wm.open_mainfile(filepath={blend!r})
        bpy.ops.render.render(animation=True)
    """)
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp_path / "user"))
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=300, env=env, cwd=str(tmp_path))
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    frames = sorted(glob.glob(str(tmp_path / "frames" / "frame_*.exr")))
    assert [os.path.basename(f) for f in frames] == ["frame_0001.exr", "frame_0002.exr",
                                                    "frame_0003.exr"]
    images = [read_passes(f)["Scattering"] for f in frames]
    for a, b_ in ((0, 1), (1, 2), (0, 2)):
        assert float(np.abs(images[a] - images[b_]).max()) > 0.05
    # The puff moves right in the image (the camera looks along +y), frame by frame.
    xs = [_centroid_x(image) for image in images]
    assert xs[0] < xs[1] < xs[2], xs


def test_sequence_outside_its_frame_range_renders_no_medium_quietly(blank, tmp_path):
    extract = importlib.import_module(MODULE + ".tfm_addon.blender.extract")
    density = np.zeros((8, 8, 8), np.float32)
    density[2:6, 2:6, 2:6] = 1.0
    for frame in (1, 2, 3):
        scene_builder.write_vdb(str(tmp_path / f"puff_{frame:04d}.vdb"), density)
    data = bpy.data.volumes.new("Puff")
    data.filepath = str(tmp_path / "puff_0001.vdb")
    data.is_sequence, data.frame_start, data.frame_duration, data.sequence_mode = True, 1, 3, 'CLIP'
    bpy.context.scene.collection.objects.link(bpy.data.objects.new("Puff", data))
    blank.frame_set(2)
    assert extract.extract(bpy.context.evaluated_depsgraph_get()).media
    blank.frame_set(5)
    ex = extract.extract(bpy.context.evaluated_depsgraph_get())
    assert not ex.media and ex.all_warnings == []


def test_a_frame_missing_from_a_sequence_names_the_file_tried_once(blank, tmp_path):
    """Frames 1, 2 and 4 of a 4-frame sequence on disk: frame 3 renders the rest of the scene and
    the render report names the full path Blender tried, in one line (Blender's own message:
    'puff_0003.vdb not found'); frame 2 renders the medium with no such line."""
    final_render = importlib.import_module(MODULE + ".tfm_addon.blender.final_render")
    made = scene_builder.build(smoke(), str(tmp_path), settings=SETTINGS)
    density = np.zeros((8, 8, 8), np.float32)
    density[2:6, 2:6, 2:6] = 1.0
    for frame in (1, 2, 4):
        scene_builder.write_vdb(str(tmp_path / "seq" / f"puff_{frame:04d}.vdb"), density, 0.25)
    data = made["medium"].data
    data.filepath = str(tmp_path / "seq" / "puff_0001.vdb")
    data.is_sequence, data.frame_start, data.frame_duration, data.sequence_mode = True, 1, 4, 'CLIP'
    missing = os.path.normpath(str(tmp_path / "seq" / "puff_0003.vdb"))
    blank.frame_set(2)
    image = render_passes(tmp_path, "frame2")
    assert image["Scattering"].max() > 0.0
    assert not [m for _level, m in final_render.last_messages if "not found" in m]
    blank.frame_set(3)
    image = render_passes(tmp_path, "frame3")
    lines = [m for level, m in final_render.last_messages if level == 'WARNING' and "puff_0003" in m]
    assert len(lines) == 1 and missing in lines[0] and "not found" in lines[0], \
        list(final_render.last_messages)
    assert image["Scattering"].max() == 0.0 and image["Surfaces"].max() > 0.1   # the rest renders
