"""The emitting medium's march skips empty space too: the occupancy grid
of the emitting medium (R: density, G: where its grids can emit), the constant part of the
emission added over the samples a skip passes, and the emission box set from the uniforms.
Each is checked by what it must not change: the numpy reference, the same march without
skipping, a renderer that builds everything."""

import dataclasses

import numpy as np
import pytest
from references import render_reference

from tfm_addon import scenes
from tfm_addon.engine import Medium, Renderer, RenderSettings, Scene, metrics
from tfm_addon.engine.passes import bindings, emission
from tfm_addon.engine.scene import GridValue

SETTINGS = RenderSettings(view_steps=96, light_steps=96, map_resolution=128, coefficients=8)


def _glow_apart_scene() -> Scene:
    """A puff of smoke in one corner of a 48^3 grid and a flame in the opposite corner where
    the density is zero: the flame's occupancy cells hold no density."""
    n = 48
    density = np.zeros((n, n, n), np.float32)
    puff = scenes.smoke_density(16)
    density[4:20, 6:22, 4:20] = puff
    flame = np.zeros_like(density)
    flame[27:43, 24:40, 26:42] = puff / puff.max()
    medium = Medium(sigma_a=(0.3,) * 3, sigma_s=(1.5,) * 3, density=density, grids={"flame": flame},
                    index_to_world=scenes.grid_to_world((n, n, n), 2.0, (0, 0, 1.2)),
                    emission_color=(1.0, 0.5, 0.2), emission_strength=GridValue("flame", 3.0, 0.0))
    base = scenes.smoke_scene(width=64, height=40, n=16, with_bar=False)
    return dataclasses.replace(base, media=(medium,), lights=(), meshes=())


def test_a_flame_where_there_is_no_density_glows(renderer):
    """The flame's cells are empty of density: the march must not skip them (it would if it
    skipped on the density's occupancy alone)."""
    scene = _glow_apart_scene()
    out = renderer.render(scene, SETTINGS).combined[..., :3]
    ref = render_reference(scene, view_steps=96).combined[..., :3]
    ratio = out.sum(axis=(0, 1)) / ref.sum(axis=(0, 1))
    print(f"SSIM {metrics.ssim(out, ref):.5f}, brightness {np.round(ratio, 4)}")
    assert ref.max() > 0.05
    assert np.all(np.abs(ratio - 1.0) <= 0.01), ratio
    assert metrics.ssim(out, ref) >= 0.99


def _fire(kind: str) -> Scene:
    scene = scenes.fire_scene(64, 36, 24, kind="FIRE", with_light=True, with_occluder=True)
    m = scene.media[0]
    if kind == "grid and constant":       # a strength offset glows in the whole grid box too
        m = dataclasses.replace(m, emission_strength=GridValue("flame", 4.0, 0.15))
    elif kind == "constant":              # reads no grid at all
        m = dataclasses.replace(m, emission_strength=GridValue(offset=0.3),
                                blackbody_intensity=GridValue(offset=0.0))
    return dataclasses.replace(scene, media=(m,))


@pytest.mark.parametrize("kind", ["grids", "grid and constant", "constant"])
def test_skipping_empty_cells_changes_no_emission(fresh, monkeypatch, kind):
    """The same frame with every occupancy cell marked (no skipping at all) differs by less than
    1e-4 of the peak: skipped cells hold neither density nor emitting voxels, and the constant
    part of the emission is added over the samples a skip passes."""
    scene = _fire(kind)
    skipped = fresh.render(scene, SETTINGS).combined[..., :3]

    def everywhere(padded_zyx, block=bindings.OCCUPANCY_BLOCK):
        cells = bindings_occupancy(padded_zyx, block)
        return np.full_like(cells, 255)

    bindings_occupancy = bindings.occupancy
    monkeypatch.setattr(bindings, "occupancy", everywhere)
    monkeypatch.setattr(emission, "occupancy", everywhere)
    marching = Renderer(gl=fresh.gl)
    try:
        full = marching.render(scene, SETTINGS).combined[..., :3]
    finally:
        marching.clear_maps()
    peak = float(full.max())
    diff = float(np.abs(skipped - full).max())
    print(f"{kind}: peak {peak:.4f}, largest difference {diff:.2e}")
    assert peak > 0.05
    assert diff <= 1e-4 * peak


