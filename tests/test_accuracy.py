"""The renderer's images against the numpy double march (tfm_addon.engine.reference), which
shares no code with the GPU path. Metrics follow tfm_addon.engine.metrics (reference second)."""

import math

import numpy as np
import pytest
from references import render_reference

from tfm_addon.engine import Camera, Light, Medium, RenderSettings, Scene
from tfm_addon.engine.metrics import brightness_ratio, psnr, ssim
from tfm_addon.scenes import (
    grid_to_world,
    homogeneous_box_scene,
    look_at,
    smoke_density,
    smoke_scene,
    stripes_gobo,
)

STEPS = dict(view_steps=128, light_steps=128)


@pytest.fixture(scope="module")
def smoke():
    scene = smoke_scene(width=96, height=64, n=64)
    return scene, render_reference(scene, **STEPS)


def test_tfm_matches_reference_on_smoke(renderer, smoke):
    scene, ref = smoke
    out = renderer.render(scene, RenderSettings(coefficients=8, map_resolution=256, **STEPS))
    assert ssim(out.rgb, ref.rgb) >= 0.99
    assert abs(brightness_ratio(out.rgb, ref.rgb) - 1) <= 0.02
    # The bar's shadow crosses the smoke: the scattering pass must carry it too.
    assert ssim(out.passes["scattering"], ref.passes["scattering"]) >= 0.99
    assert np.allclose(out.passes["transmittance"], ref.passes["transmittance"], atol=2e-3)


def test_brute_force_matches_reference_on_smoke(renderer, smoke):
    scene, ref = smoke
    out = renderer.render(scene, RenderSettings(method="BRUTE_FORCE", map_resolution=256, **STEPS))
    assert ssim(out.rgb, ref.rgb) >= 0.995
    assert abs(brightness_ratio(out.rgb, ref.rgb) - 1) <= 0.02


def test_homogeneous_analytic_matches_reference(renderer):
    scene = homogeneous_box_scene(width=96, height=64, ambient=(0.02, 0.02, 0.03))
    ref = render_reference(scene, view_steps=256, light_steps=32)
    before = renderer.counters["tfms"]
    out = renderer.render(scene, RenderSettings(view_steps=128, map_resolution=512))
    assert renderer.counters["tfms"] == before, "a homogeneous medium needs no TFM"
    assert ssim(out.rgb, ref.rgb) >= 0.995
    assert abs(brightness_ratio(out.rgb, ref.rgb) - 1) <= 0.01


@pytest.mark.parametrize("eye", [(-0.6, -3.6, 4.2), (3.5, -5.0, 2.5)], ids=["collinear", "side"])
def test_projective_sampling_beats_world_sampling_under_a_gobo(renderer, eye):
    """Paper Fig. 5: a box lit through high-frequency rings; 16 samples per ray, against a
    1000-sample render."""
    scene = homogeneous_box_scene(gobo=stripes_gobo(64, 4), camera_eye=eye, with_bar=False)
    ref = renderer.render(scene, RenderSettings(view_steps=1000, map_resolution=512)).rgb

    def rmse(sampling):
        img = renderer.render(scene, RenderSettings(view_steps=16, sampling=sampling, map_resolution=512)).rgb
        return float(np.sqrt(((img - ref) ** 2).mean()))

    world, projective = rmse("WORLD"), rmse("PROJECTIVE")
    assert projective < 0.6 * world, (projective, world)


