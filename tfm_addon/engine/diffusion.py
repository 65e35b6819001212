"""Light that scatters many times in thick media, light that the surfaces reflect into the media,
and the media's own emission, on a coarse lattice over the media (numpy; the renderer supplies
the light at points).

All are read by the camera pass as a fluence (W/m², the light arriving at a point from every
direction) that the media scatter isotropically: sigma_s * fluence / (4 pi) per metre of ray.

- The surfaces' light, ``surface``: the fluence that solids lit by the lights reflect (diffusely,
  their base colour) into the media, attenuated by the media between. Cycles renders it from one
  volume bounce on (a camera ray scattered in the medium meets a lit surface). Surface points are
  sampled by area near the media; their reflected radiance is binned by direction into the six
  lattice axes at a few probe positions, and each cell takes each axis' light through the optical
  depth from the cell to the lattice's edge along it.
- The diffusion, ``diffused``: the fluence of light scattered at least twice, the solution of the
  diffusion equation -div(D grad phi) + sigma_a phi = sigma_s (phi_lights + phi_surfaces), D =
  1 / (3 sigma_t), with the light that has not scattered yet (phi_lights: the lights' radiance
  past the solids and media at each cell, from the renderer's light maps) as its source, weighed
  by the share of the six axis directions along which the medium holds the light (in thin media
  scattered light mostly leaves, and diffusion overstates what stays), and Marshak's boundary
  (the fluence falls to 0 two thirds of a mean free path out) at the lattice's edge. Empty cells
  (optical thickness below ``VACUUM_TAU``) pass light on as a gap does, with a resistance per
  cell of half a boundary's, and lose ``EMPTY_LOSS`` of it per cell: light leaving a part of the
  medium reaches the parts around it (a porous cloud), or leaves. Conjugate gradients on the
  7-point finite-volume stencil, each face's resistance the sum of the two half cells'.

- The emission, ``emission`` and ``emission_diffused``: the fluence of the media's own emission
  (engine/fire_light.py's points) at each cell, and its diffused light (the same solve with it as
  the source): a glowing core lighting the smoke around it.
- Light linking: a light that lights some media only is a source of the diffused light through
  their own scattering (``Lattice.media_sigma_s``).
- The world, ``world``: the world's light at each cell (the world faces' light past the solids
  and media, summed over the faces; engine/frame_plan.py) with the octaves of its multiple
  scattering (multiple_scattering.py; the phase function's mean for each: the world lights from
  every side), scattered by the camera pass at every bounce count, 0 included.

The lattice is world-aligned, cubic cells, at most ``MAX_SIDE`` a side, over the finite media's
bounds (fog that fills the scene is left out). Nothing here depends on the bounce count: the
bounce count weighs the two fields in the camera pass (multiple_scattering.Octaves).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .medium_grid import clean_density, downsample
from .quality import trilinear

MAX_SIDE = 48               # cells along the lattice's longest side
VACUUM_TAU = 1e-3           # cells thinner than this (optical depth across) are empty
THIN_TAU = 0.05             # a half cell's resistance is at least that of this optical depth
EMPTY_HALF = 0.5            # an empty cell's half resistance (a gap: 1, half a boundary's 2)
EMPTY_LOSS = 0.3            # the share of its light an empty cell loses (to its six neighbours' 6)
SURFACE_SAMPLES = 2048      # points sampled on the surfaces near the media
PROBES = 4                  # probe positions per side where the surfaces' light is binned
REACH = 4.0                 # surfaces within REACH half-diagonals of the media's centre light them
SURFACE_SECANT = 1.5        # mean path length over depth of light arriving within an axis' bin
MAX_ITERATIONS = 400
TOLERANCE = 1e-4

AXES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], np.float64)


@dataclass(frozen=True)
class Lattice:
    """Cell (i, j, k) is centred at ``origin`` + h (i, j, k), world; ``sigma_t``, ``sigma_s``
    (nx, ny, nz, 3) per metre; ``media_sigma_s`` each medium's own share of ``sigma_s`` by name
    (for light linking: a light that lights some media only)."""

    origin: np.ndarray
    h: float
    sigma_t: np.ndarray
    sigma_s: np.ndarray
    media_sigma_s: tuple[tuple[str, np.ndarray], ...] = ()

    def sigma_s_of(self, names) -> np.ndarray:
        """The scattering coefficient of the media named (the lattice's, where it holds no
        medium's share)."""
        if not self.media_sigma_s:
            return self.sigma_s
        own = [s for name, s in self.media_sigma_s if name in names]
        return np.minimum(sum(own), self.sigma_s) if own else np.zeros_like(self.sigma_s)

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.sigma_t.shape[:3]

    def points(self) -> np.ndarray:
        """(n, 3) world centres of the cells, C order."""
        idx = np.indices(self.shape, dtype=np.float64).reshape(3, -1).T
        return self.origin + self.h * idx

    @cached_property
    def axis_depths(self) -> np.ndarray:
        """(6, nx, ny, nz, 3) optical depth from each cell's centre to the lattice's edge along
        each of AXES."""
        tau = self.sigma_t * self.h
        out = []
        for axis in range(3):
            before = np.cumsum(tau, axis=axis) - 0.5 * tau                # toward -axis
            after = np.flip(np.cumsum(np.flip(tau, axis), axis=axis), axis) - 0.5 * tau
            out += [after, before]
        return np.stack(out)

    def cell_to_world(self) -> np.ndarray:
        m = np.eye(4)
        m[:3, :3] *= self.h
        m[:3, 3] = self.origin
        return m


@dataclass(frozen=True)
class Fluence:
    """The fields on ``lattice``: (nx, ny, nz, 3) float32, W/m²; ``emission`` the media's own
    emission arriving unscattered, ``emission_diffused`` its diffused light (zeros where none
    emits: the bounce count weighs it apart from the lights'), ``world`` the world's light
    arriving unscattered. ``scattered`` False: the surfaces' and diffused light were not solved
    for (zeros; a frame of single scattering, or the viewport's coarse image)."""

    lattice: Lattice
    surface: np.ndarray
    diffused: np.ndarray
    emission: np.ndarray
    emission_diffused: np.ndarray
    world: np.ndarray
    scattered: bool = True


def _finite_media(media) -> list:
    return [m for m in media if m is not None and (m.density is not None or m.box_to_world is not None)]


def _world_box(m) -> tuple[np.ndarray, np.ndarray]:
    if m.density is not None:
        lo, hi = -np.ones(3), np.asarray(m.density.shape, np.float64)     # zero one voxel past
        mat = np.asarray(m.index_to_world, np.float64)
    else:
        lo, hi = -np.ones(3), np.ones(3)
        mat = np.asarray(m.box_to_world, np.float64)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    w = corners @ mat[:3, :3].T + mat[:3, 3]
    return w.min(axis=0), w.max(axis=0)


def _sampler(m, h: float) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray | None]]:
    """points -> (the medium's density D at world points (n,), its scattering tint (n, 3) or None):
    a grid cleaned (NaN and clipped values as 0) and, where its voxels are finer than half a cell
    of size h, averaged over blocks first."""
    if m.density is None:
        to_box = np.linalg.inv(np.asarray(m.box_to_world, np.float64))
        return lambda p: (np.all(np.abs(p @ to_box[:3, :3].T + to_box[:3, 3]) <= 1.0, axis=1)
                          .astype(np.float64), None)
    index_to_world = np.asarray(m.index_to_world, np.float64)
    voxel = float(np.linalg.norm(index_to_world[:3, :3], axis=0).min())
    f = max(1, int(h / (2.0 * max(voxel, 1e-12))))
    grid, _ = clean_density(m.density, m.clipping)
    colour = m.grids.get(m.color_grid) if m.color_grid is not None else None
    if f > 1:
        grid = downsample(grid, f)
        if colour is not None:
            colour = np.stack([downsample(np.asarray(colour[..., k], np.float32), f) for k in range(3)], -1)
        block = np.diag([f, f, f, 1.0])
        block[:3, 3] = (f - 1) / 2.0
        index_to_world = index_to_world @ block
    to_index = np.linalg.inv(index_to_world)
    grid = np.pad(grid, 1)                  # 0 one voxel past the outermost centres
    colour = None if colour is None else np.pad(np.asarray(colour, np.float32), [(1, 1)] * 3 + [(0, 0)])

    def sample(p):
        idx = (p @ to_index[:3, :3].T + to_index[:3, 3]).T + 1.0
        tint = None if colour is None else np.stack([trilinear(colour[..., k], idx) for k in range(3)], 1)
        return trilinear(grid, idx).astype(np.float64), tint

    return sample


