"""The light an emitting medium casts on the solids (engine/fire_light.py): its points and maps
against the exact sum over every emitting voxel, each with its own transmittance marched to the
lit point (independent numpy). The image against Cycles is the conformance row
fire_lights_ground (tests/blender/test_camera_and_fire.py holds its ground to 10 %)."""

import numpy as np

from tfm_addon.bench.conformance import density_grid
from tfm_addon.engine import fire_light as fl
from tfm_addon.engine.quality import trilinear
from tfm_addon.engine.scene import GridValue, Medium

N = 16
VOXEL = 2.0 / N


def _fire() -> Medium:
    d = density_grid(N)
    to_world = np.eye(4)
    to_world[:3, :3] *= VOXEL
    to_world[:3, 3] = -(N - 1) * VOXEL / 2
    return Medium(sigma_a=(1.0, 1.0, 1.0), sigma_s=(0.0, 0.0, 0.0), density=d, index_to_world=to_world,
                  grids={"density": d}, emission_strength=GridValue("density", 2.0, 0.0),
                  emission_color=(1.0, 0.45, 0.12), lights_surfaces=True)


def _exact(medium: Medium, points: np.ndarray, normal) -> np.ndarray:
    e = fl.emission_per_voxel(medium)
    to_world = medium.index_to_world
    to_index = np.linalg.inv(to_world)
    idx = np.argwhere(e.sum(-1) > 0)
    power = e[tuple(idx.T)] * VOXEL ** 3
    xyz = idx @ to_world[:3, :3].T + to_world[:3, 3]
    s = (np.arange(64) + 0.5) / 64
    out = np.zeros((len(points), 3))
    for j, p in enumerate(points):
        v = p - xyz
        r = np.linalg.norm(v, axis=1)
        cos = 1.0 if normal is None else np.maximum(-(v @ normal) / r, 0.0)   # None: fluence
        q = (xyz[:, None, :] + v[:, None, :] * s[None, :, None]).reshape(-1, 3)
        tau = trilinear(medium.density, (q @ to_index[:3, :3].T + to_index[:3, 3]).T).reshape(len(xyz), -1)
        out[j] = (power * (cos * np.exp(-tau.mean(axis=1) * r) / r ** 2)[:, None]).sum(axis=0)
    return out


def test_the_points_light_the_ground_as_the_whole_emission_does():
    medium = _fire()
    light = fl.fire_light(medium)
    assert 8 <= len(light) <= fl.MAX_POINTS
    # the intensities add up to the whole emission (W/sr)
    total = fl.emission_per_voxel(medium).sum(axis=(0, 1, 2)) * VOXEL ** 3
    assert np.allclose(light.intensity.sum(axis=0), total)
    ground = np.array([[x, y, -1.25] for x in (-2.5, -0.8, 0.0, 1.7) for y in (-1.5, 0.4)])
    normal = np.array([0.0, 0.0, 1.0])
    exact = _exact(medium, ground, normal)
    approx = light.irradiance(ground, np.tile(normal, (len(ground), 1)), *fl.placement(medium)[::2])
    ratio = approx[:, 0] / exact[:, 0]
    print("ratios", np.round(ratio, 3), "total", approx[:, 0].sum() / exact[:, 0].sum())
    assert np.all(np.abs(ratio - 1.0) < 0.10)
    assert abs(approx[:, 0].sum() / exact[:, 0].sum() - 1.0) < 0.06
    # unshadowed (no density), the same points are within 10 % too, and brighter
    assert np.all(light.transmittance <= 1.0) and light.transmittance.min() < 0.5


def test_no_emission_no_points():
    medium = Medium(density=np.ones((4, 4, 4), np.float32))
    assert fl.fire_light(medium) is None


def test_octahedral_map_directions_round_trip():
    dirs = fl.octahedral_directions(8).reshape(-1, 3)
    uv = fl.octahedral(dirs)
    texel = np.floor(uv * 8).astype(int)
    expect = np.stack(np.meshgrid(np.arange(8), np.arange(8)), axis=-1).reshape(-1, 2)
    assert np.array_equal(texel, expect)


