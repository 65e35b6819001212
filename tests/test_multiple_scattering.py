"""Multiple scattering by octaves (engine/multiple_scattering.py, shaders/octaves.glsl): the bounce
count reads the same maps (counters), and the octave sum against independent renders: an octave
whose light transmittance is T^0 = 1 adds the unshadowed image (times the albedo) in fog that fills
the scene, one with T^1 the single-scattering image again; thin media gain less than thick ones.
(Against Cycles with bounces: tests/blender/test_multiple_scattering.py.)"""

import dataclasses

import numpy as np

from tfm_addon import scenes
from tfm_addon.engine import RenderSettings
from tfm_addon.engine.multiple_scattering import SINGLE, Octaves, octaves

SETTINGS = RenderSettings(view_steps=48, light_steps=48, map_resolution=64, coefficients=6, ambient=False)
MAPS = ("tfms", "shadow_maps", "grid_uploads", "gbuffers")
FOG_SA = (0.05, 0.05, 0.05)
FOG_ALBEDO = 0.5 / 0.55


def _scene():
    return scenes.smoke_scene(width=48, height=32, n=24, with_ground=True)


def _scatter(renderer, **kw) -> np.ndarray:
    out = renderer.render(_scene(), dataclasses.replace(SETTINGS, **kw))
    return out.passes["scattering"].astype(np.float64)


def test_bounce_count_rebuilds_no_map(fresh):
    single = _scatter(fresh)
    built = {k: fresh.counters[k] for k in MAPS}
    sixteen = _scatter(fresh, volume_bounces=16)
    fields = fresh.counters["fluences"]
    many = _scatter(fresh, volume_bounces=128)
    assert {k: fresh.counters[k] for k in MAPS} == built
    assert fields == 1 and fresh.counters["fluences"] == 1      # the fields too: built once
    assert built["tfms"] >= 1
    assert sixteen.sum() > 1.05 * single.sum()
    assert many.sum() >= sixteen.sum()
    assert np.array_equal(_scatter(fresh, volume_bounces=0), single)
    report = fresh.render(_scene(), dataclasses.replace(SETTINGS, volume_bounces=16)).warnings
    assert [w for w in report if w.startswith("Volume Bounces 16: multiple scattering approximated")]
    assert not [w for w in fresh.render(_scene(), SETTINGS).warnings if w.startswith("Volume Bounces")]


def test_fields_light_the_media_in_proportion_to_their_weights(fresh):
    """The diffused light and the surfaces' light (engine/diffusion.py) add light where the medium
    is and nowhere else, in proportion to their weights, from one build."""
    single = _scatter(fresh)
    out = {}
    for name, o in (("surface", Octaves(1, surface=1.0)), ("grid", Octaves(1, grid=1.0)),
                    ("grid2", Octaves(1, grid=2.0))):
        out[name] = _scatter(fresh, volume_bounces=16, octaves=o) - single
    assert fresh.counters["fluences"] == 1
    seen = fresh.render(_scene(), SETTINGS).passes["transmittance"]
    medium = seen.min(axis=-1) < 1.0 - 1e-6          # pixels that see the medium
    for name in ("surface", "grid"):
        assert out[name][medium].sum() > 0.01 * single.sum(), name
        assert np.abs(out[name][~medium]).max() <= 1e-6 * single.max(), name
        assert out[name].min() >= -1e-6 * single.max(), name
    np.testing.assert_allclose(out["grid2"], 2.0 * out["grid"], rtol=1e-4, atol=1e-6 * single.max())


def test_a_gl_with_16_texture_units_says_so_and_keeps_the_slab_term(fresh):
    """Where the GL lacks the two units of the fields they are left out, said once, and the slab
    diffusion term lights the thick media instead."""
    fresh.gl.ctx.info["GL_MAX_TEXTURE_IMAGE_UNITS"] = 16
    single = _scatter(fresh)
    out = fresh.render(_scene(), dataclasses.replace(SETTINGS, volume_bounces=16))
    assert [w for w in out.warnings if "too few texture units" in w]
    assert fresh.counters["fluences"] == 0
    assert out.passes["scattering"].sum() > 1.05 * single.sum()


def test_zero_bounces_is_single_scattering():
    assert octaves(0) == SINGLE and SINGLE.count == 1
    assert octaves(16).count > 1 and octaves(128).count >= octaves(16).count


def _fog_scatter(renderer, **kw) -> np.ndarray:
    """Fog everywhere (no way out for the light: T_through = 0, each octave keeps b albedo)."""
    scene = scenes.homogeneous_box_scene(width=48, height=32, sigma_s=(0.5, 0.5, 0.5), sigma_a=FOG_SA)
    scene = dataclasses.replace(scene, media=(dataclasses.replace(scene.media[0], box_to_world=None),))
    out = renderer.render(scene, dataclasses.replace(SETTINGS, **kw))
    return out.passes["scattering"].astype(np.float64)


