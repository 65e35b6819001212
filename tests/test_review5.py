"""Review of the fire's emission combined per voxel (passes/emission.AttributesGPU.combine) and of
the lone grid's view march at texture coordinates stepped along the ray (scatter.frag, grid_ray).

The combined texture is checked texel by texel against the per-voxel emission computed here in
numpy (the blackbody term by the reference's own function), the frames against the numpy
reference (engine/reference.py); where the per-voxel clamp differs from the reference's clamp of
the trilinear blend (a negative scale or offset, a strength grid with negative values), against
references of scenes whose emission is that per-voxel clamp written out (the image is linear in
the emission)."""

import dataclasses

import numpy as np
import pytest

from tfm_addon import scenes
from tfm_addon.engine import Renderer, RenderSettings, metrics
from tfm_addon.engine import reference as ref_mod
from tfm_addon.engine.passes import emission
from tfm_addon.engine.reference import render_reference
from tfm_addon.engine.scene import GridValue

SETTINGS = RenderSettings(view_steps=96, light_steps=64, map_resolution=128, coefficients=8)


def _fire(width=48, height=27, light=False):
    """The fire (both grids) with its flame in two blocks, one touching three faces of the grid,
    and its temperature burning in a third block touching the opposite faces, so that the
    emission's box is not the whole grid and reaches the texture's border."""
    scene = scenes.fire_scene(width, height, 24, kind="FIRE", with_light=light, with_occluder=light)
    m = scene.medium
    nx, ny, nz = m.density.shape
    flame = np.zeros(m.density.shape, np.float32)
    rng = np.random.default_rng(5)
    flame[0:7, 0:6, 0:9] = 0.3 + 0.7 * rng.random((7, 6, 9))
    flame[9:15, 8:16, 12:20] = 0.2 + 0.8 * rng.random((6, 8, 8))
    temperature = np.zeros(m.density.shape, np.float32)
    temperature[16:nx, 14:ny, 26:nz] = 1.5 + 1.5 * rng.random((nx - 16, ny - 14, nz - 26))
    m = dataclasses.replace(m, grids={"flame": flame, "temperature": temperature})
    return dataclasses.replace(scene, medium=m)


def _with(scene, **fields):
    return dataclasses.replace(scene, medium=dataclasses.replace(scene.medium, **fields))


def _expected_texels(medium, stored_r):
    """The combined texture (z, y, x, 4) as passes/emission documents it, from the medium's grids:
    R the packed density, GBA colour x (max(scale x max(s, 0) + offset, 0) - max(offset, 0)) +
    tint x blackbody per voxel, 0 in the padding."""
    v = medium.emission_strength
    s = np.asarray(medium.grids[v.grid], np.float64)
    s = np.where(np.isfinite(s), s, 0.0)
    glow = np.maximum(v.scale * np.maximum(s, 0.0) + v.offset, 0.0) - max(v.offset, 0.0)
    t = medium.temperature
    temp = np.maximum(t.scale * np.maximum(np.asarray(medium.grids[t.grid], np.float64), 0.0) + t.offset, 0.0)
    b = medium.blackbody_intensity.offset
    bb = ref_mod._blackbody_term(temp.reshape(-1), np.full(temp.size, b)).reshape(*temp.shape, 3)
    e = (np.asarray(medium.emission_color)[None, None, None, :] * glow[..., None]
         + np.asarray(medium.blackbody_tint)[None, None, None, :] * bb)
    out = np.zeros((*(n + 2 for n in s.shape), 4), np.float64)
    out[1:-1, 1:-1, 1:-1, 1:] = e
    out = out.transpose(2, 1, 0, 3).copy()
    out[..., 0] = stored_r
    return out


