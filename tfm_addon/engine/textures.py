"""Blender 5.0's procedural shader textures in numpy, evaluated at many 3D points at once.

Each function is a port of the algorithm that Cycles' SVM kernel (intern/cycles/kernel/svm/*.h,
intern/cycles/util/hash.h) and Blender's own C++ implementation (source/blender/blenlib/intern/
noise.cc, called by the shader nodes' multi-functions in source/blender/nodes/shader/nodes/
node_shader_tex_*.cc, which Geometry Nodes evaluate) share: the same hashes of the same integers
and float bit patterns (Jenkins lookup3 for Perlin noise, its seed offsets and White Noise; since
5.0 a signed-integer PCG3D hash of the integer cell for Voronoi), the same Perlin gradients,
fractal loops and Voronoi cell scans. The texture coordinate is held in float32 as Blender holds
it (times Scale, the octaves' lacunarity steps, distortion and seed offsets are rounded to float32,
so the fractions Perlin and Voronoi see are Blender's); the rest is float64, so results agree with
Blender to float32 rounding (measured <= 1e-5; the Noise colour with distortion and many octaves
1.8e-4), not bit for bit.

``p`` is an (n, 3) array of texture coordinates, already through any Mapping node (for an
object's volume that is usually the Generated or Object coordinate). Outputs are float64.

========== =========================================================== ==============================
Texture    Parameters                                                   Not ported
========== =========================================================== ==============================
noise      scale, detail, roughness, lacunarity, distortion, normalize, 1D, 2D and 4D (W input)
           noise_type (FBM, MULTIFRACTAL, HETERO_TERRAIN,
           HYBRID_MULTIFRACTAL, RIDGED_MULTIFRACTAL), offset, gain;
           outputs Fac and Color
white      outputs Value and Color (3D)                                 1D, 2D and 4D
_noise
gradient   gradient_type: LINEAR, QUADRATIC, EASING, DIAGONAL,          Color output (Blender's is
           SPHERICAL, QUADRATIC_SPHERE, RADIAL; output Fac              Fac as grey)
voronoi    scale, randomness, feature (F1, F2), distance (EUCLIDEAN,    SMOOTH_F1, DISTANCE_TO_EDGE,
           MANHATTAN, CHEBYCHEV, MINKOWSKI), exponent, detail,          N_SPHERE_RADIUS (raise
           roughness, lacunarity, normalize; outputs Distance, Color,   NotImplementedError); 1D, 2D,
           Position                                                     4D (W)
wave       wave_type (BANDS, RINGS), bands_direction (X, Y, Z,          nothing
           DIAGONAL), rings_direction (X, Y, Z, SPHERICAL),
           wave_profile (SIN, SAW, TRI), scale, distortion, detail,
           detail_scale, detail_roughness, phase_offset; Fac, Color
checker    scale, color1, color2; outputs Fac, Color                    alpha (colours are RGB)
========== =========================================================== ==============================

Each texture is checked against Blender 5.0.1 through Geometry Nodes (tests/blender/
test_textures_blender.py): their texture nodes are the shader nodes' multi-functions
(node_shader_tex_*.cc; read for Noise: it calls blenlib's noise::perlin_fractal_distorted and
perlin_float3_fractal_distorted, the Cycles noisetex.h algorithm). For all six textures the
Geometry Nodes output agrees with this port of the Cycles kernel to float32 rounding (hash outputs
exactly), which a different algorithm could not do; no Cycles render was needed.
"""

from __future__ import annotations

import numpy as np

_U32 = np.uint32


# ---------------------------------------------------------------------------------------------
# Hashes: Jenkins lookup3 (util/hash.h, blenlib noise.cc), uint32 arrays with wrap-around
# ---------------------------------------------------------------------------------------------

def _rot(x, k: int):
    return (x << _U32(k)) | (x >> _U32(32 - k))


