"""Issue 14: frames are transactions, bad voxels, exact cache keys, scale-free biases, lights."""

import dataclasses

import numpy as np
import pytest

from tfm_addon.engine import RenderCancelled, Renderer, RenderSettings
from tfm_addon.scenes import look_at, smoke_scene

SETTINGS = RenderSettings(view_steps=32, light_steps=32, map_resolution=64)


def replace(obj, **changes):
    fields = {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)}
    return type(obj)(**{**fields, **changes})


@pytest.fixture
def fresh():
    r = Renderer()
    yield r
    r.release()


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
    d = np.array(scene.medium.density)
    d[12, 12, 12] = bad                             # in the middle of the smoke
    out = renderer.render(replace(scene, medium=replace(scene.medium, density=d.copy())), auto)
    name = "NaN" if np.isnan(bad) else "infinite"
    assert out.warnings == [f"The density grid has 1 {name} voxel; rendered as 0."]
    assert np.isfinite(out.combined).all()
    d[12, 12, 12] = 0.0
    zeroed = renderer.render(replace(scene, medium=replace(scene.medium, density=d)), auto)
    assert zeroed.warnings == []
    # The same AUTO settings and the same image as the grid with that voxel at 0.
    np.testing.assert_allclose(out.combined, zeroed.combined, atol=1e-6 * float(zeroed.combined.max()))


def test_clipping_empties_densities_below_it(renderer):
    scene = smoke_scene(width=40, height=24, n=24)
    d = np.array(scene.medium.density)
    clip = float(np.percentile(d[d > 0], 30))
    clipped = renderer.render(replace(scene, medium=replace(scene.medium, clipping=clip)), SETTINGS)
    zeroed = renderer.render(replace(scene, medium=replace(scene.medium, density=np.where(d < clip, 0, d))),
                             SETTINGS)
    full = renderer.render(scene, SETTINGS)
    assert clipped.warnings == []
    np.testing.assert_allclose(clipped.combined, zeroed.combined, atol=1e-6 * float(full.combined.max()))
    assert not np.allclose(clipped.combined, full.combined)
