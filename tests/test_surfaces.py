"""Surfaces shaded as Cycles' Principled BSDF (engine/surface.py, shaders/surface.glsl) against an
independent numpy evaluation of the same BSDF, and textured surfaces against their graph evaluated
in numpy. Each image is one flat ground seen by an orthographic camera, so that every pixel has the
same view and light directions."""

import math
from dataclasses import replace

import numpy as np
import pytest

from tfm_addon.engine import Camera, Light, RenderSettings, Scene
from tfm_addon.engine import shading as S
from tfm_addon.engine.sampling import render_samples
from tfm_addon.engine.surface import Surface, f0_from_ior, ggx_tables, mix
from tfm_addon.scenes import look_at, plane_mesh

VIEW_DEG, SUN_DEG, SUN = 70.0, 40.0, 3.0      # view and light angles from the normal; irradiance


def _direction(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def _render(renderer, surface, sun_phi=180.0, size=(8, 6)):
    v = _direction(VIEW_DEG, 0.0)
    camera = Camera(matrix_world=look_at(10.0 * v, (0, 0, 0)), width_px=size[0], height_px=size[1],
                    projection="ORTHO", ortho_scale=1.0, clip_end=100.0)
    sun = Light(kind="SUN", power_w=SUN, matrix_world=look_at(5.0 * _direction(SUN_DEG, sun_phi), (0, 0, 0)))
    ground = plane_mesh((0, 0, 0), 40.0)
    scene = Scene(camera=camera, lights=(sun,), media=(), meshes=(replace(ground, surface=surface),))
    return renderer.render(scene, RenderSettings(quality="CUSTOM")).combined[..., :3]


def _lut(table, x, y):
    n = table.shape[-1]
    fx, fy = np.clip(x, 0, 1) * (n - 1), np.clip(y, 0, 1) * (table.shape[-2] - 1)
    i0, j0 = min(int(fx), n - 1), min(int(fy), table.shape[-2] - 1)
    i1, j1 = min(i0 + 1, n - 1), min(j0 + 1, table.shape[-2] - 1)
    tx, ty = fx - i0, fy - j0
    return ((table[..., j0, i0] * (1 - tx) + table[..., j0, i1] * tx) * (1 - ty)
            + (table[..., j1, i0] * (1 - tx) + table[..., j1, i1] * tx) * ty)


def _fresnel(c, eta):
    g = math.sqrt(max(eta * eta - 1 + c * c, 0.0))
    a, b = (g - c) / (g + c), (c * (g + c) - 1) / (c * (g - c) + 1)
    return 0.5 * a * a * (1 + b * b)


def expected(s: Surface, sun_phi=180.0) -> np.ndarray:
    """Cycles' Principled BSDF times cos for this view and sun, by its published formulas."""
    t = ggx_tables()
    n, v, lt = np.array([0, 0, 1.0]), _direction(VIEW_DEG, 0.0), _direction(SUN_DEG, sun_phi)
    mu, ndl = v @ n, lt @ n
    h = (v + lt) / np.linalg.norm(v + lt)
    a2 = s.roughness ** 4
    d = a2 / (math.pi * (1 + (a2 - 1) * (n @ h) ** 2) ** 2)

    def lam(c):
        return 0.5 * (math.sqrt(1 + a2 * (1 / c ** 2 - 1)) - 1)

    spec = d * 0.25 / mu / (1 + lam(mu) + lam(ndl))
    e, eavg = _lut(t["E"], s.roughness, mu), np.interp(s.roughness, np.linspace(0, 1, 32), t["Eavg"])

    def comp(fss):
        fms = fss * eavg / (1 - fss * (1 - eavg))
        return 1 + fms * (1 - e) / e if s.multiscatter else 1.0

    base, tint = np.array(s.base_color), np.array(s.specular_tint)
    f0 = f0_from_ior(s.ior)
    z = math.sqrt(abs((s.ior - 1) / (s.ior + 1)))
    zi = z * 15
    k0 = min(int(zi), 15)
    k1 = min(k0 + 1, 15)
    sv = (_lut(t["s_ior"][k0], s.roughness, mu) * (1 - (zi - k0))
          + _lut(t["s_ior"][k1], s.roughness, mu) * (zi - k0))
    real_fss = (s.ior - 1) / (4.08567 + 1.00071 * s.ior)
    fss = f0 * tint + (1 - f0 * tint) * np.clip((real_fss - f0) / (1 - f0), 0, 1)
    c = comp(fss)
    albedo = (e * c if s.multiscatter else 1.0) * (f0 * tint + (1 - f0 * tint) * sv)
    diffuse = np.clip(1 - albedo.max(), 0, 1)
    sf = (_fresnel(v @ h, s.ior) - f0) / (1 - f0)
    f_d = f0 * tint + (1 - f0 * tint) * sf
    cc = np.clip(base, 0, 1)
    b = (cc + (1 - cc) * 0.46266436) * 17.651384 * (1 - np.minimum(tint, 1))
    q = 1 - v @ h
    f_m = np.clip(cc + (1 - cc) * q ** 5 - b * (v @ h) * q ** 6, 0, 1)
    fss_m = np.clip(cc + (1 - cc) / 21 - b / 126, 0, 1)
    m = s.metallic
    out = (1 - m) * (base * diffuse * ndl / math.pi + spec * f_d * c) + m * spec * f_m * comp(fss_m)
    return s.weight * SUN * out


@pytest.mark.parametrize("surface", [
    Surface(),
    Surface(base_color=(0.95, 0.64, 0.54), metallic=1.0, roughness=0.3),
    Surface(base_color=(0.1, 0.3, 0.8), roughness=0.2, ior=2.1, specular_tint=(1.0, 0.7, 0.4),
            multiscatter=False),
    Surface(base_color=(0.6, 0.5, 0.2), metallic=0.4, roughness=0.6, specular_tint=(0.8, 0.9, 1.0)),
], ids=["default", "copper", "tinted_ggx", "half_metal_tint"])
@pytest.mark.parametrize("sun_phi", [180.0, 30.0], ids=["highlight", "aside"])
def test_principled_matches_its_formulas(renderer, surface, sun_phi):
    """Every pixel within 0.5 % of the numpy evaluation (float32 and table interpolation)."""
    img = _render(renderer, surface, sun_phi)
    want = expected(surface, sun_phi)
    np.testing.assert_allclose(img, np.broadcast_to(want, img.shape), rtol=5e-3)


def test_lambert_and_emission(renderer):
    """A Lambertian ground gives albedo E cos / pi; an emission-only surface its radiance alone."""
    img = _render(renderer, None)
    cos = math.cos(math.radians(SUN_DEG))
    np.testing.assert_allclose(img, 0.8 * SUN * cos / math.pi, rtol=1e-4)
    img = _render(renderer, Surface(weight=0.0, emission=(0.5, 1.0, 2.0)))
    np.testing.assert_allclose(img, np.broadcast_to([0.5, 1.0, 2.0], img.shape), rtol=1e-5)


def test_alpha_is_the_fraction_of_samples_that_see_the_surface(renderer):
    """An emitting surface of alpha 0.4 over black: each pixel's mean over 32 samples is 0.4 of
    its radiance to within two samples (the samples' seeds are the R1 sequence), the image's mean
    to within 1 %; a Mix Shader's alpha is its parts' mean."""
    v = _direction(VIEW_DEG, 0.0)
    camera = Camera(matrix_world=look_at(10.0 * v, (0, 0, 0)), width_px=16, height_px=12,
                    projection="ORTHO", ortho_scale=1.0, clip_end=100.0)
    veil = Surface(weight=0.0, emission=(1.0, 1.0, 1.0), alpha=0.4)
    ground = replace(plane_mesh((0, 0, 0), 40.0), surface=veil)
    scene = Scene(camera=camera, lights=(), media=(), meshes=(ground,))
    img = render_samples(renderer, scene, RenderSettings(quality="CUSTOM"), 32,
                         adaptive_threshold=None).combined[..., 0]
    assert np.abs(img - 0.4).max() <= 2.0 / 32 + 1e-6
    assert img.mean() == pytest.approx(0.4, rel=0.01)
    assert mix([(0.5, veil), (0.5, Surface())]) == (replace(Surface(), base_color=Surface().base_color,
                                                            weight=0.5, emission=(0.5, 0.5, 0.5),
                                                            alpha=0.7), False)


def test_checker_texture_per_pixel(renderer):
    """A Checker Texture on Generated coordinates: each pixel the Lambertian shading of the colour
    the numpy graph gives at that pixel's point (pixels on a square's edge left out)."""
    graph = S.ShaderGraph((S.Node("TEX_CHECKER", (), (S.Input("Color1", "RGBA", (0.9, 0.7, 0.3)),
                                                        S.Input("Color2", "RGBA", (0.2, 0.2, 0.2)),
                                                        S.Input("Scale", "VALUE", 160.0))),),
                          S.Link(0, "Color", "RGBA"), texspace=((0.0, 0.0, 0.0), (0.5, 0.5, 0.0)))
    img = _render(renderer, Surface(base_texture=graph, ior=1.0, multiscatter=False), size=(32, 24))
    shade = SUN * math.cos(math.radians(SUN_DEG)) / math.pi
    colours = img / shade
    bright = np.isclose(colours, [0.9, 0.7, 0.3], atol=2e-3).all(-1)
    dark = np.isclose(colours, [0.2, 0.2, 0.2], atol=2e-3).all(-1)
    assert (bright | dark).mean() > 0.9 and 0.3 < bright.mean() < 0.7


def test_more_surfaces_than_the_table_holds_are_reported():
    from tfm_addon.engine.surface import MAX_MATERIALS, table_note

    meshes = [replace(plane_mesh((i, 0, 0), 0.5), surface=Surface(roughness=i / 1000.0))
              for i in range(MAX_MATERIALS + 1)]
    assert table_note(meshes[:MAX_MATERIALS]) == []
    assert "129 distinct surfaces" in table_note(meshes)[0]


def test_ambient_light_is_the_directional_albedo(renderer):
    """Uniform ambient light L: the surface's albedo toward the camera times L (the diffuse layer
    under the specular one, plus the specular layer's energy-compensated albedo)."""
    t = ggx_tables()
    s = Surface()
    v = _direction(VIEW_DEG, 0.0)
    camera = Camera(matrix_world=look_at(10.0 * v, (0, 0, 0)), width_px=8, height_px=6,
                    projection="ORTHO", ortho_scale=1.0, clip_end=100.0)
    scene = Scene(camera=camera, lights=(), media=(), ambient=(0.5, 0.5, 0.5),
                  meshes=(replace(plane_mesh((0, 0, 0), 40.0), surface=s),))
    img = renderer.render(scene, RenderSettings(quality="CUSTOM")).combined[..., :3]
    mu = math.cos(math.radians(VIEW_DEG))
    e, eavg = _lut(t["E"], s.roughness, mu), np.interp(s.roughness, np.linspace(0, 1, 32), t["Eavg"])
    f0 = f0_from_ior(s.ior)
    zi = math.sqrt((s.ior - 1) / (s.ior + 1)) * 15
    k0 = int(zi)
    sv = (_lut(t["s_ior"][k0], s.roughness, mu) * (1 - (zi - k0))
          + _lut(t["s_ior"][k0 + 1], s.roughness, mu) * (zi - k0))
    fss = f0 + (1 - f0) * ((s.ior - 1) / (4.08567 + 1.00071 * s.ior) - f0) / (1 - f0)
    fms = fss * eavg / (1 - fss * (1 - eavg))
    spec = (e + fms * (1 - e)) * (f0 + (1 - f0) * sv)
    want = 0.5 * (0.8 * (1 - spec) + spec)
    np.testing.assert_allclose(img, want, rtol=5e-3)


def test_roughness_texture_per_pixel(renderer):
    """A Checker Fac into Roughness (0.2 and 0.7) of a copper metal: each pixel is the BSDF of one
    of the two roughnesses (12-bit steps in the G-buffer), both seen."""
    checker = S.Node("TEX_CHECKER", (), (S.Input("Color1", "RGBA", (1.0, 1.0, 1.0)),
                                         S.Input("Color2", "RGBA", (0.0, 0.0, 0.0)),
                                         S.Input("Scale", "VALUE", 160.0)))
    ranged = S.Node("MAP_RANGE", (("interpolation_type", "LINEAR"), ("clamp", True)), (
        S.Input("Value", "VALUE", S.Link(0, "Fac")), S.Input("From Min", "VALUE", 0.0),
        S.Input("From Max", "VALUE", 1.0), S.Input("To Min", "VALUE", 0.2), S.Input("To Max", "VALUE", 0.7)))
    graph = S.ShaderGraph((checker, ranged), S.Link(1, "Result"), texspace=((0.0, 0.0, 0.0), (0.5, 0.5, 0.0)))
    copper = Surface(base_color=(0.95, 0.64, 0.54), metallic=1.0)
    img = _render(renderer, replace(copper, roughness_texture=graph), size=(32, 24))
    smooth, rough = expected(replace(copper, roughness=0.2)), expected(replace(copper, roughness=0.7))
    is_smooth = np.isclose(img, smooth, rtol=5e-3).all(-1)
    is_rough = np.isclose(img, rough, rtol=5e-3).all(-1)
    assert (is_smooth | is_rough).mean() > 0.9 and 0.3 < is_smooth.mean() < 0.7
