"""Emission, blackbody and per-voxel colour against the numpy reference; what an emission edit
rebuilds (nothing on the light side) and what the cache keys hash."""

import dataclasses

import numpy as np
import pytest
from references import render_reference

from tfm_addon import scenes
from tfm_addon.engine import Medium, Renderer, RenderSettings, Scene, blackbody, metrics
from tfm_addon.engine.reference import blackbody_rec709
from tfm_addon.engine.scene import HASHED, GridValue

SETTINGS = RenderSettings(view_steps=96, light_steps=96, map_resolution=128, coefficients=8)
CASES = {
    "emission": dict(kind="EMISSION"),
    "blackbody": dict(kind="BLACKBODY"),
    "quick_fire_lit": dict(kind="QUICK_FIRE", with_light=True, with_occluder=True, with_ground=True),
    "fire_lit": dict(kind="FIRE", with_light=True, with_occluder=True, with_ground=True),
    "color_grid": dict(kind="COLOR", with_light=True, with_occluder=True),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_matches_reference(renderer, case):
    scene = scenes.fire_scene(64, 36, 24, **CASES[case])
    out = renderer.render(scene, SETTINGS).combined[..., :3]
    ref = render_reference(scene, view_steps=96, light_steps=96).combined[..., :3]
    ratio = out.sum(axis=(0, 1)) / ref.sum(axis=(0, 1))
    s = metrics.ssim(out, ref)
    print(f"{case}: SSIM {s:.5f}, brightness per channel {np.round(ratio, 4)}")
    assert ref.max() > 1e-3
    assert s >= 0.99
    assert np.all(np.abs(ratio - 1.0) <= 0.01)


def test_homogeneous_box_emission(renderer):
    base = scenes.homogeneous_box_scene(width=48, height=32)
    medium = dataclasses.replace(base.media[0], emission_color=(0.2, 0.5, 1.0),
                                 emission_strength=GridValue(offset=0.8))
    scene = dataclasses.replace(base, lights=(), media=(medium,), meshes=())
    out = renderer.render(scene, SETTINGS).combined[..., :3]
    ref = render_reference(scene, view_steps=256).combined[..., :3]
    ratio = out.sum(axis=(0, 1)) / ref.sum(axis=(0, 1))
    assert ref.max() > 0.05
    assert np.all(np.abs(ratio - 1.0) <= 0.01)
    assert metrics.ssim(out, ref) >= 0.99


def test_constant_emission_in_a_grid_stays_in_the_grid_box(renderer):
    """A constant strength emits in the grid's box [-1, n] only (the reference's march), not out
    to the far clip (it was 73x too bright: the emission box defaulted to [-2, 1e30])."""
    base = scenes.fire_scene(64, 36, 24, kind="EMISSION")
    scene = dataclasses.replace(base, media=(dataclasses.replace(
        base.media[0], emission_strength=GridValue(offset=0.5)),))
    out = renderer.render(scene, SETTINGS).combined[..., :3]
    ref = render_reference(scene, view_steps=96, light_steps=96).combined[..., :3]
    ratio = out.sum(axis=(0, 1)) / ref.sum(axis=(0, 1))
    assert ref.max() > 1e-3
    assert np.all(np.abs(ratio - 1.0) <= 0.01), ratio
    assert metrics.ssim(out, ref) >= 0.99


@pytest.mark.parametrize("colour", [blackbody_rec709, blackbody.color_rec709])
def test_blackbody_colour_is_cycles_fit(colour):
    # Values of Cycles' svm_math_blackbody_color_rec709 beyond its range and in between.
    t = np.array([700.0, 1000.0, 2000.0, 6500.0, 12000.0])
    c = colour(t)
    assert np.allclose(c[0], (5.413294490189271, -0.20319390035873933, -0.0822535242887164))
    assert np.allclose(c[4], (0.8262954810464208, 0.9945080501520986, 1.566307710274283))
    # The fit is luminance-balanced: Rec.709 luminance close to 1 over the range.
    lum = c[1:4] @ np.array([0.2126, 0.7152, 0.0722])
    assert np.all(np.abs(lum - 1.0) < 0.1)


def _edits(r, scene, edits):
    before = dict(r.counters)
    first = r.render(scene, SETTINGS).combined
    images = [r.render(dataclasses.replace(scene, media=(dataclasses.replace(scene.media[0], **edit),)),
                       SETTINGS).combined for edit in edits]
    delta = {k: r.counters[k] - before.get(k, 0) for k in r.counters}
    return first, images, delta


def test_emission_edits_rebuild_no_map():
    r = Renderer()
    try:
        scene = scenes.fire_scene(48, 27, 24, kind="FIRE", with_light=True, with_occluder=True)
        r.render(scene, SETTINGS)
        # Colour, strength and tint are uniforms: nothing is rebuilt or uploaded.
        first, images, delta = _edits(r, scene, [dict(emission_color=(0.2, 0.9, 0.3)),
                                                 dict(emission_strength=GridValue("flame", 9.0, 0.0)),
                                                 dict(blackbody_tint=(0.5, 0.5, 1.0))])
        assert delta["renders"] == 4
        for counter in ("shadow_maps", "tfms", "grid_uploads", "attribute_uploads", "gbuffers"):
            assert delta.get(counter, 0) == 0, counter
        for image in images:
            assert np.abs(image - first).max() > 1e-3   # each edit shows
        # The blackbody term is evaluated per voxel: a temperature or intensity edit uploads it
        # again, and still builds no light map.
        first, images, delta = _edits(r, scene, [dict(temperature=GridValue("temperature", 1300.0, 0.0)),
                                                 dict(blackbody_intensity=GridValue(offset=0.5))])
        assert delta["attribute_uploads"] == 2
        for counter in ("shadow_maps", "tfms", "grid_uploads", "gbuffers"):
            assert delta.get(counter, 0) == 0, counter
        for image in images:
            assert np.abs(image - first).max() > 1e-3
    finally:
        r.release()


def test_source_key_spares_hashing_the_grid():
    d = np.random.default_rng(0).random((64, 64, 64), dtype=np.float32)
    HASHED.clear()
    keyed = Medium(density=d, grids={"flame": d}, source_key="file.vdb:12:mtime")
    _ = keyed.density_key, keyed.grids_key, keyed.key
    assert HASHED["bytes"] < 1024
    plain = Medium(density=d)
    _ = plain.density_key
    assert HASHED["bytes"] >= d.nbytes
    assert Medium(density=d, source_key="a").density_key != Medium(density=d, source_key="b").density_key


def test_grids_must_share_the_lattice():
    d = np.zeros((4, 4, 4), np.float32)
    with pytest.raises(ValueError, match="lattice"):
        Medium(density=d, grids={"flame": np.zeros((4, 4, 5), np.float32)})
    with pytest.raises(ValueError, match="no scalar grid 'heat'"):
        Medium(density=d, emission_strength=GridValue("heat", 1.0, 0.0))


def test_bad_attribute_voxels_are_named_once_and_rendered_as_zero(renderer):
    scene = scenes.fire_scene(48, 27, 16, kind="FIRE")
    flame = np.array(scene.media[0].grids["flame"])
    flame[3, 4, 5], flame[6, 7, 8] = np.nan, np.inf
    medium = dataclasses.replace(scene.media[0], grids={**scene.media[0].grids, "flame": flame})
    out = renderer.render(dataclasses.replace(scene, media=(medium,)), SETTINGS)
    assert np.isfinite(out.combined).all()
    assert [w for w in out.warnings if "'flame'" in w] == [
        "Grid 'flame' had 2 NaN/infinite values; they were set to 0."]


def test_attributes_are_downsampled_with_the_density():
    r = Renderer()
    try:
        scene = scenes.fire_scene(48, 27, 24, kind="FIRE")
        full = r.render(scene, SETTINGS).combined
        small = dataclasses.replace(SETTINGS, max_grid_bytes=scene.media[0].density.nbytes // 8)
        out = r.render(scene, small)
        assert any("downsampled by 2" in w for w in out.warnings)
        (attributes,) = r._attributes.items.values()
        (medium_gpu, _), = r._media.items.values()
        assert tuple(attributes.attrs_size) == tuple(medium_gpu.grid_size)
        assert metrics.ssim(out.combined[..., :3], full[..., :3]) > 0.95
    finally:
        r.release()


def test_every_sampler_of_the_light_map_and_probe_shaders_has_its_own_unit():
    """One table (bindings.UNIT) gives every sampler a program declares (with its includes) a
    distinct unit (the colour grid once shared unit 15 with the occupancy grid; the probe's points
    unit 10 with the attribute grids, then unit 12 with the second density grid)."""
    import re
    from pathlib import Path

    from tfm_addon.engine.passes import bindings
    shaders = Path(bindings.__file__).parent.parent / "shaders"

    def samplers(name: str) -> set[str]:
        text = (shaders / name).read_text()
        found = set(re.findall(r"uniform\s+\w*sampler\w*\s+(\w+)\s*;", text))
        for included in re.findall(r'#include\s+"([^"]+)"', text):
            found |= samplers(included)
        return found

    programs = [p.name for p in shaders.iterdir() if p.suffix == ".frag" and p.name != "composite.frag"]
    assert "scatter.frag" in programs and "probe.frag" in programs
    for program in programs:
        names = samplers(program)
        assert names <= set(bindings.UNIT), (program, sorted(names - set(bindings.UNIT)))
        units = [bindings.UNIT[n] for n in names]
        assert len(set(units)) == len(units), (program, sorted((bindings.UNIT[n], n) for n in names))


@pytest.mark.parametrize("first", ["glowing box", "empty grid before it"])
def test_the_first_marched_medium_emits(renderer, first):
    """The medium that emits is the first one marched: a glowing fog box beside a smoke grid
    (crashed: the attributes read the box's missing grid), or after a skipped empty grid (its
    emission was dropped in silence: 0 % of the reference's light)."""
    from tests.test_lights import _camera, _smoke
    glow = Medium(sigma_a=(0.1,) * 3, sigma_s=(0.3,) * 3, name="Glow", box_to_world=scenes.translate_scale(
        (0.8, 0.0, 1.0), 1.0), emission_color=(1.0, 0.5, 0.2), emission_strength=GridValue(offset=0.8))
    media = (glow, _smoke())
    if first != "glowing box":
        media = (dataclasses.replace(_smoke(), density=np.zeros((8, 8, 8), np.float32), name="Empty"), *media)
    scene = Scene(camera=_camera(48, 27), lights=(), media=media)
    out = renderer.render(scene, SETTINGS).combined[..., :3]
    ref = render_reference(scene, view_steps=96, light_steps=96).combined[..., :3]
    ratio = out.sum(axis=(0, 1)) / ref.sum(axis=(0, 1))
    assert ref.max() > 0.05
    assert np.all(np.abs(ratio - 1.0) <= 0.02), ratio
    assert metrics.ssim(out, ref) >= 0.98


def test_moving_an_emitting_medium_uploads_no_attribute_grid(fresh):
    """A move of a fire changes its placement only: no grid or attribute texture is uploaded again
    (the attributes were keyed by the placement: one upload per move), and the image is that of a
    renderer that builds everything."""
    scene = scenes.fire_scene(48, 27, 24, kind="FIRE", with_light=True)
    fresh.render(scene, SETTINGS)
    placed = scene.media[0].index_to_world.copy()
    placed[0, 3] += 0.3
    moved = dataclasses.replace(scene, media=(dataclasses.replace(scene.media[0], index_to_world=placed),))
    before = dict(fresh.counters)
    out = fresh.render(moved, SETTINGS).combined
    assert fresh.counters["attribute_uploads"] == before["attribute_uploads"]
    assert fresh.counters["grid_uploads"] == before["grid_uploads"]
    fresh.clear_maps()
    again = fresh.render(moved, SETTINGS).combined
    assert fresh.counters["attribute_uploads"] == before["attribute_uploads"] + 1
    assert np.abs(out - again).max() <= 1e-6
