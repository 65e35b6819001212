"""A lone emission grid combined per voxel (passes/emission.AttributesGPU: a strength grid
alone, or a blackbody grid alone as Blender's Quick Smoke fire), of the EMISSION 2 march adding a
packed sample's emission without the box test, and of the emission summed once per ray
(scatter.frag).

The combined texture is checked texel by texel against the per-voxel emission computed here in
numpy (the blackbody term by the reference's own function); the frames against the numpy
reference (engine/reference.py) where the per-voxel clamp is the reference's clamp of the
trilinear blend, else against references of scenes whose emission is that per-voxel clamp written
out (the image is linear in the emission)."""

import dataclasses

import numpy as np
import pytest
from references import render_reference

from tfm_addon import scenes
from tfm_addon.engine import Renderer, RenderSettings, metrics
from tfm_addon.engine import reference as ref_mod
from tfm_addon.engine.passes import emission
from tfm_addon.engine.scene import GridValue

SETTINGS = RenderSettings(view_steps=96, light_steps=64, map_resolution=64, coefficients=8)
COUNTERS = ("attribute_uploads", "grid_uploads", "shadow_maps", "tfms")


def _with(scene, **fields):
    return dataclasses.replace(scene, media=(dataclasses.replace(scene.media[0], **fields),))


def _grid_value(medium, v):
    """A GridValue per voxel, float64 (``scale * max(G, 0) + offset``, NaN as 0), or its constant."""
    if v.grid is None:
        return np.full(medium.density.shape, float(v.offset))
    g = np.asarray(medium.grids[v.grid], np.float64)
    return v.scale * np.maximum(np.where(np.isfinite(g), g, 0.0), 0.0) + v.offset


def _per_voxel_emission(medium, strength_grid, blackbody_grid):
    """(nx, ny, nz, 3): the grids' part of the emission per voxel, as passes/emission documents it:
    colour x (max(strength, 0) - max(offset, 0)) + tint x blackbody."""
    v = medium.emission_strength
    e = np.zeros((*medium.density.shape, 3))
    if strength_grid:
        glow = np.maximum(_grid_value(medium, v), 0.0) - max(v.offset, 0.0)
        e += np.asarray(medium.emission_color)[None, None, None, :] * glow[..., None]
    if blackbody_grid:
        temp = np.maximum(_grid_value(medium, medium.temperature), 0.0)
        b = _grid_value(medium, medium.blackbody_intensity)
        bb = ref_mod._blackbody_term(temp.reshape(-1), b.reshape(-1)).reshape(*temp.shape, 3)
        e += np.asarray(medium.blackbody_tint)[None, None, None, :] * bb
    return e


def _texels(renderer, attributes):
    """The attribute texture (z, y, x, 4) and the density texture's values, read on the renderer's
    context."""
    nx, ny, nz = attributes.attrs_size
    with renderer.gl.ctx:
        got = np.frombuffer(attributes.attrs.read(), np.float32).reshape(nz, ny, nx, 4).copy()
        stored = emission.stored_density(attributes.density_grid)
    return got, stored


