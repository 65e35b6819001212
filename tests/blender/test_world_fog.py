"""Fog on the World's Volume output, as Blender users make light shafts: a spot, an occluder and
a ground in a Volume Scatter world, against Cycles (single scattering, rendered here)."""

import importlib
import math

import bpy
import numpy as np
from blender_helpers import MODULE, against_cycles

from tfm_addon import scenes
from tfm_addon.blender import scene_builder
from tfm_addon.engine import Camera, Light, RenderSettings, Scene

SETTINGS = RenderSettings(view_steps=128, light_steps=64, map_resolution=256, coefficients=8)


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


def _shaft_scene(width=96, height=54) -> Scene:
    light = Light(matrix_world=scenes.look_at((-2.0, -1.0, 4.5), (0.3, 0.2, 0.0)), power_w=3000.0,
                      spot_size_rad=math.radians(35), spot_blend=0.15)
    meshes = (scenes.box_mesh((-1.05, -0.5, 3.2), (0.15, 1.2, 0.15), name="Bar"),
              scenes.plane_mesh((0, 0, 0), 10.0))
    camera = Camera(matrix_world=scenes.look_at((5.0, -6.0, 2.5), (0.0, 0.0, 1.5)), width_px=width,
                    height_px=height, lens_mm=35.0)
    return Scene(camera=camera, lights=(light,), meshes=meshes)


def _world_fog(density: float):
    nt = bpy.context.scene.world.node_tree
    out = next(n for n in nt.nodes if n.bl_idname == 'ShaderNodeOutputWorld')
    scatter = nt.nodes.new('ShaderNodeVolumeScatter')
    scatter.inputs["Density"].default_value = density
    nt.links.new(scatter.outputs[0], out.inputs["Volume"])


def test_world_fog_light_shaft_matches_cycles(blank, tmp_path):
    scene_builder.build(_shaft_scene(), str(tmp_path), settings=SETTINGS, samples=16)
    _world_fog(0.06)
    ex = _mod("extract").extract(bpy.context.evaluated_depsgraph_get())
    fog = [m for m in ex.scene().media if m.box_to_world is None and m.density is None]
    assert len(fog) == 1 and np.allclose(fog[0].sigma_s, 0.06 * 0.8)      # Volume Scatter's colour 0.8
    ssim, ratio, cycles = against_cycles(tmp_path)
    print(f"world fog shaft: SSIM {ssim:.4f}, brightness {ratio:.4f}")
    assert float(cycles[..., :3].mean()) > 1e-3
    assert ssim >= 0.98 and abs(ratio - 1.0) <= 0.03
