"""Brute-force CPU reference: single scattering by a double ray march in numpy.

This is the ground truth the GPU renderer is tested against, so it shares no code with it: it reads
only the scene dataclasses and returns a :class:`RenderOutput`. Everything is float64 internally.

The model (units: metres, watts, radians; colours are scene-linear RGB):

- Camera: Blender's viewplane (sensor fit, shift, perspective or orthographic), one ray through
  each pixel centre, valid between the clip depths. The camera matrix is normalised (Blender ignores
  a camera object's scale).
- Solids: two-sided triangles, Lambert with the normal turned to the camera, lit by the spots
  (shadowed by any triangle strictly between the point and the light, attenuated by the medium
  along the light ray) plus the unattenuated ambient ``albedo * ambient``.
- Lights: spots of intensity ``color * power / (4 pi)`` W/sr with Blender's smoothstep cone
  falloff and an optional gobo; point lights of the same intensity in every direction; area
  lights as a point at their centre of intensity ``color * power / pi * cos(theta)`` W/sr about
  their -Z; all with inverse-square falloff. Suns: parallel light along their -Z, irradiance
  ``color * strength`` W/m^2, shadowed along the whole ray toward the sun.
- Media: each ``sigma = D(p) * sigma_per_density``; D trilinear in a grid that fades to zero one
  voxel beyond the outermost centres, or 1 inside a box (or everywhere) for a homogeneous
  medium. Several media add their coefficients; the phase is their sigma_s-weighted mixture.
- View rays: ``view_steps`` midpoint samples over the part of the valid range in front of the first
  solid and inside the union of the media's bounds. At each sample the in-scattered radiance is
  ``T_view * sigma_s * D * dt * (sum_lights phase * I * spot * gobo * V * T_light / r^2 + ambient)``
  with Henyey-Greenstein phase; ``T_light`` is a ``light_steps`` midpoint march toward the light
  over the part of that segment inside the medium's bounds (analytic for a homogeneous medium).
"""

from __future__ import annotations

import math
import os
import time
from concurrent.futures import Executor, ThreadPoolExecutor

import numpy as np
from scipy import ndimage

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


