"""The 'AUTO' quality setting: the cheapest settings that the benchmark found to reach SSIM >= 0.99
against the ground truth, chosen from a few numbers measured on the scene (numpy only, no GL).

The rule and the sweeps it comes from are written down in ``docs/benchmark.md``:

- heterogeneous medium: density weighting on (automatic alpha, for a spot reaching one medium
  the probe's largest density integral below: no GPU pass, no read-back); the coefficient count
  from the largest optical depth tau along the lights' rays (``AUTO_COEFFICIENTS``: 2
  coefficients, beside the K range in one texture, where tau <= 2, 6 in two textures where
  tau <= 8, 10 in three where tau <= 16; a smooth density of sharpness g reads
  ``AUTO_COEFFICIENTS_SMOOTH`` at tau x g: 2 where it is <= 0.625, 6 to 5, 10 to 10); view and
  light steps from the number of voxels the longest view / light ray crosses through the
  non-zero density, times
  the steps per voxel the density's sharpness asks for (``sharpness``: one step per "feature",
  the distance over which the density changes by its maximum, clamped to ``STEPS_PER_VOXEL``
  for the view, ``LIGHT_STEPS_PER_VOXEL`` for the TFM build, whose cosines smooth the light ray
  anyway, and for a smooth density at most ``SMOOTH_LIGHT_STEPS_PER_COEFFICIENT`` per
  coefficient; a sharp density deeper than ``THICK_SHARP_DEPTH`` up to twice that:
  ``thick_steps_factor``), clamped to ``MIN_STEPS``..``MAX_STEPS``;
- homogeneous medium: no TFM (analytic transmittance), projective-space sampling,
  ``HOMOGENEOUS_VIEW_STEPS`` view steps;
- the TFM filter: 'LINEAR' (as accurate as 'EXACT' on every benchmark scene, SSIM within 1e-4,
  for a quarter of the lookups; docs/benchmark.md);
- the TFM's side from the medium's footprint in the light's view ('FOOTPRINT': one texel per
  voxel where the medium is nearest to the light for a sharp or optically thick density, one per
  three voxels for a smooth thin one (``footprint_texels_per_voxel``), at most the map
  resolution); the shadow maps keep
  the user's resolution;
- map resolution, method and ambient are the user's.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass

import numpy as np

from . import caches
from .boxes import nonzero_bounds, slab
from .light import LightFrame, is_dark, light_faces
from .medium_grid import clean_density, downsample
from .scene import RenderSettings, Scene

# (largest optical depth, coefficients): the first row whose depth is >= tau applies.
# The counts are those that fill the textures a lookup fetches (passes/tfm.coefficient_textures:
# 2 in one texture, 6 in two, 10 in three), so each row reads the most for its fetches.
AUTO_COEFFICIENTS: tuple[tuple[float, int], ...] = ((2.0, 2), (8.0, 6), (16.0, 10), (math.inf, 16))
# The same for a smooth density (sharpness g < SHARP_FOOTPRINT), whose transmittance has no steps
# for the cosines to ring on, read at tau x max(g, SMOOTH_SHARPNESS_FLOOR): the depth per "feature"
# of the density. Measured with sigma scaled (docs/benchmark.md), SSIM >= 0.995 against
# the numpy ground truth: 2 coefficients on the smoke (g 0.125) to tau ~ 5 (0.9950 at 6, 0.9933
# at 8); 6 on the dense smoke to 40 (0.9975), on the cloud (g 0.185) to ~28 (0.9958 at 24,
# 0.9949 at 30).
AUTO_COEFFICIENTS_SMOOTH: tuple[tuple[float, int], ...] = ((0.625, 2), (5.0, 6), (10.0, 10), (math.inf, 16))
SMOOTH_SHARPNESS_FLOOR = 0.1
SHARP_FOOTPRINT = 0.5               # sharpness from which the TFM keeps one texel per voxel
OPTICALLY_THICK_VOXEL = 1.0         # ... and the optical depth across a voxel from which it does too
THICK_SHARP_DEPTH = 8.0             # a sharp density deeper than this gets up to twice the steps
STEPS_PER_VOXEL = (0.1, 0.5)        # the range the sharpness may ask for
MIN_STEPS = 32
LIGHT_STEPS_PER_VOXEL = (0.1, 0.2)  # the TFM build: its cosines smooth the transmittance along the ray
LIGHT_MIN_STEPS = 32
SMOOTH_LIGHT_STEPS_PER_COEFFICIENT = 5   # a smooth density's TFM build: at most this many steps per cosine
MAX_STEPS = 256
HOMOGENEOUS_VIEW_STEPS = 32

_COARSE_SIDE = 64                   # the optical depth is marched on a grid this coarse
_LIGHT_RAYS = 24                    # per side of the light's map (48: the same choices, 2-4x the time)
_VIEW_RAYS = 24                     # along the longer image side
_SHARPNESS_SAMPLES = 200_000        # voxels looked at for the sharpness
_cache = caches.memo("quality.medium parts", 16)   # medium_stats' parts by content


@dataclass(frozen=True)
class MediumStats:
    """What the rule reads from a scene.

    ``optical_depth``: the largest optical depth (most extinguishing channel, dimensionless)
    along the rays of the lights whose cone reaches the medium, solids ignored (0 when none).
    ``light_voxels``: voxels crossed by the longest light ray between the first and the last
    non-zero density it meets; ``view_voxels``: by the longest camera ray through the tight box
    of the grid's non-zero voxels, where the view march steps (a homogeneous medium: its box, in
    units of the box's half side).
    ``sharpness``: the 99th percentile, over the non-zero voxels, of the largest change of
    density to a neighbour, divided by the largest density (1 for a step from 0 to the maximum in
    one voxel, ~0.1 for a smoke whose features span ten voxels); 0 for a homogeneous medium.
    """

    optical_depth: float
    light_voxels: float
    view_voxels: float
    sharpness: float


def _affine_inverse(m) -> np.ndarray:
    """The inverse of an affine 4x4 matrix (last row 0 0 0 1) by the adjugate of its 3x3 part,
    without LAPACK: numpy's inverse wakes OpenBLAS's threads, which on the shared 2 cores, beside
    llvmpipe's, took ~1 ms a call at times (a few per frame from scratch); another matrix goes to
    numpy."""
    m = np.asarray(m, dtype=np.float64)
    if not np.array_equal(m[3], (0.0, 0.0, 0.0, 1.0)):
        return np.linalg.inv(m)
    a, b, c = m[:3, 0], m[:3, 1], m[:3, 2]
    rows = np.array([[b[1] * c[2] - b[2] * c[1], b[2] * c[0] - b[0] * c[2], b[0] * c[1] - b[1] * c[0]],
                     [c[1] * a[2] - c[2] * a[1], c[2] * a[0] - c[0] * a[2], c[0] * a[1] - c[1] * a[0]],
                     [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]])
    det = float(rows[0] @ a)
    if det == 0.0 or not math.isfinite(det):
        return np.linalg.inv(m)            # numpy's error for a singular matrix
    out = np.eye(4)
    out[:3, :3] = rows / det
    out[:3, 3] = -(out[:3, :3] @ m[:3, 3])
    return out


def _bounds(scene: Scene):
    return _bounds_of(scene.media[0] if scene.media else None)


def _bounds_of(m):
    """(world -> local matrix, lo, hi, local units per voxel): the medium's box in its own space."""
    if m.density is not None:
        to_local = _affine_inverse(m.index_to_world)
        lo, hi = _cached(("bounds", m.grid_key), lambda: _summary(m)[3])
        return to_local, np.asarray(lo), np.asarray(hi), 1.0
    if m.box_to_world is not None:
        return _affine_inverse(m.box_to_world), -np.ones(3), np.ones(3), None
    return None, None, None, None


