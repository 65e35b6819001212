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


def visibility(instance, view_layer) -> dict[str, bool]:
    """Mesh visibility flags of an object instance, as Cycles reads them: the object's camera and
    shadow ray visibility (and its instancer's, for an instance) and its holdout, set on the
    object or by a holdout collection of the view layer."""
    ob = instance.object
    owners = [ob]
    if instance.is_instance and instance.parent is not None:
        owners.append(instance.parent)
    holdout = False
    for owner in owners:
        original = owner.original
        try:
            holdout = holdout or bool(original.holdout_get(view_layer=view_layer))
        except (RuntimeError, TypeError, ValueError):
            holdout = holdout or bool(original.is_holdout)
    return {"visible_camera": all(o.visible_camera for o in owners),
            "cast_shadow": all(o.visible_shadow for o in owners),
            "holdout": holdout}