def _read(renderer, attributes, pack):
    """The attribute texture (z, y, x, 4) and the density texture's values (0: not packed), read
    with the renderer's context current."""
    nx, ny, nz = attributes.attrs_size
    with renderer.gl.ctx:
        got = np.frombuffer(attributes.attrs.read(), np.float32).reshape(nz, ny, nx, 4).copy()
        stored = (emission.stored_density(attributes.density_grid) if pack
                  else np.zeros((nz, ny, nx), np.float32))
    return got, stored


EDITS = [
    ("as made", {}),
    ("negative scale", dict(emission_strength=GridValue("flame", -4.0, 0.5))),
    ("negative offset", dict(emission_strength=GridValue("flame", 4.0, -0.3))),
    ("offset above 0", dict(emission_strength=GridValue("flame", 4.0, 0.2))),
    ("offset below 0", dict(emission_strength=GridValue("flame", 4.0, -0.2))),
    ("colour 0", dict(emission_color=(0.0, 0.0, 0.0))),
    ("tint 0", dict(blackbody_tint=(0.0, 0.0, 0.0))),
    ("scale 0", dict(emission_strength=GridValue("flame", 0.0, 0.0))),
]


@pytest.mark.parametrize("pack", [True, False])
def test_the_combined_texture_is_the_per_voxel_emission_everywhere(fresh, monkeypatch, pack):
    """Every texel of the combined texture, after each of a row of edits (negative scale, negative
    offset, an offset across 0, colour 0, tint 0) and with a strength grid holding negative
    values and NaNs: the per-voxel emission computed here (within 1e-6 of its peak), exactly 0
    wherever that is 0 (outside the emission's box above all), and R the density texture's own
    values (packed) or 0 (not packed), untouched by the edits."""
    monkeypatch.setattr(emission, "PACK_DENSITY", pack)
    scene = _fire()
    flame = scene.medium.grids["flame"].copy()
    flame[3, 2, 4] = np.nan
    flame[10, 9, 13] = -0.8          # a negative voxel among emitting ones
    flame[20, 20, 2] = -0.5          # and one alone, where nothing emits
    scene = _with(scene, grids={**scene.medium.grids, "flame": flame})
    for k, (name, change) in enumerate(EDITS):
        edited = _with(scene, **change)
        fresh.render(edited, SETTINGS)
        (attributes,) = fresh._attributes.items.values()
        assert attributes.combined and attributes.grids_read() == 4
        assert attributes.packed == (emission.PACKED_ATTRS_R if pack else 0)
        assert attributes.combines == k + 1        # each edit recomputed it once
        got, stored = _read(fresh, attributes, pack)
        want = _expected_texels(edited.medium, stored)
        peak = float(np.abs(want[..., 1:]).max())
        diff = float(np.abs(got - want).max())
        print(f"{name}: peak {peak:.4g}, largest texel difference {diff:.2e}")
        assert np.array_equal(got[..., 0], stored), name
        assert diff <= 1e-6 * max(peak, 1e-30), name
        zero = want[..., 1:] == 0.0
        assert np.all(got[..., 1:][zero] == 0.0), name
        if name == "colour 0":
            assert peak > 0.0      # the blackbody alone still glows


def _frame(renderer, scene, combine=True, monkeypatch=None):
    if not combine:
        monkeypatch.setattr(emission, "COMBINE_EMISSION", False)
    try:
        other = Renderer(gl=renderer.gl)
        try:
            out = other.render(scene, SETTINGS).combined[..., :3]
            (attributes,) = other._attributes.items.values()
            assert attributes.combined == combine
            return out
        finally:
            other.clear_maps()
    finally:
        if not combine:
            monkeypatch.undo()


def _ref(scene):
    return render_reference(scene, view_steps=96, light_steps=64).combined[..., :3]


def _agree(out, ref):
    """(brightness ratio per channel, SSIM, largest difference / peak) of out against ref."""
    ratio = out.sum(axis=(0, 1)) / ref.sum(axis=(0, 1))
    return ratio, metrics.ssim(out, ref), float(np.abs(out - ref).max()) / float(ref.max())


