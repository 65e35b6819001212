"""The diffused light and the surfaces' light (engine/diffusion.py) against closed forms: the
diffusion equation's solution in a slab and in an absorbing medium, the solid angle of a lit
plane, the lattice's extinction against the media's."""

import numpy as np

from tfm_addon.engine import diffusion
from tfm_addon.engine.scene import Medium, Mesh


def test_slab_fluence_is_the_diffusion_equations():
    """A white slab 8 mean free paths thick, wide sideways, uniform source Q: -D phi'' = Q with the
    fluence 0 at 2D past each face, phi(x) = Q / (2D) (x + 2D)(L + 2D - x)."""
    h, sigma, q = 0.1, 10.0, 1.0
    shape = (40, 40, 8)
    st = np.full(shape, sigma)
    phi, iterations = diffusion.diffuse(st, np.zeros(shape), np.full(shape, q), h)
    d, thick = 1.0 / (3.0 * sigma), shape[2] * h
    x = (np.arange(shape[2]) + 0.5) * h
    expected = q / (2.0 * d) * (x + 2.0 * d) * (thick + 2.0 * d - x)
    np.testing.assert_allclose(phi[20, 20], expected, rtol=0.03)
    assert 0 < iterations < diffusion.MAX_ITERATIONS


def test_absorbing_medium_holds_source_over_absorption():
    """Far from the edges (15 diffusion lengths) of an absorbing medium, phi = Q / sigma_a."""
    shape, h = (30, 30, 30), 0.1
    phi, _ = diffusion.diffuse(np.full(shape, 10.0), np.full(shape, 1.0), np.full(shape, 2.0), h)
    assert abs(phi[15, 15, 15] / 2.0 - 1.0) < 0.01
    assert phi[0, 15, 15] < 0.8 * phi[15, 15, 15]          # light leaves at the edges


def _thin_box(height: float) -> Medium:
    box = np.diag([1.0, 1.0, 0.05, 1.0])
    box[2, 3] = height
    return Medium(sigma_a=(0.0, 0.0, 0.0), sigma_s=(1e-4, 1e-4, 1e-4), box_to_world=box)


def test_lattice_holds_the_media_extinction():
    box = np.diag([0.5, 0.8, 0.3, 1.0])
    box[:3, 3] = (1.0, -2.0, 0.5)
    medium = Medium(sigma_a=(0.5, 0.5, 0.5), sigma_s=(1.5, 2.0, 2.5), box_to_world=box)
    lat = diffusion.lattice([medium], max_side=32)
    volume = 8.0 * 0.5 * 0.8 * 0.3
    integral = lat.sigma_t.sum(axis=(0, 1, 2)) * lat.h ** 3
    np.testing.assert_allclose(integral, volume * np.array([2.0, 2.5, 3.0]), rtol=0.02)
    np.testing.assert_allclose(lat.sigma_s.sum(axis=(0, 1, 2)) / lat.sigma_t.sum(axis=(0, 1, 2)),
                               [0.75, 0.8, 2.5 / 3.0], rtol=1e-6)
    centre = lat.origin + lat.h * (np.array(lat.shape) - 1) / 2
    np.testing.assert_allclose(centre, (1.0, -2.0, 0.5), atol=lat.h)


