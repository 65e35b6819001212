"""Bad input gets a clear message and a usable image, never a crash."""

import dataclasses
import math

import numpy as np
import pytest

from tfm_addon.engine import GLUnavailableError, Light, RenderCancelled, Renderer, RenderSettings
from tfm_addon.engine.gl_context import GLContext
from tfm_addon.engine.metrics import ssim
from tfm_addon.engine.worker import RenderWorker
from tfm_addon.scenes import look_at, smoke_scene

SETTINGS = RenderSettings(view_steps=48, light_steps=48, map_resolution=128)


def replace(obj, **changes):
    fields = {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)}
    return type(obj)(**{**fields, **changes})


def with_density(scene, density):
    return replace(scene, media=(replace(scene.media[0], density=density),))


def test_nan_inf_and_negative_densities_are_cleaned_with_a_warning(renderer):
    scene = smoke_scene(width=48, height=32, n=32)
    d = np.array(scene.media[0].density)
    clean = renderer.render(scene, SETTINGS)
    assert clean.warnings == []
    d[0, 0, 0], d[1, 2, 3], d[4, 4, 4], d[5, 5, 5] = np.nan, np.inf, -np.inf, -3.0
    out = renderer.render(with_density(scene, d), SETTINGS)
    assert "The density grid has 1 NaN voxel; rendered as 0." in out.warnings, out.warnings
    assert "The density grid has 2 infinite voxels; rendered as 0." in out.warnings
    assert "The density grid has 1 negative voxel; rendered as 0." in out.warnings
    assert np.isfinite(out.combined).all()
    # The bad voxels sat at the empty border of the grid: the image is the clean one.
    np.testing.assert_allclose(out.combined, clean.combined, atol=1e-4)


def test_grid_over_the_memory_budget_is_downsampled_with_a_warning(renderer):
    scene = smoke_scene(width=64, height=48, n=64)
    full = renderer.render(scene, SETTINGS)
    small = renderer.render(scene, dataclasses.replace(SETTINGS, max_grid_bytes=40**3 * 4))
    assert any("downsampled by 2 to 32x32x32" in w for w in small.warnings), small.warnings
    assert ssim(small.rgb, full.rgb) >= 0.97


def test_grid_over_the_gl_3d_texture_limit_is_downsampled(fresh_renderer):
    scene = smoke_scene(width=48, height=32, n=48)
    fresh_renderer.gl.max_3d_texture_size = 30          # as if the driver allowed 30 voxels a side
    out = fresh_renderer.render(scene, SETTINGS)
    assert any("exceeds the GPU limit (30 voxels" in w and "by 2 to 24x24x24" in w for w in out.warnings)
    assert np.isfinite(out.combined).all() and out.rgb.max() > 0


def test_empty_grid_renders_the_surfaces_alone(renderer):
    scene = smoke_scene(width=48, height=32, n=32)
    out = renderer.render(with_density(scene, np.zeros((32, 32, 32), np.float32)), SETTINGS)
    alone = renderer.render(replace(scene, media=()), SETTINGS)
    assert any("empty" in w for w in out.warnings)
    np.testing.assert_allclose(out.combined, alone.combined, atol=1e-6)
    assert alone.rgb.max() > 0
    out = renderer.render(with_density(scene, np.zeros((0, 0, 0), np.float32)), SETTINGS)
    np.testing.assert_allclose(out.combined, alone.combined, atol=1e-6)


@pytest.mark.parametrize(("change", "said"), [
    (dict(spot_size_rad=0.0), "has a spot cone of angle 0"), (dict(power_w=0.0), "has zero power"),
    (dict(power_w=-500.0), "has a negative power (-500 W), which renders as no light"),
    (dict(color=(0.0, 0.0, 0.0)), "has a black colour")], ids=["cone", "power", "negative", "black"])
def test_a_dark_light_renders_black_without_nan_and_says_why(renderer, change, said):
    scene = smoke_scene(width=48, height=32, n=32)
    scene = replace(scene, lights=(replace(scene.lights[0], name="Key", **change),))
    out = renderer.render(scene, SETTINGS)
    assert np.isfinite(out.combined).all()
    assert out.rgb.max() == 0.0
    lines = [w for w in out.warnings if w.startswith("No light lights the scene")]
    assert lines == [f"No light lights the scene ('Key' {said}): no light beam."], out.warnings


def test_no_spot_light_renders_surfaces_and_ambient_and_says_why(renderer):
    scene = replace(smoke_scene(width=48, height=32, n=32), lights=(), ambient=(0.1, 0.1, 0.1))
    out = renderer.render(scene, SETTINGS)
    assert out.rgb.max() > 0 and np.isfinite(out.combined).all()
    assert any("no spot light" in w for w in out.warnings)


def test_missing_opengl_raises_one_clear_error(monkeypatch):
    import moderngl

    def fail(**_kwargs):
        raise Exception("libEGL.so.1: cannot open shared object file")

    monkeypatch.setattr(moderngl, "create_standalone_context", fail)
    with pytest.raises(GLUnavailableError) as err:
        Renderer().render(smoke_scene(width=8, height=8, n=8))
    message = str(err.value)
    assert "OpenGL 3.3" in message and "libEGL.so.1" in message and "install" in message


def test_cancel_stops_between_passes_and_leaves_the_renderer_usable(fresh_renderer):
    scene = smoke_scene(width=48, height=32, n=32)
    calls = []

    def cancel():
        calls.append(1)
        return True

    with pytest.raises(RenderCancelled):
        fresh_renderer.render(scene, SETTINGS, cancel=cancel)
    assert len(calls) == 1, "the first check after a pass stops the render"
    assert fresh_renderer.counters["renders"] == 0
    out = fresh_renderer.render(scene, SETTINGS)
    assert np.isfinite(out.combined).all() and out.rgb.max() > 0


def test_worker_renders_like_the_renderer_and_releases_its_context(renderer):
    scene = smoke_scene(width=48, height=32, n=32)
    live = GLContext.live
    worker = RenderWorker()
    progress = []
    out = worker.render(scene, SETTINGS, progress=progress.append)
    assert GLContext.live == live + 1
    assert progress[-1] == 1.0 and progress == sorted(progress)
    np.testing.assert_allclose(out.combined, renderer.render(scene, SETTINGS).combined, atol=1e-6)
    assert worker.counters["renders"] == 1
    worker.close()
    assert not worker.alive and GLContext.live == live


def test_light_with_cone_wider_than_the_map_still_renders(renderer):
    scene = smoke_scene(width=48, height=32, n=32)
    wide = Light(matrix_world=look_at((-2.5, -1.0, 4.0), (0, 0, 1.0)), power_w=500.0,
                     spot_size_rad=math.radians(179.0))
    out = renderer.render(replace(scene, lights=(wide,)), SETTINGS)
    assert np.isfinite(out.combined).all() and out.rgb.max() > 0


@pytest.fixture
def fresh_renderer():
    r = Renderer()
    yield r
    r.release()