def lattice(media, max_side: int = MAX_SIDE) -> Lattice | None:
    """The lattice over the finite media, their coefficients averaged over 2^3 points a cell."""
    finite = _finite_media(media)
    if not finite:
        return None
    boxes = [_world_box(m) for m in finite]
    lo = np.min([b[0] for b in boxes], axis=0)
    hi = np.max([b[1] for b in boxes], axis=0)
    h = float(np.max(hi - lo)) / max_side
    if not h > 0.0:
        return None
    shape = tuple(int(max(1, np.ceil((hi[k] - lo[k]) / h))) for k in range(3))
    origin = lo + 0.5 * h
    idx = np.indices(shape, dtype=np.float64).reshape(3, -1).T
    sigma_t = np.zeros((len(idx), 3))
    own = [np.zeros((len(idx), 3)) for _ in finite]         # each medium's sigma_s
    samplers = [(m, _sampler(m, h)) for m in finite]
    for offset in np.array([[x, y, z] for x in (-0.25, 0.25) for y in (-0.25, 0.25) for z in (-0.25, 0.25)]):
        p = origin + h * (idx + offset)
        for k, (m, sample) in enumerate(samplers):
            d, tint = sample(p)
            sigma_t += d[:, None] * np.asarray(m.sigma_t, np.float64) / 8.0
            s = d[:, None] * np.asarray(m.sigma_s, np.float64)
            own[k] += (s if tint is None else s * np.clip(tint, 0.0, None)) / 8.0
    sigma_s = np.minimum(sum(own), sigma_t).reshape(*shape, 3)
    return Lattice(origin, h, sigma_t.reshape(*shape, 3), sigma_s,
                   tuple((m.name, s.reshape(*shape, 3)) for m, s in zip(finite, own, strict=True)))