def test_density_weighting_reduces_the_error_of_a_thick_medium(renderer):
    """Optical depth ~50 along the light rays: with 4 coefficients and no weighting (alpha = 1)
    the truncated series rings and the display-space squared error is at least 5x (7 dB) that
    of the automatic alpha; no reconstructed transmittance leaves [0, 1]."""
    scene = smoke_scene(width=96, height=64, n=64, sigma_s=(60.0,) * 3, sigma_a=(6.0,) * 3,
                        with_bar=False)
    ref = render_reference(scene, **STEPS)

    def render(alpha):
        return renderer.render(scene, RenderSettings(coefficients=4, density_weight=alpha,
                                                     map_resolution=256, **STEPS))

    plain, weighted = render(1.0), render(None)
    assert psnr(weighted.rgb, ref.rgb) >= psnr(plain.rgb, ref.rgb) + 7.0
    assert ssim(weighted.rgb, ref.rgb) >= 0.99

    rng = np.random.default_rng(0)
    idx = rng.uniform(-1, 64, (4000, 3))
    points = (np.c_[idx, np.ones(len(idx))] @ scene.media[0].index_to_world.T)[:, :3]
    for alpha in (1.0, None):
        t = renderer.light_transmittance_at(scene, RenderSettings(coefficients=4, density_weight=alpha,
                                                                  map_resolution=256), 0, points)
        assert np.isfinite(t).all()
        assert t.min() >= 0.0 and t.max() <= 1.0


def _inside_scene(camera_eye, camera_target, light_eye, light_target, g=0.0, size=(64, 48)):
    n = 40
    medium = Medium(sigma_a=(0.1, 0.1, 0.1), sigma_s=(1.2, 1.0, 0.8), anisotropy=g,
                    density=0.3 + 0.7 * smoke_density(n, seed=3),
                    index_to_world=grid_to_world((n, n, n), 4.0, (0, 0, 0)))
    light = Light(matrix_world=look_at(light_eye, light_target), power_w=800.0,
                      spot_size_rad=math.radians(50), spot_blend=0.3)
    camera = Camera(matrix_world=look_at(camera_eye, camera_target), width_px=size[0], height_px=size[1],
                    lens_mm=30.0, clip_start=0.05)
    return Scene(camera=camera, lights=(light,), media=(medium,))


@pytest.mark.parametrize("case", ["light_inside", "camera_inside", "looking_at_light"])
def test_hard_configurations_match_reference(renderer, case):
    if case == "light_inside":
        scene = _inside_scene((0.5, -6.0, 0.5), (0, 0, 0), (0.3, 0.2, 0.5), (0, 0, -3))
    elif case == "camera_inside":
        scene = _inside_scene((0.2, -0.8, 0.1), (0, 2, 0), (-3.0, -3.0, 3.0), (0, 0, 0))
    else:  # the light shines toward the camera, which sees it through the medium
        scene = _inside_scene((0.0, -5.0, 0.3), (0, 0, 0), (0.0, 3.0, 0.0), (0, -5, 0.3), g=0.6)
    ref = render_reference(scene, **STEPS)
    out = renderer.render(scene, RenderSettings(coefficients=8, map_resolution=256, **STEPS))
    assert np.isfinite(out.combined).all()
    assert ssim(out.rgb, ref.rgb) >= 0.985, case
    assert abs(brightness_ratio(out.rgb, ref.rgb) - 1) <= 0.03, case


def test_camera_projections_match_reference(renderer):
    """Orthographic, shifted and vertically fitted cameras see the same pixels as the reference."""
    base = homogeneous_box_scene(width=64, height=48)
    eye = look_at((3.5, -5.0, 2.5), (0, 0, 1.2))
    cameras = [
        Camera(matrix_world=eye, width_px=64, height_px=48, projection="ORTHO", ortho_scale=7.0),
        Camera(matrix_world=eye, width_px=48, height_px=64, lens_mm=30.0, sensor_fit="VERTICAL",
               sensor_height_mm=30.0, shift_x=0.1, shift_y=-0.05),
    ]
    for cam in cameras:
        scene = Scene(camera=cam, lights=base.lights, media=(base.media[0],), meshes=base.meshes)
        ref = render_reference(scene, view_steps=128, light_steps=16)
        out = renderer.render(scene, RenderSettings(view_steps=128, map_resolution=512))
        assert ssim(out.rgb, ref.rgb) >= 0.99, cam.projection
        assert psnr(out.rgb, ref.rgb) >= 30.0, cam.projection