def _slab(o: np.ndarray, d: np.ndarray, lo: np.ndarray, hi: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray]:
    """Parameter interval [t_in, t_out] of the lines o + t d, (n, 3) each, inside the box
    lo <= x <= hi (empty where t_in >= t_out)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        ta = (lo - o) * inv
        tb = (hi - o) * inv
    t_near = np.minimum(ta, tb)
    t_far = np.maximum(ta, tb)
    parallel = d == 0
    inside = (o >= lo) & (o <= hi)
    t_near = np.where(parallel, np.where(inside, -np.inf, np.inf), t_near)
    t_far = np.where(parallel, np.where(inside, np.inf, -np.inf), t_far)
    return t_near.max(axis=1), t_far.min(axis=1)


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

class _Field:
    """The density D of a medium: its bounds, point look-ups and integrals toward a light."""

    def __init__(self, medium: Medium, light_steps: int, pool: Executor):
        self.light_steps = int(light_steps)
        self.pool = pool
        self.heterogeneous = medium.density is not None
        if self.heterogeneous:
            grid = np.asarray(medium.density, dtype=np.float64)
            self.grid = np.pad(grid, 1, mode="constant", constant_values=0.0)
            self.to_local = np.linalg.inv(np.asarray(medium.index_to_world, np.float64))
            self.lo = np.full(3, -1.0)
            self.hi = np.asarray(grid.shape, dtype=np.float64)
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
        return _slab(self._points_local(o), self._dirs_local(d), self.lo, self.hi)

    def density(self, p: np.ndarray) -> np.ndarray:
        """D at the points (n, 3); homogeneous media answer 1 (callers only ask inside bounds)."""
        if not self.heterogeneous:
            return np.ones(len(p))
        idx = self._points_local(p) + 1.0  # padded grid
        return ndimage.map_coordinates(self.grid, idx.T, order=1, mode="constant", cval=0.0,
                                       output=np.float64)

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
        s0, s1 = _slab(a, dl, self.lo, self.hi)
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

    def densities(self, p: np.ndarray) -> list[np.ndarray]:
        """D of each medium at p (0 outside its bounds)."""
        out = []
        for f in self.fields:
            if f.to_local is None:
                out.append(np.ones(len(p)))
                continue
            a, b = f.interval(p, np.zeros_like(p) + np.array([1.0, 0.0, 0.0]))
            inside = (a <= 0) & (b >= 0)
            dens = np.zeros(len(p))
            if inside.any():
                dens[inside] = f.density(p[inside])
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


def _march_view(o: np.ndarray, d: np.ndarray, t0: np.ndarray, t1: np.ndarray, media: _Media,
                solids: _Solids, lights: list[_Light], ambient: np.ndarray,
                view_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """In-scattered radiance (n, 3) and transmittance (n, 3) along the segments [t0, t1] of the
    rays o + t d (non-empty segments only)."""
    n, steps = len(o), int(view_steps)
    dt = (t1 - t0) / steps
    t = t0[:, None] + (np.arange(steps) + 0.5)[None, :] * dt[:, None]
    p = (o[:, None, :] + t[:, :, None] * d[:, None, :]).reshape(-1, 3)
    dens = [x.reshape(n, steps) for x in media.densities(p)]
    ext = sum(dm[:, :, None] * st for dm, st in zip(dens, media.sigma_t, strict=True))   # (n, s, 3)
    ss = sum(dm[:, :, None] * sc for dm, sc in zip(dens, media.sigma_s, strict=True))
    tau = (np.cumsum(ext, axis=1) - 0.5 * ext) * dt[:, None, None]
    t_view = np.exp(-tau)
    t_end = np.exp(-ext.sum(axis=1) * dt[:, None])
    weight = t_view * dt[:, None, None]                              # (n, steps, 3)
    source = (ss.reshape(-1, 3) * ambient).copy()
    any_dens = sum(dm for dm in dens) > 0
    if lights and any(np.any(sc != 0) for sc in media.sigma_s):
        active = np.flatnonzero(any_dens.reshape(-1))
        pa = p[active]
        da = np.repeat(d, steps, axis=0)[active]
        dens_a = [dm.reshape(-1)[active] for dm in dens]
        for light in lights:
            unit, fac = light.emission(pa)
            live = np.flatnonzero((fac > 0).any(axis=1))
            if len(live) == 0:
                continue
            live = live[~light.blocked(solids, pa[live])]
            if len(live) == 0:
                continue
            cos = -np.einsum("nk,nk->n", unit[live], da[live])
            phase_ss = sum(dm[live, None] * sc * _henyey_greenstein(cos, float(m.anisotropy))[:, None]
                           for dm, sc, m in zip(dens_a, media.sigma_s, media.media, strict=True))
            trans = np.exp(-media.optical_depth_to(pa[live], light.ends(pa[live])))
            source[active[live]] += phase_ss * fac[live] * trans
    scattering = np.einsum("nsk,nsk->nk", weight, source.reshape(n, steps, 3))
    return scattering, t_end


def render_reference(scene: Scene, settings: RenderSettings | None = None, *,
                     view_steps: int = 128, light_steps: int = 128) -> RenderOutput:
    """Render ``scene`` by brute force on the CPU (the ground truth for the GPU renderer).

    ``view_steps`` midpoint samples per view ray through the medium and ``light_steps`` per light
    ray from each of them. Only ``settings.ambient`` is read (None: ambient on). Returns
    scene-linear radiance (W/(sr m^2)) passes of camera.width_px x height_px pixels, top row
    first: 'scattering', 'surfaces' (already attenuated by the medium), 'transmittance'
    (dimensionless), composed by :meth:`RenderOutput.compose`.
    """
    start_time = time.perf_counter()
    ambient_on = True if settings is None else bool(settings.ambient)
    ambient = np.asarray(scene.ambient, np.float64) if ambient_on else np.zeros(3)
    cam = scene.camera
    w, h = int(cam.width_px), int(cam.height_px)
    origins, dirs, t_near, t_far = _camera_rays(cam)
    n_pix = len(origins)
    solids = _Solids(scene.camera_meshes)        # what the camera sees (holdouts included)
    casters = _Solids(scene.shadow_casters)      # what shadows the lights
    lights = [_Light(light) for light in scene.lights if _Light.usable(light)]

    scattering = np.zeros((n_pix, 3))
    surfaces = np.zeros((n_pix, 3))
    transmittance = np.ones((n_pix, 3))
    mask = np.zeros(n_pix, dtype=bool)
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
                                                  casters, lights, ambient, view_steps)
                    trans[seg] = trans_seg
                    scattering[k + seg] = scat
            transmittance[sl] = trans
            hit = hit[~solids.holdout[tri[hit]]]   # a holdout: no radiance, alpha left open
            if len(hit):
                p = o[hit] + t_hit[hit, None] * d[hit]
                radiance = _shade_surfaces(p, d[hit], tri[hit], solids, lights, field,
                                           ambient, casters)
                surfaces[k + hit] = trans[hit] * radiance
                mask[k + hit] = True

    def image(a: np.ndarray) -> np.ndarray:
        return a.reshape(h, w, 3).astype(np.float32)

    return RenderOutput.compose(image(scattering), image(surfaces), image(transmittance),
                                mask.reshape(h, w),
                                timings_s={"reference": time.perf_counter() - start_time})
