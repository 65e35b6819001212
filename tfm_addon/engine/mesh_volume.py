"""A closed mesh as a medium: the inside of its surface voxelised into a coverage grid.

A mesh with a volume material holds its medium inside its surface (Cycles and EEVEE render it so).
The renderer's grid pipeline (shadow maps, TFMs, the view march) already handles any density grid,
so a mesh medium is a density grid: ``coverage x 1``, the material's sigma per unit density.

Voxelisation (numpy, exact per column): for each of the three axes, a ray runs along every column
of voxel centres; its crossings with the triangles are sorted and, by parity, bound the inside
intervals. The coverage of each voxel along that axis is the exact length of the inside intervals
within it (so a voxel the surface cuts gets its fraction, not 0 or 1). The grid is the median of
the three axes' coverages: for a voxel the surface cuts, the axis across the surface gives the
fraction and the other two 0 and 1, so the median keeps the fraction. A column that crosses the
surface an odd number of times (a hole in the mesh) says nothing for its axis; the median then
comes from the other axes, which closes small holes (Suzanne's eye sockets). Nested shells toggle
(an inner shell is a hollow), which is what Cycles shows for a ray that enters the outer shell
first; ``docs/architecture.md`` discusses where Cycles' volume stack differs.

The grid is in object space, cached by the mesh's shape (vertices, triangles) and resolution, not
by its transform: instances share it, a camera move or an object move rebuilds nothing of it.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from . import caches
from .scene import RGB, GridValue, Medium, _digest

# Voxels along the longest side of the mesh's bounding box.
DEFAULT_RESOLUTION = 96
MIN_RESOLUTION, MAX_RESOLUTION = 8, 512
# The coverage as an extra grid of the medium (what a constant emission is scaled by).
INSIDE_GRID = "mesh inside"
# Pairs (triangle, column) handled at once (each costs ~100 bytes).
_PAIRS_PER_CHUNK = 1 << 20


@dataclass(frozen=True, eq=False)
class Occupancy:
    """The inside of a mesh on a grid: ``coverage`` (nx, ny, nz) float32 in [0, 1] (the fraction
    of each voxel inside), voxel centres at integer index coordinates, ``index_to_object`` mapping
    index space to the mesh's object space (metres before its transform). ``open_edges``: edges
    of the mesh used by one triangle only, ``odd_columns``: the fraction of columns that crossed
    the surface an odd number of times (both 0 for a closed mesh)."""

    coverage: np.ndarray
    index_to_object: np.ndarray
    open_edges: int
    odd_columns: float
    key: str

    @property
    def closed(self) -> bool:
        return self.open_edges == 0


def open_edge_count(triangles: np.ndarray) -> int:
    """Edges used by exactly one triangle (0 for a closed surface)."""
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if len(t) == 0:
        return 0
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return int((counts == 1).sum())


def enclosed_volume(vertices: np.ndarray, triangles: np.ndarray) -> float:
    """The signed volume a closed triangle mesh encloses (divergence theorem), cubic metres."""
    p = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)[np.asarray(triangles, dtype=np.int64)]
    return float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0)


def box_of(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray | None:
    """For a closed mesh that fills its bounding box (a cuboid), the matrix mapping [-1, 1]^3 onto
    that box; else None."""
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    if len(v) == 0 or open_edge_count(triangles) != 0:
        return None
    lo, hi = v.min(axis=0), v.max(axis=0)
    box_volume = float(np.prod(hi - lo))
    if box_volume <= 0.0 or abs(abs(enclosed_volume(v, triangles)) - box_volume) > 1e-6 * box_volume:
        return None
    m = np.diag([*((hi - lo) / 2.0), 1.0])
    m[:3, 3] = (hi + lo) / 2.0
    return m


def grid_frame(vertices: np.ndarray, resolution: int) -> tuple[np.ndarray, tuple[int, int, int]]:
    """index_to_object and shape of the grid for a mesh: ``resolution`` voxels along the longest
    side of its bounding box, cubic voxels, one empty voxel of margin on every side."""
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    lo, hi = v.min(axis=0), v.max(axis=0)
    size = hi - lo
    n = int(min(max(resolution, MIN_RESOLUTION), MAX_RESOLUTION))
    h = float(size.max()) / n if size.max() > 0 else 1.0
    shape = tuple(int(np.ceil(s / h - 1e-9)) + 2 for s in size)
    m = np.diag([h, h, h, 1.0])
    m[:3, 3] = 0.5 * (lo + hi) - 0.5 * h * (np.asarray(shape, dtype=np.float64) - 1)
    return m, shape


def _axis_coverage(tri: np.ndarray, shape: tuple[int, int, int], axis: int):
    """Coverage along ``axis`` of every voxel, and the mask of columns with an odd crossing count.
    ``tri``: (m, 3, 3) triangle corners in index space."""
    a, b = [k for k in range(3) if k != axis]
    na, nb, nz = shape[a], shape[b], shape[axis]
    pa, pb, pz = tri[:, :, a], tri[:, :, b], tri[:, :, axis]
    ia0 = np.clip(np.ceil(pa.min(axis=1)), 0, na).astype(np.int64)
    ia1 = np.clip(np.floor(pa.max(axis=1)), -1, na - 1).astype(np.int64)
    ib0 = np.clip(np.ceil(pb.min(axis=1)), 0, nb).astype(np.int64)
    ib1 = np.clip(np.floor(pb.max(axis=1)), -1, nb - 1).astype(np.int64)
    ca, cb = np.maximum(ia1 - ia0 + 1, 0), np.maximum(ib1 - ib0 + 1, 0)
    det = (pb[:, 1] - pb[:, 2]) * (pa[:, 0] - pa[:, 2]) + (pa[:, 2] - pa[:, 1]) * (pb[:, 0] - pb[:, 2])
    # A ray along +axis enters the inside where the (outward) normal points against it.
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, axis]
    step = np.where(normal < 0.0, 1, -1)
    count = np.where(np.abs(det) > 1e-14, ca * cb, 0)
    cols, zs, steps = [], [], []
    ends = np.cumsum(count)
    start = 0
    while start < len(tri):
        # Triangles whose pairs fit in one chunk (at least one triangle).
        base = ends[start - 1] if start else 0
        stop = max(int(np.searchsorted(ends, base + _PAIRS_PER_CHUNK, side="right")), start + 1)
        idx = np.arange(start, stop)
        cnt = count[idx]
        total = int(cnt.sum())
        start = stop
        if total == 0:
            continue
        t = np.repeat(idx, cnt)
        local = np.arange(total) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        A = ia0[t] + local // cb[t]
        B = ib0[t] + local % cb[t]
        d = det[t]
        l0 = ((pb[t, 1] - pb[t, 2]) * (A - pa[t, 2]) + (pa[t, 2] - pa[t, 1]) * (B - pb[t, 2])) / d
        l1 = ((pb[t, 2] - pb[t, 0]) * (A - pa[t, 2]) + (pa[t, 0] - pa[t, 2]) * (B - pb[t, 2])) / d
        l2 = 1.0 - l0 - l1
        hit = (l0 >= 0) & (l1 >= 0) & (l2 >= 0)
        z = l0[hit] * pz[t[hit], 0] + l1[hit] * pz[t[hit], 1] + l2[hit] * pz[t[hit], 2]
        cols.append(A[hit] * nb + B[hit])
        zs.append(z)
        steps.append(step[t[hit]])
    coverage = np.zeros((na * nb, nz), dtype=np.float64)
    odd = np.zeros(na * nb, dtype=bool)
    if cols:
        col, z, dw = np.concatenate(cols), np.concatenate(zs), np.concatenate(steps)
        order = np.lexsort((z, col))
        col, z, dw = col[order], z[order], dw[order]
        # Winding number after each crossing, per column (non-zero: inside).
        total = np.cumsum(dw)
        first = np.r_[True, col[1:] != col[:-1]]
        group_start = np.maximum.accumulate(np.where(first, np.arange(len(col)), 0))
        winding = total - (total - dw)[group_start]
        inside_after = winding != 0
        inside_before = np.r_[False, inside_after[:-1]] & ~first
        sign = inside_after.astype(np.float64) - inside_before
        last = np.r_[col[1:] != col[:-1], True]
        odd = np.zeros(na * nb, dtype=bool)
        odd[col[last & inside_after]] = True      # a column that ends inside: a hole
        # Inside length below u: c(u) = sum_k sign_k * max(u - z_k, 0), at the voxel faces
        # u_j = j - 0.5 (j = 0..nz); each crossing adds a ramp from the first face above it.
        j0 = np.clip(np.ceil(z + 0.5), 0, nz + 1).astype(np.int64)
        flat, size = col * (nz + 2) + j0, na * nb * (nz + 2)
        slope = np.bincount(flat, weights=sign, minlength=size).reshape(na * nb, nz + 2)
        offset = np.bincount(flat, weights=sign * (-0.5 - z), minlength=size).reshape(na * nb, nz + 2)
        j = np.arange(nz + 2, dtype=np.float64)
        c = np.cumsum(slope, axis=1) * j + np.cumsum(offset, axis=1)
        coverage = np.diff(c[:, :nz + 1], axis=1)
    coverage = np.clip(coverage, 0.0, 1.0).reshape(na, nb, nz)
    order = [0, 0, 0]
    order[a], order[b], order[axis] = 0, 1, 2
    odd = np.broadcast_to(odd.reshape(na, nb, 1), (na, nb, nz))
    return np.transpose(coverage, order), np.transpose(odd, order)


def voxelize(vertices: np.ndarray, triangles: np.ndarray, resolution: int = DEFAULT_RESOLUTION) -> Occupancy:
    """The inside of a triangle mesh (object space, metres) on a grid of ``resolution`` voxels
    along its longest side (module docstring)."""
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    key = shape_key(vertices, triangles, resolution)
    index_to_object, shape = grid_frame(v, resolution)
    to_index = np.linalg.inv(index_to_object)
    vi = v @ to_index[:3, :3].T + to_index[:3, 3]
    # An irrational offset (in voxels) keeps the column rays off shared edges and vertices.
    vi = vi + np.array([1.234567e-5, 2.345678e-5, 3.456789e-5])
    tri = vi[t]
    covs, oks = [], []
    for axis in range(3):
        cov, odd = _axis_coverage(tri, shape, axis)
        covs.append(cov.astype(np.float32))
        oks.append(~odd)
    c0, c1, c2 = covs
    median3 = np.maximum(np.minimum(c0, c1), np.minimum(np.maximum(c0, c1), c2))
    n_ok = oks[0].astype(np.uint8) + oks[1] + oks[2]
    # Median of the usable axes: of 3 the middle value, of 2 their mean, of 1 that one, of none 0.
    mean_ok = (c0 * oks[0] + c1 * oks[1] + c2 * oks[2]) / np.maximum(n_ok, 1).astype(np.float32)
    coverage = np.where(n_ok == 3, median3, mean_ok).astype(np.float32)
    odd_fraction = float(np.mean([1.0 - ok.mean() for ok in oks]))
    coverage.setflags(write=False)
    return Occupancy(coverage=coverage, index_to_object=index_to_object, open_edges=open_edge_count(t),
                     odd_columns=odd_fraction, key=key)


def shape_key(vertices: np.ndarray, triangles: np.ndarray, resolution: int) -> str:
    """What a mesh's coverage grid depends on: its object-space shape and the resolution."""
    return _digest("mesh volume", np.ascontiguousarray(vertices, dtype=np.float32),
                   np.ascontiguousarray(triangles, dtype=np.int32), int(resolution))


