"""Grey extinction (passes/scattering.grey_extinction): where every medium's extinction is the same
in the three channels the march computes one exponential per sample instead of three. Images
against the numpy reference; the program is chosen by the media."""

import dataclasses

import numpy as np
import pytest
from references import render_reference

from tfm_addon import scenes
from tfm_addon.engine import Renderer, RenderSettings, metrics

SETTINGS = RenderSettings(view_steps=64, light_steps=64, map_resolution=96, coefficients=6)


def _compiled(gl) -> set:
    return {dict(k[2]).get("GREY_EXTINCTION") for k in gl._programs if k[1] == "scatter.frag"}


def _scene(grey: bool, method: str):
    scene = scenes.smoke_scene(width=64, height=36, n=32, with_ground=True,
                               sigma_s=(1.5, 1.5, 1.5), sigma_a=(0.2, 0.2, 0.2) if grey else (0.1, 0.2, 0.4))
    if method == "two media":     # a second, grey or coloured, instance beside the first
        m = scene.media[0]
        placed = m.index_to_world.copy()
        placed[0, 3] += 0.8
        other = dataclasses.replace(m, name="Other", index_to_world=placed,
                                    sigma_a=(0.3, 0.3, 0.3) if grey else (0.3, 0.1, 0.05))
        scene = dataclasses.replace(scene, media=(m, other))
    return scene


@pytest.mark.parametrize("method", ["TFM", "BRUTE_FORCE", "two media"])
@pytest.mark.parametrize("grey", [True, False])
def test_grey_extinction_is_compiled_where_the_media_are_grey_and_keeps_the_reference(grey, method):
    scene = _scene(grey, method)
    settings = dataclasses.replace(SETTINGS, method="BRUTE_FORCE" if method == "BRUTE_FORCE" else "TFM")
    r = Renderer()
    try:
        image = r.render(scene, settings).combined
        compiled = _compiled(r.gl)
    finally:
        r.release()
    assert compiled == {int(grey)}, compiled
    ref = render_reference(scene, settings, view_steps=64, light_steps=64).combined[..., :3]
    assert float(ref.max()) > 0.05
    ssim = metrics.ssim(image[..., :3], ref)
    ratio = image[..., :3].sum(axis=(0, 1)) / ref.sum(axis=(0, 1))
    print(f"{method} grey={grey}: SSIM {ssim:.4f}, brightness {np.round(ratio, 4)}")
    assert ssim >= 0.98
    assert np.all(np.abs(ratio - 1.0) <= 0.02), ratio
