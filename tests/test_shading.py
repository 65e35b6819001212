"""engine/shading.py: node functions against Blender's documented formulas, and the split of
per-voxel fields into the renderer's medium (density, colour grid, emission grid)."""

import numpy as np
import pytest

from tfm_addon.engine import shading as S

L = S.Link


def _principled(density, color=(0.5, 0.5, 0.5), emission=0.0, anisotropy=0.0):
    ins = [("Color", "RGBA", color), ("Density", "VALUE", density), ("Anisotropy", "VALUE", anisotropy),
           ("Absorption Color", "RGBA", (0.0, 0.0, 0.0)), ("Emission Strength", "VALUE", emission),
           ("Emission Color", "RGBA", (1.0, 1.0, 1.0)), ("Blackbody Intensity", "VALUE", 0.0),
           ("Blackbody Tint", "RGBA", (1.0, 1.0, 1.0)), ("Temperature", "VALUE", 1000.0)]
    return S.Node("PRINCIPLED_VOLUME", (("density_attribute", ""),), tuple(S.Input(*i) for i in ins))


def _graph(*nodes):
    return S.ShaderGraph(tuple(nodes), L(len(nodes) - 1, "Volume", "SHADER"))


@pytest.mark.parametrize("op, a, b, c, expected", [
    ("DIVIDE", 1.0, 0.0, 0.0, 0.0), ("POWER", -8.0, 1.0 / 3.0, 0.0, 0.0), ("POWER", 2.0, 3.0, 0.0, 8.0),
    ("LOGARITHM", 8.0, 2.0, 0.0, 3.0), ("SQRT", -4.0, 0.0, 0.0, 0.0), ("FLOORED_MODULO", -1.0, 3.0, 0.0, 2.0),
    ("MODULO", -1.0, 3.0, 0.0, -1.0), ("WRAP", 5.5, 2.0, 1.0, 1.5), ("SNAP", 5.3, 2.0, 0.0, 4.0),
    ("PINGPONG", 3.0, 2.0, 0.0, 1.0), ("COMPARE", 1.0, 1.05, 0.1, 1.0), ("SMOOTH_MIN", 1.0, 1.0, 0.6, 0.9),
    ("INVERSE_SQRT", 4.0, 0.0, 0.0, 0.5), ("ROUND", -1.5, 0.0, 0.0, -1.0), ("TRUNC", -1.7, 0.0, 0.0, -1.0),
])
def test_math_operations(op, a, b, c, expected):
    out = S.MATH[op](np.asarray(a), np.asarray(b), np.asarray(c))
    assert float(out) == pytest.approx(expected, abs=1e-6)


def test_map_range_modes():
    def run(kind, v, clamp=True, steps=4.0):
        node = S.Node("MAP_RANGE", (("interpolation_type", kind), ("clamp", clamp)))
        ins = {"Value": np.asarray(v), "From Min": np.asarray(0.2), "From Max": np.asarray(0.6),
               "To Min": np.asarray(1.0), "To Max": np.asarray(3.0), "Steps": np.asarray(steps)}
        return float(S.NODES["MAP_RANGE"](node, ins, None)["Result"])
    assert run("LINEAR", 0.4) == pytest.approx(2.0)
    assert run("LINEAR", 0.9) == pytest.approx(3.0)
    assert run("LINEAR", 0.9, clamp=False) == pytest.approx(4.5)
    assert run("STEPPED", 0.45) == pytest.approx(1.0 + 2.0 * np.floor(0.625 * 5) / 4)
    t = 0.25
    assert run("SMOOTHSTEP", 0.3) == pytest.approx(1.0 + 2.0 * t * t * (3 - 2 * t))
    assert run("SMOOTHERSTEP", 0.3) == pytest.approx(1.0 + 2.0 * t ** 3 * (t * (t * 6 - 15) + 10))


def test_color_ramp_table_lookup_interpolates_like_cycles():
    table = np.linspace(0.0, 1.0, 256)[:, None] * np.array([[1.0, 0.5, 0.25, 1.0]])
    node = S.Node("COLOR_RAMP", (("table", tuple(table.ravel())), ("interpolate", True)))
    out = S.NODES["COLOR_RAMP"](node, {"Fac": np.array([0.3, 1.5, -1.0])}, None)
    assert out["Color"][:, 0] == pytest.approx([0.3, 1.0, 0.0], abs=1e-6)
    assert out["Color"][0, 1] == pytest.approx(0.15, abs=1e-6)


