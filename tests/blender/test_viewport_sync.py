"""The viewport follows the depsgraph's own updates (as ``view_update`` hands them over): a
selection changes nothing that renders, a moved object keeps its triangles and its grid, an edit
reads again only what it touched."""

import importlib
import time

import bpy
import numpy as np
from blender_helpers import MODULE, SETTINGS, smoke

from tfm_addon.blender import scene_builder


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


class _Updates:
    """Hands every depsgraph update (and frame change) to the session, as view_update does."""

    def __init__(self, session):
        self.session, self.flags, self.seconds = session, [], []

    def __call__(self, scene, depsgraph):
        self.flags.append(self.session.update(depsgraph))
        self.seconds.append(self.session.update_s)

    def after(self, edit):
        Change = _mod("changes").Change
        self.flags.clear()
        self.seconds.clear()
        edit()
        bpy.context.view_layer.update()
        flags = Change.NONE
        for f in self.flags:
            flags |= f
        return flags


def _session_with_updates():
    session = _mod("viewport").ViewportSession()
    session.update(bpy.context.evaluated_depsgraph_get())
    updates = _Updates(session)
    bpy.app.handlers.depsgraph_update_post.append(updates)
    bpy.app.handlers.frame_change_post.append(updates)
    return session, updates


def _remove(updates):
    bpy.app.handlers.depsgraph_update_post.remove(updates)
    bpy.app.handlers.frame_change_post.remove(updates)


def _converged(session, samples, timeout_s=60.0):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        frame = session.frame()
        if frame is not None and frame.samples == samples and session.view.state == "idle":
            return frame
        time.sleep(0.01)
    raise AssertionError(f"the viewport did not converge: {session.view.counters}")


def test_a_selection_click_changes_nothing_and_keeps_the_converged_image(blank, tmp_path):
    Change = _mod("changes").Change
    made = scene_builder.build(smoke(width=48, height=36), str(tmp_path), settings=SETTINGS,
                                       samples=2)
    session, updates = _session_with_updates()
    try:
        camera = session.extraction.camera
        assert session.request(camera, 2)
        frame = _converged(session, 2)
        extraction, requests = session.extraction, session.view.counters["requests"]
        bar, medium = made["meshes"][0], made["medium"]
        triangulations = session.kept.counters["triangulations"]

        def click(ob):
            def edit():
                for o in bpy.context.view_layer.objects:
                    o.select_set(o is ob)
                bpy.context.view_layer.objects.active = ob
            return edit
        for edit in (click(bar), click(medium), click(None)):
            assert updates.after(edit) == Change.NONE
            assert session.extraction is extraction          # nothing re-read
            assert not session.request(camera, 2)             # the same request: no restart
            assert session.frame() is frame and session.view.state == "idle"
        assert session.view.counters["requests"] == requests
        assert session.kept.counters["triangulations"] == triangulations

        # What renders still does: a render setting, the world, an object hidden.
        render = bpy.context.scene.render
        flags = updates.after(lambda: setattr(render, "film_transparent", not render.film_transparent))
        assert flags == Change.SETTINGS
        assert session.extraction.settings.film_transparent == render.film_transparent
        world = bpy.context.scene.world
        background = world.node_tree.nodes["Background"]
        ambient = session.extraction.ambient
        def light_the_world():
            background.inputs["Color"].default_value = (0.2, 0.3, 0.4, 1.0)
            background.inputs["Strength"].default_value = 0.37
        assert Change.WORLD in updates.after(light_the_world)
        assert session.extraction.ambient != ambient
        assert updates.after(lambda: bar.hide_set(True)) & Change.SOLIDS
        assert bar.name not in {m.name for m in session.extraction.meshes}
        assert updates.after(lambda: bar.hide_set(False)) & Change.SOLIDS
        assert bar.name in {m.name for m in session.extraction.meshes}
        def simplify():
            render.use_simplify, render.simplify_volumes = True, 0.5
        full = session.extraction.media[0].density.shape
        assert Change.MEDIUM in updates.after(simplify)
        assert session.extraction.media[0].density.shape[0] < full[0]
        assert session.request(camera, 2)                      # those restart the image
    finally:
        _remove(updates)
        session.close()


def _big_mesh(segments=256, rings=100):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=rings, radius=1.0)
    big = bpy.context.object
    big.name = "Big"
    return big


