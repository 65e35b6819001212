"""Density grids of Volume data-blocks, read through Blender's openvdb module, cached.

Voxel values are not reachable through Blender's RNA API. A Volume that comes straight from a
.vdb file (one file or a frame sequence, no modifiers) is read from that file; any other (Geometry
Nodes, Mesh to Volume, packed files) is written with ``grids.save`` and read back. Grids are cached
by what they depend on: the file (path, size, modification time) or the saved data's hash, and the
grid's name, so an unchanged volume is not read twice and an animated one is read per frame.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

FLOAT_GRID_TYPES = ("FLOAT", "DOUBLE")


class VolumeReadError(Exception):
    """A volume that cannot give a density grid; the message is meant for the user."""


class NoGridThisFrame(VolumeReadError):
    """A frame sequence outside its frame range: nothing to render, nothing wrong."""


@dataclass(frozen=True, eq=False)
class DensityGrid:
    """A dense copy of one float grid.

    ``density``: (nx, ny, nz) float32 in x, y, z index order, voxel centres at integer indices.
    ``index_to_object``: 4x4 matrix from this array's indices to the Volume object's space.
    """

    density: np.ndarray
    index_to_object: np.ndarray
    grid_name: str


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
    shape = tuple(int(h - l + 1) for l, h in zip(lo, hi, strict=True))
    dtype = np.float64 if grid.valueTypeName == "double" else np.float32
    array = np.zeros(shape, dtype=dtype)
    grid.copyToArray(array, ijk=tuple(int(v) for v in lo))
    return np.ascontiguousarray(array, dtype=np.float32), tuple(int(v) for v in lo)


class GridCache:
    """Dense density grids by (source, grid name), least recently used first out."""

    def __init__(self, max_entries: int = 4):
        self.max_entries = max_entries
        self._entries: OrderedDict[tuple, DensityGrid] = OrderedDict()
        self.reads = 0  # grids read from openvdb, for tests
        self.hits = 0

    def clear(self):
        self._entries.clear()

    def __len__(self):
        return len(self._entries)

    def read(self, volume, preferred: str, label: str, *, generated: bool) -> tuple[DensityGrid, list[str]]:
        """Read the density grid of an evaluated Volume data-block.

        ``generated``: the evaluated grids may differ from the file (modifiers, Geometry Nodes,
        instancing from nodes), so they are saved and hashed instead of read from the file.
        Returns the grid and warnings; raises VolumeReadError.
        """
        from .openvdb_module import import_openvdb

        grids = volume.grids
        if volume.is_sequence and not grids.frame_filepath:
            raise NoGridThisFrame(f"Volume '{label}': the sequence has no file for this frame")
        if len(grids) == 0 and not grids.load():
            where = grids.frame_filepath or volume.filepath
            raise VolumeReadError(f"Volume '{label}': cannot read '{where}': {grids.error_message}")
        warnings = []
        name, warning = choose_grid([(g.name, g.data_type) for g in grids], preferred, label)
        if warning:
            warnings.append(warning)

        path = _file_path(volume)
        if not generated and path and volume.packed_file is None and os.path.isfile(path):
            st = os.stat(path)
            key = ("file", path, st.st_mtime_ns, st.st_size, name)
            cached = self._lookup(key)
            if cached is None:
                cached = self._store(key, self._read_file(import_openvdb(), path, name, label))
            return cached, warnings

        with tempfile.TemporaryDirectory(prefix="tfm_volume_") as tmp:
            saved = os.path.join(tmp, "grids.vdb")
            if not grids.save(saved):
                raise VolumeReadError(f"Volume '{label}': cannot save its grids: {grids.error_message}")
            with open(saved, "rb") as f:
                digest = hashlib.blake2b(f.read(), digest_size=16).hexdigest()
            key = ("data", digest, name)
            cached = self._lookup(key)
            if cached is None:
                cached = self._store(key, self._read_file(import_openvdb(), saved, name, label))
        return cached, warnings

    def _lookup(self, key):
        grid = self._entries.get(key)
        if grid is not None:
            self._entries.move_to_end(key)
            self.hits += 1
        return grid

    def _store(self, key, grid):
        self._entries[key] = grid
        while len(self._entries) > self.max_entries:
            self._entries.popitem(last=False)
        return grid

    def _read_file(self, openvdb, path, name, label) -> DensityGrid:
        self.reads += 1
        try:
            grid = openvdb.read(path, name)
        except Exception as ex:
            raise VolumeReadError(f"Volume '{label}': cannot read grid '{name}' from '{path}': {ex}") from ex
        try:
            array, lo = dense_array(grid)
        except VolumeReadError as ex:
            raise VolumeReadError(f"Volume '{label}': {ex}") from None
        to_object, exact = index_to_world_matrix(grid.transform)
        if not exact:
            raise VolumeReadError(f"Volume '{label}': grid '{name}' has a frustum transform, "
                                  f"which is not supported")
        shift = np.eye(4)
        shift[:3, 3] = lo
        array.setflags(write=False)
        return DensityGrid(density=array, index_to_object=to_object @ shift, grid_name=name)


def _file_path(volume) -> str:
    import bpy

    path = volume.grids.frame_filepath or volume.filepath
    if not path:
        return ""
    library = volume.original.library if volume.original is not None else None
    return os.path.normpath(bpy.path.abspath(path, library=library))


grid_cache = GridCache()
