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


def _split(layout):
    layout.use_property_split = True
    layout.use_property_decorate = False
    return layout


class TFM_PT_sampling(_TFMPanel, bpy.types.Panel):
    """Samples per pixel, as EEVEE's Sampling panel (Render, Viewport)."""

    bl_label = "Sampling"
    bl_context = "render"

    def draw(self, context):
        tfm = context.scene.tfm
        col = _split(self.layout).column(align=True)
        col.prop(tfm, "samples")
        col.prop(tfm, "viewport_samples")


class TFM_PT_light_paths(_TFMPanel, bpy.types.Panel):
    """Where Cycles sets its bounces."""

    bl_label = "Light Paths"
    bl_context = "render"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        tfm = context.scene.tfm
        col = _split(self.layout).column(heading="Max Bounces")
        col.prop(tfm, "volume_bounces", text="Volume")
        if tfm.volume_bounces < 0:      # Cycles' own setting, read as it is
            cycles = getattr(context.scene, "cycles", None)
            col.label(text=f"Cycles' Volume Bounces: {cycles.volume_bounces if cycles else 0}")


class TFM_PT_volumes(_TFMPanel, bpy.types.Panel):
    """Volume quality, as Cycles' and EEVEE's Volumes panels: Auto shows what it chose for the
    last render; the hand-set fields exist only under Custom."""

    bl_label = "Volumes"
    bl_context = "render"

    def draw(self, context):
        layout = _split(self.layout)
        tfm = context.scene.tfm
        layout.row().prop(tfm, "quality", expand=True)
        if tfm.quality == 'AUTO':
            draw_auto_choice(layout, context.scene)
            return
        col = layout.column(align=True)
        col.prop(tfm, "view_steps")
        col.prop(tfm, "sampling")


def draw_auto_choice(layout, scene):
    """What Auto chose for ``scene``'s last final render, or how to see it."""
    from ..blender import final_render

    box = layout.box()
    chosen = final_render.auto_choices.get(scene.name)
    if not chosen:
        box.label(text="Auto chooses when you render (F12)", icon='INFO')
        return
    box.label(text="Auto chose for the last render:", icon='CHECKMARK')
    for name, value in final_render.auto_fields(chosen):
        box.label(text=f"{name}: {value}")


class TFM_PT_volume_shadows(_TFMPanel, bpy.types.Panel):
    """How volumes shadow themselves and each other."""

    bl_label = "Shadows"
    bl_context = "render"
    bl_parent_id = "TFM_PT_volumes"

    def draw(self, context):
        layout = _split(self.layout)
        tfm = context.scene.tfm
        col = layout.column()
        col.prop(tfm, "method")
        maps = col.column()
        maps.active = tfm.method == 'TFM'
        maps.prop(tfm, "map_resolution")
        if tfm.quality != 'CUSTOM':
            return
        col.prop(tfm, "light_steps")
        maps = col.column()
        maps.active = tfm.method == 'TFM'
        maps.prop(tfm, "coefficients")
        maps.prop(tfm, "tfm_filter")
        maps.prop(tfm, "density_weight_auto", text="Automatic Weight")
        sub = maps.column()
        sub.active = tfm.method == 'TFM' and not tfm.density_weight_auto
        sub.prop(tfm, "density_weight")


class TFM_PT_performance(_TFMPanel, bpy.types.Panel):
    """As Cycles' Performance panel: memory, the viewport's resolution, final renders."""

    bl_label = "Performance"
    bl_context = "render"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        layout = _split(self.layout)
        tfm = context.scene.tfm
        layout.prop(tfm, "memory_budget_gb")
        layout.prop(tfm, "viewport_scale")
        layout.prop(tfm, "strict")


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
        col.prop(tfm, "sigma_s")          # in the Principled Volume's order: Color, Density,
        col.prop(tfm, "density_scale")    # Anisotropy, Absorption Color, then emission
        col.prop(tfm, "anisotropy")
        col.prop(tfm, "sigma_a")
        col.prop(tfm, "emission_color")
        col.prop(tfm, "emission_strength")
        col.prop_search(tfm, "emission_grid", volume, "grids")


class _LightSubpanel(_TFMPanel):
    """A subpanel of Blender's Light panel (Object Data ▸ Light), which TFM shows."""

    bl_context = "data"
    bl_parent_id = "DATA_PT_EEVEE_light"

    @classmethod
    def poll(cls, context):
        return context.light is not None and super().poll(context)


class TFM_PT_light(_LightSubpanel, bpy.types.Panel):
    bl_label = "Volumes"

    def draw(self, context):
        layout = _split(self.layout)
        light = context.light
        layout.prop(light.tfm, "use_tfm")


class TFM_PT_light_texture(_LightSubpanel, bpy.types.Panel):
    bl_label = "Projected Texture"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.light.type == 'SPOT'

    def draw(self, context):
        self.layout.template_ID(context.light.tfm, "gobo", open="image.open")


class TFM_PT_world(_TFMPanel, bpy.types.Panel):
    """The world's colour, and how it lights the scene: the one place for world light."""

    bl_label = "Surface"
    bl_context = "world"

    @classmethod
    def poll(cls, context):
        return context.world is not None and super().poll(context)

    def draw(self, context):
        from ..blender import world

        layout = _split(self.layout)
        node = world.background_node(context.world)
        if node is not None:
            layout.prop(node.inputs["Color"], "default_value", text="Color")
            layout.prop(node.inputs["Strength"], "default_value", text="Strength")
        else:
            layout.prop(context.world, "color")


class TFM_PT_world_lighting(_TFMPanel, bpy.types.Panel):
    bl_label = "Lighting"
    bl_context = "world"
    bl_parent_id = "TFM_PT_world"

    def draw_header(self, context):
        self.layout.prop(context.scene.tfm, "ambient", text="")

    def draw(self, context):
        layout = _split(self.layout)
        tfm = context.scene.tfm
        layout.active = tfm.ambient
        col = layout.column()
        col.prop(tfm, "world_light")
        if tfm.world_light == 'SHADOWED':
            col.prop(tfm, "world_directions")


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
    TFM_PT_sampling,
    TFM_PT_light_paths,
    TFM_PT_volumes,
    TFM_PT_volume_shadows,
    TFM_PT_performance,
    TFM_PT_volume_medium,
    TFM_PT_light,
    TFM_PT_light_texture,
    TFM_PT_world,
    TFM_PT_world_lighting,
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
