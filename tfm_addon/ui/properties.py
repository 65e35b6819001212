"""The add-on's settings stored in .blend files: ``scene.tfm``, ``volume.tfm``, ``light.tfm``."""

import bpy
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatProperty,
    FloatVectorProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)


class TFM_SceneSettings(bpy.types.PropertyGroup):
    """Render settings of the TFM engine (Render Properties)."""

    quality: EnumProperty(
        name="Quality",
        items=(
            ('AUTO', "Auto", "Choose coefficients, density weight, steps and sampling from the scene "
                             "(the cheapest settings the benchmark found to reach SSIM 0.99)", 0),
            ('CUSTOM', "Custom", "Use the steps, coefficients and weight set below", 1),
        ),
        default='AUTO',
        description="How the quality settings are chosen",
    )
    view_steps: IntProperty(
        name="View Steps", default=100, min=1, soft_max=512, max=4096,
        description="Samples along each view ray through the medium",
    )
    light_steps: IntProperty(
        name="Light Steps", default=100, min=1, soft_max=512, max=4096,
        description="Samples along each light ray when a transmittance map is built",
    )
    coefficients: IntProperty(
        name="Coefficients", default=8, min=1, max=16,
        description="Cosine coefficients stored per transmittance map texel",
    )
    density_weight_auto: BoolProperty(
        name="Automatic Density Weight", default=True,
        description="Choose the density weight from the thickest light ray of the medium",
    )
    density_weight: FloatProperty(
        name="Density Weight", default=10.0, min=1.0, soft_max=100.0,
        description="Alpha: the transmittance map stores T to the power 1/alpha, which rings less "
                    "in thick media; at least the optical depth along the light rays",
    )
    map_resolution: IntProperty(
        name="Map Resolution", default=512, min=16, soft_max=2048, max=8192, subtype='PIXEL',
        description="Side of the shadow and transmittance maps, texels",
    )
    sampling: EnumProperty(
        name="Sampling",
        items=(
            ('WORLD', "World", "Space view samples evenly along the view ray", 0),
            ('PROJECTIVE', "Projective", "Space view samples evenly in the light's shadow map, "
                                         "following its texel density", 1),
        ),
        default='WORLD',
        description="How view samples are spaced in a homogeneous medium",
    )
    method: EnumProperty(
        name="Method",
        items=(
            ('TFM', "Transmittance Maps", "Transmittance function mapping (fast)", 0),
            ('BRUTE_FORCE', "Brute Force", "March toward the light at every view sample "
                                           "(slow reference)", 1),
        ),
        default='TFM',
        description="How the transmittance toward the lights is found",
    )
    tfm_filter: EnumProperty(
        name="Map Filter",
        items=(
            ('EXACT', "Exact", "Reconstruct the four nearest map texels, each over its own light "
                               "ray, and blend the results", 0),
            ('LINEAR', "Linear", "Let the GPU blend neighbouring coefficients (faster; blurs the "
                                 "medium's edges as seen from the light)", 1),
        ),
        default='LINEAR',
        description="How transmittance maps are filtered between texels",
    )
    ambient: BoolProperty(
        name="Ambient", default=True,
        description="Light the medium and the solids with the world colour",
    )
    world_light: EnumProperty(
        name="World Light",
        items=(
            ('SHADOWED', "Shadowed", "The world's light reaches the medium and the surfaces through what "
             "lies in its way, as in Cycles (world directions as shadowed suns)"),
            ('UNSHADOWED', "Unshadowed", "The world's light is added as is: faster, brighter inside dense "
             "smoke and under objects"),
        ),
        default='SHADOWED',
        description="How the world colour lights the medium and the surfaces",
    )
    world_light_viewport: EnumProperty(
        name="Viewport World Light",
        items=(
            ('SHADOWED', "Shadowed", "As the final render: the world's light through what lies in its way"),
            ('UNSHADOWED', "Unshadowed", "The world's light added as is: the viewport stays fast (a shadowed "
             "world costs a light pass per direction)"),
        ),
        default='UNSHADOWED',
        description="How the world colour lights the medium and the surfaces in the viewport",
    )
    world_directions: IntProperty(
        name="World Directions", default=16, min=4, max=128,
        description="Directions the shadowed world light comes from: more is smoother and slower",
    )
    volume_bounces: IntProperty(
        name="Volume Bounces", default=-1, min=-1, soft_max=128, max=1024,
        description="Times light may scatter in the media (approximated from the same maps): 0 renders "
                    "single scattering; -1 reads Cycles' Light Paths > Max Bounces > Volume",
    )
    viewport_scale: FloatProperty(
        name="Viewport Resolution", default=0.5, min=0.1, max=1.0, subtype='FACTOR',
        description="Resolution of the viewport image relative to the viewport",
    )
    samples: IntProperty(
        name="Samples", default=0, min=0, soft_max=256, max=4096,
        description="Antialiasing samples per pixel of a final render, each at its own place in the "
                    "pixel (one-pixel box filter) with its own view-march start; 0 chooses "
                    "automatically (16), 1 renders pixel centres",
    )
    viewport_samples: IntProperty(
        name="Viewport Samples", default=16, min=1, soft_max=256, max=4096,
        description="Samples the viewport accumulates while nothing changes",
    )
    strict: BoolProperty(
        name="Strict", default=False,
        description="Fail a final render instead of rendering without something it needs (a "
                    "missing or unreadable volume file or grid, no OpenGL): the frame is not written, "
                    "and command-line Blender exits with a non-zero code. The environment variable "
                    "TFM_STRICT=1 turns it on for every scene",
    )
    memory_budget_gb: FloatProperty(
        name="Memory Budget", default=0.0, min=0.0, soft_max=256.0, unit='NONE',
        description="Largest memory (GiB) a final render's image may use; a frame estimated above it "
                    "is refused before anything is allocated, with its size and the estimate. 0: "
                    "half of the machine's memory (the environment variable TFM_MEMORY_BUDGET_GB "
                    "overrides it)",
    )

    @classmethod
    def register(cls):
        bpy.types.Scene.tfm = PointerProperty(type=cls, name="TFM", description="TFM engine settings")

    @classmethod
    def unregister(cls):
        del bpy.types.Scene.tfm


