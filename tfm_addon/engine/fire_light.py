"""The light an emitting medium casts on the solids around it (a fire lighting the ground).

Cycles lights a surface with a volume's emission directly, even with no bounces: a ray leaving the
surface that crosses the glowing medium brings back the emission along it, times the medium's
transmittance up to each point. For a Lambertian surface at P with normal n that is the
irradiance E(P) = ∫ L_e(y) T(y, P) max(n·ω, 0) / |y - P|² dy over the medium's volume (L_e the
emitted radiance per metre, W/(sr m²) per m, so L_e dV is the intensity of a volume element).

Approximation (numpy, cached by the renderer by the medium's content, not its placement): the
emission grid is cut into blocks of b³ voxels, b the smallest even size for which at most MAX_POINTS
blocks emit; each block becomes a point at its emission-weighted centre with intensity ∑ L_e ΔV
(W/sr) and a softening radius, its emission's RMS spread (a point's 1/r² would blow up next to a
large block). The medium's own shadowing of a point is its transmittance outwards along each of
DIRECTIONS² directions (an octahedral map), the emission-weighted mean of its eight half blocks'
maps, each marched from the centre of the half block's emitting voxels to the edge of the grid's
box through the density: exact for a surface outside the medium's box, where rays from the point
leave the medium before they reach it. The maps are kept by where the medium emits
(``_half_maps``), so an edit of the emission's colour or strength recomputes the points only. The
surfaces read, per pixel, each point's map once (shaders/fire_light.glsl's ``fire_irradiance``);
solids do not shadow this light (the render report says so).
"""

from __future__ import annotations

import dataclasses
import hashlib
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from . import blackbody, boxes, caches
from .camera_effects import orthonormal
from .quality import trilinear
from .scene import GridValue, Medium

MAX_POINTS = 64          # points a medium's emission becomes (the shader's uniform arrays)
DIRECTIONS = 16          # the octahedral transmittance map of each point: DIRECTIONS² directions
MARCH_STEPS = 24         # steps of each direction's march to the edge of the grid's box
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


@dataclass(frozen=True, eq=False)
class FireLight:
    """An emitting medium as points: ``positions`` (n, 3) m, ``intensity`` (n, 3) W/sr,
    ``softening`` (n,) m², ``transmittance`` (n, DIRECTIONS, DIRECTIONS, 3), the medium's
    transmittance from each point outwards by octahedral direction (rows: v, columns: u),
    ``block`` the voxels per side of a point's block; ``to_index`` (4, 4) the points' frame to the
    grid's index space, ``grid_shape`` the grid's voxels (the box the maps reach: -1 .. shape)."""

    positions: np.ndarray
    intensity: np.ndarray
    softening: np.ndarray
    transmittance: np.ndarray
    block: int
    to_index: np.ndarray | None = None
    grid_shape: tuple[int, int, int] | None = None

    def __len__(self) -> int:
        return len(self.positions)

    @cached_property
    def atlas(self) -> np.ndarray:
        """(DIRECTIONS, n * DIRECTIONS, 3) float32: the points' maps side by side."""
        n = len(self)
        return np.ascontiguousarray(self.transmittance.transpose(1, 0, 2, 3).reshape(
            DIRECTIONS, n * DIRECTIONS, 3), dtype=np.float32)

    def irradiance(self, points: np.ndarray, normals: np.ndarray, rotation=None, offset=None) -> np.ndarray:
        """(m, 3) W/m² at ``points`` (m, 3) with unit ``normals``, the medium placed by
        ``rotation`` and ``offset`` (``placement``'s R and t; None: identity): what the shader
        computes (with the nearest map texel instead of a bilinear read)."""
        r = _rotation(rotation)
        points = self._in_frame(points, rotation, offset)
        normals = np.asarray(normals, np.float64) @ r
        out = np.zeros((len(points), 3))
        for i in range(len(self)):
            v = self.positions[i] - points
            r2 = np.einsum("ij,ij->i", v, v)
            cos = np.maximum(np.einsum("ij,ij->i", normals, v) / np.sqrt(r2), 0.0)
            t = self._outward(i, -v / np.sqrt(r2)[:, None])
            out += self.intensity[i] * (cos / (r2 + self.softening[i]))[:, None] * t
        return out

    def fluence(self, points: np.ndarray, rotation=None, offset=None, softening: float = 0.0) -> np.ndarray:
        """(m, 3) W/m² the fluence at ``points`` (m, 3) (the light arriving from every direction,
        summed; placement as ``irradiance``): each point's intensity over its softened squared
        distance (its own softening plus ``softening``, m²: a point read over a lattice cell),
        through its map's transmittance raised to the share of the way to the grid box's edge that
        the point lies at (a map reaches that edge; a point inside the medium is shadowed by the
        part of the ray before it, taken as the ray's mean), 1 beyond the edge."""
        points = self._in_frame(points, rotation, offset)
        to_index = np.asarray(self.to_index, np.float64)
        lo, hi = np.full(3, -1.0), np.asarray(self.grid_shape, np.float64)
        out = np.zeros((len(points), 3))
        for i in range(len(self)):
            v = points - self.positions[i]                       # from the point of emission
            r2 = np.maximum(np.einsum("ij,ij->i", v, v), 1e-30)
            o = to_index[:3, :3] @ self.positions[i] + to_index[:3, 3]
            _, t_out = boxes.slab(np.broadcast_to(o, v.shape), v @ to_index[:3, :3].T, lo, hi)
            share = np.clip(np.nan_to_num(1.0 / np.maximum(t_out, 1e-30), nan=0.0), 0.0, 1.0)
            trans = np.maximum(self._outward(i, v / np.sqrt(r2)[:, None]), 1e-30) ** share[:, None]
            out += self.intensity[i] * (1.0 / (r2 + self.softening[i] + softening))[:, None] * trans
        return out

    @staticmethod
    def _in_frame(points: np.ndarray, rotation, offset) -> np.ndarray:
        """World ``points`` in the points' frame: R^T (P - t)."""
        t = np.zeros(3) if offset is None else np.asarray(offset, np.float64)
        return (np.asarray(points, np.float64) - t) @ _rotation(rotation)

    def _outward(self, i: int, directions: np.ndarray) -> np.ndarray:
        """Point i's map at unit ``directions`` (m, 3) outwards: its nearest texel."""
        uv = np.clip((octahedral(directions) * DIRECTIONS).astype(int), 0, DIRECTIONS - 1)
        return self.transmittance[i, uv[:, 1], uv[:, 0]]


