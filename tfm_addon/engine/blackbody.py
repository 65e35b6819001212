"""Blender's blackbody emission as Cycles' Principled Volume computes it, per voxel.

Cycles looks volume attributes up stochastically (one voxel, drawn with the trilinear weights),
so what a render converges to is the trilinear blend of each voxel's emission, not the emission
of the blended temperature; the engine therefore evaluates the blackbody term per voxel and lets
the texture filter blend it.
"""

from __future__ import annotations

import math

import numpy as np

STEFAN_BOLTZMANN = 5.670373e-8   # W / (m^2 K^4)

# Cycles' fit of the blackbody colour in Rec.709 (intern/cycles/kernel/tables.h): per temperature
# segment, a / t + b t + c for red and green, a cubic for blue.
_EDGES = (965.0, 1167.0, 1449.0, 1902.0, 3315.0, 6365.0)
_RED = (
    (1.61919106e+03, -2.05010916e-03, 5.02995757e+00),
    (2.48845471e+03, -1.11330907e-03, 3.22621544e+00),
    (3.34143193e+03, -4.86551192e-04, 1.76486769e+00),
    (4.09461742e+03, -1.27446582e-04, 7.25731635e-01),
    (4.67028036e+03, 2.91258199e-05, 1.26703442e-01),
    (4.59509185e+03, 2.87495649e-05, 1.50345020e-01),
    (3.78717450e+03, 9.35907826e-06, 3.99075871e-01),
)
_GREEN = (
    (-4.88999748e+02, 6.04330754e-04, -7.55807526e-02),
    (-7.55994277e+02, 3.16730098e-04, 4.78306139e-01),
    (-1.02363977e+03, 1.20223470e-04, 9.36662319e-01),
    (-1.26571316e+03, 4.87340896e-06, 1.27054498e+00),
    (-1.42529332e+03, -4.01150431e-05, 1.43972784e+00),
    (-1.17554822e+03, -2.16378048e-05, 1.30408023e+00),
    (-5.00799571e+02, -4.59832026e-06, 1.09098763e+00),
)
_BLUE = ((5.96945309e-11, -4.85742887e-08, -9.70622247e-05, -4.07936148e-03),
         (2.40430366e-11, 5.55021075e-08, -1.98503712e-04, 2.89312858e-02),
         (-1.40949732e-11, 1.89878968e-07, -3.56632824e-04, 9.10767778e-02),
         (-3.61460868e-11, 2.84822009e-07, -4.93211319e-04, 1.56723440e-01),
         (-1.97075738e-11, 1.75359352e-07, -2.50542825e-04, -2.22783266e-02),
         (-1.61997957e-13, -1.64216008e-08, 3.86216271e-04, -7.38077418e-01),
         (6.72650283e-13, -2.73078809e-08, 4.24098264e-04, -7.52335691e-01))
_ABOVE = (0.8262954810464208, 0.9945080501520986, 1.566307710274283)     # t >= 12000 K
_BELOW = (5.413294490189271, -0.20319390035873933, -0.0822535242887164)  # t < 800 K


def color_rec709(temperature_k: np.ndarray) -> np.ndarray:
    """Cycles' blackbody colour, (..., 3), for temperatures in kelvin (unclamped, as Cycles)."""
    t = np.asarray(temperature_k, dtype=np.float64)
    i = np.searchsorted(np.asarray(_EDGES), t, side="right")
    r, g, b = np.asarray(_RED)[i], np.asarray(_GREEN)[i], np.asarray(_BLUE)[i]
    ts = np.maximum(t, 800.0)
    out = np.stack([r[..., 0] / ts + r[..., 1] * ts + r[..., 2],
                    g[..., 0] / ts + g[..., 1] * ts + g[..., 2],
                    ((b[..., 0] * ts + b[..., 1]) * ts + b[..., 2]) * ts + b[..., 3]], axis=-1)
    out = np.where((t >= 12000.0)[..., None], np.asarray(_ABOVE), out)
    return np.where((t < 800.0)[..., None], np.asarray(_BELOW), out)


def radiance(temperature_k: np.ndarray, intensity: np.ndarray | float) -> np.ndarray:
    """The blackbody term before the tint, W/(sr m^2) per metre, (..., 3): 1e-6 sigma / pi *
    mix(1, T^4, intensity) * colour(T) where the intensity and that power are positive, else zero
    (Cycles' svm_node_principled_volume emits nothing where ``intensity > 0`` fails: an intensity
    above 1 at T = 0 K gives a negative power, which would darken the red)."""
    t = np.maximum(np.asarray(temperature_k, dtype=np.float64), 0.0)
    b = np.broadcast_to(np.asarray(intensity, dtype=np.float64), t.shape)
    power = STEFAN_BOLTZMANN * 1e-6 / math.pi * ((1.0 - b) + b * t ** 4)
    power = np.where((b > 0.0) & (power > 0.0), power, 0.0)
    return power[..., None] * color_rec709(t)
