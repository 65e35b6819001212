"""The panels draw only properties that exist, only for the TFM engine, and in Blender's terms:
Auto shows what it chose and hides the hand-set fields, the world light has one place, the light's
settings sit under Blender's Light panel (the recording layout that draws the README's picture of
the panels stands in for Blender's UI, which background mode does not have)."""

import importlib
from types import SimpleNamespace

import pytest
from blender_helpers import MODULE, smoke

from tfm_addon.bench.panels_picture import record
from tfm_addon.blender import scene_builder


def _panel(panel_name):
    return getattr(importlib.import_module(MODULE + ".tfm_addon.ui.panels"), panel_name)


def _draw(panel_name, context, method="draw"):
    panel = _panel(panel_name)
    assert panel.poll(context)
    assert not panel.poll(SimpleNamespace(**{**context.__dict__, "engine": "CYCLES"}))
    return [row.key for row in record(panel, context, method)]


@pytest.fixture
def context(blank, tmp_path):
    made = scene_builder.build(smoke(width=16, height=12, n=16), str(tmp_path))
    return SimpleNamespace(engine='TFM', scene=blank, volume=made["medium"].data,
                           light=made["lights"][0].data, world=blank.world)


RENDER_PANELS = ("TFM_PT_sampling", "TFM_PT_light_paths", "TFM_PT_volumes", "TFM_PT_volume_shadows",
                 "TFM_PT_performance")
# Set by hand under Custom; under Auto chosen per scene, and not shown.
MANUAL = ("view_steps", "light_steps", "sampling", "coefficients", "tfm_filter", "density_weight_auto",
          "density_weight")


def _render_tab(context):
    return [name for panel in RENDER_PANELS for name in _draw(panel, context)]


def test_auto_shows_what_it_chose_and_hides_the_manual_fields(context, addon):
    import bpy

    final_render = importlib.import_module(MODULE + ".tfm_addon.blender.final_render")
    final_render.auto_choices.pop(context.scene.name, None)
    assert context.scene.tfm.quality == 'AUTO'
    drawn = _render_tab(context)
    assert not set(MANUAL) & set(drawn), drawn
    assert {"samples", "viewport_samples", "quality", "method", "map_resolution", "memory_budget_gb",
            "viewport_scale", "strict"} <= set(drawn)
    assert "label:Auto chooses when you render (F12)" in drawn
    # A final render: the panel shows what Auto chose, as the render report says it.
    bpy.ops.render.render()
    chosen = final_render.auto_choices[context.scene.name]
    shown = [d[len("label:"):] for d in _draw("TFM_PT_volumes", context) if ": " in d]
    assert shown == [f"{name}: {value}" for name, value in final_render.auto_fields(chosen)]
    assert shown[:3] == [f"Steps: {chosen['view_steps']}", f"Shadow Steps: {chosen['light_steps']}",
                         f"Coefficients: {chosen['coefficients']}"]
    (line,) = [m for _, m in final_render.last_messages if m.startswith("Auto quality:")]
    assert line == "Auto quality: " + ", ".join(s.replace(": ", " ") for s in shown)


def test_custom_shows_each_manual_field_once(context):
    context.scene.tfm.quality = 'CUSTOM'
    drawn = _render_tab(context)
    assert not any(d.startswith("label:Auto") for d in drawn)
    assert all(drawn.count(name) == 1 for name in MANUAL), drawn
    # Volume bounces: one field, under Light Paths as in Cycles; -1 shows Cycles' own count.
    assert drawn.count("volume_bounces") == 1
    context.scene.tfm.volume_bounces = -1
    context.scene.cycles.volume_bounces = 5
    assert _draw("TFM_PT_light_paths", context) == ["volume_bounces", "label:Cycles' Volume Bounces: 5"]
    context.scene.tfm.volume_bounces = 16
    assert _draw("TFM_PT_light_paths", context) == ["volume_bounces"]
    context.scene.tfm.volume_bounces = -1
    context.scene.cycles.volume_bounces = 0


def test_medium_panel_says_where_sigma_comes_from(context):
    drawn = _draw("TFM_PT_volume_medium", context)
    assert {"density_grid", "use_node_material", "sigma_a", "sigma_s", "density_scale",
            "anisotropy"} <= set(drawn)
    assert any(d.startswith("label:Read from Principled Volume") for d in drawn), drawn
    # the fallback fields in the Principled Volume's order and names
    assert [d for d in drawn if d in ("sigma_s", "density_scale", "sigma_a")] == [
        "sigma_s", "density_scale", "sigma_a"]
    rna = context.volume.tfm.bl_rna.properties
    assert (rna["sigma_s"].name, rna["sigma_a"].name) == ("Color", "Absorption Color")


def test_light_settings_sit_under_the_light_panel(context):
    import bpy

    for name in ("TFM_PT_light", "TFM_PT_light_texture"):   # Object Data > Light > ...
        assert _panel(name).bl_parent_id == "DATA_PT_EEVEE_light"
    assert 'TFM' in bpy.types.DATA_PT_EEVEE_light.COMPAT_ENGINES
    assert _draw("TFM_PT_light", context) == ["use_tfm"]
    assert _draw("TFM_PT_light_texture", context) == ["gobo"]
    context.light.type = 'POINT'
    context.light.shadow_soft_size = 0.2
    assert not _panel("TFM_PT_light_texture").poll(context)     # a spot's only
    assert _draw("TFM_PT_light", context) == ["use_tfm"]        # a radius renders: nothing to say
    context.light.type = 'AREA'
    assert _draw("TFM_PT_light", context) == ["use_tfm"]        # its shape and size render


def test_world_light_has_one_place_the_world_tab(context):
    assert "default_value" in _draw("TFM_PT_world", context)
    assert _draw("TFM_PT_world_lighting", context, "draw_header") == ["ambient"]
    assert _draw("TFM_PT_world_lighting", context) == ["world_light", "world_directions"]
    world = {"ambient", "world_light", "world_directions"}
    assert not world & set(_render_tab(context))


def test_visibility_and_passes_panels(context):
    import bpy

    ground = next(ob for ob in bpy.context.scene.objects if ob.type == 'MESH')
    context.object = ground
    context.view_layer = bpy.context.scene.view_layers[0]
    assert {"hide_render", "visible_camera", "visible_shadow", "is_holdout"} <= set(
        _draw("TFM_PT_object_visibility", context))
    assert _draw("TFM_PT_view_layer_passes", context) == [
        "use_pass_scattering", "use_pass_surfaces", "use_pass_transmittance"]
