"""Robustness: frames are transactions, bad voxels, exact cache keys, scale-free biases, lights."""

import dataclasses

import numpy as np
import pytest

from tfm_addon.engine import RenderCancelled, Renderer, RenderSettings
from tfm_addon.scenes import look_at, smoke_scene

SETTINGS = RenderSettings(view_steps=32, light_steps=32, map_resolution=64)


replace = dataclasses.replace


def _cancel_after(n):
    calls = [0]

    def cancel():
        calls[0] += 1
        return calls[0] >= n
    return cancel


def test_a_frame_cancelled_after_any_step_leaves_the_next_equal_to_a_fresh_renderers(fresh):
    scene = smoke_scene(width=40, height=24, n=24)
    scene = replace(scene, meshes=scene.meshes[::-1])      # the ground first, the bar over it
    light = scene.lights[0]
    moved = replace(scene, camera=replace(scene.camera, matrix_world=look_at((0.6, -6.2, 2.1), (0, 0, 1))),
                    lights=(replace(light, matrix_world=look_at((-2.4, -1.1, 4.0), (0, 0, 1.0))),))
    reference = Renderer()
    try:
        want = reference.render(moved, SETTINGS).combined
    finally:
        reference.release()
    peak = float(np.abs(want).max())
    steps = 2 + 2 * len(scene.lights)          # scene, maps per light, G-buffer, light passes
    for n in range(1, steps + 1):
        fresh.clear_maps()
        with pytest.raises(RenderCancelled):
            fresh.render(scene, SETTINGS, cancel=_cancel_after(n))
        got = fresh.render(moved, SETTINGS).combined
        err = float(np.abs(got - want).max())
        assert err <= 1e-5 * peak, f"cancelled after step {n}: max error {err / peak:.2e} of the peak"


def test_a_frame_that_fails_midway_caches_nothing_partial(fresh):
    scene = smoke_scene(width=40, height=24, n=24)
    moved = replace(scene, camera=replace(scene.camera, matrix_world=look_at((0.6, -6.2, 2.1), (0, 0, 1))))
    want = fresh.render(moved, SETTINGS).combined
    for n in range(1, 5):
        fresh.clear_maps()
        calls = [0]

        def progress(_, calls=calls, n=n):
            calls[0] += 1
            if calls[0] >= n:
                raise ValueError("a host callback failed")
        with pytest.raises(ValueError):
            fresh.render(scene, SETTINGS, progress=progress)
        assert all(not cache.items for cache in fresh._caches), f"failed at step {n}: entries kept"
        np.testing.assert_array_equal(fresh.render(moved, SETTINGS).combined, want)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_a_bad_voxel_under_auto_quality_renders_finite_with_one_warning(renderer, bad):
    scene = smoke_scene(width=40, height=24, n=24)
    auto = dataclasses.replace(SETTINGS, quality="AUTO")
    d = np.array(scene.media[0].density)
    d[12, 12, 12] = bad                             # in the middle of the smoke
    out = renderer.render(replace(scene, media=(replace(scene.media[0], density=d.copy()),)), auto)
    name = "NaN" if np.isnan(bad) else "infinite"
    assert out.warnings == [f"The density grid has 1 {name} voxel; rendered as 0."]
    assert np.isfinite(out.combined).all()
    d[12, 12, 12] = 0.0
    zeroed = renderer.render(replace(scene, media=(replace(scene.media[0], density=d),)), auto)
    assert zeroed.warnings == []
    # The same AUTO settings and the same image as the grid with that voxel at 0.
    np.testing.assert_allclose(out.combined, zeroed.combined, atol=1e-6 * float(zeroed.combined.max()))


def test_clipping_empties_densities_below_it(renderer):
    scene = smoke_scene(width=40, height=24, n=24)
    d = np.array(scene.media[0].density)
    clip = float(np.percentile(d[d > 0], 30))
    clipped = renderer.render(replace(scene, media=(replace(scene.media[0], clipping=clip),)), SETTINGS)
    zeroed = renderer.render(replace(scene, media=(replace(scene.media[0],
                                                           density=np.where(d < clip, 0, d)),)),
                             SETTINGS)
    full = renderer.render(scene, SETTINGS)
    assert clipped.warnings == []
    np.testing.assert_allclose(clipped.combined, zeroed.combined, atol=1e-6 * float(full.combined.max()))
    assert not np.allclose(clipped.combined, full.combined)


