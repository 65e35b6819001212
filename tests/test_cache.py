"""What the renderer rebuilds, and what it must not: read from its counters."""

import dataclasses
import math

import numpy as np
from references import render_reference

from tfm_addon.engine import Camera, Light, Medium, RenderSettings, Scene
from tfm_addon.engine.metrics import ssim
from tfm_addon.scenes import look_at, smoke_scene

SETTINGS = RenderSettings(view_steps=48, light_steps=48, map_resolution=128)


replace = dataclasses.replace


def built(renderer, scene, settings=SETTINGS):
    before = dict(renderer.counters)
    out = renderer.render(scene, settings)
    return {k: renderer.counters[k] - before.get(k, 0) for k in renderer.counters}, out


def test_first_render_builds_each_map_once(fresh):
    delta, _ = built(fresh, smoke_scene(width=48, height=32, n=32))
    assert delta["shadow_maps"] == 1 and delta["tfms"] == 1 and delta["gbuffers"] == 1
    assert delta["grid_uploads"] == 1


def test_camera_move_reuses_the_light_maps(fresh):
    scene = smoke_scene(width=48, height=32, n=32)
    built(fresh, scene)
    moved = replace(scene, camera=replace(scene.camera, matrix_world=look_at((1.0, -6.0, 2.0), (0, 0, 1))))
    delta, _ = built(fresh, moved)
    assert delta.get("shadow_maps", 0) == 0 and delta.get("tfms", 0) == 0
    assert delta.get("grid_uploads", 0) == 0
    assert delta["gbuffers"] == 1


def test_sigma_change_rebuilds_nothing_light_side_and_changes_the_image(fresh):
    scene = smoke_scene(width=48, height=32, n=32)
    _, first = built(fresh, scene)
    redder = replace(scene, media=(replace(scene.media[0], sigma_s=(3.0, 1.0, 0.5)),))
    delta, second = built(fresh, redder)
    assert sum(delta.get(k, 0) for k in ("shadow_maps", "tfms", "gbuffers", "grid_uploads")) == 0
    assert not np.allclose(first.rgb, second.rgb)
    # ... and the recoloured image is right, not a stale one.
    ref = render_reference(redder, view_steps=48, light_steps=48)
    assert ssim(second.rgb, ref.rgb) >= 0.98


def test_fixed_density_weight_ties_the_map_to_sigma(fresh):
    settings = dataclasses.replace(SETTINGS, density_weight=4.0)
    scene = smoke_scene(width=48, height=32, n=32)
    built(fresh, scene, settings)
    denser = replace(scene, media=(replace(scene.media[0], sigma_s=(6.0, 6.0, 6.0)),))
    delta, _ = built(fresh, denser, settings)
    assert delta["tfms"] == 1 and delta.get("shadow_maps", 0) == 0


def test_light_move_rebuilds_only_that_light(fresh):
    scene = smoke_scene(width=48, height=32, n=32)
    second = Light(matrix_world=look_at((2.5, -1.0, 4.0), (0, 0, 1.0)), power_w=1500.0,
                       spot_size_rad=math.radians(35))
    scene = replace(scene, lights=(scene.lights[0], second))
    delta, _ = built(fresh, scene)
    assert delta["tfms"] == 2 and delta["shadow_maps"] == 2
    moved = replace(second, matrix_world=look_at((2.0, -1.5, 4.0), (0, 0, 1.0)))
    delta, _ = built(fresh, replace(scene, lights=(scene.lights[0], moved)))
    assert delta["tfms"] == 1 and delta["shadow_maps"] == 1 and delta.get("gbuffers", 0) == 0
    # Colour and power are not in the maps.
    brighter = replace(moved, power_w=3000.0, color=(1.0, 0.5, 0.2))
    delta, _ = built(fresh, replace(scene, lights=(scene.lights[0], brighter)))
    assert delta.get("tfms", 0) == 0 and delta.get("shadow_maps", 0) == 0


def test_solids_change_rebuilds_shadow_maps_and_tfms(fresh):
    scene = smoke_scene(width=48, height=32, n=32)
    built(fresh, scene)
    without_bar = replace(scene, meshes=scene.meshes[1:])
    delta, _ = built(fresh, without_bar)
    assert delta["shadow_maps"] == 1 and delta["tfms"] == 1 and delta["gbuffers"] == 1


def test_light_missing_the_medium_gets_no_tfm_but_still_lights_surfaces(fresh):
    scene = smoke_scene(width=64, height=48, n=32)
    away = Light(matrix_world=look_at((3.0, 2.0, 3.0), (3.5, 3.0, 0.0)), power_w=1500.0,
                     spot_size_rad=math.radians(30))
    scene = replace(scene, lights=(scene.lights[0], away))
    delta, out = built(fresh, scene)
    assert delta["tfms"] == 1, "only the light whose cone meets the medium gets a TFM"
    assert delta["shadow_maps"] == 2
    ref = render_reference(scene, view_steps=48, light_steps=48)
    assert ssim(out.rgb, ref.rgb) >= 0.98


def test_scene_without_solids_builds_no_shadow_map(fresh):
    scene = smoke_scene(width=48, height=32, n=32, with_bar=False, with_ground=False)
    delta, _ = built(fresh, scene)
    assert delta.get("shadow_maps", 0) == 0 and delta["tfms"] == 1


def test_homogeneous_medium_builds_no_tfm(fresh):
    cam = Camera(matrix_world=look_at((0, -5, 1), (0, 0, 1)), width_px=32, height_px=24)
    light = Light(matrix_world=look_at((-2, -2, 3), (0, 0, 1)))
    delta, _ = built(fresh, Scene(camera=cam, lights=(light,), media=(Medium(box_to_world=np.eye(4)),)))
    assert delta.get("tfms", 0) == 0 and delta.get("grid_uploads", 0) == 0
