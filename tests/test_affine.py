"""The affine fast path (tfm_addon/engine/affine.py) against the per-voxel evaluation of the same
graph (tfm_addon/engine/shading.py): one graph, two readings, the same numbers."""

import numpy as np

from tfm_addon.engine import shading
from tfm_addon.engine.affine import fold
from tfm_addon.engine.shading import Input, Link, Node, ShaderGraph


def test_a_scatter_without_anisotropy_folds_with_none():
    """Volume Scatter with a phase that has no Anisotropy socket (Rayleigh, Mie...): g 0."""
    scatter = Node("VOLUME_SCATTER", (), (Input("Color", "RGBA", (0.8, 0.8, 0.8)),
                                          Input("Density", "VALUE", 2.0)), "Volume Scatter")
    graph = ShaderGraph((scatter,), Link(0, "Volume", "SHADER"))
    medium = fold(graph)
    assert medium.sigma_s == (1.6, 1.6, 1.6) and medium.anisotropy == 0.0
    fields = shading.evaluate(graph, {}, 1)
    assert np.allclose(fields.sigma_s, 1.6) and float(fields.anisotropy[0]) == 0.0


def _principled(**values) -> Node:
    ins = {"Color": (0.5, 0.5, 0.5), "Density": 1.0, "Anisotropy": 0.0, "Absorption Color": (0.0, 0.0, 0.0),
           "Emission Strength": 0.0, "Emission Color": (1.0, 1.0, 1.0), "Blackbody Intensity": 0.0,
           "Blackbody Tint": (1.0, 1.0, 1.0), "Temperature": 1000.0, **values}
    kinds = {k: "RGBA" if isinstance(v, tuple) else "VALUE" for k, v in ins.items()}
    return Node("PRINCIPLED_VOLUME", (("density_attribute", "density"), ("color_attribute", ""),
                                      ("temperature_attribute", "temperature")),
                tuple(Input(k, kinds[k] if not isinstance(v, Link) else "VALUE", v) for k, v in ins.items()),
                "Principled Volume")


def test_the_affine_fold_and_the_per_voxel_evaluation_agree():
    """The two readings of one graph (engine/affine.py's fold, engine/shading.py's evaluation)
    give the same coefficients, emission and anisotropy at every voxel."""
    flame = Node("ATTRIBUTE", (("name", "flame"),), (), "Flame")
    times3 = Node("MATH", (("operation", "MULTIPLY"), ("use_clamp", False)),
                  (Input("A", "VALUE", Link(0, "Fac")), Input("B", "VALUE", 3.0), Input("C", "VALUE", 0.0)),
                  "x3")
    principled = _principled(**{"Color": (0.8, 0.5, 0.2), "Density": 2.0,
                                "Absorption Color": (0.25, 0.0, 1.0), "Anisotropy": 0.4,
                                "Emission Strength": Link(1, "Value"), "Emission Color": (1.0, 0.5, 0.1)})
    density = Node("ATTRIBUTE", (("name", "density"),), (), "Density")
    scatter = Node("VOLUME_SCATTER", (), (Input("Color", "RGBA", (0.3, 0.6, 0.9)),
                                          Input("Density", "VALUE", Link(3, "Fac")),
                                          Input("Anisotropy", "VALUE", -0.3)), "Scatter")
    mix = Node("MIX_SHADER", (), (Input("Fac", "VALUE", 0.3), Input("Shader", "SHADER", Link(2, "Volume")),
                                  Input("Shader_001", "SHADER", Link(4, "Volume"))), "Mix")
    graphs = [ShaderGraph((flame, times3, principled), Link(2, "Volume", "SHADER")),
              ShaderGraph((flame, times3, principled, density, scatter, mix), Link(5, "Shader", "SHADER"))]
    rng = np.random.default_rng(4)
    grids = {"density": rng.random(50).astype(np.float32), "flame": rng.random(50).astype(np.float32)}
    for graph in graphs:
        folded = fold(graph)
        fields = shading.evaluate(graph, grids, 50)
        d = grids[folded.grid][:, None]
        assert np.allclose(fields.sigma_s, d * np.array(folded.sigma_s), atol=1e-5)
        assert np.allclose(fields.sigma_a, d * np.array(folded.sigma_a), atol=1e-5)
        e = folded.emission_strength
        strength = (e.scale * grids[e.grid] + e.offset)[:, None] if e.grid else e.offset
        assert np.allclose(fields.emission, np.array(folded.emission_color) * strength, atol=1e-5)
        assert np.allclose(fields.anisotropy, folded.anisotropy, atol=1e-5)