def test_the_reference_clips_and_cleans_the_grid_as_the_renderer_does(renderer):
    """reference.py reads Medium.clipping and renders bad voxels as 0 with its own code (it read
    the raw grid: NaN everywhere from one NaN voxel; without the NaN, twice the mean error)."""
    from references import render_reference

    from tfm_addon.engine.metrics import ssim

    scene = smoke_scene(width=40, height=24, n=24)
    d = np.array(scene.media[0].density)
    medium = replace(scene.media[0], density=d, clipping=float(np.percentile(d[d > 0], 50)))
    for bad in (None, np.nan):
        if bad is not None:
            d = d.copy()
            d[12, 12, 12] = bad
            medium = replace(medium, density=d)
        clipped = replace(scene, media=(medium,))
        out = renderer.render(clipped, SETTINGS).combined[..., :3]
        ref = render_reference(clipped, view_steps=96, light_steps=96).combined[..., :3]
        assert np.isfinite(ref).all()
        error = float(np.abs(out - ref).mean() / ref.mean())
        assert error <= 0.03, error          # 0.022 (0.041 with the grid unclipped)
        assert ssim(out, ref) >= 0.98


def _built(renderer, scene, settings=SETTINGS, **kwargs):
    before = dict(renderer.counters)
    out = renderer.render(scene, settings, **kwargs)
    return {k: renderer.counters[k] - before.get(k, 0) for k in renderer.counters}, out


def test_a_downsampled_grid_gets_its_own_tfm(fresh):
    scene = smoke_scene(width=40, height=24, n=32)
    _built(fresh, scene)
    small = dataclasses.replace(SETTINGS, max_grid_bytes=20**3 * 4)
    delta, out = _built(fresh, scene, small)
    assert any("downsampled by 2" in w for w in out.warnings)
    assert delta["grid_uploads"] == 1 and delta["tfms"] == 1 and delta.get("shadow_maps", 0) == 0


def test_a_gobo_or_a_colour_rebuilds_no_shadow_map_and_no_tfm(fresh):
    from tfm_addon.scenes import stripes_gobo

    scene = smoke_scene(width=40, height=24, n=24)
    _, plain = _built(fresh, scene)
    light = scene.lights[0]
    delta, gobo = _built(fresh, replace(scene, lights=(replace(light, gobo=stripes_gobo(32, 4)),)))
    assert delta["gobos"] == 1 and delta.get("shadow_maps", 0) == 0 and delta.get("tfms", 0) == 0
    assert not np.allclose(gobo.combined, plain.combined)
    delta, _ = _built(fresh, replace(scene, lights=(replace(light, color=(1.0, 0.5, 0.2), power_w=900.0),)))
    assert sum(delta.get(k, 0) for k in ("shadow_maps", "tfms", "gobos", "gbuffers", "grid_uploads")) == 0


def test_sigma_edits_under_auto_rebuild_a_tfm_only_when_the_coefficient_count_grows(fresh):
    from tfm_addon.engine.renderer import effective_settings

    auto = dataclasses.replace(SETTINGS, quality="AUTO")
    scene = smoke_scene(width=40, height=24, n=24)
    thick = replace(scene, media=(replace(scene.media[0], sigma_s=(24.0, 24.0, 24.0)),))   # smooth: tau / 4
    slightly = replace(scene, media=(replace(scene.media[0], sigma_s=(2.2, 2.1, 2.0)),))
    n0, n1 = (effective_settings(s, auto).coefficients for s in (scene, thick))
    assert effective_settings(slightly, auto).coefficients == n0 and n1 > n0, (n0, n1)
    _built(fresh, scene, auto)
    delta, _ = _built(fresh, slightly, auto)                # same count: nothing rebuilt
    assert sum(delta.get(k, 0) for k in ("shadow_maps", "tfms", "gbuffers", "grid_uploads")) == 0
    delta, _ = _built(fresh, thick, auto)                   # more coefficients: one TFM (documented)
    assert delta["tfms"] == 1 and delta.get("shadow_maps", 0) == 0
    delta, back = _built(fresh, scene, auto)                # fewer: the wider map serves, exactly
    assert delta.get("tfms", 0) == 0
    # ... and its automatic alpha is AUTO's probe (a spot, one medium): no alpha pass was cached.
    assert sum(1 for k in fresh._tfms.items if k[-1] == "alpha") == 0
    other = Renderer()
    try:
        want = other.render(scene, auto).combined
    finally:
        other.release()
    assert float(np.abs(back.combined - want).max()) <= 1e-5 * float(want.max())