def _rotation(rotation) -> np.ndarray:
    return np.eye(3) if rotation is None else np.asarray(rotation, np.float64)


def octahedral(d: np.ndarray) -> np.ndarray:
    """Unit directions (..., 3) to [0, 1]² (the octahedral map; light.glsl's ``octahedral``)."""
    d = np.asarray(d, np.float64)
    p = d[..., :2] / np.abs(d).sum(axis=-1, keepdims=True)
    folded = (1.0 - np.abs(p[..., ::-1])) * np.where(p >= 0.0, 1.0, -1.0)
    p = np.where(d[..., 2:3] < 0.0, folded, p)
    return p * 0.5 + 0.5


def octahedral_directions(side: int = DIRECTIONS) -> np.ndarray:
    """(side, side, 3) the unit directions at the map's texel centres (rows: v)."""
    c = (np.arange(side) + 0.5) / side * 2.0 - 1.0
    fx, fy = np.meshgrid(c, c)          # fx along u (columns), fy along v (rows)
    n = np.stack([fx, fy, 1.0 - np.abs(fx) - np.abs(fy)], axis=-1)
    t = np.maximum(-n[..., 2], 0.0)
    n[..., 0] -= np.where(n[..., 0] >= 0.0, t, -t)
    n[..., 1] -= np.where(n[..., 1] >= 0.0, t, -t)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def _value(medium: Medium, v: GridValue) -> np.ndarray | float:
    if v.grid is None:
        return float(v.offset)
    return float(v.scale) * np.asarray(medium.grids[v.grid], np.float64) + float(v.offset)


def emission_per_voxel(medium: Medium) -> np.ndarray:
    """(nx, ny, nz, 3) the emitted radiance per metre at each voxel (scene.Medium's emission
    terms, per voxel as Cycles converges to them)."""
    shape = medium.density.shape
    out = np.zeros(shape + (3,))
    strength = np.maximum(_value(medium, medium.emission_strength), 0.0)
    out += np.broadcast_to(np.asarray(strength)[..., None] if np.ndim(strength) else strength,
                           shape + (1,)) * np.asarray(medium.emission_color, np.float64)
    tint = np.asarray(medium.blackbody_tint, np.float64)
    bb = medium.blackbody_intensity
    if np.any(tint != 0.0) and (bb.grid is not None or bb.offset > 0.0):
        temperature = np.broadcast_to(_value(medium, medium.temperature), shape)
        out += tint * blackbody.radiance(temperature, np.broadcast_to(_value(medium, bb), shape))
    if medium.emission_grid is not None:
        out += tint * np.asarray(medium.grids[medium.emission_grid], np.float64)
    return np.nan_to_num(out, nan=0.0, posinf=0.0, neginf=0.0)


