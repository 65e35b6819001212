"""Brute-force CPU reference: single scattering by a double ray march in numpy.

This is the ground truth the GPU renderer is tested against, so it shares no code with it: it reads
only the scene dataclasses and returns a :class:`RenderOutput`. Everything is float64 internally.

The model (units: metres, watts, radians; colours are scene-linear RGB):

- Camera: Blender's viewplane (sensor fit, shift, perspective or orthographic), one ray through
  each pixel centre, valid between the clip depths. The camera matrix is normalised (Blender ignores
  a camera object's scale).
- Solids: two-sided triangles, Lambert with the normal turned to the camera, lit by the spots
  (shadowed by any triangle strictly between the point and the light, attenuated by the medium
  along the light ray) plus, with ``world_light='UNSHADOWED'``, the unattenuated ambient
  ``albedo * ambient``.
- Lights: spots of intensity ``color * power / (4 pi)`` W/sr with Blender's smoothstep cone
  falloff and an optional gobo; point lights of the same intensity in every direction; area
  lights as a point at their centre of intensity ``color * power / pi * cos(theta)`` W/sr about
  their -Z; all with inverse-square falloff. Suns: parallel light along their -Z, irradiance
  ``color * strength`` W/m^2, shadowed along the whole ray toward the sun. A light whose
  ``lights_medium`` / ``lights_surfaces`` is False lights no medium / no surface.
- The world (``world_light='SHADOWED'``): as Cycles gathers it with no bounces, its radiance from
  every direction attenuated by the media and the solids that way, estimated by ``world_directions``
  suns drawn at random (a fixed seed), with probability proportional to the environment's radiance
  times solid angle (uniform for a constant world), each carrying L dOmega / (K p), the Monte Carlo
  estimate of the integral; the scene's ``world_lights_medium`` / ``world_lights_surfaces`` say what
  it lights. With 'UNSHADOWED' (the engine's fast mode, not Cycles') the ambient term is added as is.
- Media: each ``sigma = D(p) * sigma_per_density``; D trilinear in a grid that fades to zero one
  voxel beyond the outermost centres, or 1 inside a box (or everywhere) for a homogeneous
  medium. Several media add their coefficients; the phase is their sigma_s-weighted mixture.
  Grid voxels that are NaN, infinite, negative or below ``Medium.clipping`` are 0 (attribute
  grids: NaN and infinite voxels).
- View rays: ``view_steps`` steps over the part of the valid range in front of the first solid and
  inside the union of the media's bounds, the coefficients read at each step's midpoint and taken
  as constant over it. A step's in-scattered radiance is ``W * sigma_s * D * (sum_lights phase * I
  * spot * gobo * V * T_light / r^2 + ambient)``, W = ``T_before * (1 - exp(-sigma_t dt)) /
  sigma_t`` its exact share of the view transmittance (per channel), with Henyey-Greenstein phase;
  the lights are read where the camera sees into the step on average (the mean of the depth in it
  weighted by the view transmittance); ``T_light`` is a ``light_steps`` midpoint march toward the
  light over the part of that segment inside the medium's bounds (analytic for a homogeneous
  medium). A colour grid C multiplies sigma_s per channel at the sample (not the extinction).
- Emission: ``W * L_e(p)`` at every step, zero-density ones included, with
  ``L_e = emission_color * max(strength, 0) + tint * B``, B the blackbody term
  ``1e-6 sigma_SB / pi * ((1 - b) + b T^4) * bb(T)`` where the intensity b > 0 (Cycles' Principled
  Volume); each grid-driven quantity is ``scale * max(G, 0) + offset``, strength trilinear in G,
  B evaluated per voxel and blended trilinearly (what Cycles' stochastic look-ups converge to);
  where b and T both read grids, Cycles draws a voxel for each on its own, so B is the blend of
  ``1{b > 0} (1 - b)`` times that of its T-only part, plus the blend of ``max(b, 0)`` times that
  of its ``T^4`` part.
"""

from __future__ import annotations

import math
import os
import time
from concurrent.futures import Executor, ThreadPoolExecutor

import numpy as np
from scipy import ndimage

from .boxes import slab
from .camera import view_plane
from .output import RenderOutput
from .scene import Camera, Light, Medium, Mesh, RenderSettings, Scene

# Samples (pixels x view steps) handled at once; each (n, 3) float64 array of them is 12 MiB.
_SAMPLES_PER_CHUNK = 1 << 19
# Density look-ups per light-march task; each task holds about 36 bytes per look-up.
_LOOKUPS_PER_TASK = 1 << 21
# Pairs (rays x triangles) tested at once.
_PAIRS_PER_CHUNK = 1 << 21
# Offset (m) of a surface point toward the light before its shadow ray.
_SURFACE_OFFSET_M = 1e-4
# Shadow-ray parameter margin (fraction of the segment) for "strictly between".
_SEGMENT_EPS = 1e-9


# --------------------------------------------------------------------------------------------
# Geometry helpers
# --------------------------------------------------------------------------------------------

def _rotation(matrix: np.ndarray) -> np.ndarray:
    """The 3x3 part of a 4x4 matrix with its columns normalised (scale removed)."""
    r = np.array(matrix[:3, :3], dtype=np.float64)
    return r / np.linalg.norm(r, axis=0, keepdims=True)


def _normalise(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, v / n, 0.0)