def test_a_preview_between_two_viewport_frames_evicts_none_of_the_viewports_maps(fresh):
    scene = smoke_scene(width=40, height=24, n=24)
    preview = smoke_scene(width=24, height=24, n=16, sigma_s=(1.0, 1.0, 1.0))
    light = replace(preview.lights[0], matrix_world=look_at((2, -2, 4), (0, 0, 1)))
    preview = replace(preview, lights=(light,))
    _built(fresh, scene, client="viewport")
    delta, _ = _built(fresh, preview, client="preview")
    assert delta["grid_uploads"] == 1 and delta["tfms"] == 1
    delta, _ = _built(fresh, scene, client="viewport")
    assert sum(delta.get(k, 0) for k in ("shadow_maps", "tfms", "gbuffers", "grid_uploads")) == 0
    # A client's next frame still releases what only its previous frame used.
    moved = replace(scene, camera=replace(scene.camera, matrix_world=look_at((0.5, -6, 2), (0, 0, 1))))
    _built(fresh, moved, client="viewport")
    assert len(fresh._gbuffers.items) == 2                 # the preview's and the moved view's
    fresh.forget_client("preview")
    assert len(fresh._gbuffers.items) == 1 and len(fresh._media.items) == 1


def scaled(scene, s: float):
    """The scene scaled by ``s`` about the origin, sigma / s and power * s^2: every optical depth
    and every pixel's radiance stay the same."""
    S = np.diag([s, s, s, 1.0])

    def place(m):
        return S @ np.asarray(m) @ np.diag([1 / s, 1 / s, 1 / s, 1.0])    # rigid part moved, not scaled
    cam = replace(scene.camera, matrix_world=place(scene.camera.matrix_world),
                  clip_start=scene.camera.clip_start * s, clip_end=scene.camera.clip_end * s)
    lights = tuple(replace(light, matrix_world=place(light.matrix_world), power_w=light.power_w * s * s)
                   for light in scene.lights)
    meshes = tuple(replace(m, matrix_world=S @ np.asarray(m.matrix_world)) for m in scene.meshes)
    med = scene.media[0]
    placed = {k: S @ np.asarray(getattr(med, k)) for k in ("index_to_world", "box_to_world")
              if getattr(med, k) is not None}
    med = replace(med, sigma_a=tuple(x / s for x in med.sigma_a), sigma_s=tuple(x / s for x in med.sigma_s),
                  **placed)
    return replace(scene, camera=cam, lights=lights, meshes=meshes, media=(med,))


def test_the_smoke_at_1mm_1m_and_1km_gives_the_same_image(renderer):
    """The demo's smoke with its bar's shadow shaft; 0.1 mm too, where the former absolute 2 mm
    shadow bias lost the shaft (1.27x the 1 m image's mean)."""
    from tfm_addon.engine.metrics import ssim
    from tfm_addon.scenes import demo_scene

    scene = demo_scene(width=64, height=36, n=32)
    settings = dataclasses.replace(SETTINGS, map_resolution=128)
    metre = renderer.render(scene, settings).rgb
    for s in (1e-4, 1e-3, 1e3):
        other = renderer.render(scaled(scene, s), settings).rgb
        assert np.isfinite(other).all()
        value = ssim(other, metre)
        ratio = float(other.mean() / metre.mean())
        assert value >= 0.99 and abs(ratio - 1.0) <= 0.02, (s, value, ratio)


