"""The emitting medium's density packed beside the values its view march reads anyway (one
texture fetch per sample instead of two). Each packed frame is checked against
the numpy reference (engine/reference.py), and the path a frame took is counted."""

import dataclasses

import numpy as np
import pytest
from references import render_reference

from tfm_addon import scenes
from tfm_addon.engine import Renderer, RenderSettings, Scene, metrics
from tfm_addon.engine.medium_attributes import prepare_attributes
from tfm_addon.engine.medium_grid import prepare_grid
from tfm_addon.engine.passes import bindings, emission
from tfm_addon.engine.scene import GridValue

SETTINGS = RenderSettings(view_steps=96, light_steps=96, map_resolution=128, coefficients=8)


def _colored(scene: Scene) -> Scene:
    m = scene.media[0]
    return dataclasses.replace(scene, media=(dataclasses.replace(
        m, grids={**m.grids, "color": scenes.color_grid_for(m.density)}, color_grid="color"),))


def _instanced(scene: Scene) -> Scene:
    """The fire and a second, darker instance of its density grid beside it (one texture, two
    media: only the first reads the packed density, the other the density texture)."""
    m = scene.media[0]
    placed = m.index_to_world.copy()
    placed[0, 3] += 1.6
    dark = dict(emission_strength=GridValue(offset=0.0), blackbody_intensity=GridValue(offset=0.0),
                temperature=GridValue(offset=1000.0))
    other = dataclasses.replace(m, name="Smoke", index_to_world=placed, grids={}, **dark)
    return dataclasses.replace(scene, media=(m, other))


def _scene(case: str) -> Scene:
    kind = {"quick fire": "QUICK_FIRE", "strength": "EMISSION",
            "fire": "FIRE", "colour": "COLOR", "quick fire instanced": "QUICK_FIRE"}
    kind = kind.get(case.replace(" + colour grid", ""), "FIRE")
    scene = scenes.fire_scene(64, 36, 24, kind=kind, with_light=True, with_occluder=True)
    if case.endswith("+ colour grid"):
        scene = _colored(scene)
    if case == "quick fire instanced":
        scene = _instanced(scene)
    return scene


def _render(gl, scene: Scene) -> tuple[np.ndarray, list[int]]:
    """The frame and the PACKED_DENSITY of its passes, by a renderer that builds everything."""
    r = Renderer(gl=gl)
    try:
        out = r.render(scene, SETTINGS).combined[..., :3]
        (attributes,) = r._attributes.items.values()
        return out, sorted(v for v, n in attributes.packed_passes.items() if n)
    finally:
        r.clear_maps()


# Where each case reads its density: 1 the attributes' R (beside the emission of a blackbody grid,
# as Blender's Quick Smoke fire material, of a strength grid, or of both, combined per voxel), 3 the
# colour grid's A.
CASES = {"quick fire": [1], "strength": [1], "fire": [1], "colour": [3],
         "fire + colour grid": [3], "quick fire + colour grid": [3], "quick fire instanced": [1]}


def _reference(scene: Scene) -> np.ndarray:
    return render_reference(scene, view_steps=96, light_steps=96).combined[..., :3]


def _agree(out: np.ndarray, ref: np.ndarray, what, min_ssim: float = 0.99) -> None:
    """``out`` within 1 % of ``ref``'s brightness per channel, SSIM >= ``min_ssim``."""
    ratio = out.sum(axis=(0, 1)) / ref.sum(axis=(0, 1))
    ssim = metrics.ssim(out, ref)
    print(f"{what}: SSIM {ssim:.5f}, brightness {np.round(ratio, 4)}")
    assert float(ref.max()) > 0.05, what
    assert np.all(np.abs(ratio - 1.0) <= 0.01), (what, ratio)
    assert ssim >= min_ssim, what


@pytest.mark.parametrize("case", list(CASES))
def test_the_packed_density_gives_the_reference_frame(fresh, case):
    scene = _scene(case)
    packed, where = _render(fresh.gl, scene)
    assert where == CASES[case]
    # Two media (the instance's TFM weights, its own march): SSIM 0.988 seen, the others >= 0.9998.
    _agree(packed, _reference(scene), f"{case}: density read from {where}",
           0.985 if case.endswith("instanced") else 0.999)