def test_render_border_is_the_matching_crop(renderer):
    scene = homogeneous_box_scene(width=64, height=48)
    full = renderer.render(scene, RenderSettings(view_steps=64)).combined
    cam = scene.camera
    bordered = Camera(**{**{f: getattr(cam, f) for f in cam.__dataclass_fields__},
                         "border": (0.25, 0.5, 0.75, 1.0)})
    crop = renderer.render(Scene(camera=bordered, lights=scene.lights, media=(scene.media[0],),
                                 meshes=scene.meshes), RenderSettings(view_steps=64)).combined
    assert crop.shape == (24, 32, 4)
    # y up in Blender's border: (0.5, 1.0) is the top half, rows 0..23 of a top-first array.
    np.testing.assert_allclose(crop, full[0:24, 16:48], atol=1e-5)


def test_fog_filling_the_scene_with_two_spots_matches_reference(renderer):
    """Homogeneous fog everywhere (bounded by the camera's clip range), forward scattering,
    two spot lights (one through a gobo), a solid: the analytic path against the reference."""
    base = homogeneous_box_scene(width=64, height=48)
    fog = Medium(sigma_a=(0.01, 0.01, 0.01), sigma_s=(0.08, 0.06, 0.05), anisotropy=0.5)
    second = Light(matrix_world=look_at((3.0, -2.0, 3.5), (0.5, 0.5, 0.0)), power_w=1500.0,
                       color=(1.0, 0.6, 0.3), spot_size_rad=math.radians(30), spot_blend=0.4,
                       gobo=stripes_gobo(32, 8))
    cam = Camera(matrix_world=look_at((3.5, -5.0, 2.5), (0, 0, 1.2)), width_px=64, height_px=48,
                 lens_mm=35.0, clip_end=20.0)
    scene = Scene(camera=cam, lights=(base.lights[0], second), media=(fog,), meshes=base.meshes)
    ref = render_reference(scene, view_steps=512, light_steps=8)
    out = renderer.render(scene, RenderSettings(view_steps=256, map_resolution=512))
    assert ssim(out.rgb, ref.rgb) >= 0.99
    assert abs(brightness_ratio(out.rgb, ref.rgb) - 1) <= 0.02


def test_auto_quality_is_what_the_renderer_uses_and_reaches_ssim_099(renderer, smoke):
    from tfm_addon.engine.quality import auto_settings

    scene, ref = smoke
    auto = renderer.render(scene, RenderSettings(quality="AUTO", map_resolution=256))
    chosen = auto_settings(scene, RenderSettings(map_resolution=256))
    explicit = renderer.render(scene, chosen)
    np.testing.assert_array_equal(auto.combined, explicit.combined)
    assert chosen.density_weight is None and 1 <= chosen.coefficients <= 16
    assert ssim(auto.rgb, ref.rgb) >= 0.99


def test_auto_summarises_a_grid_once_whatever_its_placement():
    """Moving a volume redoes AUTO's light part only: the grid's summary (cleaning, coarse copy,
    sharpness, bounds) is the content's (it was keyed by the placement: ~45 ms per move at 128^3)."""
    import dataclasses

    from tfm_addon.engine import quality
    from tfm_addon.scenes import smoke_scene

    scene = smoke_scene(width=32, height=18, n=24)
    quality._cache.clear()
    quality.auto_settings(scene)
    placed = scene.media[0].index_to_world.copy()
    for dx in (0.1, 0.2):
        placed[0, 3] += dx
        medium = dataclasses.replace(scene.media[0], index_to_world=placed.copy())
        quality.auto_settings(dataclasses.replace(scene, media=(medium,)))
    assert sum(k[0] == "grid" for k in quality._cache.keys()) == 1
    assert sum(k[0] == "light" for k in quality._cache.keys()) == 3      # the light part per placement
