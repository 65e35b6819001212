"""Soft shadows from a light's size: a sun's penumbra on the ground against the geometry of its disk
(independent math), an area light's irradiance against its rectangle, and a size edit that
rebuilds no map (counters)."""

import dataclasses
import math

import numpy as np
import pytest

from tfm_addon.engine import Camera, Light, Medium, RenderSettings, Scene
from tfm_addon.engine.sampling import render_samples
from tfm_addon.scenes import box_mesh, grid_to_world, look_at, plane_mesh, smoke_density

BAR_WIDTH, BAR_HEIGHT = 0.1, 1.0     # metres: a bar along y, its centre above the ground at x = 0
HALF_ANGLE = math.radians(5.0)       # the sun's angular radius (Blender's angle 10 degrees)
VIEW = 1.0                           # metres of ground the orthographic camera sees across


def _disk_below(u: np.ndarray) -> np.ndarray:
    """The fraction of the unit disk's area at first coordinate below ``u``."""
    u = np.clip(u, -1.0, 1.0)
    return (u * np.sqrt(1.0 - u * u) + np.arcsin(u)) / np.pi + 0.5


def _sun_scene(angle: float) -> Scene:
    camera = Camera(matrix_world=look_at((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0)),
                    width_px=64, height_px=8, projection="ORTHO", ortho_scale=VIEW)
    bar = dataclasses.replace(box_mesh((0.0, 0.0, BAR_HEIGHT), (BAR_WIDTH, 3.0, 0.02), name="Bar"),
                              visible_camera=False)      # the camera looks at the ground through it
    sun = Light(matrix_world=look_at((0.0, 0.0, 10.0), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0)), kind="SUN",
                power_w=np.pi, angle_rad=angle, name="Sun")
    ground = plane_mesh((0.0, 0.0, 0.0), 4.0, color=(1, 1, 1))
    return Scene(camera=camera, lights=(sun,), meshes=(bar, ground))


def test_sun_penumbra_follows_its_disk(renderer):
    """The ground's brightness across the bar's shadow is the part of the sun's disk the bar leaves
    visible (the albedo 1 and E = pi make a fully lit ground 1): within 0.03 on average and 0.08 at
    any pixel; the sharp shadow (angle 0) misses that by far."""
    x = ((np.arange(64) + 0.5) / 64 - 0.5) * VIEW
    reach = (BAR_HEIGHT - 0.01) * math.tan(HALF_ANGLE)    # the bar's underside
    expected = 1.0 - (_disk_below((BAR_WIDTH / 2 - x) / reach) - _disk_below((-BAR_WIDTH / 2 - x) / reach))
    settings = RenderSettings(map_resolution=512)
    profiles = {}
    for angle in (2 * HALF_ANGLE, 0.0):
        out = render_samples(renderer, _sun_scene(angle), settings, 16, adaptive_threshold=None)
        profiles[angle] = out.rgb[..., 0].mean(axis=0)
    soft = profiles[2 * HALF_ANGLE]
    err = np.abs(soft - expected)
    print(f"sun penumbra: mean error {err.mean():.4f}, largest {err.max():.4f}; sharp shadow's mean error "
          f"{np.abs(profiles[0.0] - expected).mean():.4f}")
    assert err.mean() <= 0.03 and err.max() <= 0.08, (err.mean(), err.max())
    assert np.abs(profiles[0.0] - expected).mean() > 0.05


def test_point_light_penumbra_follows_its_sphere(renderer):
    """A point light of radius 0.3 m, 3 m above the ground, past the bar: the ground's brightness
    over its brightness without the bar is the part of the light's disk (seen from below) the bar
    leaves visible: within 0.03 on average and 0.1 at any pixel."""
    radius, height = 0.3, 3.0
    x = ((np.arange(64) + 0.5) / 64 - 0.5) * VIEW
    # Light points (lateral offset e) whose ray to the ground point x crosses the bar's underside.
    h = BAR_HEIGHT - 0.01
    e_lo, e_hi = x + (-BAR_WIDTH / 2 - x) * height / h, x + (BAR_WIDTH / 2 - x) * height / h
    expected = 1.0 - (_disk_below(e_hi / radius) - _disk_below(e_lo / radius))
    scene = _sun_scene(0.0)
    point = Light(matrix_world=look_at((0.0, 0.0, height), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0)), kind="POINT",
                  power_w=1000.0, radius_m=radius, name="Point")
    settings = RenderSettings(map_resolution=512)
    lit = render_samples(renderer, dataclasses.replace(scene, lights=(point,)), settings, 16,
                         adaptive_threshold=None).rgb[..., 0].mean(axis=0)
    bare = render_samples(renderer, dataclasses.replace(scene, lights=(point,), meshes=scene.meshes[1:]),
                          settings, 1).rgb[..., 0].mean(axis=0)
    err = np.abs(lit / bare - expected)
    print(f"point light penumbra: mean error {err.mean():.4f}, largest {err.max():.4f}")
    assert err.mean() <= 0.03 and err.max() <= 0.1, (err.mean(), err.max())