class OccupancyCache:
    """Coverage grids by shape key, the ``capacity`` most recent kept (the registry's memo
    ``name``: engine/caches.py). ``counters``: 'voxelisations' (grids built), 'hits' (grids reused)."""

    def __init__(self, capacity: int = 8, name: str | None = None):
        self.capacity = capacity
        self.counters: Counter = Counter()
        self._items = caches.memo(name, capacity) if name else caches.Memo("mesh volume", capacity)

    def get(self, vertices: np.ndarray, triangles: np.ndarray,
            resolution: int = DEFAULT_RESOLUTION) -> Occupancy:
        key = shape_key(vertices, triangles, resolution)
        hit = self._items.get(key)
        if hit is not None:
            self.counters["hits"] += 1
            return hit
        built = voxelize(vertices, triangles, resolution)
        self.counters["voxelisations"] += 1
        return self._items.put(key, built)

    def clear(self) -> None:
        self._items.clear()


occupancy_cache = OccupancyCache(name="mesh_volume.coverage grids")


def mesh_medium(vertices: np.ndarray, triangles: np.ndarray, matrix_world: np.ndarray, *,
                sigma_a: RGB, sigma_s: RGB, anisotropy: float = 0.0, density: float = 1.0,
                resolution: int = DEFAULT_RESOLUTION, cache: OccupancyCache | None = None,
                label: str = "Mesh", **fields) -> tuple[Medium | None, list[str]]:
    """The medium inside a mesh: its coverage grid times ``density``, placed by
    ``matrix_world``; sigma per unit density as for any Medium. ``fields``: more Medium fields
    (emission, blackbody); a constant emission or blackbody intensity glows inside the mesh only
    (it becomes ``GridValue`` of the coverage, as Cycles renders a mesh's volume emission).
    Returns the medium (None for a mesh without faces or volume) and warnings for the user (one
    line for a mesh that is not closed)."""
    cache = occupancy_cache if cache is None else cache
    notes: list[str] = []
    if len(np.asarray(triangles).reshape(-1, 3)) == 0:
        return None, [f"{label}: the mesh has no faces, so it holds no medium"]
    box = box_of(vertices, triangles)
    if box is not None:      # a closed box: the exact homogeneous medium, no grid
        box = np.asarray(matrix_world, dtype=np.float64) @ box
        return Medium(sigma_a=tuple(density * c for c in sigma_a),
                      sigma_s=tuple(density * c for c in sigma_s), anisotropy=anisotropy,
                      box_to_world=box, **fields), notes
    occ = cache.get(vertices, triangles, resolution)
    if not occ.closed:
        notes.append(f"{label}: the mesh is not closed ({occ.open_edges} open edges); its medium fills "
                     f"what most of three axis-aligned views see inside")
    grid = occ.coverage if density == 1.0 else (occ.coverage * np.float32(density))
    if not grid.any():
        notes.append(f"{label}: the mesh encloses no volume, so it holds no medium")
        return None, notes
    grids = {}
    for name in ("emission_strength", "blackbody_intensity"):
        value = fields.get(name)
        if isinstance(value, GridValue) and value.grid is None and value.offset != 0.0:
            fields[name] = GridValue(grid=INSIDE_GRID, scale=value.offset, offset=0.0)
            grids[INSIDE_GRID] = occ.coverage
    return Medium(sigma_a=sigma_a, sigma_s=sigma_s, anisotropy=anisotropy, density=grid,
                  index_to_world=np.asarray(matrix_world, dtype=np.float64) @ occ.index_to_object,
                  grids=grids, source_key=occ.key if density == 1.0 else None, **fields), notes
