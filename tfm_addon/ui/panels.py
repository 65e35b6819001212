"""Panels in the Properties editor, shown only when the render engine is TFM.

Our own panels draw the add-on's settings; Blender's panels that fit this engine as they are
(dimensions, output, colour management, camera, light, volume file and grids, material slots) are
opted in by adding 'TFM' to their ``COMPAT_ENGINES`` and opted out again on unregister.
"""

import bpy

ENGINE = 'TFM'

BUILTIN_PANELS = (
    # Render and Output properties.
    "RENDER_PT_color_management",
    "RENDER_PT_color_management_advanced",
    "RENDER_PT_color_management_curves",
    "RENDER_PT_color_management_white_balance",
    "RENDER_PT_color_management_working_space",
    "RENDER_PT_format",
    "RENDER_PT_frame_range",
    "RENDER_PT_time_stretching",
    "RENDER_PT_output",
    "RENDER_PT_output_color_management",
    "RENDER_PT_encoding",
    "RENDER_PT_encoding_video",
    "RENDER_PT_encoding_audio",
    "RENDER_PT_stamp",
    "RENDER_PT_stamp_note",
    "RENDER_PT_stamp_burn",
    "RENDER_PT_post_processing",
    # Camera.
    "DATA_PT_context_camera",
    "DATA_PT_lens",
    "DATA_PT_camera",
    "CAMERA_PT_presets",
    "DATA_PT_camera_display",
    "DATA_PT_camera_display_composition_guides",
    "DATA_PT_camera_safe_areas",
    "DATA_PT_camera_safe_areas_center_cut",
    "DATA_PT_camera_background_image",
    "DATA_PT_custom_props_camera",
    # Light: type, colour, power, then the cone.
    "DATA_PT_context_light",
    "DATA_PT_EEVEE_light",
    "DATA_PT_spot",
    "DATA_PT_custom_props_light",
    # Volume.
    "DATA_PT_context_volume",
    "DATA_PT_volume_file",
    "DATA_PT_volume_grids",
    "DATA_PT_volume_viewport_display",
    "DATA_PT_custom_props_volume",
    # Material and world.
    "MATERIAL_PT_preview",
    "EEVEE_MATERIAL_PT_context_material",
    "EEVEE_MATERIAL_PT_surface",
    "EEVEE_MATERIAL_PT_volume",
    "MATERIAL_PT_custom_props",
    "WORLD_PT_context_world",
    "WORLD_PT_custom_props",
    # Object.
    "OBJECT_PT_visibility",
)

_opted_in: list[type] = []


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
        col.prop(tfm, "ambient")
        col.prop(tfm, "viewport_scale")
        col.prop(tfm, "samples")
        col.prop(tfm, "viewport_samples")


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
        if light.type != 'SPOT':
            layout.label(text="Only spot lights light the medium", icon='INFO')
            return
        layout.prop(light.tfm, "use_tfm")
        layout.template_ID(light.tfm, "gobo", open="image.open")
        if light.shadow_soft_size > 0.0:
            layout.label(text="The radius is treated as zero", icon='INFO')


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


classes = (
    TFM_PT_render,
    TFM_PT_render_maps,
    TFM_PT_volume_medium,
    TFM_PT_light,
    TFM_PT_world,
)

_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)


def register():
    _register_classes()
    for name in BUILTIN_PANELS:
        panel = getattr(bpy.types, name, None)
        if panel is None or ENGINE in panel.COMPAT_ENGINES:
            continue
        panel.COMPAT_ENGINES.add(ENGINE)
        _opted_in.append(panel)


def unregister():
    for panel in _opted_in:
        panel.COMPAT_ENGINES.discard(ENGINE)
    _opted_in.clear()
    _unregister_classes()
