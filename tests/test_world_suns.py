"""The world's light as suns (engine/world_light.py): each sun's cone of directions, which softens
its shadows on surfaces, covers its share of the sphere; an environment's sun is as wide as the
light of its part is spread."""

import math

import numpy as np

from tfm_addon.engine import environment, world_light


def _cap(angle_rad: float) -> float:
    return 2.0 * math.pi * (1.0 - math.cos(0.5 * angle_rad))


def test_a_constant_world_s_suns_share_the_sphere():
    for n in (8, 16, 64):
        suns = world_light.world_suns((1.0, 1.0, 1.0), n)
        assert len(suns) == n
        assert math.isclose(sum(_cap(s.angle_rad) for s in suns), 4.0 * math.pi, rel_tol=1e-9)


def test_an_environment_s_sun_is_as_wide_as_its_light():
    h, w = 32, 64
    dirs, _ = environment.directions((h, w))
    even = np.ones((h, w, 3))
    # a patch of 10 degrees' radius, 1000 times as bright as the even sky
    towards = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    patch = even.copy().reshape(-1, 3)
    patch[dirs @ towards > math.cos(math.radians(10.0))] = 1000.0
    patch = patch.reshape(h, w, 3)
    wide = world_light.environment_suns(even, 16)
    sharp = max(world_light.environment_suns(patch, 16), key=lambda s: s.color[0])
    # an even sky's suns are about as wide as the constant world's
    assert np.allclose([s.angle_rad for s in wide], world_light.world_suns((1, 1, 1), 16)[0].angle_rad,
                       rtol=0.25)
    # the patch's sun comes from the patch and is about as wide as it (20 degrees)
    # (pixels of 5.6 degrees)
    assert np.degrees(np.arccos(np.clip(-sharp.matrix_world[:3, 2] @ -towards, -1, 1))) < 3.0
    assert 15.0 < math.degrees(sharp.angle_rad) < 25.0


def test_the_world_s_directions_follow_its_share_of_the_light():
    """The grey default world beside a sun: the world's fluence 4 pi 0.05 = 0.63 W/m² against the
    sun's 3 W/m², a share of 0.17, takes the fewest directions; the world alone, the user's count."""
    import dataclasses

    from tfm_addon import scenes
    from tfm_addon.engine import Light

    base = scenes.homogeneous_box_scene(width=32, height=18)
    grey = dataclasses.replace(base, lights=(), ambient=(0.05,) * 3)
    assert world_light.world_share(grey) == 1.0 and world_light.directions_for(grey, 16) == 16
    sun = Light(matrix_world=scenes.look_at((1.0, -1.0, 5.0), (0.0, 0.0, 0.0)), kind="SUN", power_w=3.0)
    lit = dataclasses.replace(grey, lights=(sun,))
    share = 4.0 * math.pi * 0.05 / (4.0 * math.pi * 0.05 + 3.0)
    assert math.isclose(world_light.world_share(lit), share, rel_tol=1e-9)
    assert world_light.directions_for(lit, 16) == world_light.MIN_DIRECTIONS
    assert world_light.directions_for(lit, 4) == 4                 # never more than asked
    # a dim sun: the world is most of the light, most of the directions
    dim = dataclasses.replace(grey, lights=(dataclasses.replace(sun, power_w=0.1),))
    assert 12 <= world_light.directions_for(dim, 16) < 16
    assert len(world_light.with_world_light(lit, 16).lights) == 1 + world_light.MIN_DIRECTIONS