def _shifted(a: np.ndarray, axis: int, step: int, fill) -> np.ndarray:
    """a's neighbour along ``axis`` (a[i + step]), ``fill`` past the edge."""
    out = np.full_like(a, fill)
    src = [slice(None)] * a.ndim
    dst = [slice(None)] * a.ndim
    if step > 0:
        src[axis], dst[axis] = slice(step, None), slice(None, -step)
    else:
        src[axis], dst[axis] = slice(None, step), slice(-step, None)
    out[tuple(dst)] = a[tuple(src)]
    return out


def diffuse(sigma_t: np.ndarray, sigma_a: np.ndarray, source: np.ndarray, h: float) -> tuple[np.ndarray, int]:
    """The diffusion equation's fluence on one channel's lattice (see the module): (nx, ny, nz)
    arrays per metre and W/m³, h the cell size; returns the fluence and the iterations taken."""
    norm_b = float(np.sqrt((source * source).sum()))
    if norm_b == 0.0:
        return np.zeros_like(source), 0
    # Each cell's half resistance (h / 2) / D = 3 sigma_t h / 2: at least that of THIN_TAU
    # (diffusion does not hold in thin media, whose light leaves them); an empty cell's is
    # EMPTY_HALF, light crossing a gap between parts of the media as it crosses a boundary. Past
    # the lattice's edge the fluence falls to 0 two thirds of a mean free path out (+2).
    empty = sigma_t * h < VACUUM_TAU
    half = np.where(empty, EMPTY_HALF, 1.5 * np.maximum(sigma_t * h, THIN_TAU))
    diag = np.where(empty, EMPTY_LOSS / h, np.maximum(sigma_a, 0.0))
    couplings = []
    for axis in range(3):
        for step in (-1, 1):
            edge = _shifted(np.zeros(sigma_t.shape, bool), axis, step, True)
            r = half + np.where(edge, 2.0, _shifted(half, axis, step, 0.0))
            c = 1.0 / (h * r)                                   # conductance per volume
            diag = diag + c
            couplings.append((axis, step, np.where(edge, 0.0, c)))

    def apply(x):
        y = diag * x
        for axis, step, c in couplings:
            y -= c * _shifted(x, axis, step, 0.0)
        return y

    b = source
    x = b / diag
    r = b - apply(x)
    z = r / diag
    p = z.copy()
    rz = float((r * z).sum())
    it = 0
    while it < MAX_ITERATIONS:
        it += 1
        ap = apply(p)
        alpha = rz / float((p * ap).sum())
        x += alpha * p
        r -= alpha * ap
        if float(np.sqrt((r * r).sum())) <= TOLERANCE * norm_b:
            break
        z = r / diag
        rz_new = float((r * z).sum())
        p = z + (rz_new / rz) * p
        rz = rz_new
    return np.maximum(x, 0.0), it


