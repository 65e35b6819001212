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


def _quality_changed(self, context):
    """Custom starts from what Auto chose for the scene's last final render (its steps, shadow
    steps and coefficients): the same picture at Auto's cost, to be tuned from there. Without a
    render yet, Custom keeps its own values."""
    if self.quality != 'CUSTOM':
        return
    from ..blender import final_render

    chosen = final_render.auto_choices.get(self.id_data.name)
    if chosen:
        self.view_steps = int(chosen["view_steps"])
        self.light_steps = int(chosen["light_steps"])
        self.coefficients = int(chosen["coefficients"])


class TFM_SceneSettings(bpy.types.PropertyGroup):
    """Render settings of the TFM engine (Render Properties)."""

    quality: EnumProperty(
        name="Quality",
        items=(
            ('AUTO', "Auto", "Choose the steps, shadow steps, coefficients and map sizes from the scene: "
                             "the fewest that keep the picture within SSIM 0.99 of a converged one. "
                             "The panel and the render report show what was chosen", 0),
            ('CUSTOM', "Custom", "Set the steps, shadow steps, coefficients and density weight by hand, "
                                 "starting from what Auto chose for the last render", 1),
        ),
        default='AUTO', update=_quality_changed,
        description="Who sets the volume quality: Auto from the scene, or you",
    )
    view_steps: IntProperty(
        name="Steps", default=100, min=1, soft_max=512, max=4096,
        description="Steps along each camera ray through a volume: more keeps thin wisps and sharp "
                    "shafts from banding, at a cost that grows with the steps",
    )
    light_steps: IntProperty(
        name="Shadow Steps", default=100, min=1, soft_max=512, max=4096,
        description="Steps along each light ray when the volume's shadow is computed: more keeps "
                    "small dense clumps casting their shadows into the volume",
    )
    coefficients: IntProperty(
        name="Coefficients", default=8, min=1, max=16,
        description="Detail of the volume's shadow along each light ray: more keeps shadow edges "
                    "inside the volume sharp and removes ringing, and costs memory and time",
    )
    density_weight_auto: BoolProperty(
        name="Automatic Density Weight", default=True,
        description="Choose the density weight from the thickest part of the volume as seen from "
                    "the light",
    )
    density_weight: FloatProperty(
        name="Density Weight", default=10.0, min=1.0, soft_max=100.0,
        description="Higher removes the light and dark rings that very dense volumes can show in "
                    "their shadows, and softens thin shadow detail; at least the volume's "
                    "thickness (optical depth) along the light rays",
    )
    map_resolution: IntProperty(
        name="Shadow Resolution", default=512, min=16, soft_max=2048, max=8192, subtype='PIXEL',
        description="Size of each light's shadow maps: higher gives sharper shadows of objects and "
                    "of the volume, and uses more memory. Auto uses it as the largest size",
    )
    sampling: EnumProperty(
        name="Distribution",
        items=(
            ('WORLD', "Even", "Steps evenly spaced along the camera ray", 0),
            ('PROJECTIVE', "Toward Lights", "Steps spaced as a spot light's shadow map is: denser "
                                            "near the light, where its beam is narrow and sharp", 1),
        ),
        default='WORLD',
        description="How the steps are spread along a camera ray through fog of even density",
    )
    method: EnumProperty(
        name="Volume Shadows",
        items=(
            ('TFM', "Shadow Maps", "Each light's shadow through the volume is computed once per light "
                                   "and stored in a map (fast)", 0),
            ('BRUTE_FORCE', "Ray Marched", "Each step marches toward every light: exact shadows, many "
                                           "times slower (a reference to compare with)", 1),
        ),
        default='TFM',
        description="How the shadow the volume casts on itself is computed",
    )
    tfm_filter: EnumProperty(
        name="Filter",
        items=(
            ('EXACT', "Exact", "Blend four neighbouring shadow map texels each along its own light ray: "
                               "crisper volume edges as seen from the light, slower", 0),
            ('LINEAR', "Linear", "Let the GPU blend neighbouring texels: faster, slightly softer "
                                 "volume edges as seen from the light", 1),
        ),
        default='LINEAR',
        description="How the volume's shadow maps are smoothed between texels",
    )
    ambient: BoolProperty(
        name="World Lighting", default=True,
        description="The world's colour lights the volumes and the surfaces; off, only the lights "
                    "do (the world still shows behind them)",
    )
    world_light: EnumProperty(
        name="Shadows",
        items=(
            ('SHADOWED', "Shadowed", "The world's light reaches the volumes and the surfaces through "
             "what lies in its way, as in Cycles (it comes as shadowed suns from the world's directions, "
             "carried to the volumes by a field over them)"),
            ('UNSHADOWED', "Unshadowed", "The world's light is added as is: faster, brighter inside dense "
             "smoke and under objects"),
        ),
        default='SHADOWED',
        description="Whether the world's light casts shadows, in the viewport and in final renders alike",
    )
    world_directions: IntProperty(
        name="Directions", default=16, min=4, max=128,
        description="Directions the shadowed world light comes from: more gives smoother shadows of "
                    "the sky, slower",
    )
    volume_bounces: IntProperty(
        name="Volume Bounces", default=-1, min=-1, soft_max=128, max=1024,
        description="Times light may scatter in the media (approximated from the same maps): 0 renders "
                    "single scattering; -1 reads Cycles' Light Paths > Max Bounces > Volume",
    )
    viewport_scale: FloatProperty(
        name="Viewport Resolution", default=0.5, min=0.1, max=1.0, subtype='FACTOR',
        description="Resolution of the rendered viewport relative to the viewport: lower is faster "
                    "and blurrier",
    )
    samples: IntProperty(
        name="Render Samples", default=0, min=0, soft_max=256, max=4096,
        description="Samples per pixel of a final render: more gives smoother edges and less "
                    "banding in volumes; 0 chooses 16, 1 renders each pixel's centre once",
    )
    viewport_samples: IntProperty(
        name="Viewport Samples", default=16, min=1, soft_max=256, max=4096,
        description="Samples the viewport adds up while nothing changes: more gives a smoother "
                    "image after a short wait",
    )
    strict: BoolProperty(
        name="Fail on Missing Data", default=False,
        description="Fail a final render instead of rendering without something it needs (a "
                    "missing or unreadable volume file or grid, no OpenGL): the frame is not written, "
                    "and command-line Blender exits with a non-zero code. The environment variable "
                    "TFM_STRICT=1 turns it on for every scene",
    )
    memory_budget_gb: FloatProperty(
        name="Memory Limit", default=0.0, min=0.0, soft_max=256.0, unit='NONE',
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
        description="Render the volume with its material, as Cycles does (any volume node graph). "
                    "Off, or with no material, the colours and density below are used",
    )
    sigma_a: FloatVectorProperty(
        name="Absorption Color", subtype='COLOR', size=3, default=(0.1, 0.1, 0.1), min=0.0, soft_max=1.0,
        description="Light absorbed per metre at density 1, per colour (the Principled Volume's "
                    "Absorption Color): darkens the volume and its "
                    "shadow without lighting it (soot, dark smoke)",
    )
    sigma_s: FloatVectorProperty(
        name="Color", subtype='COLOR', size=3, default=(1.0, 1.0, 1.0), min=0.0, soft_max=1.0,
        description="Light scattered per metre at density 1, per colour (the Principled Volume's "
                    "Color): how brightly the volume "
                    "is lit and how much it dims the light behind it (white smoke, fog, clouds)",
    )
    density_scale: FloatProperty(
        name="Density Scale", default=1.0, min=0.0, soft_max=100.0,
        description="Multiplies the Color and Absorption Color above, as the Principled Volume's "
                    "Density does: thicker or thinner volume",
    )
    anisotropy: FloatProperty(
        name="Anisotropy", default=0.0, min=-0.99, max=0.99, subtype='FACTOR',
        description="Direction light scatters in: positive sends it on forward (bright when looking "
                    "toward the light, as in fog), negative back toward the light",
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
    """Per light settings (Light Data Properties ▸ Light)."""

    use_tfm: BoolProperty(
        name="Volume Shadow", default=True,
        description="Volumes shadow this light: their dense parts darken the light behind them, "
                    "as in Cycles. Off, the light crosses every volume undimmed (faster, flatter)",
    )
    gobo: PointerProperty(
        name="Projected Texture", type=bpy.types.Image,
        description="Image the spot light projects, like a slide in a projector: its colours tint "
                    "the beam over the square that bounds the cone",
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
