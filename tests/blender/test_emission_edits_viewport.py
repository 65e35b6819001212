"""Emission edits of a lone grid's material in Blender's viewport: a strength grid alone
and Blender's Quick Smoke fire (a blackbody grid alone), each edit a real depsgraph update of the
material's nodes, rendered by the viewport session on the add-on's GL worker."""

import dataclasses
import importlib

import bpy
import numpy as np
import pytest
from blender_helpers import MODULE, SETTINGS, render_passes

from tfm_addon import scenes
from tfm_addon.blender import scene_builder

COUNTERS = ("attribute_uploads", "grid_uploads", "shadow_maps", "tfms")


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


def _counters():
    return dict(_mod("render_worker").get_worker().counters)


def _view_camera(dg, width, height):
    ob = bpy.context.scene.camera.evaluated_get(dg)
    view = np.linalg.inv(_mod("camera").without_scale(ob.matrix_world))
    projection = np.array(ob.calc_matrix_camera(dg, x=width, y=height))
    return _mod("camera").camera_from_view(view, projection, width, height)


def _edits(nodes, kind):
    """(name, edit of the material's nodes, the emission strength or tint extracted after it)."""
    pv = next(n for n in nodes if n.bl_idname == 'ShaderNodeVolumePrincipled')
    color = tuple(pv.inputs["Emission Color"].default_value)
    if kind == "EMISSION":
        math = pv.inputs["Emission Strength"].links[0].from_node

        def strength(k, v):
            return lambda: setattr(math.inputs[k], "default_value", v)

        def colour(c):
            return lambda: setattr(pv.inputs["Emission Color"], "default_value", c)

        return [("scale 9", strength(1, 9.0), ("flame", 9.0, 0.0)),
                ("offset 0.2", strength(2, 0.2), ("flame", 9.0, 0.2)),
                ("offset -0.2", strength(2, -0.2), ("flame", 9.0, -0.2)),
                ("colour black (no emission)", colour((0.0, 0.0, 0.0, 1.0)), ("flame", 9.0, -0.2)),
                ("colour back", colour(color), ("flame", 9.0, -0.2))]

    def tint(c):
        return lambda: setattr(pv.inputs["Blackbody Tint"], "default_value", c)

    def strength(v):
        return lambda: setattr(pv.inputs["Emission Strength"], "default_value", v)

    return [("tint", tint((0.5, 0.7, 1.0, 1.0)), (None, 1.0, 0.0)),
            ("strength 0.2", strength(0.2), (None, 1.0, 0.2)),
            ("tint black, strength 0 (no emission)", lambda: (tint((0.0, 0.0, 0.0, 1.0))(), strength(0.0)()),
             (None, 1.0, 0.0)),
            ("tint back", tint((1.0, 0.4, 0.2, 1.0)), (None, 1.0, 0.0))]


@pytest.mark.parametrize("kind", ["EMISSION", "QUICK_FIRE"])
def test_an_emission_edit_in_the_viewport_uploads_nothing(blank, tmp_path, flags_of_next_update, kind):
    """Strength scale and offset (across 0) edits of a strength grid alone, tint and strength edits
    of Quick Fire's blackbody grid, and the emission turned off (colour or tint black) and on again:
    each is a MEDIUM change whose viewport frame shows it and uploads no grid or attribute texture
    and builds no map; the last frame is Blender's final render of the edited scene."""
    changes = _mod("changes")
    made = scene_builder.build(scenes.fire_scene(48, 27, 24, kind=kind, with_light=True),
                                       str(tmp_path), settings=SETTINGS)
    nodes = made["medium"].data.materials[0].node_tree.nodes
    session = _mod("viewport").ViewportSession()
    session.update(bpy.context.evaluated_depsgraph_get())
    camera = _view_camera(bpy.context.evaluated_depsgraph_get(), 48, 27)
    image = session.render(camera).combined
    assert session.extraction.media[0].has_emission
    for name, edit, strength in _edits(nodes, kind):
        edit()
        flags = flags_of_next_update()
        assert changes.Change.MEDIUM in flags and changes.Change.CAMERA not in flags, name
        session.update(bpy.context.evaluated_depsgraph_get(), flags)
        before = _counters()
        out = session.render(camera).combined
        after = _counters()
        medium = session.extraction.media[0]
        v = medium.emission_strength
        print(f"{kind}, {name}: strength {v}, emits {medium.has_emission}, "
              f"{float(np.abs(out - image).max()):.3f} from the frame before")
        assert v.grid == strength[0] and (v.scale, v.offset) == pytest.approx(strength[1:]), name
        for counter in COUNTERS:
            assert after.get(counter, 0) == before.get(counter, 0), (name, counter)
        assert float(np.abs(out - image).max()) > 1e-3, name      # the edit shows
        image = out
    final = render_passes(tmp_path)["Combined"]
    assert float(np.abs(image - final).max()) <= 1e-4
    session.close()


