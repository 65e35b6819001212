"""Sun, point and area lights and several volumes against Cycles (single scattering, BLENDER.md
settings), 160x90: the scene is written into Blender by scene_builder and rendered by both engines
through bpy.ops.render.render()."""

import dataclasses
import math
import time

import bpy
import numpy as np
import pytest
from blender_helpers import render_passes

from tfm_addon.blender import scene_builder
from tfm_addon.engine import Camera, Light, Medium, RenderSettings, Scene, metrics
from tfm_addon.scenes import box_mesh, grid_to_world, look_at, plane_mesh, smoke_density, translate_scale

SETTINGS = RenderSettings(view_steps=128, light_steps=128, map_resolution=256, coefficients=16)
CYCLES_SAMPLES = 512
N = 32


def _camera():
    return Camera(matrix_world=look_at((0.0, -6.5, 1.6), (0, 0, 1.1)), width_px=160, height_px=90,
                  lens_mm=40.0)


def _smoke(center=(0, 0, 1.2), size=2.0, sigma_s=2.0, sigma_a=0.2, g=0.0, seed=1, name="Smoke"):
    d = smoke_density(N, seed=seed)
    return Medium(sigma_a=(sigma_a,) * 3, sigma_s=(sigma_s,) * 3, anisotropy=g, density=d,
                  index_to_world=grid_to_world(d.shape, size, center), name=name)


def _ground():
    return plane_mesh((0, 0, 0), 8.0)


def _sun(strength=3.0):
    return Light(matrix_world=look_at((-3.0, -1.0, 5.0), (0, 0, 1.0)), power_w=strength, kind="SUN",
                 name="Sun")


def _scenes():
    spot = Light(matrix_world=look_at((-2.5, -1.0, 4.0), (0, 0, 1.0)), power_w=2000.0,
                 spot_size_rad=math.radians(45), spot_blend=0.2, name="Spot")
    turned = translate_scale((0.5, 0.2, 1.4), 1.0)
    turned[:3, :3] = np.array([[0.8, -0.6, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]]) * 0.8
    shape = (N, N, N)
    b = Medium(sigma_a=(0.6,) * 3, sigma_s=(4.0,) * 3, anisotropy=0.5, density=smoke_density(N, seed=5),
               index_to_world=turned @ grid_to_world(shape, 2.0, (0, 0, 0)), name="B")
    copies = tuple(dataclasses.replace(_smoke(size=1.2), name=f"Copy{i}",
                                       index_to_world=grid_to_world(shape, 1.2, (x, 0, 1.0)))
                   for i, x in enumerate((-1.4, 0.0, 1.4)))
    return {
        "sun_shaft": Scene(camera=_camera(), lights=(_sun(),), media=(_smoke(),),
                           meshes=(box_mesh((-1.2, -0.4, 3.2), (0.15, 1.2, 0.15), name="Bar"), _ground())),
        "point_inside": Scene(camera=_camera(), media=(_smoke(sigma_s=1.0, sigma_a=0.1),),
                              lights=(Light(matrix_world=translate_scale((0.3, 0.0, 1.3), 1.0), power_w=400.0,
                                            kind="POINT", name="Point"),),
                              meshes=(_ground(),)),
        "two_overlapping": Scene(camera=_camera(), lights=(spot,),
                                 media=(_smoke(center=(-0.4, 0, 1.2), name="A"), b), meshes=(_ground(),)),
        "instanced_three": Scene(camera=_camera(), lights=(_sun(),), media=copies, meshes=(_ground(),)),
        "area": Scene(camera=_camera(), lights=(Light(matrix_world=look_at((-1.5, -1.5, 3.5), (0, 0, 1.0)),
                                                      power_w=1500.0, kind="AREA", size_m=(0.5, 0.5),
                                                      name="Area"),),
                      media=(_smoke(),), meshes=(_ground(),)),
    }


# (SSIM at least, brightness ratio within): the bars; the area light is an approximation
# whose tolerance docs/benchmark.md states ("Measurements behind design choices").
LIMITS = {"sun_shaft": (0.98, 0.03), "point_inside": (0.98, 0.03), "two_overlapping": (0.98, 0.03),
          "instanced_three": (0.98, 0.03), "area": (0.97, 0.10)}


@pytest.mark.parametrize("case", list(LIMITS))
def test_lights_and_volumes_agree_with_cycles(blank, tmp_path, case):
    scene = _scenes()[case]
    made = scene_builder.build(scene, str(tmp_path), settings=SETTINGS)
    assert len(made["media"]) == len(scene.media)
    if case == "instanced_three":
        assert len({ob.data.name for ob in made["media"]}) == 1      # one Volume data, three objects
    tfm = render_passes(tmp_path, "tfm")["Combined"]
    scene_builder.cycles_single_scattering(bpy.context.scene, samples=CYCLES_SAMPLES)
    t0 = time.perf_counter()
    cycles = render_passes(tmp_path, "cycles")["Combined"]
    seconds = time.perf_counter() - t0
    ssim, ratio = metrics.ssim(tfm, cycles), metrics.brightness_ratio(tfm, cycles)
    print(f"{case}: TFM vs Cycles ({CYCLES_SAMPLES} spp, {seconds:.1f} s): SSIM {ssim:.4f}, brightness "
          f"ratio {ratio:.4f}, PSNR {metrics.psnr(tfm, cycles):.1f} dB")
    min_ssim, tolerance = LIMITS[case]
    assert ssim >= min_ssim
    assert abs(ratio - 1.0) <= tolerance
