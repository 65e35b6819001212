"""The fire's emission combined per voxel (passes/emission.AttributesGPU.combine) and of
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
from references import render_reference

from tfm_addon import scenes
from tfm_addon.engine import Renderer, RenderSettings, metrics
from tfm_addon.engine import reference as ref_mod
from tfm_addon.engine.passes import emission
from tfm_addon.engine.scene import GridValue

SETTINGS = RenderSettings(view_steps=96, light_steps=64, map_resolution=128, coefficients=8)
DOWNSAMPLED_BRIGHTNESS, DOWNSAMPLED_SSIM = 0.08, 0.93
"""A fire downsampled by 2 against the reference of its full grids (seen: 3-6 % brighter, SSIM
0.946-0.978): the bound says the frame is that fire, the downsampling's blur aside."""


def _fire(width=48, height=27, light=False):
    """The fire (both grids) with its flame in two blocks, one touching three faces of the grid,
    and its temperature burning in a third block touching the opposite faces, so that the
    emission's box is not the whole grid and reaches the texture's border."""
    scene = scenes.fire_scene(width, height, 24, kind="FIRE", with_light=light, with_occluder=light)
    m = scene.media[0]
    nx, ny, nz = m.density.shape
    flame = np.zeros(m.density.shape, np.float32)
    rng = np.random.default_rng(5)
    flame[0:7, 0:6, 0:9] = 0.3 + 0.7 * rng.random((7, 6, 9))
    flame[9:15, 8:16, 12:20] = 0.2 + 0.8 * rng.random((6, 8, 8))
    temperature = np.zeros(m.density.shape, np.float32)
    temperature[16:nx, 14:ny, 26:nz] = 1.5 + 1.5 * rng.random((nx - 16, ny - 14, nz - 26))
    m = dataclasses.replace(m, grids={"flame": flame, "temperature": temperature})
    return dataclasses.replace(scene, media=(m,))


def _with(scene, **fields):
    return dataclasses.replace(scene, media=(dataclasses.replace(scene.media[0], **fields),))


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


def _read(renderer, attributes):
    """The attribute texture (z, y, x, 4) and the density texture's values, read with the
    renderer's context current."""
    nx, ny, nz = attributes.attrs_size
    with renderer.gl.ctx:
        got = np.frombuffer(attributes.attrs.read(), np.float32).reshape(nz, ny, nx, 4).copy()
        stored = emission.stored_density(attributes.density_grid)
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


def test_the_combined_texture_is_the_per_voxel_emission_everywhere(fresh):
    """Every texel of the combined texture, after each of a row of edits (negative scale, negative
    offset, an offset across 0, colour 0, tint 0) and with a strength grid holding negative
    values and NaNs: the per-voxel emission computed here (within 1e-6 of its peak), exactly 0
    wherever that is 0 (outside the emission's box above all), and R the density texture's own
    values (packed), untouched by the edits."""
    scene = _fire()
    flame = scene.media[0].grids["flame"].copy()
    flame[3, 2, 4] = np.nan
    flame[10, 9, 13] = -0.8          # a negative voxel among emitting ones
    flame[20, 20, 2] = -0.5          # and one alone, where nothing emits
    scene = _with(scene, grids={**scene.media[0].grids, "flame": flame})
    for k, (name, change) in enumerate(EDITS):
        edited = _with(scene, **change)
        fresh.render(edited, SETTINGS)
        (attributes,) = fresh._attributes.items.values()
        assert attributes.combined and attributes.grids_read() == 4
        assert attributes.packed == emission.PACKED_ATTRS_R
        assert attributes.combines == k + 1        # each edit recomputed it once
        got, stored = _read(fresh, attributes)
        want = _expected_texels(edited.media[0], stored)
        peak = float(np.abs(want[..., 1:]).max())
        diff = float(np.abs(got - want).max())
        print(f"{name}: peak {peak:.4g}, largest texel difference {diff:.2e}")
        assert np.array_equal(got[..., 0], stored), name
        assert diff <= 1e-6 * max(peak, 1e-30), name
        zero = want[..., 1:] == 0.0
        assert np.all(got[..., 1:][zero] == 0.0), name
        if name == "colour 0":
            assert peak > 0.0      # the blackbody alone still glows