def _mix(a, b, c):
    a = a - c
    a = a ^ _rot(c, 4)
    c = c + b
    b = b - a
    b = b ^ _rot(a, 6)
    a = a + c
    c = c - b
    c = c ^ _rot(b, 8)
    b = b + a
    a = a - c
    a = a ^ _rot(c, 16)
    c = c + b
    b = b - a
    b = b ^ _rot(a, 19)
    a = a + c
    c = c - b
    c = c ^ _rot(b, 4)
    b = b + a
    return a, b, c


def _final(a, b, c):
    c = c ^ b
    c = c - _rot(b, 14)
    a = a ^ c
    a = a - _rot(c, 11)
    b = b ^ a
    b = b - _rot(a, 25)
    c = c ^ b
    c = c - _rot(b, 16)
    a = a ^ c
    a = a - _rot(c, 4)
    b = b ^ a
    b = b - _rot(a, 14)
    c = c ^ b
    c = c - _rot(b, 24)
    return c


def _u32(x) -> np.ndarray:
    """Integers (any sign) as uint32 arrays, wrapping like a C cast."""
    return np.asarray(x).astype(np.int64).astype(np.uint32)


def _seed(n: int, like) -> np.ndarray:
    return np.full(np.shape(like), 0xDEADBEEF + (n << 2) + 13, dtype=np.uint32)


def hash_uint2(kx, ky) -> np.ndarray:
    """lookup3 of two uint32 arrays."""
    s = _seed(2, kx)
    return _final(s + kx, s + ky, s)


def hash_uint3(kx, ky, kz) -> np.ndarray:
    """lookup3 of three uint32 arrays."""
    s = _seed(3, kx)
    return _final(s + kx, s + ky, s + kz)


def hash_uint4(kx, ky, kz, kw) -> np.ndarray:
    """lookup3 of four uint32 arrays."""
    s = _seed(4, kx)
    a, b, c = _mix(s + kx, s + ky, s + kz)
    return _final(a + kw, b, c)


def _bits(x) -> np.ndarray:
    """The bit pattern of float32(x) as uint32."""
    return np.ascontiguousarray(np.asarray(x, dtype=np.float32)).view(np.uint32)


def _to_01(h) -> np.ndarray:
    """uint_to_float_incl: float32(h) / 2^32 (1.0f / float(0xFFFFFFFF) is exactly 2^-32)."""
    return h.astype(np.float32).astype(np.float64) * (2.0 ** -32)


def hash_float2_to_float(x, y) -> np.ndarray:
    return _to_01(hash_uint2(_bits(x), _bits(y)))


def hash_float3_to_float(x, y, z) -> np.ndarray:
    return _to_01(hash_uint3(_bits(x), _bits(y), _bits(z)))


def hash_float4_to_float(x, y, z, w) -> np.ndarray:
    return _to_01(hash_uint4(_bits(x), _bits(y), _bits(z), _bits(w)))


def hash_float3_to_float3(x, y, z) -> np.ndarray:
    """(n,) x, y, z -> (n, 3) in [0, 1], as Cycles' hash_float3_to_float3."""
    one = np.ones(np.shape(x), dtype=np.float32)
    return np.stack([hash_float3_to_float(x, y, z),
                     hash_float4_to_float(x, y, z, one),
                     hash_float4_to_float(x, y, z, 2 * one)], axis=-1)


def hash_int3_to_float3(k: np.ndarray) -> np.ndarray:
    """(n, 3) integer cells -> (n, 3) in [0, 1]: Blender 5.0's signed PCG3D hash (hash_pcg3d_i,
    int32 with wrap-around and arithmetic shifts) that Voronoi uses since 5.0."""
    v = np.asarray(k).astype(np.int64).astype(np.int32) * np.int32(1664525) + np.int32(1013904223)
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    for step in range(2):
        x = x + y * z
        y = y + z * x
        z = z + x * y
        if step == 0:
            x, y, z = x ^ (x >> 16), y ^ (y >> 16), z ^ (z >> 16)
    h = np.stack([x, y, z], axis=-1) & np.int32(0x7FFFFFFF)
    # float(h) * (1.0f / float(0x7FFFFFFF)): float(0x7FFFFFFF) is 2^31, so the factor is 2^-31.
    return h.astype(np.float32).astype(np.float64) * (2.0 ** -31)