def test_size_edit_rebuilds_no_map(renderer):
    """An area light's size, a spot's radius and a sun's angle are read by the light passes only:
    editing them builds no shadow map nor TFM, yet changes the image."""
    n = 12
    smoke = Medium(sigma_a=(0.2,) * 3, sigma_s=(2.0,) * 3, density=smoke_density(n, seed=1),
                   index_to_world=grid_to_world((n, n, n), 2.0, (0.0, 0.0, 1.0)), name="Smoke")
    camera = Camera(matrix_world=look_at((0.0, -6.5, 1.6), (0, 0, 1.0)), width_px=32, height_px=18,
                    lens_mm=40.0)
    meshes = (box_mesh((0.0, 0.0, 2.6), (3.0, 0.06, 0.06), name="Bar"), plane_mesh((0, 0, 0), 8.0))
    settings = RenderSettings(view_steps=16, light_steps=16, map_resolution=64, coefficients=4)
    edits = (("AREA", "size_m", (0.6, 0.3), (1.2, 0.8)), ("SPOT", "radius_m", 0.0, 0.25),
             ("SUN", "angle_rad", 0.0, math.radians(8.0)))
    for kind, field, before, after in edits:
        light = Light(matrix_world=look_at((0.0, -0.4, 3.6), (0, 0, 1.0)), kind=kind,
                      power_w=3.0 if kind == "SUN" else 1000.0, name=kind, **{field: before})
        scene = Scene(camera=camera, lights=(light,), media=(smoke,), meshes=meshes)
        first = renderer.render(scene, settings).rgb
        built = (renderer.counters["shadow_maps"], renderer.counters["tfms"])
        edited = dataclasses.replace(scene, lights=(dataclasses.replace(light, **{field: after}),))
        second = renderer.render(edited, settings).rgb
        assert (renderer.counters["shadow_maps"], renderer.counters["tfms"]) == built, kind
        assert np.abs(second - first).max() > 0.01 * first.max(), kind


@pytest.mark.parametrize("height, tolerance", [(2.0, 0.02), (4.0, 0.005)])
def test_area_light_irradiance_follows_its_rectangle(renderer, height, tolerance):
    """A 1 x 1 m area light 2 m above a white ground (its solid angle: the ground within 3.5 half
    diagonals) or 4 m (beyond them: the expansion of its emission): the ground's brightness across
    16 m against the integral of cos cos / d^2 over the rectangle (independent numerics), both
    normalised by their mean: within 2 % and 0.5 % everywhere (the ground's cosine is read at the
    light's centre), where the point's cos / r^2 law is off by more than twice that."""
    width = 16.0
    camera = Camera(matrix_world=look_at((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0)),
                    width_px=64, height_px=4, projection="ORTHO", ortho_scale=width)
    area = Light(matrix_world=look_at((0.0, 0.0, height), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0)), kind="AREA",
                 power_w=1000.0, size_m=(1.0, 1.0), name="Area")
    scene = Scene(camera=camera, lights=(area,), meshes=(plane_mesh((0.0, 0.0, 0.0), 40.0, color=(1, 1, 1)),))
    lit = render_samples(renderer, scene, RenderSettings(map_resolution=256), 1).rgb[..., 0].mean(axis=0)
    x = ((np.arange(64) + 0.5) / 64 - 0.5) * width
    g = (np.arange(200) + 0.5) / 200 - 0.5
    lx, ly = np.meshgrid(g, g, indexing="ij")
    d2 = (x[:, None, None] - lx) ** 2 + ly**2 + height**2
    expected = (height**2 / d2**2).mean(axis=(1, 2))           # cos at the light times cos at the ground
    point = height**2 / (x**2 + height**2) ** 2
    ratio = (lit / lit.mean()) / (expected / expected.mean())
    point_ratio = (point / point.mean()) / (expected / expected.mean())
    print(f"area light {height} m up: largest error {np.abs(ratio - 1).max():.4f}, the point law's "
          f"{np.abs(point_ratio - 1).max():.4f}")
    assert np.abs(ratio - 1.0).max() <= tolerance
    assert np.abs(point_ratio - 1.0).max() > 2.0 * tolerance