def _frame(renderer, scene):
    other = Renderer(gl=renderer.gl)
    try:
        out = other.render(scene, SETTINGS).combined[..., :3]
        (attributes,) = other._attributes.items.values()
        assert attributes.combined
        return out
    finally:
        other.clear_maps()


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
    m = scene.media[0]
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


def test_the_combined_fire_matches_the_reference_and_differs_only_by_the_per_voxel_clamp(fresh):
    """The fire combined per voxel against the numpy reference: where the per-voxel clamp is the
    blend's (colour 0, tint 0, a positive offset, NaNs in the strength grid) against the scene's
    own reference; with a strength grid holding negative voxels, a negative offset or a negative
    scale, against the reference of the per-voxel clamp written out (within 0.5 % of the peak
    and in brightness), while the scene's own reference, which clamps the blend, differs by more
    than 2 % of the peak."""
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
            _, _, off = _agree(out, ref)
            print(f"    the reference (clamp of the blend): {off:.3f} of the peak from it")
            assert off >= 0.02, name


def _fresh_frame(renderer, scene, settings=SETTINGS):
    """``scene`` by a renderer that builds everything (on ``renderer``'s context)."""
    other = Renderer(gl=renderer.gl)
    try:
        return other.render(scene, settings).combined[..., :3]
    finally:
        other.clear_maps()


def _close(a, b, what, rel=1e-6):
    peak = max(float(b.max()), 1e-30)
    diff = float(np.abs(a - b).max())
    assert diff <= rel * peak, (what, diff, peak)
    return diff / peak


def test_edits_kind_switches_instances_and_clears_keep_the_combination_right(fresh):
    """One renderer through a row of changes of the fire (a light and a bar, so the TFM and the
    scattering are in every frame): its instance beside it (one density texture, only the first
    emits), the instances swapped (the other emits nothing: no attributes), a colour edit, the
    strength grid replaced by a constant (another kind), the blackbody intensity 0, back to both
    grids, a second renderer on the same context rendering another colour in between, and
    clear_maps: every frame is a fresh renderer's, and the combined texture is recomputed
    exactly when its uniforms changed."""
    scene = scenes.fire_scene(48, 27, 24, kind="FIRE", with_light=True, with_occluder=True)
    m = scene.media[0]
    placed = m.index_to_world.copy()
    placed[0, 3] += 1.4
    twin = dataclasses.replace(m, name="Twin", index_to_world=placed, emission_color=(0.0, 0.0, 0.0),
                               blackbody_intensity=GridValue(offset=0.0))
    pair = dataclasses.replace(scene, media=(m, twin))
    green = dataclasses.replace(m, emission_color=(0.2, 0.9, 0.3))
    steps = [
        ("alone", scene, True),
        ("with its instance", pair, True),
        ("instances swapped", dataclasses.replace(pair, media=(twin, m)), False),
        ("green", dataclasses.replace(pair, media=(green, twin)), True),
        ("constant strength", _with(scene, emission_strength=GridValue(offset=0.3)), True),
        ("no blackbody", _with(scene, blackbody_intensity=GridValue(offset=0.0)), True),
        ("both grids again", _with(scene, emission_color=(0.2, 0.9, 0.3)), True),
        ("as made", scene, True),
    ]
    other = Renderer(gl=fresh.gl)
    try:
        for name, s, combined in steps:
            out = fresh.render(s, SETTINGS).combined[..., :3]
            want = _fresh_frame(fresh, s)
            print(f"{name}: {_close(out, want, name):.1e} of the peak from a fresh renderer's")
            live = [a for a in fresh._attributes.items.values() if a.combined]
            assert bool(live) == combined, name
            # The other renderer on the same context, another colour: its own texture.
            other.render(_with(scene, emission_color=(0.9, 0.1, 0.9)), SETTINGS)
        (mine,) = [a for a in fresh._attributes.items.values() if a.combined]
        fresh.clear_maps()
        out = fresh.render(_with(scene, emission_color=(0.5, 0.5, 1.0)), SETTINGS).combined[..., :3]
        (rebuilt,) = fresh._attributes.items.values()
        assert rebuilt is not mine and rebuilt.combines == 1
        _close(out, _fresh_frame(fresh, _with(scene, emission_color=(0.5, 0.5, 1.0))), "after clear_maps")
        (theirs,) = other._attributes.items.values()
        assert theirs.combines == 1           # the same colour each time: computed once
    finally:
        other.clear_maps()


