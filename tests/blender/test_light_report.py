"""Lights as Cycles reads them, and what the report says about them: an area light with Normalize
off (its power grows with its area; against Cycles), and no report line for the lights' sizes."""

import dataclasses
import importlib

import bpy
import pytest
from blender_helpers import MODULE, against_cycles, smoke

from tfm_addon import scenes
from tfm_addon.blender import scene_builder
from tfm_addon.engine import Light, RenderSettings

SETTINGS = RenderSettings(view_steps=96, light_steps=64, map_resolution=192, coefficients=12)


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


def test_area_light_without_normalize_matches_cycles(blank, tmp_path):
    scene = smoke(width=64, height=48, n=24, with_bar=False)    # no shadow for its size to soften
    area = Light(matrix_world=scenes.look_at((-2.5, -1.0, 4.5), (0.0, 0.0, 1.2)), kind="AREA", power_w=400.0,
                 size_m=(1.5, 1.5), name="Panel")
    made = scene_builder.build(dataclasses.replace(scene, lights=(area,)), str(tmp_path),
                                       settings=SETTINGS, samples=16)
    made["lights"][0].data.normalize = False
    ssim, ratio, cycles = against_cycles(tmp_path)
    print(f"area 1.5 x 1.5 m, Normalize off: SSIM {ssim:.4f}, brightness {ratio:.4f}")
    assert ssim >= 0.98 and abs(ratio - 1.0) <= 0.03     # its shape's emission (measured 0.9993, 1.005)


def test_default_lights_say_nothing(blank):
    """Lights as the Add menu makes them (a radius, a sun's angle, an area's size) render with soft
    shadows: no report line."""
    for kind in ('SPOT', 'POINT', 'SUN', 'AREA'):
        bpy.ops.object.light_add(type=kind)
    ex = _mod("extract").extract(bpy.context.evaluated_depsgraph_get())
    assert ex.all_warnings == [], ex.all_warnings
    assert {light.kind for light in ex.lights} == {'SPOT', 'POINT', 'SUN', 'AREA'}


@pytest.mark.parametrize("flag", ["visible_volume_scatter", "visible_diffuse"])
def test_light_ray_visibility_matches_cycles(blank, tmp_path, flag):
    """A spot whose Ray Visibility ▸ Volume Scatter is off lights the ground but not the smoke; with
    Diffuse off, the smoke but not the ground (Cycles' light visibility)."""
    made = scene_builder.build(smoke(width=64, height=48, n=24), str(tmp_path), settings=SETTINGS,
                               samples=16)
    setattr(made["lights"][0], flag, False)
    ssim, ratio, cycles = against_cycles(tmp_path)
    print(f"spot with {flag} off: SSIM {ssim:.4f}, brightness {ratio:.4f}")
    assert float(cycles[..., :3].mean()) > 1e-3
    assert ssim >= 0.98 and abs(ratio - 1.0) <= 0.03


def test_light_linking_is_read(blank):
    """A receiver collection that excludes every solid darkens the surfaces for that light; one that
    includes one solid leaves the other unlit; a blocker collection (shadow linking) that excludes
    one solid leaves the other shadowing the light."""
    bpy.ops.object.light_add(type='SPOT')
    spot = bpy.context.object
    solids = []
    for x in (-2.0, 2.0):
        bpy.ops.mesh.primitive_cube_add(location=(x, 0.0, 0.0))
        solids.append(bpy.context.object)
    receivers = bpy.data.collections.new("Lit")
    for ob in solids:
        receivers.objects.link(ob)
    spot.light_linking.receiver_collection = receivers
    for entry in receivers.collection_objects:
        entry.light_linking.link_state = 'EXCLUDE'
    ex = _mod("extract").extract(bpy.context.evaluated_depsgraph_get())
    assert ex.lights[0].lights_surfaces is False and ex.lights[0].lights_medium is True
    assert not any("linking" in w for w in ex.all_warnings), ex.all_warnings
    receivers.collection_objects[0].light_linking.link_state = 'INCLUDE'
    blockers = bpy.data.collections.new("Blockers")
    spot.light_linking.blocker_collection = blockers
    ex = _mod("extract").extract(bpy.context.evaluated_depsgraph_get())
    assert ex.lights[0].lights_surfaces is True
    assert ex.lights[0].unlit_solids == (solids[1].name,)     # the included cube alone is lit
    assert not any("linking" in w for w in ex.all_warnings), ex.all_warnings
    assert ex.lights[0].shadow_solids is None        # an empty blocker collection: everything shadows
    blockers.objects.link(solids[0])
    blockers.collection_objects[0].light_linking.link_state = 'EXCLUDE'
    ex = _mod("extract").extract(bpy.context.evaluated_depsgraph_get())
    assert ex.lights[0].shadow_solids == (solids[1].name,) and ex.lights[0].media_shadow_surfaces
    assert not any("shadow linking" in w for w in ex.all_warnings), ex.all_warnings
