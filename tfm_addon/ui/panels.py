"""Panels in the Properties editor, shown only when the render engine is TFM.

Our own panels draw the add-on's settings and replace the few Blender panels that do not say
what TFM honours (object visibility, view layer passes); every other generic Blender panel is
opened to TFM by ``blender.panel_compat`` on register and closed again on unregister.
"""

import bpy

from ..blender import panel_compat

ENGINE = 'TFM'


class _TFMPanel:
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class TFM_PT_render(_TFMPanel, bpy.types.Panel):
    bl_label = "Sampling"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        tfm = context.scene.tfm
        col = layout.column()
        col.prop(tfm, "method")
        col.prop(tfm, "quality")
        custom = col.column()
        custom.active = tfm.quality == 'CUSTOM'
        custom.prop(tfm, "view_steps")
        custom.prop(tfm, "light_steps")
        custom.prop(tfm, "sampling")
        col.prop(tfm, "volume_bounces")
        col.prop(tfm, "ambient")
        world_col = col.column()
        world_col.active = tfm.ambient
        world_col.prop(tfm, "world_light")
        world_col.prop(tfm, "world_light_viewport", text="Viewport")
        if 'SHADOWED' in (tfm.world_light, tfm.world_light_viewport):
            world_col.prop(tfm, "world_directions")
        col.prop(tfm, "viewport_scale")
        col.prop(tfm, "samples")
        col.prop(tfm, "viewport_samples")
        col.prop(tfm, "strict")
        col.prop(tfm, "memory_budget_gb")


class TFM_PT_render_maps(_TFMPanel, bpy.types.Panel):
    bl_label = "Transmittance Maps"
    bl_context = "render"
    bl_parent_id = "TFM_PT_render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        tfm = context.scene.tfm
        layout.active = tfm.method == 'TFM'
        col = layout.column()
        col.prop(tfm, "map_resolution")
        col.prop(tfm, "tfm_filter")
        custom = col.column()
        custom.active = tfm.quality == 'CUSTOM'
        custom.prop(tfm, "coefficients")
        custom.prop(tfm, "density_weight_auto", text="Automatic Weight")
        sub = custom.column()
        sub.active = tfm.quality == 'CUSTOM' and not tfm.density_weight_auto
        sub.prop(tfm, "density_weight")


class TFM_PT_volume_medium(_TFMPanel, bpy.types.Panel):
    bl_label = "Medium"
    bl_context = "data"

    @classmethod
    def poll(cls, context):
        return context.volume is not None and super().poll(context)

    def draw(self, context):
        from ..blender import materials

        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        volume = context.volume
        tfm = volume.tfm
        layout.prop_search(tfm, "density_grid", volume, "grids")
        layout.prop(tfm, "use_node_material")
        node_sigma = None
        if tfm.use_node_material:
            material = volume.materials[0] if len(volume.materials) else None
            node_sigma, reason = materials.read_volume_material(material)
            box = layout.box()
            if node_sigma is not None:
                box.label(text=f"Read from {node_sigma.source}", icon='CHECKMARK')
            else:
                box.label(text=reason, icon='INFO')
        col = layout.column()
        col.active = node_sigma is None
        col.prop(tfm, "sigma_a")
        col.prop(tfm, "sigma_s")
        col.prop(tfm, "density_scale")
        col.prop(tfm, "anisotropy")
        col.prop(tfm, "emission_color")
        col.prop(tfm, "emission_strength")
        col.prop_search(tfm, "emission_grid", volume, "grids")


class TFM_PT_light(_TFMPanel, bpy.types.Panel):
    bl_label = "TFM"
    bl_context = "data"

    @classmethod
    def poll(cls, context):
        return context.light is not None and super().poll(context)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        light = context.light
        layout.prop(light.tfm, "use_tfm")
        if light.type == 'SPOT':
            layout.template_ID(light.tfm, "gobo", open="image.open")
        if light.type in ('SPOT', 'POINT') and light.shadow_soft_size > 0.0:
            layout.label(text="The radius is treated as zero", icon='INFO')
        elif light.type == 'SUN' and light.angle > 0.0:
            layout.label(text="The angle is treated as zero (a sharp sun)", icon='INFO')
        elif light.type == 'AREA':
            layout.label(text="Rendered as a point with a cosine profile", icon='INFO')


class TFM_PT_world(_TFMPanel, bpy.types.Panel):
    bl_label = "Ambient"
    bl_context = "world"

    @classmethod
    def poll(cls, context):
        return context.world is not None and super().poll(context)

    def draw(self, context):
        from ..blender import world

        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        node = world.background_node(context.world)
        if node is not None:
            layout.prop(node.inputs["Color"], "default_value", text="Color")
            layout.prop(node.inputs["Strength"], "default_value", text="Strength")
        else:
            layout.prop(context.world, "color")
        layout.prop(context.scene.tfm, "ambient", text="Light the Medium")


GEOMETRY_TYPES = {'MESH', 'CURVE', 'SURFACE', 'META', 'FONT', 'VOLUME'}


class TFM_PT_object_visibility(_TFMPanel, bpy.types.Panel):
    """Replaces OBJECT_PT_visibility (which shows ray visibility to EEVEE only)."""

    bl_label = "Visibility"
    bl_context = "object"
    bl_options = {'DEFAULT_CLOSED'}

    @classmethod
    def poll(cls, context):
        return context.object is not None and super().poll(context)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        ob = context.object
        col = layout.column()
        col.prop(ob, "hide_select", text="Selectable", toggle=False, invert_checkbox=True)
        col = layout.column(heading="Show In")
        col.prop(ob, "hide_viewport", text="Viewports", toggle=False, invert_checkbox=True)
        col.prop(ob, "hide_render", text="Renders", toggle=False, invert_checkbox=True)
        if ob.type in GEOMETRY_TYPES:
            layout.separator()
            col = layout.column(heading="Ray Visibility")
            col.prop(ob, "visible_camera", text="Camera", toggle=False)
            col.prop(ob, "visible_shadow", text="Shadow", toggle=False)
            layout.separator()
            col = layout.column(heading="Mask")
            col.prop(ob, "is_holdout")


class TFM_PT_view_layer_passes(_TFMPanel, bpy.types.Panel):
    """The engine's passes for the compositor (Combined is always written)."""

    bl_label = "Passes"
    bl_context = "view_layer"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.view_layer.tfm
        col = layout.column(heading="Include", align=True)
        col.prop(settings, "use_pass_scattering")
        col.prop(settings, "use_pass_surfaces")
        col.prop(settings, "use_pass_transmittance")


classes = (
    TFM_PT_render,
    TFM_PT_render_maps,
    TFM_PT_volume_medium,
    TFM_PT_light,
    TFM_PT_world,
    TFM_PT_object_visibility,
    TFM_PT_view_layer_passes,
)

_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)


def register():
    _register_classes()
    try:
        panel_compat.open_panels()
    except Exception:
        panel_compat.close_panels()
        _unregister_classes()
        raise


def unregister():
    panel_compat.close_panels()
    _unregister_classes()