def diffuse_rgb(lat: Lattice, source: np.ndarray) -> np.ndarray:
    """``diffuse`` per colour channel (one solve where the channels are equal)."""
    st, ss, q = lat.sigma_t, lat.sigma_s, source
    grey = all(np.array_equal(a[..., 0], a[..., k]) for a in (st, ss, q) for k in (1, 2))
    channels = 1 if grey else 3
    # light scattered where the medium is thin leaves it: the source weighed by the share of the
    # six axes along which the medium stops it (1 - mean transmittance to the lattice's edge)
    held = 1.0 - np.exp(-lat.axis_depths).mean(axis=0)
    out = [diffuse(st[..., k], st[..., k] - ss[..., k], q[..., k] * held[..., k], lat.h)[0]
           for k in range(channels)]
    return np.stack(out * 3 if grey else out, axis=-1)


@dataclass(frozen=True)
class SurfaceSamples:
    """Points on the solids near the media: world ``points`` (n, 3), unit ``normals`` (n, 3)
    facing the media, the ``area`` each stands for (m²) and the diffuse ``albedo`` (n, 3)."""

    points: np.ndarray
    normals: np.ndarray
    area: float
    albedo: np.ndarray


def _diffuse_albedo(mesh) -> np.ndarray:
    s = mesh.shading
    return np.clip(np.asarray(s.base_color, np.float64) * (1.0 - s.metallic) * s.weight * s.alpha, 0.0, 1.0)