# ---------------------------------------------------------------------------------------------
# Perlin noise and its fractals (svm/noise.h, svm/fractal_noise.h)
# ---------------------------------------------------------------------------------------------

def _fade(t):
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


def _grad3(h, x, y, z):
    h = h & _U32(15)
    u = np.where(h < 8, x, y)
    vt = np.where((h == 12) | (h == 14), x, z)
    v = np.where(h < 4, y, vt)
    return np.where(h & _U32(1), -u, u) + np.where(h & _U32(2), -v, v)


def perlin_3d(p: np.ndarray) -> np.ndarray:
    """Unscaled 3D Perlin noise of (n, 3) points (float32: the fractions are then Blender's)."""
    cell = np.floor(p)
    f = (p - cell).astype(np.float64)
    i = _u32(cell)
    i1 = i + _U32(1)
    fx, fy, fz = f[:, 0], f[:, 1], f[:, 2]
    u, v, w = _fade(fx), _fade(fy), _fade(fz)

    def g(ix, iy, iz, dx, dy, dz):
        return _grad3(hash_uint3(ix, iy, iz), fx - dx, fy - dy, fz - dz)

    X, Y, Z = i[:, 0], i[:, 1], i[:, 2]
    X1, Y1, Z1 = i1[:, 0], i1[:, 1], i1[:, 2]
    v0 = g(X, Y, Z, 0, 0, 0)
    v1 = g(X1, Y, Z, 1, 0, 0)
    v2 = g(X, Y1, Z, 0, 1, 0)
    v3 = g(X1, Y1, Z, 1, 1, 0)
    v4 = g(X, Y, Z1, 0, 0, 1)
    v5 = g(X1, Y, Z1, 1, 0, 1)
    v6 = g(X, Y1, Z1, 0, 1, 1)
    v7 = g(X1, Y1, Z1, 1, 1, 1)
    x1, y1, z1 = 1.0 - u, 1.0 - v, 1.0 - w
    return (z1 * (y1 * (v0 * x1 + v1 * u) + v * (v2 * x1 + v3 * u))
            + w * (y1 * (v4 * x1 + v5 * u) + v * (v6 * x1 + v7 * u)))


def snoise_3d(p: np.ndarray) -> np.ndarray:
    """Signed Perlin noise in about [-1, 1], repeated every 100000 on each axis like Cycles'."""
    return 0.9820 * perlin_3d(np.fmod(p, np.float32(100000.0)))


def _mix_lin(a, b, t):
    return (1.0 - t) * a + t * b


def noise_fbm(p, detail, roughness, lacunarity, normalize):
    fscale, amp, maxamp = np.float32(1.0), 1.0, 0.0
    total = np.zeros(len(p))
    for _ in range(int(detail) + 1):
        total = total + snoise_3d(fscale * p) * amp
        maxamp += amp
        amp *= roughness
        fscale = fscale * np.float32(lacunarity)
    rmd = detail - np.floor(detail)
    if rmd != 0.0:
        total2 = total + snoise_3d(fscale * p) * amp
        if normalize:
            return _mix_lin(0.5 * total / maxamp + 0.5, 0.5 * total2 / (maxamp + amp) + 0.5, rmd)
        return _mix_lin(total, total2, rmd)
    return 0.5 * total / maxamp + 0.5 if normalize else total


def noise_multi_fractal(p, detail, roughness, lacunarity):
    value = np.ones(len(p))
    pwr = 1.0
    for _ in range(int(detail) + 1):
        value = value * (pwr * snoise_3d(p) + 1.0)
        pwr *= roughness
        p = p * np.float32(lacunarity)
    rmd = detail - np.floor(detail)
    if rmd != 0.0:
        value = value * (rmd * pwr * snoise_3d(p) + 1.0)
    return value


