"""tfm_addon.engine.textures without Blender: shapes, determinism, ranges, known hash values.

Agreement with Blender itself is tests/blender/test_textures_blender.py.
"""

import ast
import inspect

import numpy as np
import pytest

from tfm_addon.engine import textures

P = np.random.default_rng(3).uniform(-2.0, 2.0, (500, 3))


def _all_outputs(p):
    """Every texture's outputs at p, with a few parameter sets each."""
    out = {}
    for noise_type in textures.NOISE_TYPES:
        out[f"noise {noise_type}"] = textures.noise(p, noise_type=noise_type, detail=2.5, distortion=0.4)
    out["white"] = textures.white_noise(p)
    for kind in textures.GRADIENT_TYPES:
        out[f"gradient {kind}"] = (textures.gradient(p, kind),)
    for feature in ('F1', 'F2'):
        for metric in textures.VORONOI_DISTANCES:
            out[f"voronoi {feature} {metric}"] = textures.voronoi(p, feature=feature, distance=metric,
                                                                  detail=1.5)
    out["wave"] = textures.wave(p, distortion=2.0)
    out["wave rings"] = textures.wave(p, wave_type='RINGS', rings_direction='SPHERICAL', wave_profile='TRI')
    out["checker"] = textures.checker(p)
    return out


def test_shapes_dtypes_and_determinism():
    first, second = _all_outputs(P), _all_outputs(P.copy())
    for name, outputs in first.items():
        for a, b in zip(outputs, second[name], strict=True):
            assert a.dtype == np.float64, name
            assert a.shape in ((len(P),), (len(P), 3)), name
            assert np.all(np.isfinite(a)), name
            np.testing.assert_array_equal(a, b, err_msg=name)


def test_different_points_give_different_values():
    a, b = _all_outputs(P), _all_outputs(P + np.array([0.37, -0.21, 0.53]))
    for name in a:
        if name in ("gradient LINEAR", "gradient QUADRATIC", "gradient EASING"):
            continue   # depend on x alone; the shift changes x, but clamping can hold values at 0 or 1
        assert not np.allclose(a[name][0], b[name][0]), name


def test_ranges():
    fac, color = textures.noise(P, detail=4.0)
    assert 0.0 <= fac.min() and fac.max() <= 1.0 and fac.std() > 0.02
    np.testing.assert_array_equal(color[:, 0], fac)
    assert not np.allclose(color[:, 1], fac) and not np.allclose(color[:, 2], color[:, 1])
    value, color = textures.white_noise(P)
    assert 0.0 <= value.min() and value.max() <= 1.0 and abs(value.mean() - 0.5) < 0.05
    np.testing.assert_array_equal(color[:, 0], value)
    for kind in textures.GRADIENT_TYPES:
        f = textures.gradient(P, kind)
        assert 0.0 <= f.min() and f.max() <= 1.0, kind
    d, c, pos = textures.voronoi(P, scale=3.0)
    assert 0.0 <= d.min() and d.max() <= np.sqrt(3.0) and 0.0 <= c.min() and c.max() <= 1.0
    # The feature point lies in the cell of p or a neighbour: within 2 cells (of 1/scale) of p.
    assert np.abs(pos - P).max() <= 2.0 / 3.0
    d2, _, _ = textures.voronoi(P, scale=3.0, feature='F2')
    assert np.all(d2 >= d)
    dn, _, _ = textures.voronoi(P, scale=3.0, normalize=True)
    np.testing.assert_allclose(dn, d / np.sqrt(3.0))
    f, c = textures.wave(P, distortion=1.0)
    assert 0.0 <= f.min() and f.max() <= 1.0
    f, c = textures.checker(P, color1=(1.0, 0.0, 0.0), color2=(0.0, 0.0, 1.0))
    assert set(np.unique(f)) == {0.0, 1.0}
    np.testing.assert_array_equal(c[:, 0], f)


def test_known_values():
    """Jenkins lookup3 and Blender's constants, and the checker's pattern."""
    zero = np.zeros(1, dtype=np.uint32)
    assert textures.hash_uint3(zero, zero, zero)[0] == 2624515579   # lookup3 'final' of (0, 0, 0)
    # Noise is 0.5 at integer lattice points (zero gradient there), for every octave of lacunarity 2.
    fac, _ = textures.noise(np.array([[1.0, 2.0, -3.0]]), scale=1.0, detail=3.0)
    assert fac[0] == pytest.approx(0.5, abs=1e-12)
    fac, _ = textures.checker(np.array([[0.1, 0.1, 0.1], [0.3, 0.1, 0.1], [0.3, 0.3, 0.1]]), scale=5.0)
    np.testing.assert_array_equal(fac, [0.0, 1.0, 0.0])   # cell (0, 0, 0) is color2
    assert textures.gradient(np.array([[0.0, 1.0, 0.0]]), 'RADIAL')[0] == pytest.approx(0.75)
    assert textures.gradient(np.array([[0.6, 0.0, 0.8]]), 'SPHERICAL')[0] == 0.0


def test_parameters_matter():
    base, _ = textures.noise(P)
    for kwargs in (dict(scale=3.0), dict(detail=5.0), dict(roughness=0.8), dict(lacunarity=2.5),
                   dict(distortion=0.5), dict(normalize=False)):
        other, _ = textures.noise(P, **kwargs)
        assert not np.allclose(base, other), kwargs
    # Fractional detail blends between the neighbouring integer details.
    lo, _ = textures.noise(P, detail=2.0)
    hi, _ = textures.noise(P, detail=3.0)
    mid, _ = textures.noise(P, detail=2.5, normalize=False)
    lo_raw, _ = textures.noise(P, detail=2.0, normalize=False)
    hi_raw, _ = textures.noise(P, detail=3.0, normalize=False)
    np.testing.assert_allclose(mid, 0.5 * (lo_raw + hi_raw), atol=1e-12)
    assert not np.allclose(lo, hi)


def test_bad_arguments():
    with pytest.raises(NotImplementedError, match="SMOOTH_F1"):
        textures.voronoi(P, feature='SMOOTH_F1')
    with pytest.raises(ValueError):
        textures.noise(P, noise_type='PERLIN')
    with pytest.raises(ValueError):
        textures.gradient(P, 'CONICAL')
    with pytest.raises(ValueError):
        textures.noise(P[:, :2])


def test_engine_module_imports_numpy_only():
    tree = ast.parse(inspect.getsource(textures))
    names = {alias.name.split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.Import)
             for alias in node.names}
    names |= {node.module.split(".")[0] for node in ast.walk(tree)
              if isinstance(node, ast.ImportFrom) and node.module}
    assert names <= {"numpy", "__future__"}, names
