"""The key Cycles' stored renders are found by (blender_helpers.cycles_key): equal for the same
scene built again in another folder, different after any change Cycles would render."""

import bpy
from blender_helpers import cycles_key, smoke

from tfm_addon.blender import scene_builder


def _build(directory, n=16, **kwargs):
    bpy.ops.wm.read_homefile(use_empty=True)
    made = scene_builder.build(smoke(width=32, height=24, n=n, **kwargs), str(directory))
    scene_builder.cycles_single_scattering(bpy.context.scene, samples=16)
    return made


def test_the_key_follows_what_cycles_reads(addon, tmp_path):
    made = _build(tmp_path / "a")
    key = cycles_key(bpy.context.scene)
    assert len(key) == 20 and key == cycles_key(bpy.context.scene)
    _build(tmp_path / "b")
    assert cycles_key(bpy.context.scene) == key         # the same scene in another folder
    _build(tmp_path / "c", sigma_s=(1.5, 1.5, 1.5))
    assert cycles_key(bpy.context.scene) != key         # the material
    _build(tmp_path / "d", n=17)
    assert cycles_key(bpy.context.scene) != key         # the grid's voxels (another .vdb)

    made = _build(tmp_path / "e")
    keys = {key}
    edits = (lambda: setattr(made["lights"][0].data, "energy", 123.0),
             lambda: setattr(made["lights"][0], "location", (0.1, 0.2, 0.3)),
             lambda: setattr(bpy.context.scene.cycles, "samples", 17),
             lambda: setattr(bpy.context.scene.render, "resolution_x", 33),
             lambda: setattr(made["meshes"][0], "visible_shadow", False),
             lambda: made["meshes"][0].modifiers.new("Bevel", 'BEVEL'),
             lambda: setattr(bpy.context.scene.world.node_tree.nodes["Background"].inputs["Strength"],
                             "default_value", 0.5))
    for k, edit in enumerate(edits):
        edit()
        keys.add(cycles_key(bpy.context.scene))
        assert len(keys) == k + 2, k
