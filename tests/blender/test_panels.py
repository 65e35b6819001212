"""The panels draw only properties that exist, and only for the TFM engine (a recording layout
stands in for Blender's UI, which background mode does not have)."""

import importlib
from types import SimpleNamespace

import pytest
from blender_helpers import MODULE, smoke

from tfm_addon.blender import scene_builder


class Layout:
    """Records what a panel draws and checks that every drawn property exists."""

    def __init__(self, drawn):
        self.drawn = drawn
        self.use_property_split = self.use_property_decorate = self.active = True

    def _child(self, *args, **kwargs):
        return Layout(self.drawn)

    column = row = box = split = _child

    def prop(self, data, name, **kwargs):
        assert name in data.bl_rna.properties, f"{data!r} has no property {name!r}"
        self.drawn.append(name)

    def prop_search(self, data, name, search_data, search_name, **kwargs):
        assert name in data.bl_rna.properties and search_name in search_data.bl_rna.properties
        self.drawn.append(name)

    def template_ID(self, data, name, **kwargs):
        assert name in data.bl_rna.properties
        self.drawn.append(name)

    def label(self, text="", **kwargs):
        self.drawn.append("label:" + text)

    def separator(self, **kwargs):
        pass


def _draw(panel_name, context):
    panel = getattr(importlib.import_module(MODULE + ".tfm_addon.ui.panels"), panel_name)
    assert panel.poll(context)
    assert not panel.poll(SimpleNamespace(**{**context.__dict__, "engine": "CYCLES"}))
    drawn = []
    panel.draw(SimpleNamespace(layout=Layout(drawn)), context)
    return drawn


@pytest.fixture
def context(blank, tmp_path):
    made = scene_builder.build(smoke(width=16, height=12, n=16), str(tmp_path))
    return SimpleNamespace(engine='TFM', scene=blank, volume=made["medium"].data,
                           light=made["lights"][0].data, world=blank.world)


def test_render_panels(context):
    assert {"view_steps", "light_steps", "sampling", "method", "ambient"} <= set(
        _draw("TFM_PT_render", context))
    assert {"coefficients", "density_weight_auto", "density_weight", "map_resolution"} <= set(
        _draw("TFM_PT_render_maps", context))


def test_medium_panel_says_where_sigma_comes_from(context):
    drawn = _draw("TFM_PT_volume_medium", context)
    assert {"density_grid", "use_node_material", "sigma_a", "sigma_s", "density_scale",
            "anisotropy"} <= set(drawn)
    assert any(d.startswith("label:Read from Principled Volume") for d in drawn), drawn


def test_light_and_world_panels(context):
    assert {"use_tfm", "gobo"} <= set(_draw("TFM_PT_light", context))
    assert "default_value" in _draw("TFM_PT_world", context)
    context.light.type = 'POINT'
    context.light.shadow_soft_size = 0.2
    assert _draw("TFM_PT_light", context) == ["use_tfm"]        # a radius renders: nothing to say
    context.light.type = 'AREA'
    assert _draw("TFM_PT_light", context) == ["use_tfm"]        # its shape and size render


def test_visibility_and_passes_panels(context):
    import bpy

    ground = next(ob for ob in bpy.context.scene.objects if ob.type == 'MESH')
    context.object = ground
    context.view_layer = bpy.context.scene.view_layers[0]
    assert {"hide_render", "visible_camera", "visible_shadow", "is_holdout"} <= set(
        _draw("TFM_PT_object_visibility", context))
    assert _draw("TFM_PT_view_layer_passes", context) == [
        "use_pass_scattering", "use_pass_surfaces", "use_pass_transmittance"]
