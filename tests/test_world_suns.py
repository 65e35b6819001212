"""The world's light as suns (engine/world_light.py): each sun's cone of directions, which softens
its shadows on surfaces, covers its share of the sphere; an environment's sun is as wide as the
light of its part is spread."""

import math

import numpy as np

from tfm_addon.engine import world_light


def _cap(angle_rad: float) -> float:
    return 2.0 * math.pi * (1.0 - math.cos(0.5 * angle_rad))


def test_a_constant_world_s_suns_share_the_sphere():
    for n in (8, 16, 64):
        suns = world_light.world_suns((1.0, 1.0, 1.0), n)
        assert len(suns) == n
        assert math.isclose(sum(_cap(s.angle_rad) for s in suns), 4.0 * math.pi, rel_tol=1e-9)


def test_an_environment_s_sun_is_as_wide_as_its_light():
    h, w = 32, 64
    dirs, _ = world_light.environment_directions(np.zeros((h, w, 3)))
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