def noise_hetero_terrain(p, detail, roughness, lacunarity, offset):
    pwr = roughness
    value = offset + snoise_3d(p)
    p = p * np.float32(lacunarity)
    for _ in range(1, int(detail) + 1):
        value = value + (snoise_3d(p) + offset) * pwr * value
        pwr *= roughness
        p = p * np.float32(lacunarity)
    rmd = detail - np.floor(detail)
    if rmd != 0.0:
        value = value + rmd * ((snoise_3d(p) + offset) * pwr * value)
    return value


def noise_hybrid_multi_fractal(p, detail, roughness, lacunarity, offset, gain):
    pwr = 1.0
    value = np.zeros(len(p))
    weight = np.ones(len(p))
    alive = np.ones(len(p), dtype=bool)   # the loop stops per point once weight <= 0.001
    for _ in range(int(detail) + 1):
        alive &= weight > 0.001
        if not alive.any():
            break
        weight = np.where(alive, np.minimum(weight, 1.0), weight)
        signal = (snoise_3d(p) + offset) * pwr
        pwr *= roughness
        value = np.where(alive, value + weight * signal, value)
        weight = np.where(alive, weight * (gain * signal), weight)
        p = p * np.float32(lacunarity)
    rmd = detail - np.floor(detail)
    if rmd != 0.0:
        on = weight > 0.001
        signal = (snoise_3d(p) + offset) * pwr
        value = np.where(on, value + rmd * np.minimum(weight, 1.0) * signal, value)
    return value


def noise_ridged_multi_fractal(p, detail, roughness, lacunarity, offset, gain):
    pwr = roughness
    signal = offset - np.abs(snoise_3d(p))
    signal = signal * signal
    value = signal
    for _ in range(1, int(detail) + 1):
        p = p * np.float32(lacunarity)
        weight = np.clip(signal * gain, 0.0, 1.0)
        signal = offset - np.abs(snoise_3d(p))
        signal = signal * signal * weight
        value = value + signal * pwr
        pwr *= roughness
    return value


NOISE_TYPES = ('FBM', 'MULTIFRACTAL', 'HETERO_TERRAIN', 'HYBRID_MULTIFRACTAL', 'RIDGED_MULTIFRACTAL')


def _noise_select(p, noise_type, detail, roughness, lacunarity, offset, gain, normalize):
    if noise_type == 'FBM':
        return noise_fbm(p, detail, roughness, lacunarity, normalize)
    if noise_type == 'MULTIFRACTAL':
        return noise_multi_fractal(p, detail, roughness, lacunarity)
    if noise_type == 'HETERO_TERRAIN':
        return noise_hetero_terrain(p, detail, roughness, lacunarity, offset)
    if noise_type == 'HYBRID_MULTIFRACTAL':
        return noise_hybrid_multi_fractal(p, detail, roughness, lacunarity, offset, gain)
    if noise_type == 'RIDGED_MULTIFRACTAL':
        return noise_ridged_multi_fractal(p, detail, roughness, lacunarity, offset, gain)
    raise ValueError(f"noise_type {noise_type!r} is not one of {NOISE_TYPES}")


def _random_float3_offset(seed: float) -> np.ndarray:
    """Cycles' random_float3_offset: a fixed offset in [100, 200]^3 per seed (float32 like it)."""
    s = np.array([seed], dtype=np.float32)
    out = []
    for i in range(3):
        h = np.float32(hash_float2_to_float(s, np.array([i], dtype=np.float32))[0])
        out.append(np.float32(100.0) + h * np.float32(100.0))
    return np.array(out, dtype=np.float32)


def _points(p) -> np.ndarray:
    p = np.asarray(p, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"p must be an (n, 3) array, not {p.shape}")
    return p


def _scaled32(p, scale) -> np.ndarray:
    """The texture coordinate times scale in float32, as Blender holds it: the fractal octaves
    multiply it by up to lacunarity^15, so its rounding is what Blender's noise sees."""
    return _points(p).astype(np.float32) * np.float32(scale)