def test_a_moved_and_turned_fire_shares_its_points_and_lights_the_moved_ground():
    import dataclasses

    medium = _fire()
    turn = np.eye(4)
    turn[:3, :3] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    turn[:3, 3] = (0.5, -0.3, 0.2)
    moved = dataclasses.replace(medium, index_to_world=turn @ medium.index_to_world)
    assert fl.content_key(moved) == fl.content_key(medium)
    light = fl.fire_light(medium)
    ground = np.array([[x, y, -1.25] for x in (-1.0, 0.6) for y in (-1.2, 0.8)])
    up = np.tile([0.0, 0.0, 1.0], (len(ground), 1))
    r, _, t = fl.placement(moved)
    here = light.irradiance(ground, up, *fl.placement(medium)[::2])
    there = light.irradiance(ground @ turn[:3, :3].T + turn[:3, 3], up, r, t)
    assert np.allclose(here, there, rtol=1e-6)


def test_the_fluence_in_and_around_the_medium_matches_the_exact_sum():
    """What the media scatter of their own emission (engine/diffusion.py's emission field): the
    fluence, each point's map raised to the share of its ray inside the grid's box, against the
    exact sum of every voxel's emission through the medium up to the point; inside the box (the
    puff's empty corners, where the smoke around a fire is) and outside it."""
    medium = _fire()
    light = fl.fire_light(medium)
    signs = (-1, 1)
    inside = np.array([[sx * 0.85, sy * 0.85, sz * 0.8] for sx in signs for sy in signs for sz in signs])
    outside = np.array([[1.6, 0.2, 0.1], [-0.3, -1.8, 0.5], [0.2, 0.1, 2.2]])
    points = np.concatenate([inside, outside])
    exact = np.stack([_exact(medium, points[i:i + 1], None)[0] for i in range(len(points))])
    approx = light.fluence(points, *fl.placement(medium)[::2])
    ratio = approx[:, 0] / exact[:, 0]
    print("ratios", np.round(ratio, 3))
    assert np.all(np.abs(ratio - 1.0) < 0.10)


def test_a_point_inside_uniform_smoke_is_shadowed_by_the_smoke_before_it_only():
    """A core glowing inside uniform absorbing smoke: the fluence at points in the smoke between
    the core and the box's edge falls as exp(-sigma_t r) / r² (the exact sum), not as the whole
    way to the edge's transmittance would have it."""
    d = np.ones((N, N, N), np.float32)
    glow = np.zeros_like(d)
    glow[7:9, 7:9, 7:9] = 1.0
    to_world = np.eye(4)
    to_world[:3, :3] *= VOXEL
    to_world[:3, 3] = -(N - 1) * VOXEL / 2
    # sigma_t 1 (what _exact marches): 2 per metre of density
    d *= 2.0
    medium = Medium(sigma_a=(0.7, 0.7, 0.7), sigma_s=(0.3, 0.3, 0.3), density=d, index_to_world=to_world,
                    grids={"density": d, "glow": glow}, emission_strength=GridValue("glow", 4.0, 0.0))
    light = fl.fire_light(medium)
    points = np.array([[0.45, 0.0, 0.0], [0.0, -0.6, 0.0], [0.3, 0.3, 0.3], [0.0, 0.0, -0.4]])
    exact = _exact(medium, points, None)
    approx = light.fluence(points, *fl.placement(medium)[::2])
    ratio = approx[:, 0] / exact[:, 0]
    print("ratios", np.round(ratio, 3))
    # the share takes the ray's optical depth as uniform up to the box's edge, where the density
    # falls to 0 over the last voxel: up to 20 % bright along the diagonals here
    assert np.all(np.abs(ratio - 1.0) < 0.20)
    # the whole way to the edge (the share ignored) would be about half as bright
    edge = fl.FireLight(light.positions, light.intensity, light.softening, light.transmittance, light.block,
                        light.to_index, (1, 1, 1))
    assert np.mean(edge.fluence(points, *fl.placement(medium)[::2])[:, 0] / exact[:, 0]) < 0.6
