"""Density grids of Volume data-blocks, read through Blender's openvdb module, cached.

Voxel values are not reachable through Blender's RNA API. A Volume that comes straight from a
.vdb file (one file or a frame sequence, no modifiers) is read from that file; any other (Geometry
Nodes, Mesh to Volume, packed files) is written with ``grids.save`` and read back. Grids are cached
by what they depend on: the file (path, size, modification time) or the saved data's hash, and the
grid's name, so an unchanged volume is not read twice and an animated one is read per frame.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import threading
from dataclasses import dataclass, field

import numpy as np

from ..engine import caches
from . import background, files

FLOAT_GRID_TYPES = ("FLOAT", "DOUBLE")
VECTOR_GRID_TYPES = ("VECTOR_FLOAT", "VECTOR_DOUBLE")


class VolumeReadError(Exception):
    """A volume that cannot give a density grid; the message is meant for the user."""


class NoGridThisFrame(VolumeReadError):
    """A frame sequence outside its frame range: nothing to render, nothing wrong."""


class GridBeingRead(VolumeReadError):
    """A big grid the viewport reads in the background: not there yet (GridCache.read)."""


@dataclass(frozen=True, eq=False)
class DensityGrid:
    """A dense copy of one float grid and the other grids the material reads, on one lattice.

    ``density``: (nx, ny, nz) float32 in x, y, z index order, voxel centres at integer indices.
    ``index_to_object``: 4x4 matrix from this array's indices to the Volume object's space.
    ``extras``: more grids by name, (nx, ny, nz) or (nx, ny, nz, 3) float32, same lattice.
    ``key``: what the arrays were read from (file and its stamp, or the saved data's hash, and the
    grid names), so the renderer's cache keys need not hash the arrays.
    """

    density: np.ndarray
    index_to_object: np.ndarray
    grid_name: str
    extras: dict = field(default_factory=dict)
    key: str = ""
    warnings: tuple[str, ...] = ()
    first_index: tuple[int, int, int] = (0, 0, 0)  # the file's voxel index of array index 0
    # (lo, hi) in array indices where Cycles draws the volume when it draws it by its object's mesh
    # (a fluid domain's cube); None: by the grids' leaf nodes (extract.glow_blocks)
    bounds: tuple | None = None
    # a big, mostly empty density read as bricks (engine.sparse_grid.SparseGrid), ``density`` then
    # being their coarse copy (1/8 resolution); None: ``density`` is the grid
    sparse: object | None = None


def choose_grid(available: list[tuple[str, str]], preferred: str, label: str) -> tuple[str, str | None]:
    """Pick the density grid among ``available`` (name, Blender data type) pairs.

    Returns the grid name and a warning for the user, or None. Raises VolumeReadError when no float
    grid exists or when the preferred grid is not a float grid.
    """
    types = dict(available)
    if preferred in types:
        if types[preferred] in FLOAT_GRID_TYPES:
            return preferred, None
        raise VolumeReadError(
            f"Volume '{label}': grid '{preferred}' is {types[preferred]}, "
            f"a float grid is expected for the density"
        )
    floats = [name for name, kind in available if kind in FLOAT_GRID_TYPES]
    found = ", ".join(f"{name} ({kind})" for name, kind in available) or "no grids"
    if not floats:
        raise VolumeReadError(
            f"Volume '{label}': no float grid to read the density from "
            f"(expected '{preferred}'; found {found})"
        )
    return floats[0], (
        f"Volume '{label}': no grid named '{preferred}', using float grid '{floats[0]}' as density"
    )


def index_to_world_matrix(transform) -> tuple[np.ndarray, bool]:
    """The 4x4 matrix of an openvdb transform's index-to-world map, and whether it is exact
    (False for a non-linear frustum transform, approximated at the index origin)."""
    origin = np.asarray(transform.indexToWorld((0.0, 0.0, 0.0)), dtype=np.float64)
    m = np.eye(4)
    for axis in range(3):
        unit = [0.0, 0.0, 0.0]
        unit[axis] = 1.0
        m[:3, axis] = np.asarray(transform.indexToWorld(tuple(unit)), dtype=np.float64) - origin
    m[:3, 3] = origin
    linear = transform.isLinear
    return m, bool(linear() if callable(linear) else linear)


def dense_array(grid) -> tuple[np.ndarray, tuple[int, int, int]]:
    """Copy a float grid's active bounding box into a float32 array; return it and its first index."""
    if grid.activeVoxelCount() == 0:
        raise VolumeReadError(f"grid '{grid.name}' has no active voxels")
    lo, hi = grid.evalActiveVoxelBoundingBox()
    return _copy(grid, tuple(int(v) for v in lo), tuple(int(v) for v in hi)), tuple(int(v) for v in lo)