def test_moving_an_object_reads_no_triangles_and_keeps_the_other_meshes(blank, capsys):
    meshes = _mod("meshes")
    big = _big_mesh()                               # ~51k triangles
    bpy.ops.mesh.primitive_cube_add(location=(4.0, 0.0, 0.0))
    cube = bpy.context.object
    bpy.ops.object.light_add(type='SPOT', location=(0.0, 0.0, 5.0))
    bpy.ops.object.camera_add(location=(0.0, -10.0, 0.0), rotation=(1.5708, 0.0, 0.0))
    bpy.context.scene.camera = bpy.context.object
    session, updates = _session_with_updates()
    try:
        by_name = {m.name: m for m in session.extraction.meshes}
        triangles = len(by_name["Big"].triangles)
        assert triangles > 50_000
        kept = session.kept.counters
        before = dict(kept)
        times = []
        for i in range(5):
            flags = updates.after(lambda i=i: setattr(cube.location, "z", 0.1 * (i + 1)))
            assert flags & _mod("changes").Change.SOLIDS
            times.append(max(updates.seconds))
        assert kept["triangulations"] == before.get("triangulations", 0)   # no mesh read again
        now = {m.name: m for m in session.extraction.meshes}
        assert now["Big"] is by_name["Big"]                  # the same Mesh: its keys kept
        assert now[cube.name].matrix_world[2, 3] == np.float64(0.5).item()
        # the whole walk as a final render does it (every mesh read), for comparison
        t0 = time.perf_counter()
        _mod("extract").extract(bpy.context.evaluated_depsgraph_get(), parts=_mod("changes").Change.SOLIDS,
                                previous=session.extraction)
        fresh = time.perf_counter() - t0
        with capsys.disabled():
            print(f"\nmove with a {triangles}-triangle mesh in the scene: {1000 * min(times):.1f}-"
                  f"{1000 * max(times):.1f} ms (re-reading every mesh: {1000 * fresh:.0f} ms)")

        # An edit of the big mesh's vertices reads it (and it alone) again.
        big.data.vertices[0].co.z += 0.5
        flags = updates.after(big.data.update)
        assert kept["triangulations"] == before.get("triangulations", 0) + 1
        moved = {m.name: m for m in session.extraction.meshes}["Big"]
        assert moved is not by_name["Big"]
        assert float(moved.vertices[0, 2]) == big.data.vertices[0].co.z
        del meshes
    finally:
        _remove(updates)
        session.close()


def test_a_frame_change_places_animated_objects_without_reading_them(blank):
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.object
    cube.keyframe_insert("location", frame=1)
    cube.location.x = 3.0
    cube.keyframe_insert("location", frame=10)
    bpy.ops.object.camera_add(location=(0.0, -10.0, 0.0), rotation=(1.5708, 0.0, 0.0))
    bpy.context.scene.camera = bpy.context.object
    bpy.context.scene.frame_set(1)
    session, updates = _session_with_updates()
    try:
        reads = session.kept.counters["triangulations"]
        assert session.extraction.meshes[0].matrix_world[0, 3] == 0.0
        updates.flags.clear()
        bpy.context.scene.frame_set(10)
        assert updates.flags and session.extraction.meshes[0].matrix_world[0, 3] == 3.0
        assert session.kept.counters["triangulations"] == reads
    finally:
        _remove(updates)
        session.close()


def test_moving_a_mesh_to_volume_object_places_its_grid_without_saving_it(blank, capsys):
    """Blender re-evaluates a Mesh to Volume object whenever it or its mesh moves (it reports a
    geometry update); its grid changes only when the mesh moves relative to it. Moved together
    (by their parent), the grid is placed anew without being saved, hashed or read."""
    volumes = _mod("volumes")
    bpy.ops.object.empty_add()
    parent = bpy.context.object
    bpy.ops.mesh.primitive_cube_add(size=2.0)
    source = bpy.context.object
    source.hide_set(True)
    bpy.ops.object.volume_add()
    ob = bpy.context.object
    source.parent = ob.parent = parent
    mod = ob.modifiers.new("ToVolume", 'MESH_TO_VOLUME')
    mod.object, mod.resolution_mode, mod.voxel_size, mod.density = source, 'VOXEL_SIZE', 2.0 / 124, 2.0
    bpy.ops.object.camera_add(location=(0.0, -10.0, 0.0), rotation=(1.5708, 0.0, 0.0))
    bpy.context.scene.camera = bpy.context.object
    session, updates = _session_with_updates()
    cache = volumes.grid_cache
    try:
        medium = session.extraction.media[0]
        assert medium is not None and max(medium.density.shape) >= 120
        saves, reads = cache.saves, cache.reads
        times = []
        for i in range(3):
            updates.after(lambda i=i: setattr(parent.location, "x", 0.5 * (i + 1)))
            times.append(max(updates.seconds))
        moved = session.extraction.media[0]
        assert (cache.saves, cache.reads) == (saves, reads)       # neither saved nor hashed nor read
        assert moved.density is medium.density
        np.testing.assert_allclose(moved.index_to_world[:3, 3] - medium.index_to_world[:3, 3],
                                   (1.5, 0.0, 0.0), atol=1e-9)
        assert session.kept.counters["grids_reused"] >= 3
        # The volume object moved alone: its mesh sits elsewhere in it, the grid is made again.
        alone = []
        for edit in (lambda: setattr(ob.location, "y", 0.3), lambda: setattr(source.location, "y", 0.7)):
            updates.after(edit)
            alone.append(max(updates.seconds))
        assert cache.saves == saves + 2
        with capsys.disabled():
            print(f"\nmove of a {medium.density.shape} Mesh to Volume object with its mesh: "
                  f"{1000 * min(times):.1f}-{1000 * max(times):.1f} ms; the volume or the mesh "
                  f"alone (grid made again): {1000 * min(alone):.0f}-{1000 * max(alone):.0f} ms")
        # Its settings edited: saved and read again.
        updates.after(lambda: setattr(mod, "density", 3.0))
        assert cache.saves == saves + 3
        assert float(session.extraction.media[0].density.max()) == 3.0
    finally:
        _remove(updates)
        session.close()