def test_a_cancelled_frame_leaves_no_stale_combination(fresh):
    """Frames cancelled after the emission was bound (after the first light pass, before the image
    is read), then the edit before it again, the cancelled one again, and others: each finished
    frame is a fresh renderer's, and a cancelled frame's combination is reused only for its own
    uniforms."""
    scene = scenes.fire_scene(48, 27, 24, kind="FIRE", with_light=True)
    a = scene
    b = _with(scene, emission_color=(0.2, 0.9, 0.3))
    c = _with(scene, emission_strength=GridValue("flame", 9.0, 0.1))

    def cancelled(s):
        calls = []

        def cancel():     # the checks: scene, light maps, G-buffer, then after each light pass
            calls.append(1)
            return len(calls) >= 4

        with pytest.raises(Exception, match="cancelled"):
            fresh.render(s, SETTINGS, cancel=cancel, client="viewport")

    fresh.render(a, SETTINGS, client="viewport")
    (attributes,) = fresh._attributes.items.values()
    # combines: each bind whose uniforms differ from the last bound ones, cancelled or not.
    for name, s, cancel_first, combines in [("a after b cancelled", a, b, 3),
                                            ("b after b cancelled", b, b, 4),
                                            ("c after c cancelled", c, c, 5),
                                            ("a after c cancelled", a, c, 6)]:
        cancelled(cancel_first)
        out = fresh.render(s, SETTINGS, client="viewport").combined[..., :3]
        assert fresh._attributes.items and attributes in fresh._attributes.items.values()
        _close(out, _fresh_frame(fresh, s), name)
        assert attributes.combines == combines, name


def test_the_viewport_shows_every_emission_edit_in_a_row():
    """The progressive viewport on the GL worker through fire edits in a row, each request posted
    as the previous one's first frame is offered (it is superseded while it refines), and back to
    the first colour: each converged image is the final render of its edit at that sample count,
    and each edit shows."""
    from tfm_addon.engine.progressive import ProgressiveView
    from tfm_addon.engine.sampling import render_samples
    from tfm_addon.engine.worker import RenderWorker

    class View(ProgressiveView):
        on_offer = None

        def _publish(self, generation, *args):
            if self.on_offer is not None:
                self.on_offer(generation)
            return super()._publish(generation, *args)

    settings = RenderSettings(view_steps=48, light_steps=32, map_resolution=64, coefficients=4)
    scene = scenes.fire_scene(48, 27, 24, kind="FIRE", with_light=True)
    edits = [scene, _with(scene, emission_color=(0.2, 0.9, 0.3)),
             _with(scene, emission_strength=GridValue("flame", 9.0, 0.1)),
             _with(scene, blackbody_tint=(0.4, 0.6, 1.0)), scene]
    worker = RenderWorker()
    try:
        view = View(worker)
        converged = []
        for k in range(0, len(edits), 2):
            nxt = k + 1

            def chain(generation, nxt=nxt):       # the next edit while this one's frame is offered
                if generation == nxt and nxt < len(edits):
                    view.on_offer = None
                    view.request(nxt + 1, edits[nxt], settings, 3)

            view.on_offer = chain
            view.request(k + 1, edits[k], settings, 3)
            last = min(k + 2, len(edits))
            for _ in range(6000):
                frame = view.frame()
                if frame is not None and frame.generation == last and view.state == "idle":
                    break
                threading_wait(0.01)
            else:
                raise AssertionError(f"not converged: {view.state}, {view.counters}")
            final = worker.call(lambda r, s=edits[last - 1]: render_samples(r, s, settings, 3, passes=False))
            diff = float(np.abs(frame.image - final.combined).max())
            print(f"edit {last - 1}: {diff:.2e} from its final render ({view.counters})")
            assert diff <= 1e-4 * max(float(final.combined.max()), 1.0)
            converged.append(frame.image)
        assert view.counters["dropped"] + worker.stats["superseded"] >= 1
        for x, y in zip(converged, converged[1:], strict=False):
            assert float(np.abs(x - y).max()) > 1e-3          # each edit shows
    finally:
        assert worker.close(10)


