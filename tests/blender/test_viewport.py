"""The viewport without a screen: depsgraph updates become change flags, and the renderer
rebuilds only what those changes touch. (Drawing with ``gpu`` cannot run in background mode.)"""

import dataclasses
import importlib

import bpy
import numpy as np
import pytest
from blender_helpers import MODULE, SETTINGS, render_passes, smoke
from mathutils import Matrix


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


@pytest.fixture
def flags_of_next_update():
    """Collect the change flags the add-on derives from real depsgraph updates."""
    changes = _mod("changes")
    seen = []

    def handler(scene, depsgraph):
        seen.append(changes.changes_from_depsgraph(depsgraph))

    bpy.app.handlers.depsgraph_update_post.append(handler)

    def collect():
        seen.clear()
        bpy.context.view_layer.update()
        flags = changes.Change.NONE
        for f in seen:
            flags |= f
        return flags

    yield collect
    bpy.app.handlers.depsgraph_update_post.remove(handler)


def _counters():
    return dict(_mod("render_worker").get_worker().counters)


def _delta(before, after, key):
    return after.get(key, 0) - before.get(key, 0)


def test_change_flags_and_what_gets_rebuilt(blank, tmp_path, flags_of_next_update):
    Change = _mod("changes").Change
    made = _mod("scene_builder").build(smoke(width=48, height=36), str(tmp_path), settings=SETTINGS)
    session = _mod("viewport").ViewportSession()
    session.update(bpy.context.evaluated_depsgraph_get())
    camera = session.extraction.camera
    first = session.render(camera)
    assert session.render(camera) is first  # nothing changed: nothing re-rendered
    assert session.renders == 1

    # Orbit the view: a new camera, the light's maps are reused.
    orbit = Matrix.Rotation(0.3, 4, 'Z') @ Matrix([list(r) for r in camera.matrix_world])
    before = _counters()
    orbited = session.render(dataclasses.replace(camera, matrix_world=np.array(orbit)))
    after = _counters()
    assert _delta(before, after, "tfms") == 0 and _delta(before, after, "shadow_maps") == 0
    assert _delta(before, after, "grid_uploads") == 0 and _delta(before, after, "gbuffers") == 1
    assert float(np.abs(orbited.combined - first.combined).max()) > 0.05

    # Edit sigma in the material: MEDIUM changes, no map is rebuilt, the image changes.
    node = made["medium"].data.materials[0].node_tree.nodes["Principled Volume"]
    node.inputs["Color"].default_value = (0.3, 0.6, 0.9, 1.0)
    flags = flags_of_next_update()
    assert Change.MEDIUM in flags and Change.CAMERA not in flags
    session.update(bpy.context.evaluated_depsgraph_get(), flags)
    before = _counters()
    recoloured = session.render(camera)
    after = _counters()
    assert _delta(before, after, "tfms") == 0 and _delta(before, after, "shadow_maps") == 0
    assert _delta(before, after, "grid_uploads") == 0
    assert float(np.abs(recoloured.combined - first.combined).max()) > 0.05

    # Move the light: LIGHTS changes, its shadow map and TFM are rebuilt.
    made["lights"][0].location.x += 0.5
    flags = flags_of_next_update()
    assert flags & Change.LIGHTS and not flags & Change.SOLIDS
    session.update(bpy.context.evaluated_depsgraph_get(), flags)
    before = _counters()
    session.render(camera)
    after = _counters()
    assert _delta(before, after, "tfms") == 1 and _delta(before, after, "shadow_maps") == 1

    # Move the bar: SOLIDS changes.
    made["meshes"][0].location.z += 0.2
    assert Change.SOLIDS in flags_of_next_update()


def test_viewport_image_equals_final_render_for_the_same_view(blank, tmp_path):
    _mod("scene_builder").build(smoke(width=48, height=36), str(tmp_path), settings=SETTINGS)
    final = render_passes(tmp_path)["Combined"]
    dg = bpy.context.evaluated_depsgraph_get()
    session = _mod("viewport").ViewportSession()
    session.update(dg)
    # The view a 3D viewport in camera view would hand over: view and projection matrices.
    ob = bpy.context.scene.camera.evaluated_get(dg)
    view = np.linalg.inv(_mod("camera").without_scale(ob.matrix_world))
    projection = np.array(ob.calc_matrix_camera(dg, x=48, y=36))
    camera = _mod("camera").camera_from_view(view, projection, 48, 36)
    image = session.render(camera).combined
    assert float(np.abs(image - final).max()) <= 1e-4