def test_octave_with_no_light_extinction_adds_the_unshadowed_image(renderer):
    single = _fog_scatter(renderer)
    unshadowed = _fog_scatter(renderer, method="UNSHADOWED")
    both = _fog_scatter(renderer, volume_bounces=1, octaves=Octaves(2, a=0.0, b=1.0, c=1.0))
    assert unshadowed.sum() > 1.2 * single.sum()        # the fog shadows itself
    np.testing.assert_allclose(both, single + FOG_ALBEDO * unshadowed, rtol=2e-3, atol=1e-5 * single.max())


def test_octave_with_the_same_extinction_repeats_single_scattering(renderer):
    single = _fog_scatter(renderer)
    thrice = _fog_scatter(renderer, volume_bounces=1, octaves=Octaves(3, a=1.0, b=0.5, c=1.0))
    factor = 1.0 + 0.5 * FOG_ALBEDO + (0.5 * FOG_ALBEDO) ** 2
    np.testing.assert_allclose(thrice, factor * single, rtol=2e-3, atol=1e-5 * single.max())


def test_thin_media_let_the_octaves_light_out(renderer):
    """The octaves scale by 1 - T_through: a thin puff gains less than a thick one."""
    alone = dataclasses.replace(octaves(16), k=0.0, surface=0.0, grid=0.0)      # the octaves alone
    gains = []
    for scale in (0.1, 3.0):
        scene = scenes.smoke_scene(width=48, height=32, n=24, sigma_s=(2.0 * scale,) * 3,
                                   sigma_a=(0.2 * scale,) * 3, with_bar=False)
        single = renderer.render(scene, SETTINGS).passes["scattering"].sum()
        multi = renderer.render(scene, dataclasses.replace(SETTINGS, volume_bounces=16, octaves=alone))
        multi = multi.passes["scattering"].sum()
        gains.append(multi / single)
    assert 1.0 < gains[0] < 1.1 and gains[1] > gains[0] + 0.2, gains


def test_diffusion_term_lights_thick_media_only(renderer):
    """The diffusion term (k) adds nothing to a thin puff and light to a thick one, in proportion to
    k; with k = 0 the octaves are unchanged."""
    gains = []
    for scale in (0.1, 3.0):
        scene = scenes.smoke_scene(width=48, height=32, n=24, sigma_s=(2.0 * scale,) * 3,
                                   sigma_a=(0.2 * scale,) * 3, with_bar=False)

        def scatter(k, scene=scene):
            o = Octaves(2, a=0.5, b=0.0, c=0.5, k=k, z=0.5)
            out = renderer.render(scene, dataclasses.replace(SETTINGS, volume_bounces=16, octaves=o))
            return out.passes["scattering"].astype(np.float64)

        single = renderer.render(scene, SETTINGS).passes["scattering"].astype(np.float64)
        np.testing.assert_allclose(scatter(0.0), single, rtol=1e-5, atol=1e-6 * single.max())
        once, twice = scatter(0.5), scatter(1.0)
        np.testing.assert_allclose(twice - single, 2.0 * (once - single), rtol=1e-3, atol=1e-5 * single.max())
        gains.append(twice.sum() / single.sum())
    assert gains[0] < 1.01 and gains[1] > 1.2, gains


def test_a_light_linked_to_one_medium_adds_no_fields_to_the_other(fresh):
    """Light linking with bounces: a light that lights medium A only gives medium B neither its
    single scattering nor, through the lattice's fields, its diffused light (B gets only the little
    of A's light that crosses the gap), while lighting both lights B as much as A."""
    from tfm_addon.engine.scene import Light
    from tfm_addon.scenes import grid_to_world, look_at, smoke_density

    base = scenes.smoke_scene(width=48, height=32, n=20, with_bar=False, with_ground=False)
    m = base.media[0]
    media = tuple(dataclasses.replace(m, name=name, density=smoke_density(20),
                                      index_to_world=grid_to_world((20, 20, 20), 1.4, (x, 0, 1.2)))
                  for name, x in (("A", -1.2), ("B", 1.2)))
    light = Light(kind="POINT", matrix_world=look_at((0.0, -1.0, 4.0), (0, 0, 1.0)), power_w=3000.0)
    images = {}
    for lit in (None, ("A",)):
        scene = dataclasses.replace(base, media=media, lights=(dataclasses.replace(light, lit_media=lit),))
        out = fresh.render(scene, dataclasses.replace(SETTINGS, volume_bounces=16))
        images[lit] = out.passes["scattering"]
    half = images[None].shape[1] // 2
    left, right = (slice(None), slice(0, half)), (slice(None), slice(half, None))
    assert images[None][right].sum() > 0.5 * images[None][left].sum()
    # (the fields of the light through B, were they added, are 1.6 % of B's light here)
    assert images[("A",)][right].sum() < 1e-3 * images[None][right].sum()
    np.testing.assert_allclose(images[("A",)][left].sum(), images[None][left].sum(), rtol=0.05)