def threading_wait(seconds):
    import threading

    threading.Event().wait(seconds)


def test_a_downsampled_fire_is_combined_on_the_density_lattice(fresh):
    """The fire over a memory budget that halves its density: its attributes are downsampled with
    it (the density's lattice), combined and packed, and its frame stays near the numpy reference
    of the full grids (the downsampling blurs it); so does the pair of the fire and its
    instance."""
    scene = scenes.fire_scene(48, 27, 24, kind="FIRE", with_light=True, with_occluder=True)
    settings = dataclasses.replace(SETTINGS, max_grid_bytes=scene.media[0].density.size * 4 // 5)
    m = scene.media[0]
    placed = m.index_to_world.copy()
    placed[0, 3] += 1.4
    pair = dataclasses.replace(scene, media=(m, dataclasses.replace(
        m, name="Twin", index_to_world=placed, emission_color=(0.0, 0.0, 0.0),
        blackbody_intensity=GridValue(offset=0.0))))
    for name, s in [("fire", scene), ("fire and its instance", pair)]:
        out = fresh.render(s, settings)
        assert any("downsampled by 2" in w for w in out.warnings), out.warnings
        (attributes,) = fresh._attributes.items.values()
        (density,) = [t.texture for t in fresh._media.items.values()]
        assert attributes.combined and attributes.packed == emission.PACKED_ATTRS_R
        assert attributes.attrs_size == density.grid_size == tuple(-(-n // 2) + 2 for n in m.density.shape)
        ratio, ssim, diff = _agree(out.combined[..., :3], _ref(s))
        print(f"{name}: brightness {np.round(ratio, 4)}, SSIM {ssim:.5f} against the full grids' reference")
        assert np.all(np.abs(ratio - 1.0) <= DOWNSAMPLED_BRIGHTNESS) and ssim >= DOWNSAMPLED_SSIM, name
        fresh.clear_maps()


def test_the_lone_grid_march_needs_no_box_test(fresh):
    """The view march of a lone grid reads its density along the ray without a box test
    (grid_ray); the packed march keeps the test (emission.glsl packed_density). For a grid whose
    non-zero voxels touch every face of the texture, under a sheared and rotated placement, with
    clipping, and for a mesh volume (engine/mesh_volume.py), the packed frame and the
    transmittance of the march that reads the density texture (the medium without emission, not
    packed) match the numpy reference."""
    from tfm_addon.engine import mesh_volume as mv

    base = scenes.fire_scene(48, 27, 24, kind="QUICK_FIRE", with_light=True, with_occluder=True)
    m = base.media[0]
    rng = np.random.default_rng(9)
    d = (0.2 + rng.random(m.density.shape)).astype(np.float32)
    a = np.asarray(m.index_to_world, np.float64)
    shear = np.eye(4)
    shear[0, 2], shear[1, 0] = 0.35, -0.2
    c, s = np.cos(0.5), np.sin(0.5)
    turn = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    centre, back = np.eye(4), np.eye(4)
    centre[:3, 3], back[:3, 3] = a[:3, 3], -a[:3, 3]
    sheared = centre @ shear @ turn @ back @ a
    v, t = scenes.uv_sphere(1.0, 24, 12, (0.0, 0.0, 1.5))
    sphere, _ = mv.mesh_medium(np.asarray(v), np.asarray(t), np.eye(4), sigma_a=(1.0,) * 3,
                               sigma_s=(1.0,) * 3, resolution=32, cache=mv.OccupancyCache(),
                               blackbody_intensity=GridValue(offset=1.0),
                               temperature=GridValue(offset=1500.0))
    cases = {"border grid, sheared, clipped": dataclasses.replace(
                 m, density=d, index_to_world=sheared, clipping=0.4,
                 grids={k: np.ones_like(g) * 1.2 for k, g in m.grids.items()}),
             "mesh volume": sphere}
    for name, medium in cases.items():
        scene = dataclasses.replace(base, media=(medium,))
        packed = fresh.render(scene, SETTINGS).combined
        (attributes,) = fresh._attributes.items.values()
        assert attributes.packed == emission.PACKED_ATTRS_R, name
        fresh.clear_maps()
        ratio, ssim, diff = _agree(packed[..., :3], _ref(scene))
        assert np.all(np.abs(ratio - 1.0) <= 0.01) and ssim >= 0.99, (name, ratio, ssim)
        unlit = dataclasses.replace(scene, lights=(), media=(dataclasses.replace(
            medium, emission_strength=GridValue(offset=0.0), blackbody_intensity=GridValue(offset=0.0)),))
        dark = render_reference(unlit, view_steps=96, light_steps=8)
        alpha = fresh.render(unlit, SETTINGS).combined[..., 3]
        compiled = {dict(k[2]).get("PACKED_DENSITY") for k in fresh.gl._programs if k[1] == "scatter.frag"}
        fresh.clear_maps()
        assert 0 in compiled
        err = float(np.abs(alpha - dark.combined[..., 3]).max())
        print(f"{name}: packed frame brightness {np.round(ratio, 4)}, SSIM {ssim:.5f}; grid_ray alpha "
              f"{err:.2e} from the reference")
        assert float(dark.combined[..., 3].max()) > 0.5 and err <= 0.01, name


@pytest.mark.parametrize("spots", ["low corner", "high corner", "both corners", "none"])
def test_the_emission_box_at_the_texture_corners(fresh, spots):
    """One emitting voxel at a corner of the grid (its texel box clamped to the texture), at both
    (the whole texture), or none (no box: nothing written, a positive offset glows through the
    uniform): the combined texture is the per-voxel emission, for a positive, a negative scale
    and a negative offset."""
    base = scenes.fire_scene(32, 18, 16, kind="FIRE")
    shape = base.media[0].density.shape
    high = tuple(n - 1 for n in shape)
    at = {"low corner": [(0, 0, 0)], "high corner": [high], "both corners": [(0, 0, 0), high], "none": []}
    flame, temperature = np.zeros(shape, np.float32), np.zeros(shape, np.float32)
    for voxel in at[spots]:
        flame[voxel], temperature[voxel] = 0.8, 2.0
    boxes = {"low corner": (0, 0, 0, 3, 3, 3), "high corner": (*(n - 1 for n in shape), 3, 3, 3),
             "both corners": (0, 0, 0, *(n + 2 for n in shape))}
    grids = {"flame": flame, "temperature": temperature}
    for strength in [GridValue("flame", 4.0, 0.0), GridValue("flame", -3.0, 0.4),
                     GridValue("flame", 2.0, -0.5)]:
        r = Renderer(gl=fresh.gl)
        try:
            scene = _with(base, grids=grids, emission_strength=strength)
            r.render(scene, SETTINGS)
            (attributes,) = r._attributes.items.values()
            assert attributes.combined
            if spots in boxes:
                assert attributes._viewport == boxes[spots]
            else:
                assert attributes._block is None
            got, stored = _read(r, attributes)
            want = _expected_texels(scene.media[0], stored)
            assert np.abs(got - want).max() <= 1e-6 * max(float(np.abs(want).max()), 1e-30)
            assert np.all(got[..., 1:][want[..., 1:] == 0.0] == 0.0)
        finally:
            r.clear_maps()