def _random_scene(rng, i):
    """A small scene drawn at random: see test_randomised_scenes_render_finite_and_warned."""
    from tfm_addon.engine import Camera, Light, Medium, Scene
    from tfm_addon.scenes import grid_to_world, plane_mesh, smoke_density, translate_scale

    kind = ["smoke", "smoke", "smoke", "empty", "tiny", "bad", "fog box"][i % 7]
    center = np.array([0.0, 0.0, 1.2])
    depth = 0.0 if rng.random() < 0.1 else 10 ** rng.uniform(-1.0, 4.0)     # optical depth across 2 m
    sigma_s = depth / 2.0 * rng.uniform(0.3, 1.0, 3)
    sigma_a = depth / 2.0 * rng.uniform(0.0, 0.3, 3)
    if kind == "fog box":
        medium = Medium(sigma_a=tuple(sigma_a), sigma_s=tuple(sigma_s),
                        box_to_world=translate_scale(center, 1.0))
    else:
        shape = {"tiny": tuple(int(x) for x in rng.integers(1, 4, 3))}.get(kind, (16, 16, 16))
        d = smoke_density(16, seed=i) if kind in ("smoke", "bad") else np.zeros(shape, np.float32)
        if kind == "tiny":
            d = rng.uniform(0.0, 1.0, shape).astype(np.float32)
        if kind == "bad":
            d = np.array(d)
            for value in (np.nan, np.inf, -1.0):
                d[tuple(rng.integers(4, 12, 3))] = value
        medium = Medium(sigma_a=tuple(sigma_a), sigma_s=tuple(sigma_s),
                        anisotropy=float(rng.uniform(-0.5, 0.8)), density=d,
                        index_to_world=grid_to_world(d.shape, 2.0, tuple(center)))
    cone = float(rng.uniform(5.0, 180.0))
    if rng.random() < 0.3:                     # the light inside the medium
        eye = center + rng.uniform(-0.3, 0.3, 3)
    else:
        eye = center + rng.normal(size=3) / 0.5 * 1.0
        eye = center + (eye - center) / np.linalg.norm(eye - center) * rng.uniform(2.5, 5.0)
    light = Light(matrix_world=look_at(tuple(eye), tuple(center + rng.uniform(-0.5, 0.5, 3))),
                      power_w=float(10 ** rng.uniform(1, 3.5)), spot_size_rad=float(np.radians(cone)),
                      spot_blend=float(rng.uniform(0, 1)), name=f"Spot{i}")
    if rng.random() < 0.25:                    # the camera inside the medium
        cam_eye = center + rng.uniform(-0.3, 0.3, 3)
    else:
        cam_eye = center + np.array([rng.uniform(-1, 1), -rng.uniform(4.0, 7.0), rng.uniform(-0.5, 1.5)])
    camera = Camera(matrix_world=look_at(tuple(cam_eye), tuple(center + rng.uniform(-0.4, 0.4, 3))),
                    width_px=24, height_px=16, lens_mm=float(rng.uniform(18, 50)), clip_start=0.05)
    meshes = (plane_mesh((0, 0, 0), 8.0),) if rng.random() < 0.6 else ()
    scene = Scene(camera=camera, lights=(light,), media=(medium,), meshes=meshes,
                  ambient=(0.01, 0.01, 0.02) if rng.random() < 0.3 else (0.0, 0.0, 0.0))
    return kind, depth, cone, scaled(scene, float(10 ** rng.uniform(-3.0, 3.0)))


def test_randomised_scenes_render_finite_and_warned(renderer):
    """~100 small random scenes (fixed seed): cameras and lights inside and outside the media,
    scales 1 mm to 1 km, empty, tiny and bad-voxel grids, optical depths 0 to 1e4, cones to 180
    degrees, CUSTOM and AUTO quality. Every render is finite and says what it could not render;
    the well-posed CUSTOM ones (a grid or box of optical depth <= 8, a cone <= 170 degrees) are
    within SSIM 0.98 of the reference. (AUTO is not compared: on these 16^3 grids at 24x16 it
    chooses 32 view steps, SSIM 0.945 on scene 65; its rule is tuned on the benchmark's scenes.)"""
    from references import render_reference

    from tfm_addon.engine.medium_grid import clean_density
    from tfm_addon.engine.metrics import ssim

    rng = np.random.default_rng(14)
    custom = RenderSettings(view_steps=48, light_steps=48, map_resolution=64, coefficients=16)
    compared, failures, lowest = 0, [], 1.0
    for i in range(98):
        kind, depth, cone, scene = _random_scene(rng, i)
        settings = dataclasses.replace(custom, quality="AUTO") if i % 2 else custom
        out = renderer.render(scene, settings)
        assert np.isfinite(out.combined).all(), (i, kind)
        said = " | ".join(out.warnings)
        assert ("wider than the 170 degrees" in said) == (cone > 170.0 + 1e-6), (i, cone, said)
        for name in ("NaN", "infinite", "negative"):
            assert sum(f"1 {name} voxel" in w for w in out.warnings) == (kind == "bad"), (i, said)
        assert ("density grid is empty" in said) == (kind == "empty"), (i, said)
        if kind in ("smoke", "tiny", "fog box") and depth <= 8.0 and cone <= 170.0 and not i % 2:
            medium = scene.media[0]
            if medium.density is not None:
                medium = replace(medium, density=clean_density(medium.density)[0])
            ref = render_reference(replace(scene, media=(medium,)), settings, view_steps=96, light_steps=96)
            value = ssim(out.rgb, ref.rgb)
            compared += 1
            lowest = min(lowest, value)
            if value < 0.98:
                failures.append((i, round(value, 4), round(depth, 2), round(cone)))
    print(f"randomised: 98 renders, {compared} against the reference, lowest SSIM {lowest:.4f}")
    assert compared >= 10 and not failures, (compared, failures)


