"""Bad input renders what it can and tells the user why the rest is missing."""

import importlib

import bpy
import numpy as np
import pytest
from blender_helpers import MODULE, SETTINGS, FakeEngine, render_passes, smoke

from tfm_addon.blender import scene_builder


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


def _messages():
    return list(_mod("final_render").last_messages)


def _smoke_in_blender(tmp_path, **kwargs):
    return scene_builder.build(smoke(**kwargs), str(tmp_path), settings=SETTINGS)


def test_missing_volume_file_renders_the_rest_and_names_the_file(blank, tmp_path):
    made = _smoke_in_blender(tmp_path)
    made["medium"].data.filepath = str(tmp_path / "gone.vdb")
    image = render_passes(tmp_path)
    warnings = [m for level, m in _messages() if level == 'WARNING']
    assert any("gone.vdb" in m and "not found" in m for m in warnings), warnings
    # No medium: the lit ground is seen unattenuated, nothing scatters.
    assert image["Surfaces"].max() > 0.1
    assert image["Scattering"].max() == 0.0
    assert image["Transmittance"].min() == 1.0


def test_vector_only_grid_says_which_grid_was_expected(blank, tmp_path):
    made = _smoke_in_blender(tmp_path)
    velocity = np.zeros((8, 8, 8, 3), np.float32)
    velocity[2:6, 2:6, 2:6] = (1.0, 0.0, 0.0)
    path = str(tmp_path / "velocity.vdb")
    scene_builder.write_vdb(path, velocity, name="velocity")
    made["medium"].data.filepath = path
    render_passes(tmp_path)
    warnings = [m for level, m in _messages() if level == 'WARNING']
    assert any("expected 'density'" in m and "velocity (VECTOR_FLOAT)" in m for m in warnings), warnings


def test_no_light_renders_ambient_light_and_says_why(blank, tmp_path):
    made = _smoke_in_blender(tmp_path, ambient=(0.2, 0.2, 0.2))
    for light in made["lights"]:
        bpy.data.objects.remove(light)
    image = render_passes(tmp_path)
    said = _messages()
    # The renderer explains it once (the add-on does not repeat it): the world lights it alone, as
    # Cycles does (Info: nothing is left unread).
    assert [level for level, m in said if "world lights it alone" in m] == ['INFO'], said
    assert image["Surfaces"].max() > 0.01  # the ground, lit by the world
    assert image["Scattering"].max() > 0.01  # the smoke scatters the world's light
    # A sun with an angle and a point light with a radius: rendered with soft shadows, nothing said.
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    point = bpy.data.lights.new("Point", 'POINT')
    point.shadow_soft_size = 0.3
    for ob in (sun, bpy.data.objects.new("Point", point)):
        bpy.context.scene.collection.objects.link(ob)
    lit = render_passes(tmp_path, "lit")
    warnings = [m for level, m in _messages() if level == 'WARNING']
    assert not any("'Sun'" in m or "'Point'" in m for m in warnings), warnings
    assert not any("light" in m.lower() and "not rendered" in m for m in warnings), warnings
    assert lit["Surfaces"].mean() > image["Surfaces"].mean()


@pytest.mark.parametrize("break_at", [1, 3])
def test_cancel_stops_within_one_pass(blank, tmp_path, break_at):
    _smoke_in_blender(tmp_path)
    dg = bpy.context.evaluated_depsgraph_get()
    full = FakeEngine(64, 48)
    _mod("final_render").render(full, dg)
    total_passes = len(full.progress)
    assert total_passes >= 4 and full.errors == []
    engine = FakeEngine(64, 48, break_at=break_at)
    _mod("final_render").render(engine, dg)
    # The pass during which the user cancelled is the last one that ran.
    assert len(engine.progress) == break_at < total_passes
    assert engine.results == 0 and engine.errors == []
    assert ('INFO', "cancelled") in _messages()


def test_no_opengl_is_reported_not_raised(blank, tmp_path, monkeypatch):
    _smoke_in_blender(tmp_path)

    # The add-on's own copy of the renderer's error class.
    error = importlib.import_module(f"{MODULE}.tfm_addon.engine.errors").GLUnavailableError

    class NoGL:
        def render(self, *args, **kwargs):
            raise error("No OpenGL 3.3 context could be created: EGL not found")

    final_render = _mod("final_render")
    monkeypatch.setattr(final_render, "get_worker", lambda: NoGL())
    engine = FakeEngine(32, 24)
    final_render.render(engine, bpy.context.evaluated_depsgraph_get())
    assert engine.errors == ["No OpenGL 3.3 context could be created: EGL not found"]
    assert ({'ERROR'}, engine.errors[0]) in engine.reports
    assert engine.results == 0