def test_emission_edits_of_a_packed_fire_upload_nothing(fresh):
    """Colour, strength (scale and an offset across 0) and tint edits of the packed fires, one after
    the other, are uniforms: no grid or attribute texture is uploaded, and each image is a fresh
    renderer's."""
    edits = {"QUICK_FIRE": [dict(blackbody_tint=(0.5, 0.7, 1.0)),
                            dict(emission_strength=GridValue(offset=0.2)),
                            dict(emission_color=(0.2, 0.9, 0.3))],
             "EMISSION": [dict(emission_color=(0.2, 0.9, 0.3)),
                          dict(emission_strength=GridValue("flame", 9.0, 0.0)),
                          dict(emission_strength=GridValue("flame", 4.0, 0.2))]}
    for kind, changes in edits.items():
        scene = scenes.fire_scene(48, 27, 24, kind=kind, with_light=True)
        first = fresh.render(scene, SETTINGS).combined
        for change in changes:
            edited = scene = dataclasses.replace(
                scene, media=(dataclasses.replace(scene.media[0], **change),))
            before = dict(fresh.counters)
            out = fresh.render(edited, SETTINGS).combined
            for counter in ("attribute_uploads", "grid_uploads", "shadow_maps", "tfms"):
                assert fresh.counters.get(counter, 0) == before.get(counter, 0), (kind, change, counter)
            assert np.abs(out - first).max() > 1e-3, (kind, change)     # the edit shows
            other = Renderer(gl=fresh.gl)
            try:
                again = other.render(edited, SETTINGS).combined
            finally:
                other.clear_maps()
            assert np.abs(out - again).max() <= 1e-6 * max(float(again.max()), 1.0), (kind, change)
            first = out
        (attributes,) = [a for a in fresh._attributes.items.values() if a.packed]
        assert attributes.packed == emission.PACKED_ATTRS_R and attributes.combined


def test_the_packed_values_are_the_density_texture_and_the_attributes():
    """The packed texture holds the density texture's own values (R16 as the GL reads them) and
    the attributes as before; grids on another lattice than the density are not packed."""
    r = Renderer()
    try:
        scene = scenes.fire_scene(48, 27, 24, kind="QUICK_FIRE")
        m = scene.media[0]
        grid = prepare_grid(m.density, np.eye(4), 256, 1 << 30, m.clipping)
        density = bindings.MediumGPU(r.gl, m, grid)
        prepared = prepare_attributes(m, 1)
        gpu = emission.AttributesGPU(r.gl, prepared, density.grid_size, density.occupancy_cells, density)
        try:
            nx, ny, nz = gpu.attrs_size
            data = np.frombuffer(gpu.attrs.read(), np.float32).reshape(nz, ny, nx, 4)
            stored = bindings.stored_grid(grid.density, np.uint16, density.density_scale) / 65535.0
            assert gpu.packed == emission.PACKED_ATTRS_R
            assert np.abs(data[..., 0] - stored).max() <= 1e-7
            # The blackbody grid's emission is combined with its tint at the first bind (combine).
            assert gpu.combined and gpu.grids_read() == 4
            gpu.combine(m)
            data = np.frombuffer(gpu.attrs.read(), np.float32).reshape(nz, ny, nx, 4)
            padded = np.pad(prepared.scalars, ((1, 1), (1, 1), (1, 1), (0, 0))).transpose(2, 1, 0, 3)
            want = padded[..., 1:] * np.asarray(m.blackbody_tint, np.float32)
            assert float(want.max()) > 0.1
            assert np.abs(data[..., 1:] - want).max() <= 1e-6 * float(want.max())
            assert np.abs(data[..., 0] - stored).max() <= 1e-7
            assert float(stored.max()) == 1.0
        finally:
            gpu.release()
        # The attributes downsampled by 2 beside the full density: not the same lattice.
        other = emission.AttributesGPU(r.gl, prepare_attributes(m, 2), density.grid_size, None, density)
        try:
            assert other.packed == 0 and other.attrs.components == 4
        finally:
            other.release()
        density.texture.release()
        density.occupancy.release()
    finally:
        r.release()