def test_a_cone_wider_than_170_degrees_renders_as_170_and_says_so(renderer):
    scene = smoke_scene(width=40, height=24, n=24)
    light = replace(scene.lights[0], spot_size_rad=float(np.radians(178.0)), spot_blend=0.0)
    out = renderer.render(replace(scene, lights=(light,)), SETTINGS)
    assert [w for w in out.warnings if "wider than" in w] == [
        f"Spot '{light.name}': its cone (178 degrees) is wider than the 170 degrees its maps cover; "
        "it is rendered as a 170 degree cone."]
    as_170 = renderer.render(replace(scene, lights=(replace(light, spot_size_rad=float(np.radians(170.0))),)),
                             SETTINGS)
    assert as_170.warnings == []
    np.testing.assert_allclose(out.combined, as_170.combined, atol=1e-5 * float(as_170.combined.max()))


def test_what_a_cancelled_viewport_frame_built_survives_a_preview(fresh):
    scene = smoke_scene(width=40, height=24, n=24)
    preview = smoke_scene(width=24, height=24, n=16, sigma_s=(1.0, 1.0, 1.0))
    with pytest.raises(RenderCancelled):
        fresh.render(scene, SETTINGS, cancel=_cancel_after(3), client="viewport")   # after the G-buffer
    fresh.render(preview, SETTINGS, client="preview")
    delta, _ = _built(fresh, scene, client="viewport")
    assert sum(delta.get(k, 0) for k in ("shadow_maps", "tfms", "gbuffers", "grid_uploads")) == 0


def test_a_run_of_cancelled_viewport_frames_holds_two_frames_of_maps(fresh):
    """A light dragged in the viewport: each request's coarse frame (sweep=False) and cancelled
    full frame build maps for a new light position. Only the last completed frame's maps and the
    cancelled frame's stay (the cache held every position's maps until a frame completed)."""
    scene = smoke_scene(width=40, height=24, n=24)
    fresh.render(scene, SETTINGS, client="viewport")
    light = scene.lights[0]
    for i in range(6):
        moved = replace(scene, lights=(replace(light, matrix_world=look_at((-2.0 + 0.3 * i, -1.5, 4.5),
                                                                          (0, 0, 1.0))),))
        small = replace(moved, camera=replace(moved.camera, width_px=10, height_px=6))
        fresh.render(small, replace(SETTINGS, map_resolution=32), client="viewport", sweep=False)
        with pytest.raises(RenderCancelled):           # after the light's maps
            fresh.render(moved, SETTINGS, cancel=_cancel_after(2), client="viewport")
    shadows = len(fresh._shadows.items)
    tfms = sum(1 for k in fresh._tfms.items if k[-1] != "alpha")
    assert (shadows, tfms) == (2, 2)


def test_auto_statistics_clean_a_new_grid_once(monkeypatch):
    """AUTO's bounds and grid summary share one cleaning of a new grid (each cleaned it: 56 ms
    a 256^3 grid with Blender's default clipping, per new frame of a sequence)."""
    from tfm_addon.engine import quality

    calls = []
    real = quality.clean_density
    monkeypatch.setattr(quality, "clean_density", lambda d, c=0.0: calls.append(1) or real(d, c))
    scene = smoke_scene(width=40, height=24, n=20)
    d = np.array(scene.media[0].density) * 1.01         # a density no earlier test cached
    medium = replace(scene.media[0], density=d, clipping=0.001)
    stats = quality.medium_stats(replace(scene, media=(medium,)))
    assert len(calls) == 1
    assert stats.view_voxels > 0 and stats.optical_depth > 0 and stats.sharpness > 0
