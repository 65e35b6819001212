"""The media's shadow-map lookups skipped where no solid can shadow them:
light.solids_may_shadow against hand-placed casters, and frames with the skip equal, to the bit,
frames that look the shadow map up, while a caster between the light and the medium keeps it."""

import dataclasses
import math

import numpy as np
import pytest

from tfm_addon.engine import RenderSettings
from tfm_addon.engine import renderer as renderer_module
from tfm_addon.engine.light import LightFrame, light_faces, solids_may_shadow
from tfm_addon.engine.scene import Light
from tfm_addon.scenes import look_at, smoke_scene, translate_scale

BOX = [(translate_scale((0.0, 0.0, 1.5), 0.5), (-1.0, -1.0, -1.0), (1.0, 1.0, 1.0))]   # z in [1, 2]


def _part(triangles):
    t = np.asarray(triangles, np.float64).reshape(-1, 3, 3)
    return (t.min(axis=(0, 1)), t.max(axis=(0, 1)), t)


def _quad(corners):
    a, b, c, d = (np.asarray(p, float) for p in corners)
    return _part([[a, b, c], [a, c, d]])


GROUND = _quad([(-20, -20, 0), (20, -20, 0), (20, 20, 0), (-20, 20, 0)])
SPOT = LightFrame.of(Light(matrix_world=look_at((0.5, -0.3, 5.0), (0.0, 0.0, 1.5)),
                               spot_size_rad=math.radians(60)))


def test_a_ground_below_the_medium_cannot_shadow_it():
    assert solids_may_shadow(SPOT, [GROUND], BOX, 512, 30.0) is False


def test_a_bar_between_the_light_and_the_medium_may():
    bar = _quad([(-0.2, -1, 3.5), (0.2, -1, 3.5), (0.2, 1, 3.5), (-0.2, 1, 3.5)])
    assert solids_may_shadow(SPOT, [GROUND, bar], BOX, 512, 30.0) is True


def test_a_caster_whose_plane_cuts_the_light_cone_but_that_stands_aside_cannot():
    # The plane y = 0 crosses the hull of the light and the box; the triangle lies at x 3..4.
    aside = _part([[(3, 0, 0.5), (4, 0, 0.5), (3.5, 0, 3.0)]])
    assert solids_may_shadow(SPOT, [aside], BOX, 512, 30.0) is False


def test_a_caster_within_the_margin_of_the_medium_may():
    # Just under the box's bottom (z = 1): closer than three shadow-map texels.
    touching = _quad([(-3, -3, 1.0 - 1e-3), (3, -3, 1.0 - 1e-3), (3, 3, 1.0 - 1e-3), (-3, 3, 1.0 - 1e-3)])
    assert solids_may_shadow(SPOT, [touching], BOX, 512, 30.0) is True
    lower = _quad([(-3, -3, 0.8), (3, -3, 0.8), (3, 3, 0.8), (-3, 3, 0.8)])
    assert solids_may_shadow(SPOT, [lower], BOX, 512, 30.0) is False


def test_a_mesh_without_kept_triangles_may_unless_its_bounds_stand_aside():
    bar = _quad([(-0.2, -1, 3.5), (0.2, -1, 3.5), (0.2, 1, 3.5), (-0.2, 1, 3.5)])
    far = _part([[(30, 30, 0), (31, 30, 0), (30, 31, 1)]])
    assert solids_may_shadow(SPOT, [(bar[0], bar[1], None)], BOX, 512, 30.0) is True
    assert solids_may_shadow(SPOT, [(far[0], far[1], None)], BOX, 512, 30.0) is False


def test_a_sun_from_above():
    sun = Light(matrix_world=look_at((1.0, -1.0, 10.0), (0.0, 0.0, 0.0)), kind="SUN", power_w=2.0)
    bar = _quad([(-0.2, -1, 3.5), (0.2, -1, 3.5), (0.2, 1, 3.5), (-0.2, 1, 3.5)])
    bounds = (np.array([-20.0, -20.0, 0.0]), np.array([20.0, 20.0, 3.5]))
    face = light_faces(sun, BOX, bounds)[0]
    assert solids_may_shadow(face, [GROUND], BOX, 512, face.far) is False
    assert solids_may_shadow(face, [GROUND, bar], BOX, 512, face.far) is True


def _looked_up(monkeypatch):
    """Make every face look the shadow map up for the media (the code before the skip)."""
    monkeypatch.setattr(renderer_module.Renderer, "_medium_shadow", lambda self, *a: True)


@pytest.mark.parametrize("settings", [RenderSettings(quality="AUTO", map_resolution=256),
                                      RenderSettings(method="UNSHADOWED", view_steps=48),
                                      RenderSettings(method="BRUTE_FORCE", view_steps=32, light_steps=32)],
                         ids=["auto", "floor", "brute-force"])
def test_the_skip_leaves_every_pixel_as_it_was(fresh, monkeypatch, settings):
    scene = smoke_scene(width=80, height=48, n=32, with_bar=False)       # a ground, no bar
    answers = []
    test = renderer_module.Renderer._medium_shadow
    monkeypatch.setattr(renderer_module.Renderer, "_medium_shadow",
                        lambda self, *a: answers.append(test(self, *a)) or answers[-1])
    skipped = fresh.render(scene, settings, passes=False).rgb
    assert answers == [False]                                   # the ground cannot shadow the smoke
    assert fresh.counters["medium_shadow_tests"] == 1
    c = np.array(scene.camera.matrix_world)
    c[0, 3] += 0.05
    moved = dataclasses.replace(scene, camera=dataclasses.replace(scene.camera, matrix_world=c))
    fresh.render(moved, settings, passes=False)
    assert fresh.counters["medium_shadow_tests"] == 1          # kept with the face's maps
    m = np.array(scene.lights[0].matrix_world)
    m[0, 3] += 0.05
    lit = dataclasses.replace(scene, lights=(dataclasses.replace(scene.lights[0], matrix_world=m),))
    fresh.render(lit, settings, passes=False)
    assert fresh.counters["medium_shadow_tests"] == 2          # a light move tests again
    _looked_up(monkeypatch)
    fresh.clear_maps()
    looked = fresh.render(scene, settings, passes=False).rgb
    assert skipped.max() > 0.05
    assert np.array_equal(skipped, looked)


def test_a_bar_that_shadows_the_smoke_keeps_the_lookup(fresh, monkeypatch):
    scene = smoke_scene(width=80, height=48, n=32, with_bar=True)
    settings = RenderSettings(quality="AUTO", map_resolution=256)
    kept = fresh.render(scene, settings, passes=False).rgb
    _looked_up(monkeypatch)
    fresh.clear_maps()
    looked = fresh.render(scene, settings, passes=False).rgb
    assert np.array_equal(kept, looked)
    # Skipping it here would lose the bar's shaft through the smoke: the test's answer matters.
    monkeypatch.setattr(renderer_module.Renderer, "_medium_shadow", lambda self, *a: False)
    fresh.clear_maps()
    wrong = fresh.render(scene, settings, passes=False).rgb
    assert np.abs(wrong - looked).max() > 0.05 * looked.max()
