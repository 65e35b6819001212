"""Solid objects as triangle meshes with a diffuse colour."""

from __future__ import annotations

import numpy as np

from . import materials

# Object types that evaluate to a mesh.
MESH_TYPES = {'MESH', 'CURVE', 'SURFACE', 'FONT', 'META'}


def triangles(evaluated_object) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices (n, 3) float32 in object space and triangles (m, 3) int32 of an evaluated object,
    or None when it has no faces."""
    mesh = evaluated_object.to_mesh()
    try:
        if mesh is None or len(mesh.polygons) == 0:
            return None
        mesh.calc_loop_triangles()
        vertices = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", vertices)
        tris = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
        mesh.loop_triangles.foreach_get("vertices", tris)
        vertices.setflags(write=False)
        tris.setflags(write=False)
        return vertices.reshape(-1, 3), tris.reshape(-1, 3)
    finally:
        evaluated_object.to_mesh_clear()


def first_material(evaluated_object):
    for slot in evaluated_object.material_slots:
        if slot.material is not None:
            return slot.material
    return None


def diffuse_color(evaluated_object, notes: list[str] | None = None) -> tuple[float, float, float]:
    """Albedo: the Principled BSDF base colour (or Diffuse BSDF colour) of the first material,
    materials.FALLBACK_GREY (with a line in ``notes``) for a surface it cannot read, else the
    object's viewport colour."""
    color = materials.surface_color(first_material(evaluated_object), notes)
    if color is None:
        color = tuple(evaluated_object.color[:3])
    return tuple(float(min(max(c, 0.0), 1.0)) for c in color)