def test_a_strength_offset_edit_widens_the_emission_box(fresh):
    """A strength offset makes the whole grid box glow: the cached attributes must not keep the
    box of the flame's voxels (an edit from offset 0 to 0.3 left the image 47 % of the peak off
    a fresh render), and the edit re-uploads nothing."""
    scene = scenes.fire_scene(48, 27, 24, kind="EMISSION")
    edited = dataclasses.replace(scene, media=(dataclasses.replace(
        scene.media[0], emission_strength=GridValue("flame", 4.0, 0.3)),))
    fresh.render(scene, SETTINGS)
    before = dict(fresh.counters)
    out = fresh.render(edited, SETTINGS).combined
    assert fresh.counters["attribute_uploads"] == before["attribute_uploads"]
    assert fresh.counters["grid_uploads"] == before["grid_uploads"]
    other = Renderer(gl=fresh.gl)
    try:
        again = other.render(edited, SETTINGS).combined
    finally:
        other.clear_maps()
    assert np.abs(out - again).max() <= 1e-6 * max(float(again.max()), 1.0)


def test_a_constant_emission_reads_no_attribute_texture(fresh):
    """A constant emission compiles the march without the attribute texture (EMISSION 1)."""
    fresh.render(_fire("constant"), SETTINGS)
    emitting = [dict(k[2]).get("EMISSION") for k in fresh.gl._programs if k[1] == "scatter.frag"]
    assert 1 in emitting and 2 not in emitting
    fresh.render(_fire("grids"), SETTINGS)
    emitting = [dict(k[2]).get("EMISSION") for k in fresh.gl._programs if k[1] == "scatter.frag"]
    assert 2 in emitting


def test_emission_cells_mark_every_cell_where_the_grids_emit():
    """G of the emitting medium's occupancy: outside the marked cells the trilinear strength is
    at most 0 and the blackbody term 0, negative blackbody channels (below ~800 K) included."""
    from scipy import ndimage

    from tfm_addon.engine.medium_attributes import emitting_voxels, padded_xyz_fastest

    rng = np.random.default_rng(5)
    n = 40
    scalars = np.zeros((n, n, n, 4), np.float32)
    scalars[3:9, 20:26, 5:11, 0] = rng.uniform(-1.0, 1.0, (6, 6, 6))      # strength, some negative
    scalars[30:34, 4:8, 28:33, 3] = -0.2                                   # a negative blue term
    live = emitting_voxels(scalars, strength_grid=True, blackbody_grid=True)
    cells = bindings.occupancy(padded_xyz_fastest(live[..., None].astype(np.uint8))[..., 0])
    b = bindings.OCCUPANCY_BLOCK
    p = rng.uniform(0.0, n + 1.0, size=(200_000, 3))                         # padded index space
    cell = np.floor(p / b).astype(int)
    marked = cells[cell[:, 2], cell[:, 1], cell[:, 0]] > 0
    padded = np.pad(scalars, ((1, 1), (1, 1), (1, 1), (0, 0)))
    value = np.stack([ndimage.map_coordinates(padded[..., k], p.T, order=1) for k in range(4)], axis=-1)
    assert (value[~marked, 0] <= 1e-7).all()
    assert (np.abs(value[~marked, 1:]) <= 1e-7).all()
    assert marked.mean() < 0.3 and (np.abs(value[marked]) > 1e-3).any()


def test_a_flame_inside_dense_smoke_stops_where_the_view_is_opaque(renderer):
    """A dense fire (optical depth ~20 across): the march stops at view transmittance 1e-3,
    skipped cells and all, and still matches the reference that marches every sample."""
    scene = scenes.fire_scene(64, 36, 24, kind="FIRE")
    scene = dataclasses.replace(scene, media=(dataclasses.replace(
        scene.media[0], sigma_s=(12.0,) * 3, sigma_a=(6.0,) * 3),))
    out = renderer.render(scene, SETTINGS).combined[..., :3]
    ref = render_reference(scene, view_steps=96, light_steps=96).combined[..., :3]
    ratio = out.sum(axis=(0, 1)) / ref.sum(axis=(0, 1))
    assert ref.max() > 0.05
    assert np.all(np.abs(ratio - 1.0) <= 0.01), ratio
    assert np.abs(out - ref).max() <= 0.01 * ref.max()
