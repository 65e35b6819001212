"""The numpy reference lights with the world as Cycles does (its radiance from every direction,
attenuated by the media and the solids that way), against stored Cycles references
(scripts/make_world_reference.py: a homogeneous box over a ground lit only by a white world or an
equirectangular sky, single scattering, 40x30, Cycles' 1-pixel box filter); then it judges the
engine's shadowed world light. Both render 2x2 points a pixel, averaged (the box filter: at one
point a pixel the box's and the horizon's aliased edges alone held SSIM to 0.976)."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from tfm_addon import scenes
from tfm_addon.engine import RenderSettings
from tfm_addon.engine.metrics import brightness_ratio, ssim
from tfm_addon.engine.reference import render_reference

DATA = Path(__file__).parent / "data"


def _box_filtered(image: np.ndarray) -> np.ndarray:
    h, w = image.shape[0] // 2, image.shape[1] // 2
    return image[..., :3].reshape(h, 2, w, 2, 3).mean(axis=(1, 3))


@pytest.fixture(scope="module", params=["white", "sky"])
def case(request):
    """(scene at 2x2 points a pixel, its Cycles image, the reference's shadowed world light)."""
    env = None if request.param == "white" else scenes.sky_environment()
    scene = scenes.world_lit_box_scene(environment=env)
    scene = dataclasses.replace(scene, camera=dataclasses.replace(scene.camera, width_px=80, height_px=60))
    with np.load(DATA / f"world_reference_{request.param}.npz") as z:
        cycles = z["rgb"].astype(np.float32)
    ref = render_reference(scene, RenderSettings(world_light="SHADOWED"), view_steps=16, light_steps=4,
                           world_directions=256)
    return scene, cycles, _box_filtered(ref.rgb)


def test_reference_world_light_matches_cycles(case):
    scene, cycles, ref = case
    s, b = ssim(ref, cycles), brightness_ratio(ref, cycles)
    print(f"SSIM {s:.4f}, brightness {b:.4f}")
    assert s >= 0.98 and abs(b - 1.0) <= 0.03, (s, b)
    # the world's light added unshadowed (the engine's fast mode) is not what Cycles renders
    flat = _box_filtered(render_reference(scene, RenderSettings(), view_steps=16, light_steps=4).rgb)
    assert ssim(flat, cycles) < s - 0.01 or abs(brightness_ratio(flat, cycles) - 1.0) > 0.05


def test_reference_judges_the_engine_s_world_light(renderer, case):
    scene, cycles, ref = case
    out = renderer.render(scene, RenderSettings(world_light="SHADOWED", view_steps=32, light_steps=32,
                                                coefficients=8, map_resolution=128))
    s, b = ssim(_box_filtered(out.rgb), ref), brightness_ratio(_box_filtered(out.rgb), ref)
    print(f"SSIM {s:.4f}, brightness {b:.4f}")
    assert s >= 0.98 and abs(b - 1.0) <= 0.03, (s, b)
