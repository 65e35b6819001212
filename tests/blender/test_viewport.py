"""The viewport without a screen: depsgraph updates become change flags, and the renderer
rebuilds only what those changes touch. (Drawing with ``gpu`` cannot run in background mode.)"""

import dataclasses
import importlib

import bpy
import numpy as np
from blender_helpers import MODULE, SETTINGS, render_passes, smoke
from mathutils import Matrix

from tfm_addon.blender import scene_builder


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


def _counters():
    return dict(_mod("render_worker").get_worker().counters)


def _delta(before, after, key):
    return after.get(key, 0) - before.get(key, 0)


def test_change_flags_and_what_gets_rebuilt(blank, tmp_path, flags_of_next_update):
    Change = _mod("changes").Change
    made = scene_builder.build(smoke(width=48, height=36), str(tmp_path), settings=SETTINGS)
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
    scene_builder.build(smoke(width=48, height=36), str(tmp_path), settings=SETTINGS)
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


def _view_camera(dg, width, height):
    """The view a 3D viewport in camera view hands over, as the add-on reads it."""
    ob = bpy.context.scene.camera.evaluated_get(dg)
    view = np.linalg.inv(_mod("camera").without_scale(ob.matrix_world))
    projection = np.array(ob.calc_matrix_camera(dg, x=width, y=height))
    return _mod("camera").camera_from_view(view, projection, width, height)


def _converged(session, samples, timeout_s=60.0):
    import time

    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        frame = session.frame()
        if frame is not None and frame.samples == samples and session.view.state == "idle":
            return frame
        time.sleep(0.01)
    raise AssertionError(f"the viewport did not converge: {session.view.counters}")


def test_converged_viewport_equals_the_final_render_at_the_same_samples(blank, tmp_path):
    scene_builder.build(smoke(width=48, height=36), str(tmp_path), settings=SETTINGS, samples=6)
    final = render_passes(tmp_path)["Combined"]
    dg = bpy.context.evaluated_depsgraph_get()
    session = _mod("viewport").ViewportSession()
    session.update(dg)
    assert session.request(_view_camera(dg, 48, 36), 6)
    frame = _converged(session, 6)
    assert session.status == "Sample 6/6"
    assert frame.image.shape == final.shape
    assert float(np.abs(frame.image - final).max()) <= 1e-4
    # The pixel-centre image differs at the edges: the samples did something.
    single = session.render(_view_camera(dg, 48, 36)).combined
    assert float(np.abs(single - final).max()) > 0.01
    session.close()


def test_two_rendered_viewports_both_show_an_edit_and_closing_one_frees_its_maps(blank, tmp_path):
    """Each viewport session has its own worker slot and cache client: two sessions requesting at
    once both converge (on one shared slot the second superseded the first, which never showed a
    frame), and closing one releases what only it kept."""
    scene_builder.build(smoke(width=48, height=36), str(tmp_path), settings=SETTINGS)
    dg = bpy.context.evaluated_depsgraph_get()
    sessions = [_mod("viewport").ViewportSession() for _ in range(2)]
    for session, (w, h) in zip(sessions, ((48, 36), (40, 30)), strict=True):
        session.update(dg)
        assert session.request(_view_camera(dg, w, h), 2)
    frames = [_converged(session, 2) for session in sessions]
    assert [f.image.shape[:2] for f in frames] == [(36, 48), (30, 40)]
    worker = _mod("render_worker").get_worker()
    gone = sessions[1].view.client
    def held(r):     # this view's client, and its image size's targets (no other view's size)
        return gone in r._targets.kept, (40, 30) in r._targets.items, (48, 36) in r._targets.items
    assert worker.call(held, timeout_s=30) == (True, True, True)
    sessions[1].close()
    assert worker.call(held, timeout_s=30) == (False, False, True)
    sessions[0].close()


def test_disabling_with_a_viewport_render_in_flight_leaves_no_thread_timer_or_context(addon, tmp_path):
    import threading

    import addon_utils

    def gl_threads():
        return [t for t in threading.enumerate() if t.name == "tfm-gl" and t.is_alive()]

    addon_utils.disable(MODULE, default_set=True)
    baseline = len(gl_threads())
    addon_utils.enable(MODULE, default_set=True)
    in_flight = 0
    for i in range(20):
        bpy.ops.wm.read_homefile(use_empty=True)
        pkg = importlib.import_module(MODULE + ".tfm_addon")
        viewport = importlib.import_module(MODULE + ".tfm_addon.blender.viewport")
        scene_builder.build(
            smoke(width=96, height=64, n=16), str(tmp_path), settings=SETTINGS)
        dg = bpy.context.evaluated_depsgraph_get()
        session = viewport.ViewportSession()
        session.redraw = lambda: None
        viewport.start_polling(session)
        session.update(dg)
        session.request(_view_camera(dg, 96, 64), 4096)
        assert viewport.is_polling()
        in_flight += session.view.state != "idle"
        addon_utils.disable(MODULE, default_set=True)
        assert len(gl_threads()) == baseline, f"GL thread left after disable #{i + 1}"
        assert not bpy.app.timers.is_registered(viewport._poll)
        assert pkg.engine.gl_context.GLContext.live == 0
        addon_utils.enable(MODULE, default_set=True)
    assert in_flight == 20