def _near(t: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    lo, hi = t.min(axis=1), t.max(axis=1)
    return np.linalg.norm(np.clip(centre, lo, hi) - centre, axis=1) <= radius


def _near_pieces(t: np.ndarray, albedo: np.ndarray, centre, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The triangles split in four until none is wider than radius / 8 where it reaches within
    ``radius`` of ``centre`` (the pieces that do not are dropped): samples spread by area then
    fall near the media even on a ground far wider than them."""
    longest = (radius / 8.0) ** 2
    done_t, done_a = [], []
    for _ in range(16):
        keep = _near(t, centre, radius)
        t, albedo = t[keep], albedo[keep]
        edges = np.stack([t[:, 1] - t[:, 0], t[:, 2] - t[:, 1], t[:, 0] - t[:, 2]], axis=1)
        big = (edges ** 2).sum(axis=2).max(axis=1) > longest
        done_t.append(t[~big])
        done_a.append(albedo[~big])
        t, albedo = t[big], albedo[big]
        if not len(t):
            break
        m01, m12, m20 = 0.5 * (t[:, 0] + t[:, 1]), 0.5 * (t[:, 1] + t[:, 2]), 0.5 * (t[:, 2] + t[:, 0])
        t = np.concatenate([np.stack(c, axis=1) for c in ((t[:, 0], m01, m20), (m01, t[:, 1], m12),
                                                          (m20, m12, t[:, 2]), (m01, m12, m20))])
        albedo = np.concatenate([albedo] * 4)
    return np.concatenate(done_t + [t]), np.concatenate(done_a + [albedo])


def surface_samples(meshes, centre: np.ndarray, radius: float,
                    n: int = SURFACE_SAMPLES) -> SurfaceSamples | None:
    """``n`` points spread by area over the parts of the triangles that reach within ``radius`` of
    ``centre`` (those of holdouts and black surfaces left out); the ones beyond it are dropped."""
    tris, albedo = [], []
    for mesh in meshes:
        if mesh.holdout:
            continue
        a = _diffuse_albedo(mesh)
        if not a.any() or not len(mesh.triangles):
            continue
        mw = np.asarray(mesh.matrix_world, np.float64)
        v = mesh.vertices.astype(np.float64) @ mw[:3, :3].T + mw[:3, 3]
        t = v[mesh.triangles]
        near = _near(t, centre, radius)
        if near.any():
            tris.append(t[near])
            albedo.append(np.broadcast_to(a, (int(near.sum()), 3)))
    if not tris:
        return None
    t, alb = _near_pieces(np.concatenate(tris), np.concatenate(albedo), centre, radius)
    if not len(t):
        return None
    cross = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    total = float(area.sum())
    if total <= 0.0:
        return None
    # stratified by area; barycentric points from two low-discrepancy sequences
    i = np.arange(n)
    which = np.minimum(np.searchsorted(np.cumsum(area), (i + 0.5) / n * total), len(t) - 1)
    r1 = np.sqrt((i * 0.7548776662466927 + 0.5) % 1.0)
    r2 = (i * 0.5698402909980532 + 0.5) % 1.0
    tw = t[which]
    p = (1 - r1)[:, None] * tw[:, 0] + (r1 * (1 - r2))[:, None] * tw[:, 1] + (r1 * r2)[:, None] * tw[:, 2]
    nrm = cross[which] / np.maximum(2.0 * area[which], 1e-30)[:, None]
    nrm *= np.where(((centre - p) * nrm).sum(axis=1) < 0.0, -1.0, 1.0)[:, None]
    keep = np.linalg.norm(p - centre, axis=1) <= radius
    if not keep.any():
        return None
    return SurfaceSamples(p[keep], nrm[keep], total / n, alb[which][keep])


def surface_fluence(lat: Lattice, samples: SurfaceSamples, irradiance: np.ndarray) -> np.ndarray:
    """The surfaces' fluence at each cell (nx, ny, nz, 3): each sample's reflected radiance
    (albedo ``irradiance`` / pi) over the solid angle it subtends at the probe positions, binned
    into the axis it lies along, interpolated to the cells and attenuated along that axis."""
    shape = np.array(lat.shape)
    probes_per_side = np.minimum(shape, PROBES)
    axes_idx = [np.linspace(0.0, s - 1.0, k) for s, k in zip(shape, probes_per_side, strict=True)]
    grid = np.stack(np.meshgrid(*axes_idx, indexing="ij"), axis=-1).reshape(-1, 3)
    probes = lat.origin + lat.h * grid
    radiance = samples.albedo * irradiance / np.pi                              # (s, 3)
    spacing2 = samples.area                                                     # a sample's patch
    binned = np.zeros((len(probes), 6, 3))
    for j, p in enumerate(probes):
        v = samples.points - p
        d2 = np.maximum((v * v).sum(axis=1), spacing2)
        u = v / np.sqrt(d2)[:, None]
        cos_s = np.clip(-(u * samples.normals).sum(axis=1), 0.0, None)
        omega = samples.area * cos_s / d2
        which = np.argmax(u @ AXES.T, axis=1)
        for b in range(6):
            sel = which == b
            binned[j, b] = (radiance[sel] * omega[sel, None]).sum(axis=0)
    # to the cells: trilinear over the probe lattice, the same eight corners for every bin
    cells = np.indices(lat.shape, dtype=np.float64).reshape(3, -1).T
    at = cells * ((probes_per_side - 1) / np.maximum(shape - 1, 1))
    lo = np.minimum(np.floor(at).astype(np.intp), np.maximum(probes_per_side - 2, 0))
    frac = at - lo
    arriving = np.zeros((len(cells), 6, 3))
    for corner in np.ndindex(2, 2, 2):
        idx = np.minimum(lo + corner, probes_per_side - 1)
        w = np.prod(np.where(np.array(corner) == 1, frac, 1.0 - frac), axis=1)
        flat = np.ravel_multi_index(tuple(idx.T), tuple(probes_per_side))
        arriving += w[:, None, None] * binned[flat]
    depth = lat.axis_depths.reshape(6, -1, 3)
    out = (arriving * np.exp(-SURFACE_SECANT * np.moveaxis(depth, 0, 1))).sum(axis=1)
    return out.reshape(*lat.shape, 3)


def fluence(lat: Lattice, meshes, arriving: Callable[[np.ndarray, np.ndarray | None], np.ndarray],
            emitted: Callable[[np.ndarray, np.ndarray | None, float], np.ndarray] | None = None,
            linked: Sequence[tuple[Callable[[np.ndarray], np.ndarray], Collection[str]]] = (),
            world: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
            scattered: bool = True) -> Fluence:
    """The fields. ``arriving(points, normals)``: the lights' radiance arriving at world points
    past the solids and media, summed over the lights (n, 3), W/m²; with ``normals``, the
    irradiance of surfaces facing them there. ``emitted(points, normals, softening)``: the same
    for the media's own emission (None: they emit nothing), its points of emission softened by
    ``softening`` m² more (at the cells half a cell's side squared: a point of emission at a cell's
    centre lights the whole cell); its fluence is a field of its own and the source of a diffused
    light of its own, and the surfaces reflect it as the lights' light. ``linked``: the lights that
    light some media only (light linking), each as (its light arriving at points, the names of the
    media it lights), left out of ``arriving``'s light at the cells: only those media scatter it
    first (the light they scatter then reaches the others). ``world(points, albedo)``: the world's
    light scattered at world points by media of that albedo (n, 3), in units of fluence (the
    ``world`` field; None: zeros). ``scattered`` False: only the
    world field and the emission's unscattered light are made, the rest left zero."""
    n_cells = int(np.prod(lat.shape))
    scattering = lat.sigma_s.reshape(-1, 3).any(axis=1)
    lights = np.zeros((n_cells, 3))
    emission = np.zeros((n_cells, 3))
    sky = np.zeros((n_cells, 3))
    if scattering.any():
        points = lat.points()[scattering]
        if scattered:
            lights[scattering] = arriving(points, None)
        if emitted is not None:
            emission[scattering] = emitted(points, None, (0.5 * lat.h) ** 2)
        if world is not None:
            albedo = (lat.sigma_s / np.maximum(lat.sigma_t, 1e-30)).reshape(-1, 3)[scattering]
            sky[scattering] = world(points, albedo)
    lights = lights.reshape(*lat.shape, 3)
    emission = emission.reshape(*lat.shape, 3)
    sky = sky.reshape(*lat.shape, 3).astype(np.float32)
    if not scattered:
        zeros = np.zeros_like(sky)
        return Fluence(lat, zeros, zeros, emission.astype(np.float32), zeros, sky, scattered=False)
    lo = lat.origin - 0.5 * lat.h
    hi = lat.origin + lat.h * (np.array(lat.shape) - 0.5)
    centre = 0.5 * (lo + hi)
    samples = surface_samples(meshes, centre, REACH * 0.5 * float(np.linalg.norm(hi - lo)))
    surface = np.zeros_like(lights)
    if samples is not None:
        lifted = samples.points + samples.normals * (1e-3 * lat.h)
        irradiance = arriving(lifted, samples.normals)
        if emitted is not None:
            irradiance = irradiance + emitted(lifted, samples.normals, 0.0)
        surface = surface_fluence(lat, samples, irradiance) * (lat.sigma_t.max(axis=-1) > 0.0)[..., None]
    source = lat.sigma_s * (lights + surface)
    for light, names in linked:
        sigma_s = lat.sigma_s_of(names)
        lit = sigma_s.reshape(-1, 3).any(axis=1)
        if lit.any():
            own = np.zeros((n_cells, 3))
            own[lit] = light(lat.points()[lit])
            source = source + sigma_s * own.reshape(*lat.shape, 3)
    diffused = diffuse_rgb(lat, source)
    emission_diffused = (diffuse_rgb(lat, lat.sigma_s * emission) if emission.any()
                         else np.zeros_like(emission))
    fields = (f.astype(np.float32) for f in (surface, diffused, emission, emission_diffused))
    return Fluence(lat, *fields, sky)
