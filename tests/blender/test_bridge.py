"""The bridge loses nothing: a scene built in Blender renders like the renderer called directly."""

import dataclasses

import bpy
import numpy as np
from blender_helpers import SETTINGS, render_passes, smoke

from tfm_addon.blender import scene_builder

PASSES = {"Combined": None, "Scattering": "scattering", "Surfaces": "surfaces",
          "Transmittance": "transmittance"}


def _direct_images(worker, scene):
    out = worker.render(scene, SETTINGS)
    return {name: out.combined if key is None else out.passes[key] for name, key in PASSES.items()}


def _as_stored(scene, made):
    """The scene with each placement as Blender stores it (single precision, recomposed from
    location, rotation and scale); shadow and transmittance-map lookups are sensitive enough to
    show a 1e-7 turn of the light at the 1e-4 level."""
    def stored(ob):
        return np.array(ob.matrix_world, dtype=np.float64)

    medium = scene.media[0]
    voxel = float(np.linalg.norm(medium.index_to_world[:3, 0]))  # the .vdb's voxel size
    to_world = stored(made["medium"]) @ np.diag([voxel, voxel, voxel, 1.0])
    return dataclasses.replace(
        scene,
        camera=dataclasses.replace(scene.camera, matrix_world=stored(made["camera"])),
        lights=[dataclasses.replace(light, matrix_world=stored(ob))
                for light, ob in zip(scene.lights, made["lights"], strict=True)],
        meshes=[dataclasses.replace(mesh, matrix_world=stored(ob))
                for mesh, ob in zip(scene.meshes, made["meshes"], strict=True)],
        media=(dataclasses.replace(medium, index_to_world=to_world),))


def test_render_through_blender_equals_direct_render(blank, tmp_path, direct_worker):
    scene = smoke(width=64, height=48, n=32)
    made = scene_builder.build(scene, str(tmp_path), settings=SETTINGS)
    through_blender = render_passes(tmp_path)
    direct = _direct_images(direct_worker, _as_stored(scene, made))
    for name in PASSES:
        assert through_blender[name].shape == direct[name].shape, name
        diff = float(np.abs(through_blender[name] - direct[name]).max())
        print(f"{name}: max abs difference {diff:.2e} (peak {float(direct[name].max()):.3f})")
        assert diff <= 1e-4, f"{name}: max abs difference {diff:.2e}"
    # Against the scene as written in double precision, only single-precision placement differs.
    unrounded = _direct_images(direct_worker, scene)
    assert float(np.abs(through_blender["Combined"] - unrounded["Combined"]).max()) <= 1e-3
    # Not an empty comparison: the beam and the lit ground are there.
    assert direct["Scattering"].max() > 0.1 and direct["Surfaces"].max() > 0.1


def test_render_border_is_the_same_window_of_the_full_frame(blank, tmp_path, direct_worker):
    scene = smoke(width=64, height=48, n=32)
    scene_builder.build(scene, str(tmp_path), settings=SETTINGS)
    full = _direct_images(direct_worker, scene)["Combined"]
    r = bpy.context.scene.render
    r.use_border, r.use_crop_to_border = True, True
    r.border_min_x, r.border_max_x = 0.13, 0.71  # 8.32 .. 45.44 px: Blender truncates to 8 .. 45
    r.border_min_y, r.border_max_y = 0.27, 0.9  # 12.96 .. 43.2 px: 12 .. 43, from the bottom
    cropped = render_passes(tmp_path, "border")["Combined"]
    assert cropped.shape == (43 - 12, 45 - 8, 4)
    expected = full[48 - 43:48 - 12, 8:45]  # rows top first
    assert float(np.abs(cropped - expected).max()) <= 1e-4