def noise(p, *, scale=5.0, detail=2.0, roughness=0.5, lacunarity=2.0, distortion=0.0, normalize=True,
          noise_type='FBM', offset=0.0, gain=1.0, color: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """The 3D Noise Texture: (Fac (n,), Color (n, 3)).

    As svm_node_tex_noise / noise_texture_3d: detail clamped to [0, 15], roughness to >= 0, the
    coordinate scaled, distorted by three signed noises at random offsets, and the colour's green
    and blue the same fractal at two more random offsets. ``normalize`` matters for FBM only.
    """
    p = _scaled32(p, scale)
    detail = float(np.clip(detail, 0.0, 15.0))
    roughness = max(float(roughness), 0.0)
    args = (noise_type, detail, roughness, float(lacunarity), float(offset), float(gain), bool(normalize))
    if distortion != 0.0:
        shift = np.stack([snoise_3d(p + _random_float3_offset(s)) * distortion for s in (0.0, 1.0, 2.0)],
                         axis=-1)
        p = p + shift.astype(np.float32)
    value = _noise_select(p, *args)
    if not color:       # the Color output is not used: its two extra fractals are not computed
        return value, None
    color = np.stack([value,
                      _noise_select(p + _random_float3_offset(3.0), *args),
                      _noise_select(p + _random_float3_offset(4.0), *args)], axis=-1)
    return value, color


# ---------------------------------------------------------------------------------------------
# White noise, gradient, checker, wave
# ---------------------------------------------------------------------------------------------

def white_noise(p) -> tuple[np.ndarray, np.ndarray]:
    """The 3D White Noise Texture: (Value (n,), Color (n, 3)), hashes of the float32 coordinate."""
    p = np.asarray(_points(p), dtype=np.float32)
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    return hash_float3_to_float(x, y, z), hash_float3_to_float3(x, y, z)


GRADIENT_TYPES = ('LINEAR', 'QUADRATIC', 'EASING', 'DIAGONAL', 'SPHERICAL', 'QUADRATIC_SPHERE', 'RADIAL')


def gradient(p, gradient_type='LINEAR') -> np.ndarray:
    """The Gradient Texture's Fac (n,), clamped to [0, 1] like svm_node_tex_gradient."""
    p = _points(p)
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    if gradient_type == 'LINEAR':
        f = x
    elif gradient_type == 'QUADRATIC':
        f = np.maximum(x, 0.0) ** 2
    elif gradient_type == 'EASING':
        r = np.clip(x, 0.0, 1.0)
        t = r * r
        f = 3.0 * t - 2.0 * t * r
    elif gradient_type == 'DIAGONAL':
        f = (x + y) * 0.5
    elif gradient_type == 'RADIAL':
        f = np.arctan2(y, x) / (2.0 * np.pi) + 0.5
    elif gradient_type in ('SPHERICAL', 'QUADRATIC_SPHERE'):
        # 0.999999: Cycles' bias so that a unit vector gives exactly 0.
        r = np.maximum(0.999999 - np.sqrt(x * x + y * y + z * z), 0.0)
        f = r * r if gradient_type == 'QUADRATIC_SPHERE' else r
    else:
        raise ValueError(f"gradient_type {gradient_type!r} is not one of {GRADIENT_TYPES}")
    return np.clip(f, 0.0, 1.0)


def checker(p, *, scale=5.0, color1=(0.8, 0.8, 0.8), color2=(0.2, 0.2, 0.2)
            ) -> tuple[np.ndarray, np.ndarray]:
    """The Checker Texture: (Fac (n,), Color (n, 3)); Fac 1 where Color is color1."""
    p = _scaled32(p, scale)
    # Cycles' nudge against precision issues on unit coordinates, in float32 like it.
    p = (p + np.float32(0.000001)) * np.float32(0.999999)
    parity = np.abs(np.floor(p).astype(np.int64)) % 2
    fac = ((parity[:, 0] == parity[:, 1]).astype(np.int64) == parity[:, 2]).astype(np.float64)
    c1 = np.asarray(color1, dtype=np.float64)[:3]
    c2 = np.asarray(color2, dtype=np.float64)[:3]
    return fac, np.where(fac[:, None] == 1.0, c1, c2)


def wave(p, *, wave_type='BANDS', bands_direction='X', rings_direction='X', wave_profile='SIN',
         scale=5.0, distortion=0.0, detail=2.0, detail_scale=1.0, detail_roughness=0.5,
         phase_offset=0.0) -> tuple[np.ndarray, np.ndarray]:
    """The Wave Texture: (Fac (n,), Color (n, 3) = grey Fac), as svm_wave."""
    p = _scaled32(p, scale)
    p = (p + np.float32(0.000001)) * np.float32(0.999999)
    if wave_type == 'BANDS':
        axes = {'X': 0, 'Y': 1, 'Z': 2}
        if bands_direction in axes:
            n = p[:, axes[bands_direction]] * 20.0
        elif bands_direction == 'DIAGONAL':
            n = (p[:, 0] + p[:, 1] + p[:, 2]) * 10.0
        else:
            raise ValueError(f"bands_direction {bands_direction!r} is not X, Y, Z or DIAGONAL")
    elif wave_type == 'RINGS':
        masks = {'X': (0.0, 1.0, 1.0), 'Y': (1.0, 0.0, 1.0), 'Z': (1.0, 1.0, 0.0),
                 'SPHERICAL': (1.0, 1.0, 1.0)}
        if rings_direction not in masks:
            raise ValueError(f"rings_direction {rings_direction!r} is not X, Y, Z or SPHERICAL")
        rp = p * np.array(masks[rings_direction], dtype=np.float32)
        n = np.sqrt(np.sum(rp * rp, axis=1)) * 20.0
    else:
        raise ValueError(f"wave_type {wave_type!r} is not BANDS or RINGS")
    n = n + np.float32(phase_offset)   # float32 up to here, like Blender
    if distortion != 0.0:
        fbm = noise_fbm(p * np.float32(detail_scale), float(detail), float(detail_roughness), 2.0, True)
        n = n + (distortion * (fbm * 2.0 - 1.0)).astype(np.float32)
    n = n.astype(np.float64)
    if wave_profile == 'SIN':
        f = 0.5 + 0.5 * np.sin(n - np.pi / 2)
    elif wave_profile == 'SAW':
        n = n / (2.0 * np.pi)
        f = n - np.floor(n)
    elif wave_profile == 'TRI':
        n = n / (2.0 * np.pi)
        f = np.abs(n - np.floor(n + 0.5)) * 2.0
    else:
        raise ValueError(f"wave_profile {wave_profile!r} is not SIN, SAW or TRI")
    return f, np.repeat(f[:, None], 3, axis=1)


# ---------------------------------------------------------------------------------------------
# Voronoi (svm/voronoi.h): F1 and F2, fractal
# ---------------------------------------------------------------------------------------------

VORONOI_DISTANCES = ('EUCLIDEAN', 'MANHATTAN', 'CHEBYCHEV', 'MINKOWSKI')


def _voronoi_distance(d, metric, exponent):
    """Distance of (n, 3) differences d under the metric."""
    if metric == 'EUCLIDEAN':
        return np.sqrt(np.sum(d * d, axis=-1))
    if metric == 'MANHATTAN':
        return np.sum(np.abs(d), axis=-1)
    if metric == 'CHEBYCHEV':
        return np.max(np.abs(d), axis=-1)
    if metric == 'MINKOWSKI':
        with np.errstate(divide='ignore', over='ignore', invalid='ignore'):
            return np.sum(np.abs(d) ** exponent, axis=-1) ** (1.0 / exponent)
    raise ValueError(f"distance {metric!r} is not one of {VORONOI_DISTANCES}")


def _voronoi_octave(coord, feature, metric, exponent, randomness):
    """voronoi_f1 / voronoi_f2 at (n, 3) coord: (distance, color, position) of the octave."""
    cell = np.floor(coord).astype(np.float64)
    local = coord - cell    # exact: coord is float32
    icell = cell.astype(np.int64)
    n = len(coord)
    inf = np.full(n, np.inf)
    d1, d2 = inf.copy(), inf.copy()
    off1, off2 = np.zeros((n, 3)), np.zeros((n, 3))
    pos1, pos2 = np.zeros((n, 3)), np.zeros((n, 3))
    for k in (-1, 0, 1):
        for j in (-1, 0, 1):
            for i in (-1, 0, 1):
                offset = np.array([i, j, k], dtype=np.float64)
                point = offset + hash_int3_to_float3(icell + np.array([i, j, k])) * randomness
                d = _voronoi_distance(point - local, metric, exponent)
                closer = d < d1
                second = ~closer & (d < d2)
                if feature == 'F2':
                    d2 = np.where(closer, d1, np.where(second, d, d2))
                    off2 = np.where(closer[:, None], off1, np.where(second[:, None], offset, off2))
                    pos2 = np.where(closer[:, None], pos1, np.where(second[:, None], point, pos2))
                d1 = np.where(closer, d, d1)
                off1 = np.where(closer[:, None], offset, off1)
                pos1 = np.where(closer[:, None], point, pos1)
    if feature == 'F2':
        d1, off1, pos1 = d2, off2, pos2
    return d1, hash_int3_to_float3(icell + off1.astype(np.int64)), pos1 + cell


def voronoi(p, *, scale=5.0, randomness=1.0, feature='F1', distance='EUCLIDEAN', exponent=0.5,
            detail=0.0, roughness=0.5, lacunarity=2.0, normalize=False
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 3D Voronoi Texture: (Distance (n,), Color (n, 3), Position (n, 3)).

    F1 and F2 under every distance metric, with fractal detail (fractal_voronoi_x_fx). The other
    features raise NotImplementedError.
    """
    if feature not in ('F1', 'F2'):
        raise NotImplementedError(
            f"Voronoi feature {feature!r} is not ported (only F1 and F2): see tfm_addon.engine.textures")
    if distance not in VORONOI_DISTANCES:
        raise ValueError(f"distance {distance!r} is not one of {VORONOI_DISTANCES}")
    scale = float(scale)
    coord = _scaled32(p, scale)
    detail = float(np.clip(detail, 0.0, 15.0))
    roughness = float(np.clip(roughness, 0.0, 1.0))
    randomness = float(np.clip(randomness, 0.0, 1.0))
    exponent = float(exponent)
    half = np.full((1, 3), 0.5 + 0.5 * randomness)
    max_distance = float(_voronoi_distance(half, distance, exponent)[0]) * (2.0 if feature == 'F2' else 1.0)

    n = len(coord)
    out_d, out_c, out_p = np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3))
    amplitude, max_amplitude, octave_scale = 1.0, 0.0, np.float32(1.0)
    zero_input = detail == 0.0 or roughness == 0.0
    for i in range(int(np.ceil(detail)) + 1):
        d, c, pos = _voronoi_octave(coord * np.float32(octave_scale), feature, distance, exponent,
                                    randomness)
        if zero_input:
            max_amplitude = 1.0
            out_d, out_c, out_p = d, c, pos
            break
        if i <= detail:
            max_amplitude += amplitude
            out_d = out_d + d * amplitude
            out_c = out_c + c * amplitude
            out_p = _mix_lin(out_p, pos / octave_scale, amplitude)
            octave_scale = octave_scale * np.float32(lacunarity)
            amplitude *= roughness
        else:
            rmd = detail - np.floor(detail)
            if rmd != 0.0:
                max_amplitude = _mix_lin(max_amplitude, max_amplitude + amplitude, rmd)
                out_d = _mix_lin(out_d, out_d + d * amplitude, rmd)
                out_c = _mix_lin(out_c, out_c + c * amplitude, rmd)
                out_p = _mix_lin(out_p, _mix_lin(out_p, pos / octave_scale, amplitude), rmd)
    if normalize:
        out_d = out_d / (max_amplitude * max_distance)
        out_c = out_c / max_amplitude
    out_p = out_p / scale if scale != 0.0 else np.zeros_like(out_p)
    return out_d, out_c, out_p