def _light_rays(frame: LightFrame, n: int) -> np.ndarray:
    """Unit world directions of an n x n grid over the light's map, inside its cone."""
    s = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    u, v = np.meshgrid(s, s)
    local = np.stack([u.ravel() * frame.tan_half, v.ravel() * frame.tan_half, -np.ones(n * n)], axis=1)
    local /= np.linalg.norm(local, axis=1, keepdims=True)
    local = local[-local[:, 2] >= frame.cos_half - 1e-9]
    to_world = _affine_inverse(frame.world_to_light)
    return local @ to_world[:3, :3].T


def _face_rays(light, m, n: int) -> tuple[np.ndarray, np.ndarray]:
    """World origins and unit directions of an n x n grid of rays over each map face of the
    light (light.py): from the light for a spot and the cube faces of a point or area light,
    parallel over the rectangle fitted to the medium for a sun."""
    if light.kind == "SPOT":
        d = _light_rays(LightFrame.of(light), n)
        return np.broadcast_to(np.asarray(light.matrix_world, float)[:3, 3], d.shape).copy(), d
    box = _medium_box(m)
    origins, dirs = [], []
    for face in light_faces(light, [box] if box is not None else []):
        to_world = _affine_inverse(face.world_to_light)
        if face.ortho:
            s = (np.arange(n) + 0.5) / n * 2.0 - 1.0
            u, v = np.meshgrid(s, s)
            q = np.stack([u.ravel() * face.tan_xy[0], v.ravel() * face.tan_xy[1], np.zeros(n * n)], axis=1)
            origins.append(q @ to_world[:3, :3].T + to_world[:3, 3])
            dirs.append(np.broadcast_to(-to_world[:3, 2], q.shape).copy())
        else:
            d = _light_rays(face, n)
            origins.append(np.broadcast_to(face.position, d.shape).copy())
            dirs.append(d)
    return np.concatenate(origins), np.concatenate(dirs)


