"""The solids as one vertex buffer: world positions, face normals, albedo."""

from __future__ import annotations

import numpy as np

from ..scene import Mesh

FORMAT = "3f 3f 3f"
POSITION_ONLY = "3f 24x"


def solids_vertices(meshes: tuple[Mesh, ...]) -> np.ndarray:
    """(3 * triangles, 9) float32: position, face normal, albedo per vertex, world space."""
    rows = []
    for mesh in meshes:
        if len(mesh.triangles) == 0:
            continue
        v = mesh.world_vertices()[mesh.triangles]            # (m, 3, 3)
        n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        length = np.linalg.norm(n, axis=1, keepdims=True)
        keep = length[:, 0] > 0
        v, n = v[keep], n[keep] / length[keep]
        block = np.empty((len(v), 3, 9), dtype=np.float32)
        block[:, :, 0:3] = v
        block[:, :, 3:6] = n[:, None, :]
        block[:, :, 6:9] = np.asarray(mesh.color, dtype=np.float32)
        rows.append(block.reshape(-1, 9))
    return np.concatenate(rows) if rows else np.zeros((0, 9), np.float32)


class SolidsBuffer:
    """The solids' vertices on the GPU, shared by the shadow-map and G-buffer passes."""

    def __init__(self, ctx, meshes: tuple[Mesh, ...]):
        data = solids_vertices(meshes)
        self.vertex_count = len(data)
        self.bounds = (data[:, :3].min(axis=0), data[:, :3].max(axis=0)) if len(data) else None
        self.vbo = ctx.buffer(data.tobytes()) if len(data) else None

    def release(self) -> None:
        if self.vbo is not None:
            self.vbo.release()
