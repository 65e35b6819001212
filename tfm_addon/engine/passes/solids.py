"""The solids as one vertex buffer: world positions, face normals, base colour, hit flag; and
the table of their surfaces (a uniform block)."""

from __future__ import annotations

import numpy as np

from ..scene import Mesh
from ..surface import MAX_MATERIALS, material_table

FORMAT = "3f 3f 3f 1f 2f"
POSITION_HIT = "3f 24x 1f 8x"     # position and hit flag (the shadow maps)
WIDTH = 12          # floats per vertex


def solids_vertices(meshes: tuple[Mesh, ...]) -> np.ndarray:
    """(3 * triangles, 12) float32: position, normal (the face's, or the corner's of a smooth-shaded
    mesh), base colour, hit flag (``hit_flags``),
    roughness and metallic per vertex, world space."""
    rows = _mesh_blocks(meshes, hit_flags(meshes)[0])
    return np.concatenate(rows) if rows else np.zeros((0, WIDTH), np.float32)


def hit_flags(meshes: tuple[Mesh, ...], unlit_by: dict | None = None) -> tuple[list[float], list]:
    """Per mesh, the G-buffer's hit flag: 2 for a holdout, 1 + 2 k for a surface that is entry k
    of the material table; and the table's entries, (surface, the lights that do not light it:
    ``unlit_by`` by mesh name, light linking): the distinct ones, at most MAX_MATERIALS (the rest
    share the last entry)."""
    unlit_by = unlit_by or {}
    table: dict = {}
    flags = []
    for mesh in meshes:
        if mesh.holdout:
            flags.append(2.0)
            continue
        k = table.setdefault((mesh.shading, unlit_by.get(mesh.name, ())), min(len(table), MAX_MATERIALS - 1))
        flags.append(1.0 + 2.0 * k)
    return flags, list(table)


def unlit_entries(entries: list, light_name: str) -> tuple[int, int, int, int]:
    """The material table's entries a light does not light (light linking), as 128 bits: bit k
    of word k // 32 for entry k."""
    words = [0, 0, 0, 0]
    for k, (_, unlit_by) in enumerate(entries[:MAX_MATERIALS]):
        if light_name in unlit_by:
            words[k // 32] |= 1 << (k % 32)
    return tuple(words)


def _world_normals(mesh: Mesh, keep: np.ndarray) -> np.ndarray:
    """The mesh's corner normals of the triangles kept, in world space (the inverse transpose of
    its matrix), unit length."""
    n = mesh.normals[keep].astype(np.float64) @ np.linalg.inv(mesh.matrix_world[:3, :3])
    return n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-30)


def _mesh_blocks(meshes: tuple[Mesh, ...], flags: list[float]) -> list[np.ndarray]:
    """solids_vertices' rows of each mesh that has triangles (degenerate ones dropped)."""
    rows = []
    for mesh, flag in zip(meshes, flags, strict=True):
        if len(mesh.triangles) == 0:
            continue
        v = mesh.world_vertices()[mesh.triangles]            # (m, 3, 3)
        n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        length = np.linalg.norm(n, axis=1, keepdims=True)
        keep = length[:, 0] > 0
        v, n = v[keep], n[keep] / length[keep]
        block = np.empty((len(v), 3, WIDTH), dtype=np.float32)
        block[:, :, 0:3] = v
        block[:, :, 3:6] = n[:, None, :] if mesh.normals is None else _world_normals(mesh, keep)
        block[:, :, 6:9] = np.asarray(mesh.shading.base_color, dtype=np.float32)
        block[:, :, 9] = flag
        block[:, :, 10] = mesh.shading.roughness
        block[:, :, 11] = mesh.shading.metallic
        rows.append(block.reshape(-1, WIDTH))
    return rows


COORDS_FORMAT = "3f 3f 2f"


def texture_coordinates(meshes: list[Mesh]) -> np.ndarray:
    """(3 * triangles, 8) float32 per corner of the textured meshes: world position, object-space
    position, UV (0 without a UV map)."""
    rows = []
    for mesh in meshes:
        if len(mesh.triangles) == 0:
            continue
        block = np.zeros((len(mesh.triangles), 3, 8), np.float32)
        block[:, :, 0:3] = mesh.world_vertices()[mesh.triangles]
        block[:, :, 3:6] = mesh.vertices[mesh.triangles]
        if mesh.uv is not None:
            block[:, :, 6:8] = mesh.uv
        rows.append(block.reshape(-1, 8))
    return np.concatenate(rows) if rows else np.zeros((0, 8), np.float32)


KEEP_TRIANGLES = 100_000   # per mesh, world triangles kept on the CPU for light.solids_may_shadow


class SolidsBuffer:
    """The solids' vertices on the GPU, shared by the shadow-map and G-buffer passes, and their
    material table (``materials``, the light passes' uniform block); ``parts``:
    per mesh, its world bounds and (k, 3, 3) float32 world triangles (None beyond
    KEEP_TRIANGLES), for light.solids_may_shadow; ``entries``: the table's (surface, lights
    that do not light it) (``hit_flags``)."""

    def __init__(self, ctx, meshes: tuple[Mesh, ...], unlit_by: dict | None = None):
        flags, self.entries = hit_flags(meshes, unlit_by)
        surfaces = [surface for surface, _ in self.entries]
        self.materials = ctx.buffer(material_table(surfaces))
        blocks = [b for b in _mesh_blocks(meshes, flags) if len(b)]
        self.parts = []
        for block in blocks:
            tri = block[:, :3].reshape(-1, 3, 3)
            self.parts.append((tri.min(axis=(0, 1)), tri.max(axis=(0, 1)),
                               tri.copy() if len(tri) <= KEEP_TRIANGLES else None))
        data = np.concatenate(blocks) if blocks else np.zeros((0, WIDTH), np.float32)
        self.textured = [(k, s) for k, s in enumerate(surfaces) if s.textured]
        coords = texture_coordinates([m for m in meshes if m.shading.textured and not m.holdout])
        self.coords_count = len(coords)
        self.coords_vbo = ctx.buffer(coords.tobytes()) if len(coords) else None
        self.vertex_count = len(data)
        self.bounds = (data[:, :3].min(axis=0), data[:, :3].max(axis=0)) if len(data) else None
        self.vbo = ctx.buffer(data.tobytes()) if len(data) else None

    def release(self) -> None:
        self.materials.release()
        if self.coords_vbo is not None:
            self.coords_vbo.release()
        if self.vbo is not None:
            self.vbo.release()