def test_a_strength_grid_with_negative_voxels_glows_as_in_cycles(blank, tmp_path):
    """A strength grid alone whose every other voxel is negative: Cycles looks the grid up one voxel
    at a time, so the negative voxels emit nothing and the others their own emission. The add-on's
    render (the strength combined per voxel, its clamp per voxel) agrees with Cycles within 3 % in
    brightness; the clamp of the trilinear blend (as the numpy reference models it) is less than
    0.7 of it."""
    from references import render_reference

    from tfm_addon.engine import metrics

    scene = scenes.fire_scene(64, 36, 24, kind="EMISSION")
    m = scene.media[0]
    flame = m.grids["flame"]
    i, j, k = np.indices(flame.shape)
    signed = np.where((i + j + k) % 2 == 0, -0.6 * flame, flame).astype(np.float32)
    scene = dataclasses.replace(scene, media=(dataclasses.replace(m, grids={**m.grids, "flame": signed}),))
    made = scene_builder.build(scene, str(tmp_path), settings=SETTINGS)
    made["medium"].visible_volume_scatter = False    # both renders: the emission alone, unscattered
    tfm = render_passes(tmp_path, "tfm")["Combined"][..., :3]
    blend = render_reference(scene, view_steps=SETTINGS.view_steps,
                             light_steps=SETTINGS.light_steps).combined[..., :3]
    scene_builder.cycles_single_scattering(bpy.context.scene, samples=256)
    made["medium"].visible_diffuse = False
    cycles = render_passes(tmp_path, "cycles")["Combined"][..., :3]
    for name, img in [("per voxel (the add-on)", tfm), ("clamp of the blend", blend)]:
        ratio = img.sum(axis=(0, 1)) / cycles.sum(axis=(0, 1))
        print(f"{name}: SSIM {metrics.ssim(img, cycles):.4f}, brightness {np.round(ratio, 4)} of Cycles'")
    assert cycles.max() > 0.05
    assert metrics.ssim(tfm, cycles) >= 0.98
    assert np.all(np.abs(tfm.sum(axis=(0, 1)) / cycles.sum(axis=(0, 1)) - 1.0) <= 0.03)
    assert np.all(blend.sum(axis=(0, 1)) / cycles.sum(axis=(0, 1)) < 0.7)


def test_a_blackbody_intensity_grid_glows_as_in_cycles(blank, tmp_path):
    """Quick Fire's blackbody intensity read from a grid beside its temperature grid: Cycles draws a
    voxel for each attribute on its own, so the frame is the blend of the intensity times that of
    the temperature's term (the per-voxel product was 1.12-1.22 times as bright here). The add-on's render
    agrees with Cycles within 2 % in total brightness and 6 % per channel (blue, small at these
    temperatures, is 4-5 % off for the fire without an intensity grid too)."""
    from tfm_addon.engine import metrics
    from tfm_addon.engine.scene import GridValue

    scene = scenes.fire_scene(64, 36, 24, kind="QUICK_FIRE")
    scene = dataclasses.replace(scene, media=(dataclasses.replace(
        scene.media[0], blackbody_intensity=GridValue("flame", 1.0, 0.0)),))
    made = scene_builder.build(scene, str(tmp_path), settings=SETTINGS)
    made["medium"].visible_volume_scatter = False    # both renders: the emission alone, unscattered
    tfm = render_passes(tmp_path, "tfm")["Combined"][..., :3]
    scene_builder.cycles_single_scattering(bpy.context.scene, samples=256)
    made["medium"].visible_diffuse = False
    cycles = render_passes(tmp_path, "cycles")["Combined"][..., :3]
    ratio = tfm.sum(axis=(0, 1)) / cycles.sum(axis=(0, 1))
    total = float(tfm.sum() / cycles.sum())
    print(f"intensity grid: SSIM {metrics.ssim(tfm, cycles):.4f}, brightness {np.round(ratio, 4)} "
          f"({total:.4f} in all) of Cycles'")
    assert cycles.max() > 0.05
    assert metrics.ssim(tfm, cycles) >= 0.98
    assert abs(total - 1.0) <= 0.02 and np.all(np.abs(ratio - 1.0) <= 0.06)
