"""Media shaped by their mesh (engine/mesh_volume.py): the voxelised inside against exact
volumes and chords, holes, nested shells, the cache that instances and camera moves share."""

from __future__ import annotations

import numpy as np
import pytest

from tfm_addon import scenes
from tfm_addon.engine import RenderSettings
from tfm_addon.engine import mesh_volume as mv
from tfm_addon.engine.scene import Camera, Scene

SPHERE = scenes.uv_sphere(1.0, 64, 32)


def _translate(x, y, z):
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def test_sphere_volume_and_closedness():
    v, t = SPHERE
    exact = mv.enclosed_volume(v, t)
    assert exact == pytest.approx(4.0 / 3.0 * np.pi, rel=0.01)      # outward facing, closed
    for n, tol in ((32, 0.003), (64, 0.001)):
        occ = mv.voxelize(v, t, n)
        h = occ.index_to_object[0, 0]
        assert occ.closed and occ.odd_columns == 0.0
        assert occ.coverage.sum() * h**3 == pytest.approx(exact, rel=tol)
        assert 0.0 < occ.coverage.min() + 1e-9 and occ.coverage.max() <= 1.0
        # fractional coverage at the boundary, none in the margin
        assert ((occ.coverage > 0.05) & (occ.coverage < 0.95)).sum() > 0
        c = occ.coverage
        assert not c[0].any() and not c[-1].any() and not c[:, 0].any() and not c[:, :, -1].any()


def test_silhouette_matches_the_exact_chords(renderer):
    """Orthographic view through a sphere medium: alpha = 1 - exp(-sigma_t * chord) with the
    exact chord of the unit sphere (an analytic reference that shares nothing with the grid)."""
    v, t = SPHERE
    sigma = 3.0
    medium, notes = mv.mesh_medium(v, t, np.eye(4), sigma_a=(0.0, 0.0, 0.0), sigma_s=(sigma,) * 3,
                                   resolution=64)
    assert notes == []
    cam = Camera(_translate(0.0, 0.0, 5.0), 64, 64, projection="ORTHO", ortho_scale=2.4)
    out = renderer.render(Scene(cam, media=(medium,)), RenderSettings(view_steps=192, ambient=False))
    px = (np.arange(64) + 0.5) / 64 * 2.4 - 1.2
    x, y = np.meshgrid(px, -px)
    chord = 2.0 * np.sqrt(np.maximum(1.0 - x**2 - y**2, 0.0))
    exact = 1.0 - np.exp(-sigma * chord)
    alpha = out.combined[..., 3]
    assert np.abs(alpha - exact).mean() < 0.008
    inside, seen = exact > 0.05, alpha > 0.05
    assert (inside & seen).sum() / (inside | seen).sum() > 0.96


