"""A constant emission that glows by blocks (scene.GlowBlocks: where Cycles' volume mesh puts a
volume, extract.glow_blocks) against the numpy reference, which masks its emission by the same
blocks: the engine's march adds the constant part only in the blocks that are in."""

import dataclasses

import numpy as np
import pytest
from references import render_reference

from tfm_addon import scenes
from tfm_addon.engine import RenderSettings, metrics
from tfm_addon.engine.scene import GlowBlocks, GridValue

SETTINGS = RenderSettings(view_steps=96, light_steps=96, map_resolution=128, coefficients=8)


def _glowing(with_light: bool):
    scene = scenes.fire_scene(64, 36, 24, kind="EMISSION", with_light=with_light)
    m = scene.media[0]
    n = np.asarray(m.density.shape)
    # Blocks of 8 voxels from index -6 (beyond the grid), every other one in along x.
    shape = tuple(int(k) for k in np.ceil((n + 12) / 8.0))
    mask = np.ones(shape, bool)
    mask[1::2, :, :] = False
    glow = GlowBlocks((-6.0, -6.0, -6.0), 8.0, mask)
    medium = dataclasses.replace(m, emission_strength=GridValue("flame", 4.0, 0.3), glow=glow)
    return dataclasses.replace(scene, media=(medium,)), glow


def test_glow_blocks_know_their_box_and_points():
    glow = GlowBlocks((-6.0, -6.0, -6.0), 8.0, np.pad(np.ones((1, 2, 1), bool), ((1, 0), (0, 0), (0, 1))))
    assert glow.box == ((2.0, -6.0, -6.0), (10.0, 10.0, 2.0))
    points = np.array([[3.0, 0.0, 0.0], [1.9, 0.0, 0.0], [3.0, 0.0, 2.5]])
    assert list(glow.contains(points)) == [True, False, False]
    with pytest.raises(ValueError):
        GlowBlocks((0.0, 0.0, 0.0), 8.0, np.zeros((2, 2, 2), bool))


@pytest.mark.parametrize("with_light", [False, True])
def test_a_constant_emission_glows_in_its_blocks_as_the_reference(fresh, with_light):
    scene, glow = _glowing(with_light)
    out = fresh.render(scene, SETTINGS).combined[..., :3]
    compiled = {dict(k[2]).get("GLOW_BLOCKS") for k in fresh.gl._programs if k[1] == "scatter.frag"}
    assert 1 in compiled
    ref = render_reference(scene, view_steps=192, light_steps=96).combined[..., :3]
    plain = fresh.render(dataclasses.replace(scene, media=(dataclasses.replace(scene.media[0], glow=None),)),
                         SETTINGS).combined[..., :3]
    ratio = out.sum(axis=(0, 1)) / ref.sum(axis=(0, 1))
    print(f"glow blocks (light {with_light}): SSIM {metrics.ssim(out, ref):.4f}, "
          f"brightness {np.round(ratio, 4)}; "
          f"without the blocks {plain.sum() / ref.sum():.3f} of the reference")
    assert ref.max() > 0.05
    assert metrics.ssim(out, ref) >= 0.99
    assert np.all(np.abs(ratio - 1.0) <= 0.01)
    assert abs(plain.sum() / ref.sum() - 1.0) > 0.05        # the blocks change the image


def test_a_gl_with_16_texture_units_glows_over_the_grid_s_box_and_says_so(fresh):
    """The glow blocks' unit is above the 16 GL guarantees: with 16 the constant emission glows
    over the grid's box (no GLOW_BLOCKS program), which the report says once."""
    scene, _glow = _glowing(False)
    fresh.gl.ctx.info["GL_MAX_TEXTURE_IMAGE_UNITS"] = 16      # moderngl keeps this dict
    out = fresh.render(scene, SETTINGS)
    plain = fresh.render(dataclasses.replace(scene, media=(dataclasses.replace(scene.media[0], glow=None),)),
                         SETTINGS)
    compiled = {dict(k[2]).get("GLOW_BLOCKS") for k in fresh.gl._programs if k[1] == "scatter.frag"}
    assert 1 not in compiled
    assert sum("too few texture units" in w for w in out.warnings) == 1, out.warnings
    assert np.abs(out.combined - plain.combined).max() <= 1e-6