def test_scene_without_camera_is_an_error_message(blank):
    engine = FakeEngine(32, 24)
    _mod("final_render").render(engine, bpy.context.evaluated_depsgraph_get())
    assert engine.errors == ["The scene has no camera to render from"]


def test_material_preview_warns_once(blank, tmp_path):
    # A preview is rendered again for every material and shape: what makes it wrong is said once.
    made = _smoke_in_blender(tmp_path)
    for light in made["lights"]:
        bpy.data.objects.remove(light)
    final_render = _mod("final_render")
    final_render._preview_reported.clear()
    reports = []
    for _ in range(2):
        engine = FakeEngine(32, 24)
        engine.is_preview = True
        final_render.render(engine, bpy.context.evaluated_depsgraph_get())
        assert engine.errors == [] and engine.results == 1
        reports.append(engine.reports)
    assert any("no light" in m or "no spot light" in m for _, m in reports[0])
    assert reports[1] == []


def test_a_warning_is_said_once_per_animation_render(blank, tmp_path):
    made = _smoke_in_blender(tmp_path)
    made["lights"][0].data.shadow_soft_size = 0.0
    area = bpy.data.lights.new("Panel", 'AREA')
    area.use_nodes = True                               # light nodes, which the engine does not render
    bpy.context.scene.collection.objects.link(bpy.data.objects.new("Panel", area))
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 3
    scene.render.filepath = str(tmp_path / "frame_")
    scene.render.image_settings.file_format = 'OPEN_EXR'
    told = []
    final_render = _mod("final_render")
    handler = lambda *args: told.extend(m for level, m in final_render.last_messages)  # noqa: E731
    bpy.app.handlers.render_post.append(handler)
    try:
        bpy.ops.render.render(animation=True)
    finally:
        bpy.app.handlers.render_post.remove(handler)
    assert len(list(tmp_path.glob("frame_*.exr"))) == 3
    assert len([m for m in told if "'Panel'" in m and "light nodes" in m]) == 1, told
    render_passes(tmp_path, "still")         # a new job: said again
    assert any("'Panel'" in m and "light nodes" in m for level, m in _messages())


def test_a_frame_whose_result_exceeds_the_budget_is_refused_before_rendering(blank, tmp_path, monkeypatch):
    _smoke_in_blender(tmp_path)
    final_render = _mod("final_render")
    asked = []

    class Spy:
        def render(self, *args, **kwargs):
            asked.append("render")
            raise AssertionError("the refused frame was rendered")

        def call(self, fn, timeout_s=None):
            return "spy GL"

    monkeypatch.setattr(final_render, "get_worker", lambda: Spy())
    monkeypatch.delenv(final_render.BUDGET_ENV, raising=False)
    bpy.context.scene.tfm.memory_budget_gb = 0.01            # 10.2 MiB
    engine = FakeEngine(512, 512)                    # its render result alone takes 13.6 MB
    final_render.render(engine, bpy.context.evaluated_depsgraph_get())
    assert asked == [] and engine.results == 0
    (message,) = engine.errors
    need = final_render.result_bytes(512, 512, 3) + final_render.ENGINE_BYTES_PER_PIXEL * 128 ** 2
    assert need > 0.01 * 1024 ** 3
    assert message.startswith(f"The frame is 512x512 (0.3 megapixels): TFM would need about "
                              f"{need / 1024 ** 3:.2f} GiB to render it even in tiles")
    assert "above the memory budget of 0.01 GiB (Render Properties > Performance > Memory Limit)" in message

    scene = bpy.context.scene
    assert final_render.tiling(scene, 256, 256, 3)[0] == 114    # within the budget in tiles
    monkeypatch.setenv(final_render.BUDGET_ENV, "64")        # the environment overrides the scene
    assert final_render.tiling(scene, 256, 256, 3) == (None, None)
    assert "TFM_MEMORY_BUDGET_GB" in final_render.tiling(scene, 65536, 65536, 3)[1]
    monkeypatch.setenv(final_render.BUDGET_ENV, "8")
    assert final_render.tiling(scene, 8192, 8192, 3) == (final_render.MAX_TILE, None)
