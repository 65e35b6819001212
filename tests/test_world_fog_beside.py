"""Fog without bounds (the World's Volume) beside other media: added to their march and to every
light's transmittance in closed form, against the numpy reference (which marches it with them)."""

import dataclasses

import numpy as np
from references import render_reference

from tfm_addon.engine import Light, Medium, RenderSettings
from tfm_addon.engine.metrics import brightness_ratio, ssim
from tfm_addon.scenes import look_at, smoke_scene

FOG = Medium(sigma_a=(0.01, 0.01, 0.01), sigma_s=(0.06, 0.05, 0.04), anisotropy=0.3, name="World fog")


def test_fog_beside_a_smoke_matches_reference(renderer):
    """A spot and a point light in fog overlapping a smoke: the fog's shafts, the smoke's shadow in
    them and the fog's extinction of the light reaching the smoke and the ground."""
    scene = smoke_scene(width=40, height=30, n=16)
    point = Light(matrix_world=look_at((-2.0, -2.0, 2.5), (0.0, 0.0, 0.0)), power_w=800.0, kind="POINT")
    camera = dataclasses.replace(scene.camera, clip_end=20.0)     # the fog's rays end there
    scene = dataclasses.replace(scene, camera=camera, media=(*scene.media, FOG),
                                lights=(*scene.lights, point))
    ref = render_reference(scene, view_steps=160, light_steps=24)
    out = renderer.render(scene, RenderSettings(view_steps=64, light_steps=64, coefficients=8,
                                                map_resolution=128))
    assert not out.warnings
    s, b = ssim(out.rgb, ref.rgb), brightness_ratio(out.rgb, ref.rgb)
    print(f"fog beside a smoke against the reference: SSIM {s:.4f}, brightness {b:.4f}")
    assert s >= 0.98 and abs(b - 1.0) <= 0.03, (s, b)
    np.testing.assert_allclose(out.passes["transmittance"], ref.passes["transmittance"], atol=2e-3)
    # the fog is there: without it the image differs
    bare = renderer.render(dataclasses.replace(scene, media=scene.media[:1]),
                           RenderSettings(view_steps=64, light_steps=64, coefficients=8, map_resolution=128))
    assert ssim(bare.rgb, ref.rgb) < 0.9


def test_a_sun_does_not_reach_through_absorbing_fog(renderer):
    """Cycles' fog without bounds takes all the light of a sun (it comes from infinitely far): the
    sun's faces are culled, the frame is dark, as Cycles renders it (64x48, 32 samples: mean 0.0)."""
    scene = smoke_scene(width=16, height=12, n=8)
    sun = Light(matrix_world=look_at((1.0, -1.0, 3.0), (0.0, 0.0, 0.0)), power_w=3.0, kind="SUN")
    lit = dataclasses.replace(scene, lights=(sun,))
    assert renderer.render(lit, RenderSettings()).rgb.max() > 0.01
    for media in ((FOG,), (*scene.media, FOG)):
        culled = renderer.counters["faces_culled"]
        out = renderer.render(dataclasses.replace(lit, media=media), RenderSettings())
        assert out.rgb.max() == 0.0 and renderer.counters["faces_culled"] == culled + 1