def _fire_scene():
    return scenes.fire_scene(48, 27, 24, kind="FIRE")


def _cases():
    """(name, scene, the reference scene whose emission is the per-voxel clamp written out, or a
    list of (weight, scene) whose references add up to it; None: the scene's own reference)."""
    scene = _fire_scene()
    m = scene.medium
    flame = m.grids["flame"]
    nan = flame.copy()
    nan[flame > 0.5] = np.nan
    yield "colour 0", _with(scene, emission_color=(0.0, 0.0, 0.0)), None
    yield "tint 0", _with(scene, blackbody_tint=(0.0, 0.0, 0.0)), None
    yield "offset 0.2", _with(scene, emission_strength=GridValue("flame", 4.0, 0.2)), None
    yield "NaN strength", _with(scene, grids={**m.grids, "flame": nan}), None
    # A strength grid with negative voxels (every other one): per voxel max(s, 0), not the blend's.
    i, j, k = np.indices(flame.shape)
    signed = np.where((i + j + k) % 2 == 0, -0.6 * flame, flame).astype(np.float32)
    neg = _with(scene, grids={**m.grids, "flame": signed}, emission_strength=GridValue("flame", 4.0, 0.05))
    yield "negative voxels", neg, _with(neg, grids={**m.grids, "flame": np.maximum(signed, 0.0)})
    # A negative offset: per voxel max(4 s - 0.3, 0), written out as the grid.
    low = _with(scene, emission_strength=GridValue("flame", 4.0, -0.3))
    clamped = np.maximum(4.0 * flame - 0.3, 0.0).astype(np.float32)
    yield "negative offset", low, _with(scene, grids={**m.grids, "clamped": clamped},
                                        emission_strength=GridValue("clamped", 1.0, 0.0))
    # A negative scale beside a positive offset: per voxel max(-4 s + 0.5, 0) = 0.5 - 4 s + r,
    # r = max(4 s - 0.5, 0); the references of the offset alone, of s and of r add up to it.
    scale, offset = -4.0, 0.5
    rest = np.maximum(-(scale * flame + offset), 0.0).astype(np.float32)
    parts = [(1.0, _with(scene, emission_strength=GridValue(offset=offset))),
             (scale, _with(scene, emission_strength=GridValue("flame", 1.0, 0.0))),
             (1.0, _with(scene, grids={**m.grids, "rest": rest},
                         emission_strength=GridValue("rest", 1.0, 0.0))),
             (-scale - 1.0, _with(scene, emission_strength=GridValue(offset=0.0)))]   # the blackbody's
    yield "negative scale", _with(scene, emission_strength=GridValue("flame", scale, offset)), parts


def test_the_combined_fire_matches_the_reference_and_differs_only_by_the_per_voxel_clamp(fresh, monkeypatch):
    """The fire combined per voxel against the numpy reference: where the per-voxel clamp is the
    blend's (colour 0, tint 0, a positive offset, NaNs in the strength grid) against the scene's
    own reference; with a strength grid holding negative voxels, a negative offset or a negative
    scale, against the reference of the per-voxel clamp written out (within 0.5 % of the peak
    and in brightness), while the scene's own reference, which clamps the blend, differs by more
    than 2 % of the peak and agrees with the two grids kept apart (COMBINE_EMISSION off)."""
    for name, scene, per_voxel in _cases():
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
        assert np.all(np.abs(ratio - 1.0) <= 0.005) and ssim >= 0.999 and diff <= 0.005, name
        if per_voxel is not None:
            apart = _frame(fresh, scene, False, monkeypatch)
            _, _, off = _agree(out, ref)
            _, _, apart_diff = _agree(apart, ref)
            print(f"    the reference (clamp of the blend): {off:.3f} of the peak from it, "
                  f"{apart_diff:.2e} from the grids apart")
            assert off >= 0.02 and apart_diff <= 0.005, name