@pytest.mark.parametrize("case", ["both", "blackbody", "strength"])
def test_the_emission_compiled_for_its_grids_matches_the_reference(fresh, case):
    """The emission compiled for the grids its texture holds (EMISSION_GRIDS 4: a strength grid's
    emission, a blackbody grid's or both, combined per voxel), with constant parts beside a grid
    (a strength offset, a blackbody term without grid) summed into one uniform, against the numpy
    reference."""
    grids = 4
    scene = scenes.fire_scene(64, 36, 24, kind="FIRE")
    m = scene.media[0]
    if case.startswith("strength"):     # the strength grid with an offset, a constant blackbody (1800 K)
        m = dataclasses.replace(m, emission_strength=GridValue("flame", 4.0, 0.05),
                                temperature=GridValue(offset=1800.0),
                                blackbody_intensity=GridValue(offset=0.3))
    elif case.startswith("blackbody"):    # the blackbody grid, a constant strength
        m = dataclasses.replace(m, emission_strength=GridValue(offset=0.1), blackbody_tint=(1.0, 0.8, 0.6))
    else:               # both grids, the strength with an offset
        m = dataclasses.replace(m, emission_strength=GridValue("flame", 4.0, 0.05))
    scene = dataclasses.replace(scene, media=(m,))
    out = fresh.render(scene, SETTINGS).combined[..., :3]
    compiled = {dict(k[2]).get("EMISSION_GRIDS") for k in fresh.gl._programs if k[1] == "scatter.frag"}
    assert compiled == {grids}
    ref = render_reference(scene, view_steps=96, light_steps=96).combined[..., :3]
    ratio = out.sum(axis=(0, 1)) / ref.sum(axis=(0, 1))
    print(f"{case}, EMISSION_GRIDS {grids}: SSIM {metrics.ssim(out, ref):.5f}, "
          f"brightness {np.round(ratio, 4)}")
    assert ref.max() > 0.05
    assert np.all(np.abs(ratio - 1.0) <= 0.01), ratio
    assert metrics.ssim(out, ref) >= 0.99


@pytest.mark.parametrize("kind", ["FIRE", "QUICK_FIRE", "EMISSION"])
def test_grids_combined_per_voxel_give_the_reference_frame(fresh, kind):
    """The fire whose emission reads a strength and a blackbody grid (FIRE), or a blackbody grid
    alone (QUICK_FIRE, Blender's Quick Smoke fire), or a strength grid alone (EMISSION): its
    emission combined per voxel (one fetch a sample, beside the density) gives the numpy
    reference's frame, before and after colour, strength and tint edits.
    The edits upload no grid and build no map; each recomputes the combination once
    (``combines``), and a frame with nothing edited recomputes nothing."""
    scene = scenes.fire_scene(64, 36, 24, kind=kind, with_light=True, with_occluder=True)
    if kind != "QUICK_FIRE":
        edits = [dict(emission_color=(0.2, 0.9, 0.3)), dict(emission_strength=GridValue("flame", 9.0, 0.0)),
                 dict(emission_strength=GridValue("flame", 4.0, 0.2)),
                 dict(blackbody_tint=(0.5, 0.7, 1.0)) if kind == "FIRE"
                 else dict(emission_strength=GridValue("flame", 6.0, 0.1))]
    else:       # a constant strength: its part stays a uniform, the tint is combined
        edits = [dict(blackbody_tint=(0.5, 0.7, 1.0)), dict(emission_strength=GridValue(offset=0.2)),
                 dict(emission_color=(0.2, 0.9, 0.3)), dict(blackbody_tint=(1.0, 0.4, 0.2))]
    got = [fresh.render(scene, SETTINGS).combined[..., :3]]
    expected = [_reference(scene)]
    (attributes,) = fresh._attributes.items.values()
    assert attributes.combined and attributes.packed == emission.PACKED_ATTRS_R
    assert attributes.grids_read() == 4 and attributes.combines == 1
    edited = scene
    for k, change in enumerate(edits):
        edited = dataclasses.replace(edited, media=(dataclasses.replace(edited.media[0], **change),))
        before = dict(fresh.counters)
        got.append(fresh.render(edited, SETTINGS).combined[..., :3])
        expected.append(_reference(edited))
        for counter in ("attribute_uploads", "grid_uploads", "shadow_maps", "tfms"):
            assert fresh.counters.get(counter, 0) == before.get(counter, 0), (change, counter)
        assert attributes.combines == k + 2, change
    fresh.render(edited, SETTINGS)
    assert attributes.combines == len(edits) + 1        # nothing edited: nothing recomputed
    for k, (a, b) in enumerate(zip(got, expected, strict=True)):
        _agree(a, b, f"edit {k}")
        if k:
            assert np.abs(a - got[k - 1]).max() > 1e-3, k      # each edit shows