def test_nested_shells_by_winding_and_holes_close():
    """Non-zero winding: a shell facing inward inside a sphere is a hollow (as Cycles' volume
    stack renders it); a shell facing outward inside it adds nothing (the union)."""
    v, t = SPHERE
    for inner_t, centre_value in ((t[:, ::-1], 0.0), (t, 1.0)):
        occ = mv.voxelize(np.concatenate([v, 0.5 * v]), np.concatenate([t, inner_t + len(v)]), 48)
        c = occ.coverage
        mid = np.array(c.shape) // 2
        assert c[tuple(mid)] == pytest.approx(centre_value)
        shell = np.array(mid)
        shell[0] += int(round(0.75 / occ.index_to_object[0, 0]))     # between the shells: full
        assert c[tuple(shell)] == pytest.approx(1.0)
    # A sphere with a hole (one ring of triangles left out): still full inside, and one warning.
    keep = np.ones(len(t), dtype=bool)
    keep[200:220] = False
    medium, notes = mv.mesh_medium(v, t[keep], np.eye(4), sigma_a=(0.1,) * 3, sigma_s=(1.0,) * 3,
                                   resolution=32, cache=mv.OccupancyCache())
    assert len(notes) == 1 and "not closed" in notes[0]
    d = medium.density
    assert d[tuple(np.array(d.shape) // 2)] == pytest.approx(1.0)
    full = mv.voxelize(v, t, 32).coverage
    assert abs(d.sum() / full.sum() - 1.0) < 0.01


def test_a_box_mesh_is_the_exact_box():
    box = scenes.box_mesh((0.5, 0.0, 1.0), (2.0, 1.0, 0.5))
    medium, _ = mv.mesh_medium(box.world_vertices(), box.triangles, _translate(0, 0, 1), sigma_a=(0.1,) * 3,
                               sigma_s=(1.0,) * 3, cache=mv.OccupancyCache())
    assert medium.is_homogeneous
    corners = medium.box_to_world @ np.array([[-1, -1, -1, 1], [1, 1, 1, 1]]).T
    np.testing.assert_allclose(corners[:3].T, [(-0.5, -0.5, 1.75), (1.5, 0.5, 2.25)], atol=1e-6)


def test_cache_by_shape_not_transform(renderer):
    """Instances and moves share the grid; an edit builds it once; a camera orbit rebuilds no
    texture or map of the shape."""
    v, t = SPHERE
    cache = mv.OccupancyCache()
    a, _ = mv.mesh_medium(v, t, _translate(0, 0, 1), sigma_a=(0.1,) * 3, sigma_s=(1.0,) * 3,
                          resolution=32, cache=cache)
    b, _ = mv.mesh_medium(v, t, _translate(3, 0, 1), sigma_a=(0.1,) * 3, sigma_s=(1.0,) * 3,
                          resolution=32, cache=cache)
    assert cache.counters["voxelisations"] == 1 and a.density is b.density
    edited = v.copy()
    edited[0] += (0.0, 0.0, 0.3)
    for _ in range(2):
        mv.mesh_medium(edited, t, np.eye(4), sigma_a=(0.1,) * 3, sigma_s=(1.0,) * 3, resolution=32,
                       cache=cache)
    assert cache.counters["voxelisations"] == 2
    light = scenes.smoke_scene().lights[0]
    before = None
    for angle in np.linspace(0.0, np.pi, 4):
        eye = (6.0 * np.sin(angle), -6.0 * np.cos(angle), 1.5)
        cam = Camera(scenes.look_at(eye, (0, 0, 1)), 32, 24)
        medium, _ = mv.mesh_medium(v, t, _translate(0, 0, 1), sigma_a=(0.1,) * 3, sigma_s=(1.0,) * 3,
                                   resolution=32, cache=cache)
        renderer.render(Scene(cam, lights=(light,), media=(medium,)), RenderSettings(map_resolution=64))
        if before is None:
            before = dict(renderer.counters)
    after = renderer.counters
    assert cache.counters["voxelisations"] == 2
    for name in ("grid_uploads", "tfms", "shadow_maps"):
        assert after[name] == before.get(name, 0), name
    assert after["gbuffers"] == before["gbuffers"] + 3


def test_constant_emission_glows_inside_the_mesh_only(renderer):
    """Cycles' constant volume emission fills the mesh, not its grid's box: it is scaled by the
    coverage."""
    from tfm_addon.engine.scene import GridValue

    v, t = SPHERE
    medium, _ = mv.mesh_medium(v, t, np.eye(4), sigma_a=(0.2,) * 3, sigma_s=(0.0,) * 3, resolution=32,
                               emission_color=(1.0, 0.5, 0.2), emission_strength=GridValue(offset=2.0),
                               cache=mv.OccupancyCache())
    assert medium.emission_strength.grid == mv.INSIDE_GRID and medium.grids[mv.INSIDE_GRID] is medium.density
    cam = Camera(_translate(0.0, 0.0, 5.0), 48, 48, projection="ORTHO", ortho_scale=2.4)
    out = renderer.render(Scene(cam, media=(medium,)), RenderSettings(view_steps=128, ambient=False))
    px = (np.arange(48) + 0.5) / 48 * 2.4 - 1.2
    x, y = np.meshgrid(px, -px)
    outside = x**2 + y**2 > 1.1**2
    assert out.rgb[outside].max() == 0.0 and out.rgb[~outside].max() > 0.5
    # through the centre: emission integrated over the chord, attenuated: (1 - e^{-0.2 * 2}) / 0.2
    expect = 2.0 * (1.0 - np.exp(-0.4)) / 0.2
    centre = out.rgb[23:25, 23:25, 0].mean()
    assert abs(centre / expect - 1.0) < 0.03