# The most voxels a grid is read into (1 GiB as float32; the renderer's default grid budget,
# RenderSettings.max_grid_bytes, holds as many in R16): a larger active box is read at a lower
# resolution (read_factor), never copied dense at full size.
MAX_READ_VOXELS = 2 ** 28
SLAB_BYTES = 64 * 2 ** 20     # the most a downsampled read copies at once
COPY_VOXELS = 2 ** 20         # the most a sparse read copies at once: openvdb's copy holds Python's
                              # lock throughout (some 10 ms a million voxels on a loaded 2-core machine)
BACKGROUND_READ_BYTES = 16 * 2 ** 20     # the viewport reads larger files in the background


SPARSE_MAX_FILL = 0.5     # a box above MAX_READ_VOXELS whose active voxels fill at most this part of
                          # it is read as bricks (read_sparse), at full resolution


def read_sparse(grid, lo, hi, max_voxels: int = MAX_READ_VOXELS):
    """The bricks of a float grid's box lo..hi (inclusive): slabs of 9 x planes (a row of 8³
    cells and the next plane) copied one at a time, only their non-empty bricks kept, so that
    memory grows with the active bricks (engine/sparse_grid.py). Returns (SparseGrid, coarse copy,
    coarse index to box index), or None when the bricks would hold more than ``max_voxels``."""
    from ..engine import sparse_grid

    shape = tuple(int(h - l + 1) for l, h in zip(lo, hi, strict=True))
    expected = int(grid.activeVoxelCount()) // sparse_grid.CELL ** 3 * 3 // 2     # blobs: about 1.4x
    collector = sparse_grid.BrickCollector(shape, min(expected, max_voxels // sparse_grid.SLOT ** 3 + 1))
    dtype = np.float64 if grid.valueTypeName == "double" else np.float32
    cell, slot = sparse_grid.CELL, sparse_grid.SLOT
    _, cy, cz = collector.cs
    limit = max_voxels // slot ** 3
    # A piece: the 9 x planes of some cells of a row, with the plane after them in y (copyToArray
    # writes all of it, the background outside the grid); at most COPY_VOXELS at a time, as
    # openvdb holds Python's lock while it copies.
    m = max(1, min(cy, COPY_VOXELS // (slot * cell * (cell * cz + 1))))
    pieces: dict = {}                       # by shape: reused (add copies the bricks out)
    for cx in range(collector.cs[0]):
        for cy0 in range(0, cy, m):
            shape = (slot, cell * min(m, cy - cy0) + 1, cell * cz + 1)
            piece = pieces.setdefault(shape, np.empty(shape, dtype))
            grid.copyToArray(piece, ijk=(lo[0] + cell * cx - 1, lo[1] + cell * cy0 - 1, lo[2] - 1))
            collector.add(cx, piece, cy0)
        if collector.count > limit:
            return None
    return collector.finish()


def read_factor(shape, max_voxels: int = MAX_READ_VOXELS) -> int:
    """1, or the smallest power of two f whose f x f x f means bring ``shape`` within
    ``max_voxels``."""
    f = 1
    while np.prod([-(-int(n) // f) for n in shape], dtype=np.float64) > max_voxels:
        f *= 2
    return f


def _copy(grid, lo, hi, factor: int = 1) -> np.ndarray:
    """The voxels lo..hi (inclusive) of a float or vec3 grid as float32; ``factor`` > 1: the means
    of factor^3 blocks from lo (zeros past hi), copied a slab at a time, so that the full-resolution
    box is never held."""
    shape = tuple(int(h - l + 1) for l, h in zip(lo, hi, strict=True))
    kind = grid.valueTypeName
    tail = (3,) if kind.startswith("vec3") else ()
    dtype = np.float64 if kind in ("vec3d", "double") else np.float32
    if factor == 1:
        array = np.zeros((*shape, *tail), dtype=dtype)
        grid.copyToArray(array, ijk=tuple(int(v) for v in lo))
        return np.ascontiguousarray(array, dtype=np.float32)
    f = factor
    out_shape = tuple(-(-n // f) for n in shape)
    out = np.zeros((*out_shape, *tail), dtype=np.float32)
    nz = out_shape[2] * f
    rows = max(1, SLAB_BYTES // (f * f * nz * 8 * (3 if tail else 1)))     # output rows of y a slab
    for i in range(out_shape[0]):
        for j0 in range(0, out_shape[1], rows):
            nj = min(rows, out_shape[1] - j0)
            block = np.zeros((f, nj * f, nz, *tail), dtype=dtype)     # contiguous, as copyToArray needs
            grid.copyToArray(block, ijk=(lo[0] + i * f, lo[1] + j0 * f, lo[2]))
            planes = block[0].astype(np.float32)         # the f planes along x added ...
            for k in range(1, f):
                planes += block[k]
            planes = planes.reshape(nj, f, out_shape[2], f, *tail)
            target = out[i, j0:j0 + nj]
            for a in range(f):                              # ... then y and z by strided slices (numpy's
                for c in range(f):                          # sum over short axes is ~10x slower)
                    target += planes[:, a, :, c]
            target *= np.float32(1.0 / f ** 3)
    return out


def read_grid_set(openvdb, path: str, density_name: str, extras, label: str, warnings: list[str],
                  key: str, max_voxels: int | None = None, sparse: bool = False) -> DensityGrid:
    """The density grid and the ``extras`` of a .vdb file, densely over the union of their active
    boxes (extras whose transform differs from the density's are skipped with a warning);
    ``max_voxels``: a box with more voxels is read as the means of f x f x f blocks (read_factor),
    said in a warning, unless ``sparse`` and the density alone is read and fills at most
    SPARSE_MAX_FILL of its box: then it is read at full resolution as bricks (read_sparse), if
    they hold at most ``max_voxels``."""
    try:
        density = openvdb.read(path, density_name)
    except Exception as ex:
        raise VolumeReadError(f"Volume '{label}': cannot read grid '{density_name}' from '{path}': {ex}") \
            from ex
    if density.activeVoxelCount() == 0:
        raise VolumeReadError(f"Volume '{label}': grid '{density_name}' has no active voxels")
    to_object, exact = index_to_world_matrix(density.transform)
    if not exact:
        raise VolumeReadError(f"Volume '{label}': grid '{density_name}' has a frustum transform, "
                              f"which is not supported")
    grids = {density_name: density}
    for name in extras:
        if name == density_name or name in grids:
            continue
        try:
            g = openvdb.read(path, name)
        except Exception:
            continue
        m, _ = index_to_world_matrix(g.transform)
        if not np.allclose(m, to_object, rtol=1e-5, atol=1e-9):
            warnings.append(f"Volume '{label}': grid '{name}' is not on the lattice of '{density_name}'; "
                            f"it is not rendered")
            continue
        if g.activeVoxelCount() > 0:
            grids[name] = g
    boxes = [g.evalActiveVoxelBoundingBox() for g in grids.values()]
    lo = tuple(min(int(b[0][k]) for b in boxes) for k in range(3))
    hi = tuple(max(int(b[1][k]) for b in boxes) for k in range(3))
    shape = tuple(h - l + 1 for l, h in zip(lo, hi, strict=True))
    factor = 1 if max_voxels is None else read_factor(shape, max_voxels)
    box = np.prod(shape, dtype=np.float64)
    if factor > 1 and sparse and len(grids) == 1 and density.activeVoxelCount() <= SPARSE_MAX_FILL * box:
        found = read_sparse(density, lo, hi, max_voxels)
        if found is not None:
            bricks, coarse, coarse_to_box = found
            coarse.setflags(write=False)
            shift = np.eye(4)
            shift[:3, 3] = lo
            return DensityGrid(density=coarse, index_to_object=to_object @ shift @ coarse_to_box,
                               grid_name=density_name, key=key, warnings=tuple(warnings), first_index=lo,
                               sparse=bricks)
        warnings.append(f"Volume '{label}': the active 8³ blocks of grid '{density_name}' hold more than "
                        f"{max_voxels // 2 ** 20} M voxels")
    if factor > 1:
        reduced = "x".join(str(-(-n // factor)) for n in shape)
        warnings.append(f"Volume '{label}': the grids' active box is {'x'.join(map(str, shape))} voxels "
                        f"({np.prod(shape, dtype=np.float64) * 4 / 2 ** 30:.1f} GiB as a dense float "
                        f"grid); read at 1/{factor} resolution, {reduced}, the means of "
                        f"{factor}x{factor}x{factor} voxels")
    arrays = {}
    for name, g in grids.items():
        try:
            arrays[name] = _copy(g, lo, hi, factor)
        except Exception as ex:   # a grid of another value type (int, bool, ...)
            if name == density_name:
                raise VolumeReadError(f"Volume '{label}': cannot read grid '{name}': {ex}") from ex
            warnings.append(f"Volume '{label}': grid '{name}' ({g.valueTypeName}) is not read")
    for a in arrays.values():
        a.setflags(write=False)
    shift = np.eye(4)                # array index -> file index (a block's centre when downsampled)
    shift[:3, :3] *= factor
    shift[:3, 3] = np.asarray(lo, np.float64) + (factor - 1) / 2
    d = arrays.pop(density_name)
    return DensityGrid(density=d, index_to_object=to_object @ shift, grid_name=density_name,
                       extras=arrays, key=key, warnings=tuple(warnings),
                       first_index=lo)


class GridCache:
    """Dense density grids by (source, grid name), least recently used first out."""

    def __init__(self, max_entries: int = 4, name: str | None = None):
        self.max_entries = max_entries
        # the registry's memo ``name`` (engine/caches.py), or one of its own
        self._entries = caches.memo(name, max_entries) if name else caches.Memo("grids", max_entries)
        self.reads = 0  # grids read from openvdb, for tests
        self.hits = 0
        self.saves = 0   # generated volumes written with grids.save (then hashed), for tests
        self.reading: dict = {}      # key -> the thread reading it in the background
        self.previews: dict = {}     # key -> a preview of a grid being read (read_preview)
        self._lock = threading.Lock()

    def clear(self):
        self._entries.clear()

    def __len__(self):
        return len(self._entries)

    def grid_types(self, volume, label: str) -> list[tuple[str, str]]:
        """(name, Blender data type) of an evaluated Volume's grids (loading them)."""
        grids = volume.grids
        if volume.is_sequence and not grids.frame_filepath:
            if grids.frame == VOLUME_FRAME_NONE:     # outside the sequence's frames (Clip mode)
                raise NoGridThisFrame(f"Volume '{label}': the sequence has no file for this frame")
            # A frame of the sequence whose file is missing: Blender names the file it looked for.
            raise VolumeReadError(f"Volume '{label}': frame {grids.frame} of the sequence, "
                                  f"'{_sequence_frame_path(volume, grids.frame)}', not found")
        if len(grids) == 0 and not grids.load():
            where = _file_path(volume) or volume.filepath      # the absolute path Blender tried
            raise VolumeReadError(f"Volume '{label}': cannot read '{where}': {grids.error_message}")
        return [(g.name, g.data_type) for g in grids]

    def read(self, volume, preferred: str, label: str, *, generated: bool,
             extras: tuple[str, ...] = (), sparse: bool = False,
             wait: bool = True) -> tuple[DensityGrid, list[str]]:
        """Read the density grid (and the grids named in ``extras`` that exist) of an evaluated
        Volume data-block.

        ``generated``: the evaluated grids may differ from the file (modifiers, Geometry Nodes,
        instancing from nodes), so they are saved and hashed instead of read from the file.
        ``sparse``: a big, mostly empty density may be read as bricks (read_grid_set).
        ``wait`` False (the viewport): a file of more than BACKGROUND_READ_BYTES not read yet is
        read on a thread of its own, which tags the volume for an update when done; meanwhile
        GridBeingRead is raised, so that Blender's thread never waits for a big read.
        Returns the grid and warnings; raises VolumeReadError.
        """
        from .openvdb_module import import_openvdb

        types = self.grid_types(volume, label)
        warnings = []
        name, warning = choose_grid(types, preferred, label)
        if warning:
            warnings.append(warning)
        present = dict(types)
        extras = tuple(sorted(e for e in set(extras) if e in present and e != name))

        path = _file_path(volume)
        grids = volume.grids
        if not generated and path and volume.packed_file is None and os.path.isfile(path):
            st = os.stat(path)
            key = ("file", path, st.st_mtime_ns, st.st_size, name, extras, sparse)
            cached = self._lookup(key)
            if cached is None and not wait and st.st_size > BACKGROUND_READ_BYTES:
                args = (path, name, label, extras, repr(key), MAX_READ_VOXELS, sparse)
                self._read_in_background(key, (volume.original or volume).name, args)
                preview = self.previews.get(key)
                if preview is not None:
                    n = "x".join(str(v) for v in preview.density.shape)
                    return preview, warnings + [f"Volume '{label}': grid '{name}' is being read in the "
                                                f"background; shown meanwhile from one voxel in 8 ({n})"]
                raise GridBeingRead(f"Volume '{label}': grid '{name}' is being read from '{path}' "
                                    f"({st.st_size / 2 ** 20:.0f} MB) in the background; it shows once read")
            if cached is None:
                cached = self._store(key, self._read_file(import_openvdb(), path, name, label,
                                                          extras, repr(key), MAX_READ_VOXELS, sparse))
            return cached, warnings + list(cached.warnings)

        with tempfile.TemporaryDirectory(prefix="tfm_volume_") as tmp:
            saved = os.path.join(tmp, "grids.vdb")
            self.saves += 1
            if not grids.save(saved):
                raise VolumeReadError(f"Volume '{label}': cannot save its grids: {grids.error_message}")
            with open(saved, "rb") as f:
                digest = hashlib.blake2b(f.read(), digest_size=16).hexdigest()
            key = ("data", digest, name, extras, sparse)
            cached = self._lookup(key)
            if cached is None:
                cached = self._store(key, self._read_file(import_openvdb(), saved, name, label,
                                                          extras, repr(key), MAX_READ_VOXELS, sparse))
        return cached, warnings + list(cached.warnings)

    def read_path(self, path: str, density_name: str, label: str, extras: tuple[str, ...] = ()
                  ) -> DensityGrid:
        """The grids of a .vdb file by path (a fluid cache), cached by the file's stamp."""
        from .openvdb_module import import_openvdb

        st = os.stat(path)
        key = ("file", path, st.st_mtime_ns, st.st_size, density_name, tuple(sorted(extras)))
        cached = self._lookup(key)
        if cached is None:
            cached = self._store(key, self._read_file(import_openvdb(), path, density_name, label,
                                                      tuple(sorted(extras)), repr(key)))
        return cached

    def _read_in_background(self, key, volume_name: str, args) -> None:
        """Read a file's grids in a process of its own (openvdb holds Python's lock while it
        loads a file, most of a second for a big one), waited for on a thread (one at a time; a
        read asked for while another runs waits for the next update), then tag the volume so
        that the viewport reads it again."""
        with self._lock:
            if key in self.reading or self.reading:
                return

            def preview(grid):
                self.previews[key] = grid

            def work():
                try:
                    self.reads += 1
                    self._store(key, read_in_process(*args, on_preview=preview))
                except VolumeReadError as ex:
                    self._store(key, ex)
                finally:
                    with self._lock:
                        self.reading.pop(key, None)
                        self.previews.pop(key, None)

            thread = threading.Thread(target=work, name="TFM grid read", daemon=True)
            self.reading[key] = thread
            background.start(thread)
        self._tag_on_news(key, volume_name)

    def _tag_on_news(self, key, volume_name: str) -> None:
        """Tag the Volume data-block for an update (a timer on Blender's thread) when the preview
        of its background read is there and when the read is done, so that the viewport reads it
        again, from the cache."""
        import bpy

        told = set()

        def poll():
            news = ({"preview"} if key in self.previews else set()) | ({"done"} if key not in self.reading
                                                                       else set())
            if news - told:
                told.update(news)
                volume = bpy.data.volumes.get(volume_name)
                if volume is not None:
                    volume.update_tag()
            return None if "done" in told else 0.1

        background.timer(poll, first_interval=0.1)

    def _lookup(self, key):
        with self._lock:
            grid = self._entries.get(key)
            if grid is not None:
                self.hits += 1
        if isinstance(grid, VolumeReadError):        # what a background read ran into
            raise grid
        return grid

    def _store(self, key, grid):
        return self._entries.put(key, grid)

    def _read_file(self, openvdb, path, name, label, extras=(), key="", max_voxels=None,
                   sparse=False) -> DensityGrid:
        self.reads += 1
        return read_grid_set(openvdb, path, name, extras, label, [], key, max_voxels, sparse)


READ_PROCESS = r"""
import os, sys, types
openvdb_dir, root, out = sys.argv[1:4]
sys.path[:0] = [openvdb_dir, root]
import tfm_addon
# tfm_addon.blender's __init__ imports bpy, which this process lacks: its modules are loaded bare.
package = types.ModuleType("tfm_addon.blender")
package.__path__ = [os.path.join(root, "tfm_addon", "blender")]
sys.modules["tfm_addon.blender"] = package
import openvdb
from tfm_addon.blender import volumes
volumes.read_into_file(openvdb, out, sys.argv[4:])
"""


def read_in_process(path, name, label, extras, key, max_voxels, sparse, on_preview=None) -> DensityGrid:
    """``read_grid_set`` run by Blender's Python in a process of its own (this thread waits
    with Python's lock released); the grids come back through an uncompressed .npz file. A box
    above ``max_voxels`` first gives a preview (``read_preview``), handed to ``on_preview`` while
    the rest is read."""
    import subprocess
    import sys
    import time

    from .openvdb_module import import_openvdb

    module = os.path.abspath(import_openvdb().__file__)      # a module file, or a package's __init__
    openvdb_dir = os.path.dirname(os.path.dirname(module) if module.endswith("__init__.py") else module)
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    with tempfile.TemporaryDirectory(prefix="tfm_read_") as tmp:
        out = os.path.join(tmp, "grids.npz")
        process = background.child(subprocess.Popen(
            [sys.executable, "-c", READ_PROCESS, openvdb_dir, root, out, path, name, label, "\n".join(extras),
             key, str(max_voxels or 0), str(int(sparse))],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True))
        preview = out + ".preview.npz"
        while on_preview is not None and process.poll() is None and not os.path.exists(preview):
            time.sleep(0.05)
        if on_preview is not None and os.path.exists(preview):
            on_preview(_grid_from_file(preview))
        try:
            error = process.communicate()[1].strip()
        finally:
            background.finished(process)
        if process.returncode == 3:
            raise VolumeReadError(error.splitlines()[-1])
        if process.returncode != 0:
            raise VolumeReadError(f"Volume '{label}': reading '{path}' failed: {error[-300:]}")
        return _grid_from_file(out)


def read_preview(grid, lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """A quick look at a big float grid's box lo..hi: its voxels at index 8 c + 3 of the box
    (one in 8 along each axis), copied a line along z at a time (a 64th of the copying of a full
    read); returns the (cx, cy, cz) float32 samples and their index to the box's index."""
    shape = tuple(int(h - l + 1) for l, h in zip(lo, hi, strict=True))
    n = tuple(-(-(s - 3) // 8) for s in shape)
    out = np.zeros(n, np.float32)
    line = np.empty((1, 1, shape[2]), np.float64 if grid.valueTypeName == "double" else np.float32)
    for c in range(n[0]):
        for j in range(n[1]):
            grid.copyToArray(line, ijk=(lo[0] + 8 * c + 3, lo[1] + 8 * j + 3, lo[2]))
            out[c, j] = line[0, 0, 3::8]
    to_box = np.diag([8.0, 8.0, 8.0, 1.0])
    to_box[:3, 3] = 3.0
    return out, to_box


def read_into_file(openvdb, out: str, argv) -> None:
    """The reading process's side of ``read_in_process``: exit status 3 and the message on the
    last line of stderr for a VolumeReadError."""
    import sys

    path, name, label, extras, key, max_voxels, sparse = argv
    try:
        density = openvdb.read(path, name)
        lo, hi = density.evalActiveVoxelBoundingBox()
        if int(max_voxels) and np.prod([h - l + 1 for l, h in zip(lo, hi, strict=True)],
                                       dtype=np.float64) > int(max_voxels):
            samples, to_box = read_preview(density, lo, hi)
            shift = np.eye(4)
            shift[:3, 3] = lo
            to_object = index_to_world_matrix(density.transform)[0] @ shift @ to_box
            _save_grid(DensityGrid(density=samples, index_to_object=to_object, grid_name=name,
                                   key=key + " preview", first_index=tuple(int(v) for v in lo)),
                       out + ".preview.npz")
            if hasattr(os, "nice"):
                os.nice(5)      # the rest after the viewport's first image of the preview
        del density
    except Exception:
        pass            # no preview: read_grid_set says what is wrong
    try:
        grid = read_grid_set(openvdb, path, name, tuple(e for e in extras.split("\n") if e), label, [],
                             key, int(max_voxels) or None, sparse == "1")
    except VolumeReadError as ex:
        print(str(ex), file=sys.stderr)
        sys.exit(3)
    _save_grid(grid, out)


def _save_grid(grid: DensityGrid, out: str) -> None:
    """A DensityGrid as an uncompressed .npz (``_grid_from_file``), written whole, then renamed."""
    arrays = {"density": grid.density, "index_to_object": grid.index_to_object,
              "first_index": np.asarray(grid.first_index)}
    arrays.update({f"extra:{k}": v for k, v in grid.extras.items()})
    if grid.sparse is not None:
        b = grid.sparse
        arrays.update(sparse_shape=np.asarray(b.shape), sparse_cells=b.cells, sparse_bricks=b.bricks,
                      sparse_to_medium=b.index_to_medium)
    text = {"grid_name": grid.grid_name, "key": grid.key, "warnings": list(grid.warnings)}
    np.savez(out + ".part.npz", meta=np.asarray(json.dumps(text)), **arrays)
    os.replace(out + ".part.npz", out)


def _grid_from_file(path: str) -> DensityGrid:
    from ..engine.sparse_grid import SparseGrid

    with np.load(path) as f:
        a = {k: f[k] for k in f.files}
    meta = json.loads(str(a.pop("meta")))
    sparse = None
    if "sparse_bricks" in a:
        sparse = SparseGrid(tuple(int(n) for n in a["sparse_shape"]), a["sparse_cells"], a["sparse_bricks"],
                            a["sparse_to_medium"])
    for k, v in a.items():
        if v.ndim >= 3 and not k.startswith("sparse"):
            v.setflags(write=False)
    return DensityGrid(density=a["density"], index_to_object=a["index_to_object"],
                       grid_name=meta["grid_name"], key=meta["key"], warnings=tuple(meta["warnings"]),
                       extras={k[6:]: v for k, v in a.items() if k.startswith("extra:")},
                       first_index=tuple(int(i) for i in a["first_index"]), sparse=sparse)


VOLUME_FRAME_NONE = 2**31 - 1     # Blender's VOLUME_FRAME_NONE: no file of the sequence this frame


def _sequence_frame_path(volume, frame: int) -> str:
    """The absolute path Blender tried for ``frame`` of an evaluated volume sequence."""
    return files.frame_path(files.abspath(volume.filepath, volume.original), frame)


def _file_path(volume) -> str:
    path = volume.grids.frame_filepath or volume.filepath
    if not path:
        return ""
    return files.abspath(path, volume.original)


grid_cache = GridCache(name="volumes.density grids")