def _camera_rays(camera: Camera) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One ray per pixel centre, rows top first: origins (n, 3) m, unit directions (n, 3), and
    the valid distance range along each ray (n,), (n,) m."""
    w, h = int(camera.width_px), int(camera.height_px)
    fit = camera.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if w >= h else "VERTICAL"
    viewfac = float(w if fit == "HORIZONTAL" else h)
    ii, jj = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)  # (h, w), row 0 at the top
    ii = ii.reshape(-1)
    jj = jj.reshape(-1)
    rot = _rotation(camera.matrix_world)
    pos = np.array(camera.matrix_world[:3, 3], dtype=np.float64)
    if camera.projection == "ORTHO":
        pix = camera.ortho_scale / viewfac
    else:
        sensor = camera.sensor_height_mm if camera.sensor_fit == "VERTICAL" else \
            camera.sensor_width_mm
        pix = sensor / camera.lens_mm / viewfac
    x = (ii - w / 2.0 + camera.shift_x * viewfac) * pix
    y = (h / 2.0 - jj + camera.shift_y * viewfac) * pix
    n = len(x)
    if camera.projection == "ORTHO":
        local = np.stack([x, y, np.zeros(n)], axis=1)
        origins = pos + local @ rot.T
        forward = -rot[:, 2] / np.linalg.norm(rot[:, 2])
        dirs = np.broadcast_to(forward, (n, 3)).copy()
        t_near = np.full(n, float(camera.clip_start))
        t_far = np.full(n, float(camera.clip_end))
    else:
        local = np.stack([x, y, -np.ones(n)], axis=1)
        length = np.linalg.norm(local, axis=1)
        dirs = _normalise((local / length[:, None]) @ rot.T)
        origins = np.broadcast_to(pos, (n, 3)).copy()
        # depth -z = clip  <=>  distance = clip * |(x, y, -1)|
        t_near = camera.clip_start * length
        t_far = camera.clip_end * length
    return origins, dirs, t_near, t_far


class _Solids:
    """All mesh triangles in world space, for first hits and shadow tests."""

    def __init__(self, meshes: tuple[Mesh, ...]):
        v0s, e1s, e2s, albedo, holdout = [], [], [], [], []
        for mesh in meshes:
            if len(mesh.triangles) == 0:
                continue
            wv = mesh.world_vertices()
            tri = wv[mesh.triangles]
            v0s.append(tri[:, 0])
            e1s.append(tri[:, 1] - tri[:, 0])
            e2s.append(tri[:, 2] - tri[:, 0])
            albedo.append(np.broadcast_to(np.asarray(mesh.color, np.float64), (len(tri), 3)))
            holdout.append(np.full(len(tri), bool(mesh.holdout)))
        if v0s:
            v0, e1, e2 = np.concatenate(v0s), np.concatenate(e1s), np.concatenate(e2s)
            alb = np.concatenate(albedo)
            normal = np.cross(e1, e2)
            area = np.linalg.norm(normal, axis=1)
            keep = area > 0
            self.v0, self.e1, self.e2, self.albedo = v0[keep], e1[keep], e2[keep], alb[keep]
            self.normal = normal[keep] / area[keep, None]
            self.holdout = np.concatenate(holdout)[keep]
        else:
            self.v0 = self.e1 = self.e2 = self.albedo = self.normal = np.zeros((0, 3))
            self.holdout = np.zeros(0, dtype=bool)

    def __len__(self) -> int:
        return len(self.v0)

    def first_hit(self, o: np.ndarray, d: np.ndarray, t_min: np.ndarray, t_max: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
        """Nearest two-sided Moller-Trumbore hit with t in [t_min, t_max]: distance (inf where
        none) and triangle index (-1 where none)."""
        n = len(o)
        best_t = np.full(n, np.inf)
        best_i = np.full(n, -1, dtype=np.int64)
        m = len(self)
        if m == 0 or n == 0:
            return best_t, best_i
        per = max(1, _PAIRS_PER_CHUNK // n)
        for k in range(0, m, per):
            v0, e1, e2 = self.v0[k:k + per], self.e1[k:k + per], self.e2[k:k + per]
            pvec = np.cross(d[:, None, :], e2[None, :, :])
            det = np.einsum("tk,ntk->nt", e1, pvec)
            with np.errstate(divide="ignore", invalid="ignore"):
                inv = 1.0 / det
                tvec = o[:, None, :] - v0[None, :, :]
                u = np.einsum("ntk,ntk->nt", tvec, pvec) * inv
                qvec = np.cross(tvec, e1[None, :, :])
                v = np.einsum("nk,ntk->nt", d, qvec) * inv
                t = np.einsum("tk,ntk->nt", e2, qvec) * inv
                hit = ((det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1)
                       & (t >= t_min[:, None]) & (t <= t_max[:, None]))
            t = np.where(hit, t, np.inf)
            j = np.argmin(t, axis=1)
            tj = t[np.arange(n), j]
            better = tj < best_t
            best_t[better] = tj[better]
            best_i[better] = j[better] + k
        return best_t, best_i

    def blocked(self, light: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Whether any triangle lies strictly between ``light`` (3,) and each of ``points``
        (n, 3). Moller-Trumbore with the common origin at the light, written as dot products."""
        n = len(points)
        out = np.zeros(n, dtype=bool)
        if len(self) == 0 or n == 0:
            return out
        d = points - light  # segment light -> point is t in [0, 1]
        tvec = light - self.v0  # (m, 3)
        qvec = np.cross(tvec, self.e1)
        e2xt = np.cross(self.e2, tvec)
        minus_n = -np.cross(self.e1, self.e2)  # det = e1 . (d x e2) = d . (e2 x e1)
        t_num = np.einsum("tk,tk->t", self.e2, qvec)
        per = max(1, _PAIRS_PER_CHUNK // len(self))
        for k in range(0, n, per):
            dk = d[k:k + per]
            det = dk @ minus_n.T
            with np.errstate(divide="ignore", invalid="ignore"):
                inv = 1.0 / det
                u = (dk @ e2xt.T) * inv
                v = (dk @ qvec.T) * inv
                t = t_num[None, :] * inv
                hit = ((det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1)
                       & (t > _SEGMENT_EPS) & (t < 1.0 - _SEGMENT_EPS))
            out[k:k + per] = hit.any(axis=1)
        return out


# --------------------------------------------------------------------------------------------
# Medium
# --------------------------------------------------------------------------------------------

# Cycles' blackbody fit in Rec.709 (a/t + b t + c for red and green, a cubic for blue), by
# temperature segment; beyond 12000 K and below 800 K constant.
_BB_EDGES = np.array([965.0, 1167.0, 1449.0, 1902.0, 3315.0, 6365.0])
_BB_RG = np.array([
    [[1.61919106e+03, -2.05010916e-03, 5.02995757e+00], [-4.88999748e+02, 6.04330754e-04, -7.55807526e-02]],
    [[2.48845471e+03, -1.11330907e-03, 3.22621544e+00], [-7.55994277e+02, 3.16730098e-04, 4.78306139e-01]],
    [[3.34143193e+03, -4.86551192e-04, 1.76486769e+00], [-1.02363977e+03, 1.20223470e-04, 9.36662319e-01]],
    [[4.09461742e+03, -1.27446582e-04, 7.25731635e-01], [-1.26571316e+03, 4.87340896e-06, 1.27054498e+00]],
    [[4.67028036e+03, 2.91258199e-05, 1.26703442e-01], [-1.42529332e+03, -4.01150431e-05, 1.43972784e+00]],
    [[4.59509185e+03, 2.87495649e-05, 1.50345020e-01], [-1.17554822e+03, -2.16378048e-05, 1.30408023e+00]],
    [[3.78717450e+03, 9.35907826e-06, 3.99075871e-01], [-5.00799571e+02, -4.59832026e-06, 1.09098763e+00]],
])
_BB_B = np.array([
    [5.96945309e-11, -4.85742887e-08, -9.70622247e-05, -4.07936148e-03],
    [2.40430366e-11, 5.55021075e-08, -1.98503712e-04, 2.89312858e-02],
    [-1.40949732e-11, 1.89878968e-07, -3.56632824e-04, 9.10767778e-02],
    [-3.61460868e-11, 2.84822009e-07, -4.93211319e-04, 1.56723440e-01],
    [-1.97075738e-11, 1.75359352e-07, -2.50542825e-04, -2.22783266e-02],
    [-1.61997957e-13, -1.64216008e-08, 3.86216271e-04, -7.38077418e-01],
    [6.72650283e-13, -2.73078809e-08, 4.24098264e-04, -7.52335691e-01],
])
_BB_HOT = np.array([0.8262954810464208, 0.9945080501520986, 1.566307710274283])
_BB_COLD = np.array([5.413294490189271, -0.20319390035873933, -0.0822535242887164])
_STEFAN_BOLTZMANN = 5.670373e-8


def blackbody_rec709(t: np.ndarray) -> np.ndarray:
    """Cycles' blackbody colour (n, 3) for temperatures t (n,) in kelvin (may be negative)."""
    t = np.asarray(t, np.float64)
    seg = np.searchsorted(_BB_EDGES, t, side="right")
    rg = _BB_RG[seg]  # (n, 2, 3)
    b = _BB_B[seg]
    ts = np.maximum(t, 1.0)
    red_green = rg[:, :, 0] / ts[:, None] + rg[:, :, 1] * ts[:, None] + rg[:, :, 2]
    blue = ((b[:, 0] * ts + b[:, 1]) * ts + b[:, 2]) * ts + b[:, 3]
    out = np.concatenate([red_green, blue[:, None]], axis=1)
    out[t >= 12000.0] = _BB_HOT
    out[t < 800.0] = _BB_COLD
    return out


def _blackbody_term(t: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n, 3): 1e-6 sigma / pi * ((1 - b) + b T^4) * colour(T) where b > 0, else 0."""
    power = _STEFAN_BOLTZMANN * 1e-6 / math.pi * ((1.0 - b) + b * t ** 4)
    return np.where((b > 0)[:, None], power[:, None] * blackbody_rec709(t), 0.0)


def _finite(a) -> np.ndarray:
    """float64 copy with NaN and infinite values as 0."""
    a = np.asarray(a, dtype=np.float64)
    return np.where(np.isfinite(a), a, 0.0)


class _Field:
    """The density D of a medium: its bounds, point look-ups and integrals toward a light."""

    def __init__(self, medium: Medium, light_steps: int, pool: Executor):
        self.light_steps = int(light_steps)
        self.pool = pool
        self.heterogeneous = medium.density is not None
        self.attributes = {name: np.pad(_finite(g), [(1, 1)] * 3 + [(0, 0)] * (g.ndim - 3))
                           for name, g in medium.grids.items()}
        if self.heterogeneous:
            grid = _finite(medium.density)
            grid = np.where((grid > 0) & (grid >= float(medium.clipping)), grid, 0.0)
            self.grid = np.pad(grid, 1, mode="constant", constant_values=0.0)
            self.to_local = np.linalg.inv(np.asarray(medium.index_to_world, np.float64))
            self.lo = np.full(3, -1.0)
            self.hi = np.asarray(grid.shape, dtype=np.float64)
            self.glow = None
            if medium.glow is not None and medium.has_emission:
                # It emits only in its glow blocks, which may reach beyond the grid (scene.Medium).
                self.glow = medium.glow
                lo, hi = medium.glow.box
                self.lo = np.minimum(self.lo, lo)
                self.hi = np.maximum(self.hi, hi)
        elif medium.box_to_world is not None:
            self.to_local = np.linalg.inv(np.asarray(medium.box_to_world, np.float64))
            self.lo = np.full(3, -1.0)
            self.hi = np.full(3, 1.0)
        else:
            self.to_local = None

    def _points_local(self, p: np.ndarray) -> np.ndarray:
        return p @ self.to_local[:3, :3].T + self.to_local[:3, 3]

    def _dirs_local(self, d: np.ndarray) -> np.ndarray:
        return d @ self.to_local[:3, :3].T

    def interval(self, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distance range of the rays o + t d inside the medium's bounds (unbounded: all t)."""
        if self.to_local is None:
            n = len(o)
            return np.full(n, -np.inf), np.full(n, np.inf)
        return slab(self._points_local(o), self._dirs_local(d), self.lo, self.hi)

    def density(self, p: np.ndarray) -> np.ndarray:
        """D at the points (n, 3); homogeneous media answer 1 (callers only ask inside bounds)."""
        if not self.heterogeneous:
            return np.ones(len(p))
        idx = self._points_local(p) + 1.0  # padded grid
        return ndimage.map_coordinates(self.grid, idx.T, order=1, mode="constant", cval=0.0,
                                       output=np.float64)

    def attribute(self, name: str, p: np.ndarray) -> np.ndarray:
        """Grid ``name`` trilinear at the points (n, 3): (n,) or (n, 3) for a colour grid."""
        g = self.attributes[name]
        idx = (self._points_local(p) + 1.0).T
        if g.ndim == 3:
            return ndimage.map_coordinates(g, idx, order=1, mode="constant", cval=0.0, output=np.float64)
        return np.stack([ndimage.map_coordinates(g[..., k], idx, order=1, mode="constant", cval=0.0,
                                                 output=np.float64) for k in range(3)], axis=1)

    def value(self, v, p: np.ndarray) -> np.ndarray:
        """A GridValue at the points (n, 3)."""
        if v.grid is None:
            return np.full(len(p), float(v.offset))
        return v.scale * np.maximum(self.attribute(v.grid, p), 0.0) + v.offset

    def emission(self, medium: Medium, p: np.ndarray) -> np.ndarray:
        """Emitted radiance per metre (n, 3), W/(sr m^3), at the points p (n, 3); 0 outside the
        medium's glow blocks where it has them."""
        out = self._emission(medium, p)
        if getattr(self, "glow", None) is not None:
            out[~self.glow.contains(self._points_local(p))] = 0.0
        return out

    def _emission(self, medium: Medium, p: np.ndarray) -> np.ndarray:
        out = np.maximum(self.value(medium.emission_strength, p), 0.0)[:, None] * \
            np.asarray(medium.emission_color, np.float64)
        tint = np.asarray(medium.blackbody_tint, np.float64)
        if medium.emission_grid is not None:
            return out + tint * self.attribute(medium.emission_grid, p)
        bb, t = medium.blackbody_intensity, medium.temperature
        if bb.grid is None and t.grid is None:
            if bb.offset > 0:
                out += tint * _blackbody_term(np.array([max(t.offset, 0.0)]), np.array([bb.offset]))[0]
            return out
        # Cycles reads the attributes stochastically (one voxel with trilinear odds): it converges
        # to the trilinear blend of each voxel's blackbody term. Each attribute is drawn on its own,
        # so where both the intensity b and the temperature T read grids the term, 1{b > 0} (1 - b)
        # K(T) + max(b, 0) K(T) T^4, converges to the blends of its two weights times those of
        # K(T) and K(T) T^4 (K = 1e-6 sigma / pi bb(T)).
        if "__blackbody" not in self.attributes:
            shape = medium.density.shape
            b_vox = np.broadcast_to(self._voxel_value(medium, bb), shape).reshape(-1)
            t_vox = np.broadcast_to(np.maximum(self._voxel_value(medium, t), 0.0), shape).reshape(-1)
            pad = [(1, 1)] * 3 + [(0, 0)]
            if bb.grid is not None and t.grid is not None:
                k = _STEFAN_BOLTZMANN * 1e-6 / math.pi * blackbody_rec709(t_vox)
                w = np.stack([np.where(b_vox > 0, 1.0 - b_vox, 0.0), np.maximum(b_vox, 0.0)], axis=-1)
                self.attributes["__bb_weights"] = np.pad(w.reshape(*shape, 2), pad)
                self.attributes["__bb_k0"] = np.pad(k.reshape(*shape, 3), pad)
                self.attributes["__bb_k4"] = np.pad((k * t_vox[:, None] ** 4).reshape(*shape, 3), pad)
                self.attributes["__blackbody"] = None
            else:
                term = _blackbody_term(t_vox, b_vox).reshape(*shape, 3)
                self.attributes["__blackbody"] = np.pad(term, pad)
        if self.attributes["__blackbody"] is None:
            g = self.attributes["__bb_weights"]
            idx = (self._points_local(p) + 1.0).T
            w0, w1 = (ndimage.map_coordinates(g[..., j], idx, order=1, mode="constant", cval=0.0,
                                              output=np.float64) for j in range(2))
            return out + tint * (w0[:, None] * self.attribute("__bb_k0", p)
                                 + w1[:, None] * self.attribute("__bb_k4", p))
        return out + tint * self.attribute("__blackbody", p)

    @staticmethod
    def _voxel_value(medium: Medium, v) -> np.ndarray:
        if v.grid is None:
            return np.asarray(float(v.offset))
        return v.scale * np.maximum(_finite(medium.grids[v.grid]), 0.0) + v.offset

    def _march_sums(self, start: np.ndarray, step: np.ndarray) -> np.ndarray:
        """Sum of D over ``light_steps`` midpoints start + (k + 1/2) step (padded index space)."""
        m = self.light_steps
        s = np.arange(m, dtype=np.float64) + 0.5
        coords = np.empty((3, len(start), m))
        for axis in range(3):
            np.multiply(step[:, axis, None], s[None, :], out=coords[axis])
            coords[axis] += start[:, axis, None]
        vals = ndimage.map_coordinates(self.grid, coords.reshape(3, -1), order=1,
                                       mode="constant", cval=0.0, output=np.float64)
        return vals.reshape(len(start), m).sum(axis=1)

    def integral_to(self, points: np.ndarray, light: np.ndarray) -> np.ndarray:
        """Integral of D (metres x density) along the segments points (n, 3) -> light (3,) or
        to per-point ends (n, 3)."""
        n = len(points)
        if n == 0:
            return np.zeros(0)
        seg = light - points
        dist = np.linalg.norm(seg, axis=1)
        if self.to_local is None:
            return dist
        a = self._points_local(points)
        dl = self._dirs_local(seg)
        s0, s1 = slab(a, dl, self.lo, self.hi)
        s0 = np.maximum(s0, 0.0)
        s1 = np.minimum(s1, 1.0)
        frac = np.clip(s1 - s0, 0.0, None)
        if not self.heterogeneous:
            return dist * frac
        out = np.zeros(n)
        nz = np.flatnonzero(frac > 0)
        if len(nz) == 0:
            return out
        m = self.light_steps
        start = a[nz] + s0[nz, None] * dl[nz] + 1.0
        step = dl[nz] * (frac[nz] / m)[:, None]
        per = max(1, _LOOKUPS_PER_TASK // m)
        tasks = [(start[k:k + per], step[k:k + per]) for k in range(0, len(nz), per)]
        sums = list(self.pool.map(lambda args: self._march_sums(*args), tasks))
        out[nz] = np.concatenate(sums) * dist[nz] * frac[nz] / m
        return out


# --------------------------------------------------------------------------------------------
# Lights
# --------------------------------------------------------------------------------------------

class _Light:
    """A light's emission toward points: I * profile * gobo / r^2 (a sun: its irradiance), and
    where its shadow rays end."""

    def __init__(self, light: Light):
        self.kind = light.kind
        self.position = np.array(light.matrix_world[:3, 3], dtype=np.float64)
        self.rotation = _rotation(light.matrix_world)
        self.direction = -self.rotation[:, 2]
        c = np.asarray(light.color, np.float64)
        if self.kind == "SUN":
            self.intensity = c * light.power_w
        elif self.kind == "AREA":
            self.intensity = c * light.power_w / math.pi
        else:
            self.intensity = c * light.power_w / (4.0 * math.pi)
        self.cos_half = math.cos(light.spot_size_rad / 2.0)
        self.blend = float(light.spot_blend)
        self.tan_half = math.tan(min(light.spot_size_rad / 2.0, math.radians(85.0)))
        self.gobo = None if light.gobo is None or self.kind != "SPOT" else np.asarray(light.gobo, np.float64)
        self.lights_medium, self.lights_surfaces = bool(light.lights_medium), bool(light.lights_surfaces)

    @staticmethod
    def usable(light: Light) -> bool:
        cone = light.spot_size_rad > 0 if light.kind == "SPOT" else True
        return light.power_w != 0 and cone and any(c != 0 for c in light.color)

    def spot(self, cos_theta: np.ndarray) -> np.ndarray:
        """Blender's cone falloff for the cosine of the angle off the spot axis."""
        inside = cos_theta > self.cos_half
        if self.blend <= 0:
            return inside.astype(np.float64)
        x = np.clip((cos_theta - self.cos_half) / ((1.0 - self.cos_half) * self.blend), 0.0, 1.0)
        return np.where(inside, x * x * (3.0 - 2.0 * x), 0.0)

    def gobo_at(self, points: np.ndarray) -> np.ndarray:
        """Bilinear gobo colour (n, 3) at world points inside the cone (clamped to the edge)."""
        g = self.gobo
        h, w = g.shape[:2]
        q = (points - self.position) @ self.rotation  # = R^T (p - pos), light-local
        depth = np.maximum(-q[:, 2], 1e-300)
        u = 0.5 + 0.5 * (q[:, 0] / depth) / self.tan_half
        v = 0.5 + 0.5 * (q[:, 1] / depth) / self.tan_half
        x = np.clip(u * w - 0.5, 0.0, w - 1.0)  # column coordinate, texel centres at integers
        y = np.clip((1.0 - v) * h - 0.5, 0.0, h - 1.0)  # row coordinate, row 0 at the top
        x0 = np.minimum(np.floor(x).astype(np.int64), max(w - 2, 0))
        y0 = np.minimum(np.floor(y).astype(np.int64), max(h - 2, 0))
        x1 = np.minimum(x0 + 1, w - 1)
        y1 = np.minimum(y0 + 1, h - 1)
        fx = (x - x0)[:, None]
        fy = (y - y0)[:, None]
        top = g[y0, x0] * (1 - fx) + g[y0, x1] * fx
        bottom = g[y1, x0] * (1 - fx) + g[y1, x1] * fx
        return top * (1 - fy) + bottom * fy

    def emission(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unit vectors of the light's travel at the points (n, 3) and the irradiance (n, 3,
        W/m^2) at normal incidence there before shadows and the medium."""
        if self.kind == "SUN":
            n = len(points)
            return (np.broadcast_to(self.direction, (n, 3)).copy(),
                    np.broadcast_to(self.intensity, (n, 3)).copy())
        v = points - self.position
        r2 = np.einsum("nk,nk->n", v, v)
        unit = _normalise(v)
        if self.kind == "SPOT":
            prof = self.spot(unit @ self.direction)
        elif self.kind == "AREA":
            prof = np.maximum(unit @ self.direction, 0.0)
        else:
            prof = np.ones(len(points))
        prof[r2 <= 0] = 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            fac = np.where((prof > 0)[:, None], prof[:, None] / r2[:, None] * self.intensity, 0.0)
        if self.gobo is not None:
            lit = np.flatnonzero(prof > 0)
            if len(lit):
                fac[lit] *= self.gobo_at(points[lit])
        return unit, fac

    def ends(self, points: np.ndarray) -> np.ndarray:
        """Where the light rays toward the points start: the light, or far toward a sun."""
        if self.kind == "SUN":
            return points - self.direction * _SUN_DISTANCE_M
        return self.position

    def blocked(self, solids: _Solids, points: np.ndarray) -> np.ndarray:
        """Whether a solid lies between the light and each point."""
        if self.kind != "SUN":
            return solids.blocked(self.position, points)
        n = len(points)
        t, _ = solids.first_hit(points, np.broadcast_to(-self.direction, (n, 3)).copy(),
                                np.full(n, 1e-7), np.full(n, np.inf))
        return np.isfinite(t)


_Spot = _Light
_SUN_DISTANCE_M = 1e5
"""How far toward a sun its rays are followed through the media, metres."""


class _Media:
    """Every medium of a scene: bounds (their union), coefficients, optical depths."""

    def __init__(self, media, light_steps: int, pool: Executor):
        self.media = list(media)
        self.fields = [_Field(m, light_steps, pool) for m in self.media]
        self.sigma_t = [m.sigma_t for m in self.media]
        self.sigma_s = [np.asarray(m.sigma_s, np.float64) for m in self.media]

    def interval(self, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lo = np.full(len(o), np.inf)
        hi = np.full(len(o), -np.inf)
        for f in self.fields:
            a, b = f.interval(o, d)
            hit = b > a
            lo = np.where(hit, np.minimum(lo, a), lo)
            hi = np.where(hit, np.maximum(hi, b), hi)
        return lo, hi

    def inside(self, p: np.ndarray) -> list[np.ndarray]:
        """Whether the points lie in each medium's bounds (n,) bool each."""
        out = []
        for f in self.fields:
            if f.to_local is None:
                out.append(np.ones(len(p), bool))
                continue
            a, b = f.interval(p, np.zeros_like(p) + np.array([1.0, 0.0, 0.0]))
            out.append((a <= 0) & (b >= 0))
        return out

    def densities(self, p: np.ndarray, inside=None) -> list[np.ndarray]:
        """D of each medium at p (0 outside its bounds)."""
        inside = self.inside(p) if inside is None else inside
        out = []
        for f, ins in zip(self.fields, inside, strict=True):
            dens = np.zeros(len(p))
            if ins.any():
                dens[ins] = f.density(p[ins])
            out.append(dens)
        return out

    def optical_depth_to(self, points: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """(n, 3) extinction integrated along points -> ends."""
        tau = np.zeros((len(points), 3))
        for f, st in zip(self.fields, self.sigma_t, strict=True):
            tau += f.integral_to(points, ends)[:, None] * st
        return tau


def _henyey_greenstein(cos_theta: np.ndarray, g: float) -> np.ndarray:
    """Henyey-Greenstein phase function, 1/sr."""
    return (1.0 - g * g) / (4.0 * math.pi * (1.0 + g * g - 2.0 * g * cos_theta) ** 1.5)


# --------------------------------------------------------------------------------------------
# Rendering
# --------------------------------------------------------------------------------------------

def _shade_surfaces(p: np.ndarray, view_dir: np.ndarray, tri: np.ndarray, solids: _Solids,
                    lights: list[_Light], media: _Media | None,
                    ambient: np.ndarray, casters: _Solids | None = None) -> np.ndarray:
    """Outgoing Lambert radiance (n, 3) of the solid points p seen along view_dir (triangles
    ``tri`` of ``solids``), shadowed by ``casters`` (default: ``solids``)."""
    casters = solids if casters is None else casters
    normal = solids.normal[tri]
    facing = np.einsum("nk,nk->n", normal, view_dir) > 0
    normal[facing] *= -1.0
    albedo = solids.albedo[tri]
    radiance = albedo * ambient
    for light in lights:
        unit, fac = light.emission(p)
        ndl = -np.einsum("nk,nk->n", normal, unit)
        live = np.flatnonzero((ndl > 0) & (fac > 0).any(axis=1))
        if len(live) == 0:
            continue
        offset = p[live] + _SURFACE_OFFSET_M * normal[live]
        live = live[~light.blocked(casters, offset)]
        if len(live) == 0:
            continue
        trans = np.ones((len(live), 3))
        if media is not None:
            ends = light.ends(p[live])
            trans = np.exp(-media.optical_depth_to(p[live], ends))
        radiance[live] += albedo[live] / math.pi * fac[live] * ndl[live, None] * trans
    return radiance


def _step_integral(x: np.ndarray) -> np.ndarray:
    """(1 - exp(-x)) / x, the mean view transmittance over a step of optical depth x."""
    small = x < 1e-4
    return np.where(small, 1.0 - 0.5 * x, -np.expm1(-x) / np.where(small, 1.0, x))


def _seen_fraction(x: np.ndarray) -> np.ndarray:
    """Where in a step of optical depth x the camera sees on average, as a fraction of the step:
    the mean of s weighted by exp(-x s), s in [0, 1]."""
    small = x < 1e-4
    xs = np.where(small, 1.0, x)
    return np.where(small, 0.5 - x / 12.0, 1.0 / xs - 1.0 / np.expm1(xs))


def _march_view(o: np.ndarray, d: np.ndarray, t0: np.ndarray, t1: np.ndarray, media: _Media,
                solids: _Solids, lights: list[_Light], ambient: np.ndarray,
                view_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """In-scattered radiance (n, 3) and transmittance (n, 3) along the segments [t0, t1] of the
    rays o + t d (non-empty segments only)."""
    n, steps = len(o), int(view_steps)
    dt = (t1 - t0) / steps
    t = t0[:, None] + (np.arange(steps) + 0.5)[None, :] * dt[:, None]
    p = (o[:, None, :] + t[:, :, None] * d[:, None, :]).reshape(-1, 3)
    inside = media.inside(p)
    dens = [x.reshape(n, steps) for x in media.densities(p, inside)]
    ext = sum(dm[:, :, None] * st for dm, st in zip(dens, media.sigma_t, strict=True))   # (n, s, 3)
    # Each medium's scattering per unit density: sigma_s, times its colour grid where it has one.
    tints = [f.attribute(m.color_grid, p).reshape(n, steps, 3) if m.color_grid is not None else 1.0
             for f, m in zip(media.fields, media.media, strict=True)]
    ss = sum(dm[:, :, None] * sc * c for dm, sc, c in zip(dens, media.sigma_s, tints, strict=True))
    # Each step's exact share of its source terms (the extinction constant over it): the view
    # transmittance before it times its integral over the step, (1 - exp(-x)) / x dt, x = ext dt.
    x = ext * dt[:, None, None]
    tau_before = np.cumsum(x, axis=1) - x
    t_end = np.exp(-x.sum(axis=1))
    weight = np.exp(-tau_before) * dt[:, None, None] * _step_integral(x)      # (n, steps, 3)
    # The lights are read where the camera sees into each step on average.
    t_lit = t0[:, None] + (np.arange(steps) + _seen_fraction(x.mean(axis=2))) * dt[:, None]
    p_lit = (o[:, None, :] + t_lit[:, :, None] * d[:, None, :]).reshape(-1, 3)
    emitted = np.zeros((n, 3))
    for f, m, ins in zip(media.fields, media.media, inside, strict=True):
        if m.has_emission and ins.any():
            glow = np.zeros((n * steps, 3))
            glow[ins] = f.emission(m, p[ins])
            emitted += np.einsum("nsk,nsk->nk", weight, glow.reshape(n, steps, 3))
    source = (ss.reshape(-1, 3) * ambient).copy()
    any_dens = sum(dm for dm in dens) > 0
    if lights and any(np.any(sc != 0) for sc in media.sigma_s):
        active = np.flatnonzero(any_dens.reshape(-1))
        pa = p_lit[active]
        da = np.repeat(d, steps, axis=0)[active]
        dens_a = [dm.reshape(-1)[active] for dm in dens]
        tint_a = [c if np.isscalar(c) else c.reshape(-1, 3)[active] for c in tints]
        for light in lights:
            unit, fac = light.emission(pa)
            live = np.flatnonzero((fac > 0).any(axis=1))
            if len(live) == 0:
                continue
            live = live[~light.blocked(solids, pa[live])]
            if len(live) == 0:
                continue
            cos = -np.einsum("nk,nk->n", unit[live], da[live])
            phase_ss = sum(dm[live, None] * sc * (c if np.isscalar(c) else c[live])
                           * _henyey_greenstein(cos, float(m.anisotropy))[:, None]
                           for dm, sc, c, m in zip(dens_a, media.sigma_s, tint_a, media.media, strict=True))
            trans = np.exp(-media.optical_depth_to(pa[live], light.ends(pa[live])))
            source[active[live]] += phase_ss * fac[live] * trans
    scattering = np.einsum("nsk,nsk->nk", weight, source.reshape(n, steps, 3)) + emitted
    return scattering, t_end


def _world_suns(scene: Scene, count: int, seed: int = 0) -> list[Light]:
    """``count`` suns drawn at random over the world's directions (see the module docstring)."""
    rng = np.random.default_rng(seed)
    env = None if scene.environment is None else scene.environment.image()
    if env is None:
        # stratified in z, the azimuths turned by the golden angle from a random start
        z = 1.0 - 2.0 * (np.arange(count) + rng.random(count)) / count
        phi = rng.random() * 2.0 * math.pi + math.pi * (3.0 - math.sqrt(5.0)) * np.arange(count)
        r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
        toward = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)
        weight = np.broadcast_to(np.asarray(scene.ambient, np.float64) * 4.0 * math.pi / count, (count, 3))
    else:
        env = np.asarray(env, np.float64)
        h, w = env.shape[:2]
        omega = (2.0 * math.pi / w) * (math.pi / h) * np.sin(math.pi * (np.arange(h) + 0.5) / h)
        power = (env * omega[:, None, None]).reshape(-1, 3)            # radiance x solid angle
        p = power.mean(axis=1) + 1e-12 * power.mean()
        p /= p.sum()
        # systematic draws through the cumulative distribution, jittered inside each pixel
        pick = np.minimum(np.searchsorted(np.cumsum(p), (np.arange(count) + rng.random()) / count), h * w - 1)
        row, col = np.divmod(pick, w)
        theta = math.pi * (row + rng.random(count)) / h
        phi = math.pi - 2.0 * math.pi * (col + rng.random(count)) / w
        toward = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)
        weight = power[pick] / (count * p[pick, None])
    suns = []
    for k in range(count):
        z_axis = toward[k]                     # local +Z toward the sky: the light travels along -Z
        helper = np.array([1.0, 0.0, 0.0]) if abs(z_axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        x_axis = _normalise(np.cross(helper, z_axis)[None])[0]
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2] = x_axis, np.cross(z_axis, x_axis), z_axis
        suns.append(Light(matrix_world=m, color=tuple(float(c) for c in weight[k]), power_w=1.0, kind="SUN",
                          name="World", from_world=True, lights_medium=scene.world_lights_medium,
                          lights_surfaces=scene.world_lights_surfaces))
    return suns


def render_reference(scene: Scene, settings: RenderSettings | None = None, *,
                     view_steps: int = 128, light_steps: int = 128,
                     world_directions: int = 256) -> RenderOutput:
    """Render ``scene`` by brute force on the CPU (the ground truth for the GPU renderer).

    ``view_steps`` midpoint samples per view ray through the medium and ``light_steps`` per light
    ray from each of them. Only ``settings.ambient``, ``settings.film_transparent`` and
    ``settings.world_light`` are read (None: ambient on and added unshadowed, transparent film);
    a shadowed world is ``world_directions`` suns. Returns
    scene-linear radiance (W/(sr m^2)) passes of camera.width_px x height_px pixels, top row
    first: 'scattering', 'surfaces' (already attenuated by the medium), 'transmittance'
    (dimensionless), composed by :meth:`RenderOutput.compose`.
    """
    start_time = time.perf_counter()
    ambient_on = True if settings is None else bool(settings.ambient)
    ambient = np.asarray(scene.ambient, np.float64) if ambient_on else np.zeros(3)
    world_suns = []
    if settings is not None and settings.world_light == "SHADOWED" and ambient.any():
        world_suns = [_Light(s) for s in _world_suns(scene, world_directions)]
        ambient = np.zeros(3)
    ambient_medium = ambient if scene.world_lights_medium else np.zeros(3)
    ambient_surface = ambient if scene.world_lights_surfaces else np.zeros(3)
    cam = scene.camera
    w, h = int(cam.width_px), int(cam.height_px)
    origins, dirs, t_near, t_far = _camera_rays(cam)
    n_pix = len(origins)
    solids = _Solids(scene.camera_meshes)        # what the camera sees (holdouts included)
    casters = _Solids(scene.shadow_casters)      # what shadows the lights
    lights = [_Light(light) for light in scene.lights if _Light.usable(light)] + world_suns
    lights_medium = [light for light in lights if light.lights_medium]
    lights_surfaces = [light for light in lights if light.lights_surfaces]

    scattering = np.zeros((n_pix, 3))
    surfaces = np.zeros((n_pix, 3))
    transmittance = np.ones((n_pix, 3))
    mask = np.zeros(n_pix, dtype=bool)
    background = np.zeros(n_pix, dtype=bool)     # no solid seen (holdouts are solids here)
    per = max(1, _SAMPLES_PER_CHUNK // max(1, int(view_steps)))
    workers = max(1, min(8, os.cpu_count() or 1))
    with ThreadPoolExecutor(max_workers=workers) as pool:
        field = _Media(scene.media, light_steps, pool) if scene.media else None
        for k in range(0, n_pix, per):
            sl = slice(k, min(k + per, n_pix))
            o, d, tn, tf = origins[sl], dirs[sl], t_near[sl], t_far[sl]
            t_hit, tri = solids.first_hit(o, d, tn, tf)
            hit = np.flatnonzero(tri >= 0)
            t_end = np.where(tri >= 0, t_hit, tf)
            trans = np.ones((len(o), 3))
            if field is not None:
                ta, tb = field.interval(o, d)
                t0 = np.maximum(tn, ta)
                t1 = np.minimum(t_end, tb)
                seg = np.flatnonzero(t1 > t0)
                if len(seg):
                    scat, trans_seg = _march_view(o[seg], d[seg], t0[seg], t1[seg], field,
                                                  casters, lights_medium, ambient_medium, view_steps)
                    trans[seg] = trans_seg
                    scattering[k + seg] = scat
            transmittance[sl] = trans
            background[sl] = tri < 0
            hit = hit[~solids.holdout[tri[hit]]]   # a holdout: no radiance, alpha left open
            if len(hit):
                p = o[hit] + t_hit[hit, None] * d[hit]
                radiance = _shade_surfaces(p, d[hit], tri[hit], solids, lights_surfaces, field,
                                           ambient_surface, casters)
                surfaces[k + hit] = trans[hit] * radiance
                mask[k + hit] = True

    def image(a: np.ndarray) -> np.ndarray:
        return a.reshape(h, w, 3).astype(np.float32)

    transparent = True if settings is None else bool(settings.film_transparent)
    world = None if transparent else scene.background
    if world is not None and not isinstance(world, tuple):       # the environment, by direction
        _, dirs, _, _ = _camera_rays(scene.camera)
        world = image(world.radiance(dirs, footprint=view_plane(scene.camera).pixel_size))
    return RenderOutput.compose(image(scattering), image(surfaces), image(transmittance),
                                mask.reshape(h, w), world=world,
                                background_mask=background.reshape(h, w),
                                timings_s={"reference": time.perf_counter() - start_time})