def test_the_gpu_drawing_puts_the_scene_linear_image_in_the_viewport(blank, tmp_path, monkeypatch):
    """DrawTexture.draw runs in background Blender (GPU module up after a Workbench render), with
    a real engine instance, into a half-float offscreen; Blender's display transform then
    applies to that scene-linear buffer as to Cycles' and EEVEE's."""
    import gpu
    from mathutils import Matrix

    scene = bpy.context.scene
    scene.camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(scene.camera)
    scene.render.engine = 'BLENDER_WORKBENCH'
    scene.render.resolution_x = scene.render.resolution_y = 32
    bpy.ops.render.render()

    h, w = 8, 12
    image = np.zeros((h, w, 4), np.float32)
    image[..., 0] = np.linspace(0.0, 1.5, w)[None, :]            # beyond 1: scene-linear, kept
    image[..., 1] = np.linspace(0.0, 1.0, h)[:, None]            # top row first
    image[..., 2] = 0.25
    image[..., 3] = np.where(np.arange(w) < w // 2, 1.0, 0.5)[None, :]
    image[..., :3] *= image[..., 3:]                              # premultiplied
    background = 0.2
    drawn = {}

    def draw_in_a_render(engine, depsgraph):
        try:
            texture = _mod("viewport").DrawTexture(image)
            offscreen = gpu.types.GPUOffScreen(w, h, format='RGBA16F')
            with offscreen.bind():
                fb = gpu.state.active_framebuffer_get()
                fb.clear(color=(background, background, background, 1.0))
                with gpu.matrix.push_pop(), gpu.matrix.push_pop_projection():
                    gpu.matrix.load_identity()
                    gpu.matrix.load_projection_matrix(Matrix(
                        ((2 / w, 0, 0, -1), (0, 2 / h, 0, -1), (0, 0, 1, 0), (0, 0, 0, 1))))
                    texture.draw(engine, depsgraph.scene, w, h)
                pixels = fb.read_color(0, 0, w, h, 4, 0, 'FLOAT')
            offscreen.free()
            drawn["pixels"] = np.array(pixels.to_list(), np.float32).reshape(h, w, 4)[::-1]
        except Exception as ex:  # noqa: BLE001 - shown by the assertion below
            drawn["error"] = repr(ex)

    monkeypatch.setattr(_mod("final_render"), "render", draw_in_a_render)
    scene.render.engine = 'TFM'
    scene.render.resolution_x, scene.render.resolution_y = w, h
    bpy.ops.render.render()
    assert "error" not in drawn, drawn.get("error")
    pixels = drawn["pixels"]
    expected = image[..., :3] + (1.0 - image[..., 3:]) * background   # ALPHA_PREMULT over the clear
    # Half floats: 11 significant bits.
    assert float(np.abs(pixels[..., :3] - expected).max()) <= 2e-3 * max(1.0, float(expected.max()))

    # Display: with the Standard view transform Blender shows the sRGB OETF of that buffer.
    scene.view_settings.view_transform = 'Standard'
    scene.view_settings.look = 'None'
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    shown = bpy.data.images.new("drawn", w, h, float_buffer=True, alpha=True)
    shown.pixels.foreach_set(np.ascontiguousarray(pixels[::-1]).ravel())
    path = str(tmp_path / "shown.png")
    scene.render.image_settings.file_format = 'PNG'
    scene.render.image_settings.color_depth = '8'
    shown.save_render(path, scene=scene)
    png = bpy.data.images.load(path)
    png.colorspace_settings.name = 'Non-Color'  # read the display values as written
    display = np.array(png.pixels[:], np.float32).reshape(h, w, 4)[::-1, :, :3]
    x = np.clip(expected, 0.0, 1.0)
    oetf = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    assert float(np.abs(display - oetf).max()) <= 0.6 / 255 + 1e-3  # 8-bit rounding


def test_the_viewport_draws_the_world_as_the_final_render_does(blank, tmp_path):
    """An HDRI world aimed by a Mapping node, seen behind the smoke (Film ▸ Transparent off): the
    converged viewport equals the final render, the background included, and the background is
    the image, not its mean."""
    import math

    from tfm_addon.bench import conformance

    scene_builder.build(smoke(width=48, height=36), str(tmp_path), settings=SETTINGS, samples=4)
    scene = bpy.context.scene
    scene.render.film_transparent = False
    wt = scene.world.node_tree
    bg = next(n for n in wt.nodes if n.bl_idname == 'ShaderNodeBackground')
    coords, mapping = wt.nodes.new('ShaderNodeTexCoord'), wt.nodes.new('ShaderNodeMapping')
    env = wt.nodes.new('ShaderNodeTexEnvironment')
    env.image = conformance._sky_image(128, 64, bands=True)
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(60.0))
    wt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    wt.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    wt.links.new(env.outputs["Color"], bg.inputs["Color"])
    final = render_passes(tmp_path)["Combined"]
    top = final[0, :, :3]
    assert float(top.std(axis=0).max()) > 0.01          # the bands: the world varies behind the smoke
    dg = bpy.context.evaluated_depsgraph_get()
    session = _mod("viewport").ViewportSession()
    session.update(dg)
    assert session.request(_view_camera(dg, 48, 36), 4)
    frame = _converged(session, 4)
    assert float(np.abs(frame.image - final).max()) <= 1e-4
    session.close()
