"""Several volumes through the add-on's viewport session: moving one volume rebuilds only the map
of the light that reaches it, and reads no grid again (counters of the add-on's worker)."""

import importlib
import math

import bpy
from blender_helpers import MODULE, SETTINGS

from tfm_addon.blender import scene_builder
from tfm_addon.engine import Camera, Light, Medium, Scene
from tfm_addon.scenes import grid_to_world, look_at, smoke_density


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


def _delta(before, after, key):
    return after.get(key, 0) - before.get(key, 0)


def test_moving_one_volume_rebuilds_only_the_map_of_the_light_reaching_it(blank, tmp_path):
    media = tuple(Medium(sigma_a=(0.2,) * 3, sigma_s=(2.0,) * 3, density=smoke_density(16, seed=s),
                         index_to_world=grid_to_world((16, 16, 16), 1.5, (x, 0.0, 1.2)), name=n)
                  for s, x, n in ((1, -2.0, "L"), (4, 2.0, "R")))
    lights = tuple(Light(matrix_world=look_at((x, 0.0, 4.5), (x, 0.0, 1.2)), spot_size_rad=math.radians(30),
                         name=n) for x, n in ((-2.0, "SpotL"), (2.0, "SpotR")))
    camera = Camera(matrix_world=look_at((0.0, -8.0, 1.6), (0, 0, 1.2)), width_px=48, height_px=27)
    made = scene_builder.build(Scene(camera=camera, lights=lights, media=media), str(tmp_path),
                                       settings=SETTINGS)
    worker = _mod("render_worker").get_worker()
    session = _mod("viewport").ViewportSession()
    session.update(bpy.context.evaluated_depsgraph_get())
    assert len(session.extraction.media) == 2
    view = session.extraction.camera
    session.render(view)

    made["media"][1].location.z += 0.3       # what the depsgraph flags as MEDIUM (test_viewport.py)
    bpy.context.view_layer.update()
    session.update(bpy.context.evaluated_depsgraph_get(), _mod("changes").Change.MEDIUM)
    before = dict(worker.counters)
    session.render(view)
    after = dict(worker.counters)
    assert _delta(before, after, "tfms") == 1          # SpotR's; SpotL's map is reused
    assert _delta(before, after, "grid_uploads") == 0  # the grids did not change, only a placement