class TFM_VolumeSettings(bpy.types.PropertyGroup):
    """How a Volume data-block becomes the medium (Volume Data Properties)."""

    density_grid: StringProperty(
        name="Density Grid", default="density",
        description="Float grid that gives the density; when absent the first float grid is used",
    )
    use_node_material: BoolProperty(
        name="Use Node Material", default=True,
        description="Take absorption, scattering and anisotropy from the volume's node material "
                    "(Principled Volume, Volume Scatter, Volume Absorption) when it can be read",
    )
    sigma_a: FloatVectorProperty(
        name="Absorption", subtype='COLOR', size=3, default=(0.1, 0.1, 0.1), min=0.0, soft_max=1.0,
        description="Absorption coefficient per unit density, per metre",
    )
    sigma_s: FloatVectorProperty(
        name="Scattering", subtype='COLOR', size=3, default=(1.0, 1.0, 1.0), min=0.0, soft_max=1.0,
        description="Scattering coefficient per unit density, per metre",
    )
    density_scale: FloatProperty(
        name="Density Scale", default=1.0, min=0.0, soft_max=100.0,
        description="Multiplies the absorption and scattering colours above",
    )
    anisotropy: FloatProperty(
        name="Anisotropy", default=0.0, min=-0.99, max=0.99, subtype='FACTOR',
        description="Henyey-Greenstein g: negative scatters backward, positive forward",
    )
    emission_color: FloatVectorProperty(
        name="Emission Color", subtype='COLOR', size=3, default=(1.0, 0.5, 0.15), min=0.0, soft_max=1.0,
        description="Colour of the light the medium emits (not scaled by density)",
    )
    emission_strength: FloatProperty(
        name="Emission Strength", default=0.0, min=0.0, soft_max=50.0,
        description="Emitted radiance per metre, times the emission grid where the volume has it",
    )
    emission_grid: StringProperty(
        name="Emission Grid", default="flame",
        description="Grid that scales the emission strength; without it the whole volume glows",
    )

    @classmethod
    def register(cls):
        bpy.types.Volume.tfm = PointerProperty(type=cls, name="TFM", description="TFM engine settings")

    @classmethod
    def unregister(cls):
        del bpy.types.Volume.tfm


class TFM_LightSettings(bpy.types.PropertyGroup):
    """Per spot light settings (Light Data Properties)."""

    use_tfm: BoolProperty(
        name="Transmittance Map", default=True,
        description="Shadow the medium by itself along this light's rays with a transmittance map",
    )
    gobo: PointerProperty(
        name="Projected Texture", type=bpy.types.Image,
        description="Image projected by the light over the square that bounds its cone",
    )

    @classmethod
    def register(cls):
        bpy.types.Light.tfm = PointerProperty(type=cls, name="TFM", description="TFM engine settings")

    @classmethod
    def unregister(cls):
        del bpy.types.Light.tfm


def _passes_changed(self, context):
    """Tell Blender the pass list of this settings' view layer changed (the compositor's Render
    Layers node follows)."""
    try:   # 'view_layers["Name"].tfm' -> that view layer, whichever is active
        view_layer = self.id_data.path_resolve(self.path_from_id().rsplit(".", 1)[0])
    except (ValueError, AttributeError):
        view_layer = getattr(context, "view_layer", None)
    if view_layer is not None:
        view_layer.update_render_passes()


class TFM_ViewLayerSettings(bpy.types.PropertyGroup):
    """The engine's passes written for a view layer (View Layer Properties ▸ Passes)."""

    use_pass_scattering: BoolProperty(
        name="Scattering", default=True, update=_passes_changed,
        description="Light scattered toward the camera by the medium (spot lights and ambient)",
    )
    use_pass_surfaces: BoolProperty(
        name="Surfaces", default=True, update=_passes_changed,
        description="Radiance of the solids as seen through the medium",
    )
    use_pass_transmittance: BoolProperty(
        name="Transmittance", default=True, update=_passes_changed,
        description="Transmittance of the medium along each view ray, to the solid or through",
    )

    @classmethod
    def register(cls):
        bpy.types.ViewLayer.tfm = PointerProperty(type=cls, name="TFM", description="TFM engine passes")

    @classmethod
    def unregister(cls):
        del bpy.types.ViewLayer.tfm


classes = (TFM_SceneSettings, TFM_VolumeSettings, TFM_LightSettings, TFM_ViewLayerSettings)

register, unregister = bpy.utils.register_classes_factory(classes)