def test_lit_plane_fills_the_solid_angle_it_subtends():
    """Media 1 m above a wide plane of albedo 0.5 lit with irradiance E: the fluence is the plane's
    radiance 0.5 E / pi times the solid angle of the disc of it within reach, 2 pi (1 - cos)."""
    medium = _thin_box(1.0)
    lat = diffusion.lattice([medium], max_side=32)
    plane = Mesh(vertices=np.array([[-100, -100, 0], [100, -100, 0], [100, 100, 0], [-100, 100, 0]], float),
                 triangles=np.array([[0, 1, 2], [0, 2, 3]]), color=(0.5, 0.5, 0.5))
    centre = lat.origin + lat.h * (np.array(lat.shape) - 1) / 2
    reach = 6.0
    samples = diffusion.surface_samples([plane], centre, reach, n=8192)
    assert samples is not None and np.allclose(samples.normals, (0.0, 0.0, 1.0))
    e = 3.0
    field = diffusion.surface_fluence(lat, samples, np.full((len(samples.points), 3), e))
    disc = np.sqrt(reach ** 2 - 1.0)
    expected = 0.5 * e / np.pi * 2.0 * np.pi * (1.0 - 1.0 / np.hypot(1.0, disc))
    middle = field[lat.shape[0] // 2, lat.shape[1] // 2].mean(axis=0)
    np.testing.assert_allclose(middle, expected, rtol=0.05)
    # black or holdout solids reflect nothing
    black = Mesh(vertices=plane.vertices, triangles=plane.triangles, color=(0.0, 0.0, 0.0))
    assert diffusion.surface_samples([black], centre, reach) is None


def test_media_between_attenuate_the_surfaces_light():
    """The same plane under a layer of optical thickness 2: the light from below falls with the
    depth into it, the light along the lattice's -z axis as exp(-SURFACE_SECANT tau); a thicker
    layer lets less through."""
    def column(sigma):
        box = np.diag([1.0, 1.0, 0.5, 1.0])
        box[2, 3] = 1.5
        medium = Medium(sigma_a=(0.0, 0.0, 0.0), sigma_s=(sigma,) * 3, box_to_world=box)
        lat = diffusion.lattice([medium], max_side=32)
        plane = Mesh(vertices=np.array([[-100, -100, 0], [100, -100, 0], [100, 100, 0], [-100, 100, 0]],
                                       float), triangles=np.array([[0, 1, 2], [0, 2, 3]]), color=(0.5,) * 3)
        centre = lat.origin + lat.h * (np.array(lat.shape) - 1) / 2
        samples = diffusion.surface_samples([plane], centre, 6.0, n=4096)
        field = diffusion.surface_fluence(lat, samples, np.full((len(samples.points), 3), 1.0))[..., 0]
        return field[lat.shape[0] // 2, lat.shape[1] // 2]

    thin, thick = column(2.0), column(4.0)
    assert np.all(np.diff(thin) < 0) and np.all(np.diff(thick) < 0)    # darker away from the plane
    assert thin[-1] < 0.3 * thin[0] and thick[-1] < 0.5 * thin[-1]


def test_fine_grid_is_averaged_and_bad_values_are_empty():
    """A grid far finer than the lattice's cells is averaged in blocks first; its integral is kept.
    NaN and negative voxels count as empty, as everywhere else in the engine."""
    n = 96
    density = np.full((n, n, n), 2.0, np.float32)
    density[:8] = np.nan
    density[8:16] = -1.0
    index_to_world = np.diag([1.0 / n, 1.0 / n, 1.0 / n, 1.0])
    medium = Medium(sigma_a=(0.0,) * 3, sigma_s=(1.0,) * 3, density=density, index_to_world=index_to_world)
    lat = diffusion.lattice([medium], max_side=16)
    expected = 2.0 * (n - 16) / n          # the voxels' volume times their density, the bad ones empty
    integral = lat.sigma_t[..., 0].sum() * lat.h ** 3
    assert np.isfinite(lat.sigma_t).all()
    assert abs(integral / expected - 1.0) < 0.03, (integral, expected)


def test_a_light_linked_to_one_medium_is_scattered_first_by_it_alone():
    """Light linking: a light that lights medium A only adds to the diffused light through A's
    scattering; B, 1.5 m away across empty space, gets only what A's light reaches it (a little),
    not the light's own (as much as A gets when it lights both)."""
    def box(x, name):
        b = np.diag([0.4, 0.4, 0.4, 1.0])
        b[0, 3] = x
        return Medium(sigma_a=(0.1, 0.1, 0.1), sigma_s=(8.0, 8.0, 8.0), box_to_world=b, name=name)

    lat = diffusion.lattice([box(-1.0, "A"), box(1.0, "B")], max_side=24)
    x = lat.points()[:, 0].reshape(lat.shape)
    a, b = (x < -0.7) & (x > -1.3), (x > 0.7) & (x < 1.3)
    ones = lambda points, normals=None: np.ones((len(points), 3))          # noqa: E731
    both = diffusion.fluence(lat, [], ones).diffused[..., 0]
    only_a = diffusion.fluence(lat, [], lambda p, n: np.zeros((len(p), 3)), linked=[(ones, ("A",))])
    only_a = only_a.diffused[..., 0]
    print("A", only_a[a].mean(), both[a].mean(), "B", only_a[b].mean(), both[b].mean())
    np.testing.assert_allclose(only_a[a].mean(), both[a].mean(), rtol=0.05)
    assert both[b].mean() > 0.9 * both[a].mean()
    assert only_a[b].mean() < 0.1 * both[b].mean()