def _blocks(a: np.ndarray, b: int) -> np.ndarray:
    """(bx, by, bz, b³, ...) the b³ blocks of ``a`` (zero-padded to whole blocks)."""
    n = np.array(a.shape[:3])
    m = -(-n // b) * b
    pad = [(0, int(m[i] - n[i])) for i in range(3)] + [(0, 0)] * (a.ndim - 3)
    p = np.pad(a, pad)
    k = m // b
    p = p.reshape(k[0], b, k[1], b, k[2], b, *a.shape[3:])
    p = np.moveaxis(p, (1, 3, 5), (3, 4, 5))
    return p.reshape(k[0], k[1], k[2], b ** 3, *a.shape[3:])


def placement(medium: Medium) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(R, S, t) with the grid's placement index_to_world = [R S | t]: R a rotation (of the
    placement's columns, Gram-Schmidt), S upper triangular.
    The points and maps are made in the frame of S (``fire_light``), so that moving or turning
    the medium (motion blur's samples, an object dragged) only turns and moves them."""
    m = np.asarray(medium.index_to_world, np.float64)
    r = orthonormal(m[:3, :3])       # Gram-Schmidt, no LAPACK: called by every sample's first pass
    return r, r.T @ m[:3, :3], m[:3, 3].copy()


def content_key(medium: Medium) -> tuple:
    """What ``fire_light`` depends on: the grids, the emission, the extinction and the shape of the
    placement (S of ``placement``), not where the medium is nor how it is turned."""
    _, shape, _ = placement(medium)
    grids = medium.source_key if medium.source_key is not None else medium.grids_key
    return (medium.grid_key, grids, medium.emission_key, tuple(float(c) for c in medium.sigma_t),
            np.round(shape, 9).tobytes())


def fire_light(medium: Medium, max_points: int = MAX_POINTS) -> FireLight | None:
    """The points and maps of ``medium``'s emission (None: a homogeneous medium, or no emission),
    in the frame of its placement's shape: world = R @ point + t (``placement``)."""
    if medium.density is None or not medium.has_emission:
        return None
    _, shape, _ = placement(medium)
    local = np.eye(4)
    local[:3, :3] = shape
    medium = dataclasses.replace(medium, index_to_world=local)
    emission = emission_per_voxel(medium)
    weight = emission @ LUMINANCE
    if not np.any(weight > 0.0):
        return None
    shape = np.array(weight.shape)
    b = 2
    while np.count_nonzero(_blocks(weight, b).sum(axis=-1) > 0.0) > max_points:
        b += 2
    index = np.stack(np.meshgrid(*[np.arange(s, dtype=np.float64) for s in shape], indexing="ij"), axis=-1)
    to_world = np.asarray(medium.index_to_world, np.float64)
    world = index @ to_world[:3, :3].T + to_world[:3, 3]
    voxel_volume = abs(float(np.linalg.det(to_world[:3, :3])))
    # The transmittance of a block is the emission-weighted mean of its eight half blocks' (one
    # ray from the block's centre would shadow its outer, less shadowed, emission as its core).
    # Each half block's map is marched from the centre of its emitting voxels, so the maps depend
    # on where the medium emits, not how much: an edit of the emission's colour or strength
    # finds them made (``_half_maps``).
    emits = weight > 0.0
    half_weight = _split(weight, world, b // 2)[0]           # (kx, ky, kz, 8)
    w = _blocks(weight, b)
    wsum = w.sum(axis=-1)
    keep = wsum > 0.0
    w, wsum = w[keep], wsum[keep]
    xyz = _blocks(world, b)[keep]
    centre = np.einsum("nk,nkc->nc", w, xyz) / wsum[:, None]
    spread = np.einsum("nk,nk->n", w, ((xyz - centre[:, None]) ** 2).sum(axis=-1)) / wsum
    intensity = _blocks(emission, b)[keep].sum(axis=1) * voxel_volume
    maps = _half_maps(medium, world, emits, b)                # (n, 8, D, D, 3), the blocks kept
    hw = half_weight[keep]
    t = np.einsum("nh,nhuvc->nuvc", hw, maps) / hw.sum(axis=1)[:, None, None, None]
    return FireLight(centre, intensity, spread, t, b, np.linalg.inv(local), tuple(int(n) for n in shape))


HALF_MAPS_KEPT = 4
_HALF_MAPS = caches.memo("fire_light.half maps", HALF_MAPS_KEPT)   # what _half_maps made


def _half_maps(medium: Medium, world: np.ndarray, emits: np.ndarray, b: int) -> np.ndarray:
    """(n, 8, D, D, 3) the transmittance maps of the eight half blocks of each of the n blocks of
    b voxels where some voxel emits (in the blocks' order), from the centre of each half block's
    emitting voxels (1 where none emits); kept by the density, its extinction, the placement's
    shape, the emitting voxels and b."""
    key = (medium.grid_key, tuple(float(c) for c in medium.sigma_t),
           np.round(np.asarray(medium.index_to_world)[:3, :3], 9).tobytes(), b,
           hashlib.blake2b(np.packbits(emits).tobytes(), digest_size=16).hexdigest(), emits.shape)
    found = _HALF_MAPS.get(key)
    if found is not None:
        return found
    count, centres = _split(emits.astype(np.float64), world, b // 2)
    keep = count.sum(axis=-1) > 0.0
    count, centres = count[keep], centres[keep]
    lit = count > 0.0
    maps = np.ones(count.shape + (DIRECTIONS, DIRECTIONS, 3), np.float32)
    maps[lit] = _outward_transmittance(medium, centres[lit])
    return _HALF_MAPS.put(key, maps)


def _split(weight: np.ndarray, world: np.ndarray, h: int) -> tuple[np.ndarray, np.ndarray]:
    """For each block of 2h voxels a side: its eight half blocks' weights (kx, ky, kz, 8) and
    weighted centres (kx, ky, kz, 8, 3)."""
    w = _blocks(weight, h)                                   # (fx, fy, fz, h³)
    c = _blocks(world, h)
    ws = w.sum(axis=-1)
    cs = np.einsum("...k,...kc->...c", w, c) / np.where(ws > 0.0, ws, 1.0)[..., None]
    f = np.array(ws.shape)
    m = -(-f // 2) * 2
    ws = np.pad(ws, [(0, int(m[i] - f[i])) for i in range(3)])
    cs = np.pad(cs, [(0, int(m[i] - f[i])) for i in range(3)] + [(0, 0)])
    return _blocks(ws, 2), _blocks(cs, 2)


def _outward_transmittance(medium: Medium, points: np.ndarray) -> np.ndarray:
    """(n, DIRECTIONS, DIRECTIONS, 3) the medium's transmittance from each point to the edge of
    its grid's box along each map direction."""
    density = np.nan_to_num(np.asarray(medium.density, np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    density = np.where(density >= max(float(medium.clipping), 0.0), np.maximum(density, 0.0), 0.0)
    to_index = np.linalg.inv(np.asarray(medium.index_to_world, np.float64))
    dirs = octahedral_directions().reshape(-1, 3)
    if len(points) > 32:          # in chunks: (points, D², steps, 3) coordinates each
        return np.concatenate([_outward_transmittance(medium, points[i:i + 32])
                               for i in range(0, len(points), 32)])
    o = (points @ to_index[:3, :3].T + to_index[:3, 3])[:, None, :]           # (n, 1, 3) index space
    d = (dirs @ to_index[:3, :3].T)[None, :, :]                                # per metre of the ray
    o, d = np.broadcast_arrays(o, d)
    lo = np.full(3, -1.0)
    hi = np.array(density.shape, np.float64)
    _, t_out = boxes.slab(o, d, lo, hi)
    t_out = np.maximum(np.nan_to_num(t_out, nan=0.0, posinf=0.0), 0.0)        # (n, D²) metres
    s = (np.arange(MARCH_STEPS) + 0.5) / MARCH_STEPS
    p = o[..., None, :] + d[..., None, :] * (t_out[..., None] * s)[..., None]  # (n, D², S, 3)
    values = trilinear(density, p.reshape(-1, 3).T).reshape(p.shape[:-1])
    depth = values.sum(axis=-1) * (t_out / MARCH_STEPS)                        # ∫ D dl
    t = np.exp(-depth[..., None] * medium.sigma_t)
    return t.reshape(len(points), DIRECTIONS, DIRECTIONS, 3)