def _flame_with_holes(scene):
    """The flame grid with a NaN and a negative voxel among the emitting ones, and a negative voxel
    where nothing emits."""
    flame = scene.media[0].grids["flame"].copy()
    hot = np.argwhere(flame > 0.3)
    flame[tuple(hot[0])] = np.nan
    flame[tuple(hot[len(hot) // 2])] = -0.8
    flame[-1, -1, -1] = -0.5
    assert scene.media[0].grids["flame"][-1, -1, -1] == 0.0
    return _with(scene, grids={**scene.media[0].grids, "flame": flame})


LONE_EDITS = {
    "EMISSION": [
        ("as made", {}),
        ("negative scale", dict(emission_strength=GridValue("flame", -4.0, 0.5))),
        ("negative offset", dict(emission_strength=GridValue("flame", 4.0, -0.3))),
        ("offset above 0", dict(emission_strength=GridValue("flame", 4.0, 0.2))),
        ("offset below 0", dict(emission_strength=GridValue("flame", 4.0, -0.2))),
        ("colour 0 beside a constant blackbody", dict(emission_color=(0.0, 0.0, 0.0),
                                                      temperature=GridValue(offset=1800.0),
                                                      blackbody_intensity=GridValue(offset=0.3))),
        ("scale 0, an offset", dict(emission_color=(1.0, 0.45, 0.12),
                                    emission_strength=GridValue("flame", 0.0, 0.3))),
        ("as made again", {}),
    ],
    "QUICK_FIRE": [
        ("as made", {}),
        ("tint", dict(blackbody_tint=(0.5, 0.7, 1.0))),
        ("a strength offset", dict(emission_strength=GridValue(offset=0.2))),
        ("a colour", dict(emission_color=(0.2, 0.9, 0.3))),
        ("tint 0, a strength offset", dict(blackbody_tint=(0.0, 0.0, 0.0),
                                           emission_strength=GridValue(offset=0.2))),
        ("no offset, another tint", dict(emission_strength=GridValue(offset=0.0),
                                         blackbody_tint=(1.0, 0.4, 0.2))),
    ],
}


@pytest.mark.parametrize("kind", list(LONE_EDITS))
def test_a_lone_grid_combined_holds_the_per_voxel_emission_after_each_edit(fresh, kind):
    """A strength grid alone (with a NaN and negative voxels) or a blackbody grid alone, through a
    row of edits in one renderer (negative scale, negative offset, an offset across 0, colour 0,
    scale 0, tint, tint 0): every texel is the per-voxel emission less its constant part (within
    1e-6 of its peak), exactly 0 wherever that is 0, R the density texture's own values; each edit
    recomputes the combination once and uploads no grid; the EMISSION define follows the offset."""
    scene = scenes.fire_scene(48, 27, 24, kind=kind)
    if kind == "EMISSION":
        scene = _flame_with_holes(scene)
    strength, blackbody = kind == "EMISSION", kind == "QUICK_FIRE"
    fresh.render(scene, SETTINGS)
    (attributes,) = fresh._attributes.items.values()
    for k, (name, change) in enumerate(LONE_EDITS[kind]):
        edited = _with(scene, **change)
        fresh.gl._programs.clear()
        before = dict(fresh.counters)
        fresh.render(edited, SETTINGS)
        for counter in COUNTERS:
            assert fresh.counters.get(counter, 0) == before.get(counter, 0), (name, counter)
        assert list(fresh._attributes.items.values()) == [attributes], name
        assert attributes.combined and attributes.grids_read() == 4
        assert attributes.packed == emission.PACKED_ATTRS_R
        assert attributes.combines == k + 1, name        # each edit differs from the one before
        got, stored = _texels(fresh, attributes)
        want = np.zeros_like(got, dtype=np.float64)
        e = _per_voxel_emission(edited.media[0], strength, blackbody)
        want[1:-1, 1:-1, 1:-1, 1:] = e.transpose(2, 1, 0, 3)
        peak = float(np.abs(want[..., 1:]).max())
        diff = float(np.abs(got[..., 1:] - want[..., 1:]).max())
        kinds = {dict(key[2]).get("EMISSION") for key in fresh.gl._programs if key[1] == "scatter.frag"}
        print(f"{kind}, {name}: EMISSION {kinds}, peak {peak:.4g}, largest texel difference {diff:.2e}")
        assert np.array_equal(got[..., 0], stored), name
        assert diff <= 1e-6 * max(peak, 1e-30), name
        assert np.all(got[..., 1:][want[..., 1:] == 0.0] == 0.0), name
        offset = edited.media[0].emission_strength.offset
        glows = offset > 0.0 and any(edited.media[0].emission_color) or "constant blackbody" in name
        assert kinds == {3 if glows else 2}, name


def _frame(renderer, scene):
    """``scene`` by a renderer that builds everything."""
    other = Renderer(gl=renderer.gl)
    try:
        out = other.render(scene, SETTINGS).combined[..., :3]
        (attributes,) = other._attributes.items.values()
        assert attributes.combined == (not attributes.intensity_grid)
        return out
    finally:
        other.clear_maps()


def _ref(scene):
    out = render_reference(scene, view_steps=SETTINGS.view_steps, light_steps=SETTINGS.light_steps)
    return out.combined[..., :3]


def _agree(out, ref):
    """(brightness ratio per channel, SSIM, largest difference / peak) of out against ref."""
    ratio = out.sum(axis=(0, 1)) / ref.sum(axis=(0, 1))
    return ratio, metrics.ssim(out, ref), float(np.abs(out - ref).max()) / float(ref.max())


def _strength_cases():
    """(name, scene, the reference scene whose emission is the per-voxel clamp written out, or a
    list of (weight, scene) whose references add up to it; None: the scene's own reference)."""
    scene = scenes.fire_scene(48, 27, 24, kind="EMISSION", with_light=True)
    m = scene.media[0]
    flame = m.grids["flame"]
    nan = flame.copy()
    nan[flame > 0.5] = np.nan
    yield "as made", scene, None
    yield "offset 0.2", _with(scene, emission_strength=GridValue("flame", 4.0, 0.2)), None
    yield "NaN strength", _with(scene, grids={**m.grids, "flame": nan}), None
    yield "colour 0 beside a constant blackbody", _with(scene, emission_color=(0.0, 0.0, 0.0),
                                                        temperature=GridValue(offset=1800.0),
                                                        blackbody_intensity=GridValue(offset=0.3)), None
    yield "a constant blackbody beside it", _with(scene, temperature=GridValue(offset=1800.0),
                                                  blackbody_intensity=GridValue(offset=0.3)), None
    yield "a colour grid", _with(scene, grids={**m.grids, "color": scenes.color_grid_for(m.density)},
                                 color_grid="color"), None
    # A strength grid with negative voxels (every other one): per voxel max(s, 0), not the blend's.
    i, j, k = np.indices(flame.shape)
    signed = np.where((i + j + k) % 2 == 0, -0.6 * flame, flame).astype(np.float32)
    neg = _with(scene, grids={**m.grids, "flame": signed})
    yield "negative voxels", neg, _with(neg, grids={**m.grids, "flame": np.maximum(signed, 0.0)})
    # A negative offset: per voxel max(4 s - 0.3, 0), written out as the grid.
    low = _with(scene, emission_strength=GridValue("flame", 4.0, -0.3))
    clamped = np.maximum(4.0 * flame - 0.3, 0.0).astype(np.float32)
    yield "negative offset", low, _with(scene, grids={**m.grids, "clamped": clamped},
                                        emission_strength=GridValue("clamped", 1.0, 0.0))
    # A negative scale beside a positive offset: per voxel max(-4 s + 0.5, 0) = 0.5 - 4 s + r,
    # r = max(4 s - 0.5, 0); the references of the offset alone, of s and of r add up to it (the
    # light's scattering, in each of them, is counted once: weights 1 + scale + 1 - scale - 1).
    scale, offset = -4.0, 0.5
    rest = np.maximum(-(scale * flame + offset), 0.0).astype(np.float32)
    dark = dict(emission_color=(0.0, 0.0, 0.0))       # the light's scattering alone
    parts = [(1.0, _with(scene, emission_strength=GridValue(offset=offset))),
             (scale, _with(scene, emission_strength=GridValue("flame", 1.0, 0.0))),
             (1.0, _with(scene, grids={**m.grids, "rest": rest},
                         emission_strength=GridValue("rest", 1.0, 0.0))),
             (-scale - 1.0, _with(scene, **dark))]
    yield "negative scale", _with(scene, emission_strength=GridValue("flame", scale, offset)), parts


def _quick_fire_cases():
    scene = scenes.fire_scene(48, 27, 24, kind="QUICK_FIRE", with_light=True)
    m = scene.media[0]
    color = {**m.grids, "color": scenes.color_grid_for(m.density)}
    yield "as made", scene
    yield "tint", _with(scene, blackbody_tint=(0.5, 0.7, 1.0))
    yield "a strength offset (EMISSION 3)", _with(scene, emission_strength=GridValue(offset=0.2),
                                                  emission_color=(0.2, 0.9, 0.3))
    yield "an intensity grid", _with(scene, blackbody_intensity=GridValue("flame", 1.0, 0.0))
    yield "an intensity grid with an offset", _with(scene, blackbody_intensity=GridValue("flame", 2.0, -0.5))
    yield "a colour grid (PACKED_DENSITY 3)", _with(scene, grids=color, color_grid="color")
    yield "a colour grid and a strength offset", _with(scene, grids=color, color_grid="color",
                                                       emission_strength=GridValue(offset=0.2))


def test_a_strength_grid_alone_combined_against_the_reference(fresh):
    """A strength grid alone combined per voxel, against the numpy reference: where the per-voxel
    clamp is the blend's (as made, a positive offset, NaNs, colour 0 beside a constant blackbody,
    a colour grid) against the scene's own reference; with negative voxels, a negative offset or a
    negative scale, against the reference of the per-voxel clamp written out (within 0.6 % of the
    peak, 0.8 % in brightness), while the scene's own reference, which clamps the blend, differs by
    more than 2 % of the peak."""
    for name, scene, per_voxel in _strength_cases():
        out = _frame(fresh, scene)
        ref = _ref(scene)
        if per_voxel is None:
            want = ref
        elif isinstance(per_voxel, list):
            want = sum(w * _ref(s) for w, s in per_voxel)
        else:
            want = _ref(per_voxel)
        ratio, ssim, diff = _agree(out, want)
        print(f"{name}: brightness {np.round(ratio, 4)}, SSIM {ssim:.6f}, largest difference {diff:.2e} "
              "of the peak")
        assert float(want.max()) > 0.05, name
        assert np.all(np.abs(ratio - 1.0) <= 0.008) and ssim >= 0.999 and diff <= 0.006, name
        if per_voxel is not None:
            ratio_off, _, off = _agree(out, ref)
            print(f"    the reference (clamp of the blend): {off:.3f} of the peak from it (brightness "
                  f"{np.round(ratio_off, 3)})")
            assert off >= 0.02, name


def test_a_blackbody_grid_alone_combined_against_the_reference(fresh):
    """Quick Fire's blackbody grid alone combined per voxel (tint edits, a constant strength offset:
    EMISSION 3, a colour grid: PACKED_DENSITY 3 and the combined emission read through
    emission_at_index) against the numpy reference; with an intensity grid beside the
    temperature grid, the blend of the intensity times that of the term (EMISSION_GRIDS 8, not
    combined), against the reference too."""
    for name, scene in _quick_fire_cases():
        fresh.gl._programs.clear()
        out = _frame(fresh, scene)
        grids = {dict(k[2]).get("EMISSION_GRIDS") for k in fresh.gl._programs if k[1] == "scatter.frag"}
        assert grids - {0} == {8 if "intensity grid" in name else 4}, name
        ref = _ref(scene)
        ratio, ssim, diff = _agree(out, ref)
        print(f"{name}: brightness {np.round(ratio, 4)}, SSIM {ssim:.6f}, largest difference {diff:.2e} "
              f"of the peak")
        assert float(ref.max()) > 0.05, name
        assert np.all(np.abs(ratio - 1.0) <= 0.008) and ssim >= 0.999 and diff <= 0.015, name


OFF_AND_ON = {
    "EMISSION": [dict(emission_strength=GridValue("flame", 0.0, 0.0)), {},
                 dict(emission_color=(0.0, 0.0, 0.0)), dict(emission_strength=GridValue("flame", 6.0, -0.2)),
                 dict(emission_strength=GridValue("flame", -2.0, 0.0)), {}],
    "QUICK_FIRE": [dict(blackbody_tint=(0.0, 0.0, 0.0)), dict(blackbody_tint=(0.5, 0.7, 1.0)),
                   dict(blackbody_tint=(0.0, 0.0, 0.0), emission_strength=GridValue(offset=0.2)), {}],
}


@pytest.mark.parametrize("colored", [False, True])
@pytest.mark.parametrize("kind", list(OFF_AND_ON))
def test_an_emission_turned_off_and_on_again_uploads_nothing(fresh, kind, colored):
    """A colour, strength scale or tint at 0 (the medium emits nothing: has_emission False) and
    back, in one renderer (a viewport's edits), with or without a colour grid: no grid or attribute
    texture is uploaded again and no map is built; each frame is a fresh renderer's (within 1e-6
    of its peak), the emission gone where it is off and back where it is on."""
    scene = scenes.fire_scene(48, 27, 24, kind=kind, with_light=True)
    if colored:
        m = scene.media[0]
        scene = _with(scene, grids={**m.grids, "color": scenes.color_grid_for(m.density)}, color_grid="color")
    first = fresh.render(scene, SETTINGS).combined[..., :3]
    dark = fresh.render(_with(scene, emission_color=(0.0, 0.0, 0.0), blackbody_tint=(0.0, 0.0, 0.0)),
                        SETTINGS).combined[..., :3]
    assert float(np.abs(first - dark).max()) > 0.1 * float(first.max())
    for change in OFF_AND_ON[kind]:
        edited = _with(scene, **change)
        before = dict(fresh.counters)
        out = fresh.render(edited, SETTINGS).combined[..., :3]
        for counter in COUNTERS:
            assert fresh.counters.get(counter, 0) == before.get(counter, 0), (change, counter)
        want = _fresh_frame(fresh, edited)
        diff = float(np.abs(out - want).max())
        assert diff <= 1e-6 * float(want.max()), change
        if not edited.media[0].has_emission:
            assert float(np.abs(out - dark).max()) <= 1e-6 * float(dark.max()), change


def _fresh_frame(renderer, scene):
    other = Renderer(gl=renderer.gl)
    try:
        return other.render(scene, SETTINGS).combined[..., :3]
    finally:
        other.clear_maps()


def _boxed_fire(kind):
    """The fire with its emitting voxels in one block (the emission's box a small part of the grid),
    negative strength voxels everywhere else, and an instance of its density beside it that emits
    nothing (rays through it sample the packed texture outside the fire's box)."""
    scene = scenes.fire_scene(48, 27, 24, kind=kind, with_light=True, with_occluder=True)
    m = scene.media[0]
    rng = np.random.default_rng(3)
    flame = -(0.2 + 0.8 * rng.random(m.density.shape)).astype(np.float32)
    flame[8:16, 8:16, 4:14] = 0.3 + 0.7 * rng.random((8, 8, 10))
    temperature = np.zeros(m.density.shape, np.float32)
    temperature[8:16, 8:16, 4:14] = 1.5 + 1.5 * rng.random((8, 8, 10))
    m = dataclasses.replace(m, grids={"flame": flame, "temperature": temperature})
    placed = m.index_to_world.copy()
    placed[0, 3] += 1.4
    dark = dict(emission_strength=GridValue(offset=0.0), blackbody_intensity=GridValue(offset=0.0),
                temperature=GridValue(offset=1000.0))
    twin = dataclasses.replace(m, name="Twin", index_to_world=placed, grids={}, **dark)
    return dataclasses.replace(scene, media=(m, twin))


SHORTCUT = {
    "strength": ("EMISSION", GridValue("flame", 4.0, -0.1)),
    "blackbody": ("QUICK_FIRE", None),
    "both, a negative scale": ("FIRE", GridValue("flame", -4.0, 0.0)),
}


@pytest.mark.parametrize("case", list(SHORTCUT))
def test_emission_2_adds_a_packed_sample_without_the_box_test(fresh, case):
    """With no constant part (EMISSION 2) the packed march adds each sample's emission without
    testing the emission's box: for a strength grid negative outside its emitting block (a negative
    offset), a blackbody grid in a block, both grids under a negative scale (PACKED_DENSITY 1),
    beside an instance whose rays sample the texture outside the fire's box, the frame is the
    numpy reference of the scene whose strength is the per-voxel clamp written out as a grid."""
    kind, strength = SHORTCUT[case]
    scene = _boxed_fire(kind)
    fire = scene.media[0]
    if strength is not None:
        fire = dataclasses.replace(fire, emission_strength=strength)
    scene = dataclasses.replace(scene, media=(fire, scene.media[1]))
    out = fresh.render(scene, SETTINGS).combined[..., :3]
    compiled = {(dict(k[2]).get("EMISSION"), dict(k[2]).get("PACKED_DENSITY"))
                for k in fresh.gl._programs if k[1] == "scatter.frag" and dict(k[2]).get("EMISSION")}
    assert compiled == {(2, 1)}
    written = fire
    if strength is not None:
        flame = np.maximum(np.nan_to_num(fire.grids["flame"]), 0.0)       # strengths below 0 read as 0
        clamped = np.maximum(strength.scale * flame + strength.offset, 0.0).astype(np.float32)
        written = dataclasses.replace(fire, grids={**fire.grids, "clamped": clamped},
                                      emission_strength=GridValue("clamped", 1.0, 0.0))
    ref = _ref(dataclasses.replace(scene, media=(written, scene.media[1])))
    ratio, ssim, diff = _agree(out, ref)
    print(f"{case}: {compiled}, brightness {np.round(ratio, 4)}, SSIM {ssim:.6f}, largest difference "
          f"{diff:.2e} of the peak")
    assert float(ref.max()) > 0.05
    # Two media (the instance marched beside the fire): SSIM 0.983-0.989 seen.
    assert np.all(np.abs(ratio - 1.0) <= 0.015) and ssim >= 0.98 and diff <= 0.02, case


ACROSS = {
    "EMISSION": [GridValue("flame", 4.0, -0.2), GridValue("flame", 4.0, 0.2), GridValue("flame", 4.0, -0.2),
                 GridValue("flame", 4.0, 0.0), GridValue("flame", -4.0, 0.5), GridValue("flame", 4.0, 0.3),
                 GridValue("flame", 4.0, 0.0)],
    "QUICK_FIRE": [GridValue(offset=0.2), GridValue(offset=0.0), GridValue(offset=0.3),
                   GridValue(offset=-0.1), GridValue(offset=0.2)],
}


@pytest.mark.parametrize("kind", list(ACROSS))
def test_a_strength_offset_across_0_in_one_renderer(fresh, kind):
    """A lone grid's strength offset edited across 0 and back in one renderer (EMISSION 2 <-> 3,
    the constant part a uniform added once: by the skipped samples and the others): every frame is a
    fresh renderer's within 1e-6 of its peak and, where the per-voxel clamp is the blend's (offset
    and scale not negative), the numpy reference's; no grid is uploaded, no map built."""
    scene = scenes.fire_scene(48, 27, 24, kind=kind, with_light=True, with_occluder=True)
    fresh.render(scene, SETTINGS)
    for strength in ACROSS[kind]:
        edited = _with(scene, emission_strength=strength)
        fresh.gl._programs.clear()
        before = dict(fresh.counters)
        out = fresh.render(edited, SETTINGS).combined[..., :3]
        for counter in COUNTERS:
            assert fresh.counters.get(counter, 0) == before.get(counter, 0), (strength, counter)
        compiled = {dict(k[2]).get("EMISSION") for k in fresh.gl._programs if k[1] == "scatter.frag"} - {0}
        assert compiled == {3 if strength.offset > 0.0 else 2}, strength
        want = _fresh_frame(fresh, edited)
        peak = float(want.max())
        assert float(np.abs(out - want).max()) <= 1e-6 * peak, strength
        if strength.offset >= 0.0 and strength.scale >= 0.0:
            ratio, ssim, diff = _agree(out, _ref(edited))
            print(f"{kind}, {strength}: EMISSION {compiled}, brightness {np.round(ratio, 4)}, "
                  f"SSIM {ssim:.6f}, largest difference {diff:.2e} of the peak")
            assert np.all(np.abs(ratio - 1.0) <= 0.008) and ssim >= 0.999 and diff <= 0.015, strength


def test_the_progressive_viewport_through_a_lone_grid_s_emission_edits():
    """The progressive viewport on the GL worker (engine/worker.py) through a strength grid's edits
    (scale, an offset across 0, the colour black and back): each converged image is the final
    render of its edit at that sample count (within 1e-4), each edit shows, and the edits upload
    no grid or attribute texture and build no map."""
    from tfm_addon.engine.progressive import ProgressiveView
    from tfm_addon.engine.sampling import render_samples
    from tfm_addon.engine.worker import RenderWorker

    settings = RenderSettings(view_steps=48, light_steps=32, map_resolution=64, coefficients=4)
    scene = scenes.fire_scene(48, 27, 24, kind="EMISSION", with_light=True)
    edits = [scene, _with(scene, emission_strength=GridValue("flame", 9.0, 0.0)),
             _with(scene, emission_strength=GridValue("flame", 9.0, 0.2)),
             _with(scene, emission_strength=GridValue("flame", 9.0, -0.2)),
             _with(scene, emission_strength=GridValue("flame", 9.0, -0.2), emission_color=(0.0, 0.0, 0.0)),
             _with(scene, emission_strength=GridValue("flame", 9.0, -0.2))]
    worker = RenderWorker()
    try:
        view = ProgressiveView(worker)
        converged = []
        for k, edited in enumerate(edits):
            if k == 1:
                before = worker.counters
            view.request(k + 1, edited, settings, 3)
            for _ in range(6000):
                frame = view.frame()
                if frame is not None and frame.generation == k + 1 and view.state == "idle":
                    break
                threading_wait(0.01)
            else:
                raise AssertionError(f"not converged: {view.state}, {view.counters}")
            final = worker.call(lambda r, s=edited: render_samples(r, s, settings, 3, passes=False))
            diff = float(np.abs(frame.image - final.combined).max())
            print(f"edit {k}: {diff:.2e} from its final render")
            assert diff <= 1e-4 * max(float(final.combined.max()), 1.0)
            converged.append(frame.image)
        after = worker.counters
        for counter in COUNTERS:
            assert after.get(counter, 0) == before.get(counter, 0), counter
        for x, y in zip(converged, converged[1:], strict=False):
            assert float(np.abs(x - y).max()) > 1e-3          # each edit shows
    finally:
        assert worker.close(10)


def threading_wait(seconds):
    import threading

    threading.Event().wait(seconds)


@pytest.mark.parametrize("kind", ["EMISSION", "QUICK_FIRE"])
def test_a_downsampled_lone_grid_is_combined_on_the_density_lattice(fresh, kind):
    """A lone strength or blackbody grid over a memory budget that halves its density: the grid is
    downsampled with it (the density's lattice), combined and packed, and its frame stays near the
    numpy reference of the full grids (the downsampling blurs it), with an offset above 0 too
    (EMISSION 3)."""
    scene = scenes.fire_scene(48, 27, 24, kind=kind, with_light=True, with_occluder=True)
    settings = dataclasses.replace(SETTINGS, max_grid_bytes=scene.media[0].density.size * 4 // 5)
    offset = GridValue("flame", 4.0, 0.2) if kind == "EMISSION" else GridValue(offset=0.2)
    for s in (scene, _with(scene, emission_strength=offset)):
        out = fresh.render(s, settings)
        assert any("downsampled by 2" in w for w in out.warnings), out.warnings
        (attributes,) = fresh._attributes.items.values()
        assert attributes.combined and attributes.packed == emission.PACKED_ATTRS_R
        assert attributes.attrs_size == tuple(-(-n // 2) + 2 for n in scene.media[0].density.shape)
        ratio, ssim, _ = _agree(out.combined[..., :3], _ref(s))
        print(f"{kind}, {s.media[0].emission_strength}: brightness {np.round(ratio, 4)}, SSIM {ssim:.5f} "
              "against the full grid's reference")
        # seen: 3-12 % brighter, SSIM 0.928-0.977 (the full grid's reference): the frame is that
        # fire, the downsampling's blur aside
        assert np.all(np.abs(ratio - 1.0) <= 0.15) and ssim >= 0.9, kind


def test_an_intensity_grid_beside_a_strength_grid_is_said_in_the_report(fresh):
    """The fire whose blackbody intensity and temperature both read grids beside a strength grid
    (five values a sample): the intensity is multiplied per voxel, which the render report says once;
    Quick Fire's intensity grid alone is rendered as Cycles does it and says nothing."""
    fire = scenes.fire_scene(32, 18, 16, kind="FIRE")
    fire = _with(fire, blackbody_intensity=GridValue("flame", 1.0, 0.0))
    said = [w for w in fresh.render(fire, SETTINGS).warnings if "intensity grid 'flame'" in w]
    assert len(said) == 1 and "per voxel" in said[0]
    quick = scenes.fire_scene(32, 18, 16, kind="QUICK_FIRE")
    quick = _with(quick, blackbody_intensity=GridValue("flame", 1.0, 0.0))
    assert not [w for w in fresh.render(quick, SETTINGS).warnings if "intensity" in w]