def _medium_box(m):
    """(box_to_world, lo, hi) of a bounded medium, or None."""
    if m.density is not None:
        hi = tuple(float(x) for x in m.density.shape)
        return np.asarray(m.index_to_world, float), (-1.0, -1.0, -1.0), hi
    if m.box_to_world is not None:
        return np.asarray(m.box_to_world, float), (-1.0, -1.0, -1.0), (1.0, 1.0, 1.0)
    return None


def _camera_rays(scene: Scene, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Origins and unit directions of a coarse grid of camera rays (perspective or ortho)."""
    from .camera import view_plane

    cam = scene.camera
    plane = view_plane(cam)
    w, h = plane.width_px, plane.height_px
    k = max(w, h) / n
    xs = (np.arange(max(2, round(w / k))) + 0.5) / max(2, round(w / k)) * w
    ys = (np.arange(max(2, round(h / k))) + 0.5) / max(2, round(h / k)) * h
    X, Y = np.meshgrid(xs, ys)
    px = plane.x0 + X.ravel() * plane.pixel_size
    py = plane.y0 + Y.ravel() * plane.pixel_size
    m = np.asarray(cam.matrix_world, dtype=np.float64)
    rot = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0, keepdims=True)
    if cam.projection == "ORTHO":
        o = np.stack([px, py, np.zeros_like(px)], axis=1) @ rot.T + m[:3, 3]
        d = np.broadcast_to(-rot[:, 2], o.shape).copy()
    else:
        d = np.stack([px, py, -np.ones_like(px)], axis=1)
        d = (d / np.linalg.norm(d, axis=1, keepdims=True)) @ rot.T
        o = np.broadcast_to(m[:3, 3], d.shape).copy()
    return o, d


def medium_stats(scene: Scene) -> MediumStats | None:
    """The numbers the rule reads, or None without a medium. Each part is cached by what it
    depends on: the grid's (coarse copy, sharpness, bounds) by its content, not its placement,
    the optical depth and light chord by the placed density and light (not sigma: the optical
    depth is sigma times a density integral), so that a camera, light or volume move costs
    milliseconds and a sigma edit nothing."""
    if not scene.media:
        return None
    m = scene.media[0]
    lights = [light for light in scene.lights if not is_dark(light)]
    to_local, lo, hi, _ = _bounds(scene)
    grid = _summary(m) if m.density is not None else None
    tau_max, light_len = 0.0, 0.0
    for light in lights:
        integral, chord = _cached(("light", m.density_key, light.key),
                                  lambda light=light: _light_part(m, light, grid))
        tau = float(m.sigma_t.max()) * integral
        tau_max, light_len = max(tau_max, tau), max(light_len, chord)
    view_len = 0.0
    if to_local is not None:
        o_w, d_w = _camera_rays(scene, _VIEW_RAYS)
        o = o_w @ to_local[:3, :3].T + to_local[:3, 3]
        d = d_w @ to_local[:3, :3].T
        t0, t1 = slab(o, d, lo, hi)
        t0 = np.maximum(t0, scene.camera.clip_start)
        hit = t1 > t0
        if hit.any():
            view_len = float(((t1 - t0) * np.linalg.norm(d, axis=1))[hit].max())
    per = 1.0 if m.sparse is None else m.sparse.voxels_per_index     # a coarse copy's voxel: more
    return MediumStats(optical_depth=tau_max, light_voxels=light_len * per, view_voxels=view_len * per,
                       sharpness=0.0 if grid is None else grid[2])




def footprint_texels_per_voxel(m) -> float:
    """TFM texels per voxel of the 'FOOTPRINT' side for the medium ``m``: one for a sharp density
    (sharpness >= SHARP_FOOTPRINT, a step of its maximum within two voxels) or an optically thick
    one (a voxel of its densest block-means at least OPTICALLY_THICK_VOXEL deep: the light dies
    within a voxel or two, so its transmittance is as sharp as the voxels however smooth the
    density), a third for a smooth thin one, whose transmittance changes over several voxels
    (docs/benchmark.md; a density grid only: other media get one)."""
    from .passes import tfm

    if m is None or getattr(m, "density", None) is None:
        return tfm.TEXELS_PER_VOXEL
    coarse, _, sharpness_, _ = _summary(m)
    sharp = sharpness_ >= SHARP_FOOTPRINT or voxel_optical_depth(m, coarse) >= OPTICALLY_THICK_VOXEL
    return tfm.TEXELS_PER_VOXEL if sharp else tfm.SMOOTH_TEXELS_PER_VOXEL


def voxel_optical_depth(m, coarse: np.ndarray) -> float:
    """The optical depth across one voxel where the medium is densest (``coarse``: its grid's
    block means, quality._grid_summary), the largest channel's."""
    voxel = float(np.mean(np.linalg.norm(np.asarray(m.index_to_world, np.float64)[:3, :3], axis=0)))
    return float(coarse.max(initial=0.0)) * float(np.max(m.sigma_t)) * voxel


def light_density_integral(m, light) -> float:
    """The largest density integral (metres at unit density) along the light's rays through the
    medium ``m``, from the probe above (cached by density and light: the number ``AUTO`` already
    computed for the frame). The renderer takes it as automatic alpha for ``AUTO``, in place of a
    GPU pass and its read-back."""
    grid = _summary(m) if m.density is not None else None
    return float(_cached(("light", m.density_key, light.key), lambda: _light_part(m, light, grid))[0])


def _cached(key, build):
    return _cache.made(key, build)


def _summary(m):
    return _cached(("grid", m.grid_key), lambda: _grid_summary(m))


def _grid_summary(m) -> tuple[np.ndarray, int, float, tuple]:
    """(the grid block-averaged to <= _COARSE_SIDE a side and padded by one voxel, the factor,
    the sharpness, its non-zero bounds), from one cleaning of the grid and one non-zero mask."""
    density, _ = clean_density(m.density, m.clipping)      # what the renderer uploads
    f = max(1, math.ceil(max(density.shape) / _COARSE_SIDE))
    coarse = np.pad(downsample(density, f) if f > 1 else density, 1)
    mask = density > 0
    bounds = nonzero_bounds(mask)
    return coarse, f, sharpness(density, mask, bounds), bounds


def _light_part(m, light, grid) -> tuple[float, float]:
    """(the largest density integral along the light's rays, metres at unit density: the optical
    depth over sigma_t; the longest light chord in voxels between the first and last non-zero
    density; for a box: through the box, in its units). Reads the density, not sigma."""
    to_local, lo, hi, _ = _bounds_of(m)
    if to_local is None:                      # fog everywhere: no bounds, no chord to speak of
        return 0.0, 0.0
    o_w, d_w = _face_rays(light, m, _LIGHT_RAYS)
    o = o_w @ to_local[:3, :3].T + to_local[:3, 3]
    d = d_w @ to_local[:3, :3].T      # local units per world metre
    t0, t1 = slab(o, d, lo, hi)
    t0 = np.maximum(t0, 0.0)
    hit = t1 > t0
    if not hit.any():
        return 0.0, 0.0
    o_h, d_h, t0, t1 = o[hit], d[hit], t0[hit], t1[hit]
    chord = (t1 - t0) * np.linalg.norm(d_h, axis=1)     # local units (voxels for a grid)
    sigma = 1.0                 # the density integral; the caller multiplies by sigma
    if grid is None:
        return sigma * float((t1 - t0).max()), float(chord.max())
    coarse, f = grid[:2]
    steps = int(min(512, max(16, math.ceil(2.0 * chord.max() / f))))
    s = (np.arange(steps) + 0.5) / steps
    t = t0[:, None] + s[None, :] * (t1 - t0)[:, None]
    # the points o + t d in the padded coarse index space, (fine - (f - 1) / 2) / f + 1, built
    # axis by axis in the (3, points) layout map_coordinates reads (no copy of a transpose)
    c = np.empty((3,) + t.shape)
    for k in range(3):
        np.multiply(t, d_h[:, k, None], out=c[k])
        c[k] += o_h[:, k, None]
        c[k] -= (f - 1) / 2.0
        c[k] /= f
        c[k] += 1.0
    dens = trilinear(coarse, c.reshape(3, -1)).reshape(t.shape)
    tau = sigma * float((dens.sum(axis=1) * (t1 - t0) / steps).max())   # world metres x density
    nonzero = dens > 0
    if not nonzero.any():
        return tau, 0.0
    first = np.where(nonzero.any(axis=1), nonzero.argmax(axis=1), steps)
    last = np.where(nonzero.any(axis=1), steps - 1 - nonzero[:, ::-1].argmax(axis=1), -1)
    span = np.clip(last - first + 1, 0, None) / steps * chord
    return tau, float(span.max())


def trilinear(grid: np.ndarray, coords: np.ndarray) -> np.ndarray:
    """``grid`` (3D) interpolated linearly at ``coords`` ((3, N) index coordinates), 0 outside
    [0, n - 1] on an axis: scipy's ``map_coordinates(order=1, mode='constant')``, which it calls
    where scipy is installed; a numpy equivalent where it is not (Blender bundles numpy, not
    scipy, and the add-on ships no scipy wheel)."""
    try:
        from scipy import ndimage
    except ImportError:
        return _trilinear_numpy(grid, coords)
    return ndimage.map_coordinates(grid, coords, order=1, mode="constant", cval=0.0)


def _trilinear_numpy(grid: np.ndarray, coords: np.ndarray) -> np.ndarray:
    g = np.asarray(grid, np.float64)
    top = np.array(g.shape, np.float64)[:, None] - 1.0
    c = np.asarray(coords, np.float64)
    inside = np.all((c >= 0.0) & (c <= top), axis=0)
    c = np.clip(c, 0.0, top)
    i0 = np.minimum(np.floor(c), np.maximum(top - 1.0, 0.0)).astype(np.intp)
    w = c - i0
    stride = np.array(g.strides) // g.itemsize
    flat = g.ravel()
    base = (i0 * stride[:, None]).sum(axis=0)
    out = np.zeros(c.shape[1])
    for corner in itertools.product((0, 1), repeat=3):
        step = sum(int(b) * int(s) for b, s, n in zip(corner, stride, g.shape, strict=True) if n > 1)
        weight = np.prod([wk if b else 1.0 - wk for b, wk in zip(corner, w, strict=True)], axis=0)
        out += weight * flat[base + step]
    out[~inside] = 0.0
    grid_dtype = np.asarray(grid).dtype
    return out.astype(grid_dtype) if grid_dtype.kind == "f" else out      # as scipy returns it


def sharpness(density: np.ndarray, mask: np.ndarray | None = None, bounds: tuple | None = None) -> float:
    """See ``MediumStats.sharpness``; from a fixed sample of the non-zero voxels (deterministic).
    ``mask``, ``bounds``: ``density > 0`` and its ``nonzero_bounds`` when the caller has them. Up to
    _SHARPNESS_SAMPLES non-zero voxels, every voxel's jump is taken from the differences between
    neighbours along each axis over the non-zero box (one pass per axis, no gathers); beyond, the
    fixed sample's voxels are gathered. Both give each voxel the jump of the voxel its index
    clamps to inside the border ring."""
    d = np.asarray(density)
    top = float(d.max()) if d.size else 0.0
    if top <= 0.0 or min(d.shape) < 3:
        return 0.0
    mask = d > 0 if mask is None else mask
    count = int(np.count_nonzero(mask))
    if count <= _SHARPNESS_SAMPLES:
        lo, hi = nonzero_bounds(mask) if bounds is None else bounds     # one voxel around the non-zero ones
        box = tuple(slice(max(int(a), 0), min(int(b), n - 1) + 1) for a, b, n in zip(lo, hi, d.shape,
                                                                                     strict=True))
        sub = d[box]
        if min(sub.shape) < 3:
            box, sub = (slice(None),) * 3, d
        jump = _jumps(sub)[mask[box]]
    else:
        nonzero = np.random.default_rng(0).choice(np.flatnonzero(mask.reshape(-1)), _SHARPNESS_SAMPLES,
                                                   replace=False)
        idx = np.clip(np.array(np.unravel_index(nonzero, d.shape)).T, 1, np.array(d.shape) - 2)
        centre = d[tuple(idx.T)]
        jump = np.zeros(len(idx), dtype=np.float32)
        for axis in range(3):
            step = np.zeros(3, dtype=np.int64)
            step[axis] = 1
            for sign in (1, -1):
                jump = np.maximum(jump, np.abs(d[tuple((idx + sign * step).T)] - centre))
    return float(np.percentile(jump, 99)) / top


def _jumps(d: np.ndarray) -> np.ndarray:
    """Per voxel of ``d`` (float32, every side >= 3), the largest |difference| to its six
    neighbours, computed on the interior voxels and copied outwards to the border ring (the
    voxel a clamped index reads). On a box cut one voxel around the non-zero voxels, a non-zero
    voxel on the box's border ring is on the grid's: the same values as on the whole grid."""
    jump = np.zeros(tuple(n - 2 for n in d.shape), dtype=np.float32)
    for axis in range(3):
        diff = np.abs(np.diff(d, axis=axis))         # |d[i+1] - d[i]| along the axis
        lo = [slice(1, -1)] * 3
        hi = [slice(1, -1)] * 3
        lo[axis] = slice(0, -1)                      # to the voxel before: diff[i - 1]
        hi[axis] = slice(1, None)                    # to the voxel after: diff[i]
        np.maximum(jump, diff[tuple(lo)], out=jump)
        np.maximum(jump, diff[tuple(hi)], out=jump)
    return np.pad(jump, 1, mode="edge")


def auto_coefficients(optical_depth: float, sharpness: float = 1.0) -> int:
    """The coefficient count for the largest optical depth along the lights' rays: the first row of
    AUTO_COEFFICIENTS whose depth is at least it; for a smooth density (sharpness <
    SHARP_FOOTPRINT) of AUTO_COEFFICIENTS_SMOOTH, read at the depth times the sharpness
    (docs/benchmark.md)."""
    table = AUTO_COEFFICIENTS
    if sharpness < SHARP_FOOTPRINT:
        table = AUTO_COEFFICIENTS_SMOOTH
        optical_depth *= max(sharpness, SMOOTH_SHARPNESS_FLOOR)
    for depth, n in table:
        if optical_depth <= depth:
            return n
    return table[-1][1]


def auto_steps(voxels: float, sharpness: float, per_voxel_range: tuple[float, float] = STEPS_PER_VOXEL,
               min_steps: int = MIN_STEPS) -> int:
    """Steps along a ray that crosses ``voxels`` voxels of a density of this sharpness, at the
    sharpness clamped to ``per_voxel_range`` steps per voxel (the view's by default)."""
    per_voxel = min(max(sharpness, per_voxel_range[0]), per_voxel_range[1])
    return int(min(MAX_STEPS, max(min_steps, math.ceil(per_voxel * voxels))))


def thick_steps_factor(optical_depth: float, sharpness: float) -> float:
    """How many times the steps a sharp density (sharpness >= SHARP_FOOTPRINT) deeper than
    THICK_SHARP_DEPTH along the light rays gets: tau / THICK_SHARP_DEPTH, at most 2; 1 otherwise.
    A sharp edge's transmittance changes by a step's optical depth from one sample to the next:
    Suzanne's head with sigma scaled to tau 12 and 16 fell to SSIM 0.992 and 0.988 against the
    numpy ground truth at the sharpness' half a step per voxel (docs/benchmark.md)."""
    if sharpness < SHARP_FOOTPRINT or optical_depth <= THICK_SHARP_DEPTH:
        return 1.0
    return min(2.0, optical_depth / THICK_SHARP_DEPTH)


def marched_first(scene: Scene) -> Scene:
    """``scene`` without the media in front of the first one the renderer marches (unbounded fog
    beside other media, empty grids: it skips them), so that the rule reads that one; a
    homogeneous box before a density grid goes behind it (the rule is the grid's whatever the
    media's order: the box alone would choose the analytic path's settings)."""
    media = list(scene.media)
    if len(media) > 1:
        media = [m for m in media if m.density is not None or m.box_to_world is not None] or media
    while len(media) > 1 and media[0].density is not None and _is_empty(media[0]):
        media.pop(0)
    grids = [m for m in media if m.density is not None and not _is_empty(m)]
    if media and media[0].density is None and grids:
        media = [grids[0]] + [m for m in media if m is not grids[0]]
    if len(media) == len(scene.media) and all(a is b for a, b in zip(media, scene.media, strict=True)):
        return scene
    return dataclasses.replace(scene, media=tuple(media))


def _is_empty(m) -> bool:
    lo, hi = _cached(("bounds", m.grid_key), lambda: _summary(m)[3])
    return any(h <= lo_ for lo_, h in zip(lo, hi, strict=True))     # nonzero_bounds: lo = hi


def auto_settings(scene: Scene, settings: RenderSettings | None = None) -> RenderSettings:
    """``settings`` (default: RenderSettings()) with the quality knobs chosen for ``scene`` by
    the rule above. A pure function of the scene's content; the same scene gives the same
    settings."""
    settings = settings or RenderSettings()
    scene = marched_first(scene)
    stats = medium_stats(scene)
    if stats is None:
        return settings
    if scene.media[0].density is None:
        return dataclasses.replace(settings, sampling="PROJECTIVE", view_steps=HOMOGENEOUS_VIEW_STEPS)
    n = auto_coefficients(stats.optical_depth, stats.sharpness)
    thick = thick_steps_factor(stats.optical_depth, stats.sharpness)
    light_steps = auto_steps(thick * stats.light_voxels, stats.sharpness, LIGHT_STEPS_PER_VOXEL,
                             LIGHT_MIN_STEPS)
    if stats.sharpness < SHARP_FOOTPRINT:
        light_steps = max(LIGHT_MIN_STEPS, min(light_steps, SMOOTH_LIGHT_STEPS_PER_COEFFICIENT * n))
    return dataclasses.replace(settings, coefficients=n,
                               density_weight=None, alpha_from_probe=True,
                               tfm_filter="LINEAR", tfm_resolution="FOOTPRINT",
                               light_steps=light_steps,
                               view_steps=auto_steps(thick * stats.view_voxels, stats.sharpness))