def test_conversions():
    rgb = np.array([[1.0, 0.0, 0.0]])
    assert float(S.convert(rgb, "RGBA", "VALUE")[0]) == pytest.approx(0.2126729)
    assert float(S.convert(rgb, "VECTOR", "VALUE")[0]) == pytest.approx(1.0 / 3.0)
    assert S.convert(np.array([0.5]), "VALUE", "RGBA").shape == (1, 3)


def test_resolve_grey_medium_with_varying_colour_keeps_extinction_and_scattering():
    rng = np.random.default_rng(1)
    d = rng.random((6, 5, 4)).astype(np.float32)
    c = rng.random((6, 5, 4, 3)).astype(np.float32)
    graph = _graph(S.Node("ATTRIBUTE", (("name", "density"),)), S.Node("ATTRIBUTE", (("name", "color"),)),
                   S.Node("PRINCIPLED_VOLUME", (("density_attribute", ""),),
                          tuple(S.Input(*i) for i in [
                              ("Color", "RGBA", L(1, "Color", "RGBA")), ("Density", "VALUE", L(0, "Fac")),
                              ("Anisotropy", "VALUE", 0.3), ("Absorption Color", "RGBA", (0.0, 0.0, 0.0)),
                              ("Emission Strength", "VALUE", 0.0), ("Emission Color", "RGBA", (1, 1, 1)),
                              ("Blackbody Intensity", "VALUE", 0.0), ("Blackbody Tint", "RGBA", (1, 1, 1)),
                              ("Temperature", "VALUE", 1000.0)])))
    r = S.resolve(graph, {"density": d, "color": c}, d.shape)
    # Principled Volume: sigma_t = density (colours <= 1, black absorption), sigma_s = density * colour
    np.testing.assert_allclose(r.density, d, rtol=1e-6)
    s = r.density[..., None] * np.asarray(r.sigma_s) * r.color
    np.testing.assert_allclose(s, d[..., None] * c, rtol=1e-5, atol=1e-6)
    assert r.sigma_a == (0.0, 0.0, 0.0) and r.anisotropy == pytest.approx(0.3)
    assert r.emission is None and r.notes == ()


def test_resolve_constant_albedo_needs_no_colour_grid_and_mask_empties_outside():
    d = np.ones((4, 4, 4), np.float32)
    graph = _graph(S.Node("ATTRIBUTE", (("name", "density"),)),
                   _principled(L(0, "Fac"), emission=2.0))
    mask = np.zeros(d.shape, bool)
    mask[:2] = True
    r = S.resolve(graph, {"density": d}, d.shape, mask=mask)
    assert r.color is None and r.sigma_s == pytest.approx((0.5, 0.5, 0.5))
    assert r.sigma_a == pytest.approx((0.5, 0.5, 0.5))
    assert float(r.density[2:].max()) == 0.0 and float(r.density[:2].min()) == 1.0
    assert r.emission[:2].reshape(-1, 3) == pytest.approx(np.full((32, 3), 2.0))
    assert float(r.emission[2:].max()) == 0.0


def test_procedural_density_reads_generated_coordinates():
    """A Gradient Texture with its Vector unlinked reads Generated coordinates (the texture space)."""
    shape = (8, 1, 1)
    graph = S.ShaderGraph((S.Node("TEX_GRADIENT", (("gradient_type", "LINEAR"),)),     # no Vector input
                           _principled(L(0, "Fac"))), L(1, "Volume", "SHADER"),
                          texspace=((3.5, 0.0, 0.0), (4.0, 1.0, 1.0)))
    r = S.resolve(graph, {}, shape, np.eye(4))
    # voxel i at x = i; the texture space spans x in [-0.5, 7.5]: Generated x = (i + 0.5) / 8
    np.testing.assert_allclose(r.density[:, 0, 0], (np.arange(8) + 0.5) / 8, atol=1e-6)
