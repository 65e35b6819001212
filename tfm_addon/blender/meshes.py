"""Solid objects as triangle meshes with their surface."""

from __future__ import annotations

import numpy as np

from . import surfaces

# Object types that evaluate to a mesh.
MESH_TYPES = {'MESH', 'CURVE', 'SURFACE', 'FONT', 'META'}


def triangles(evaluated_object) -> tuple | None:
    """Vertices (n, 3) float32 in object space, triangles (m, 3) int32, the active UV map per
    triangle corner (m, 3, 2) float32 (None without one) and the normals per triangle corner
    (m, 3, 3) float32 of a smooth-shaded mesh (None where every face is flat) of an evaluated
    object, or None when it has no faces."""
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
        uv = None
        if mesh.uv_layers.active is not None:
            loops = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
            mesh.loop_triangles.foreach_get("loops", loops)
            data = np.empty(len(mesh.loops) * 2, dtype=np.float32)
            mesh.uv_layers.active.data.foreach_get("uv", data)
            uv = data.reshape(-1, 2)[loops].reshape(-1, 3, 2)
            uv.setflags(write=False)
        normals = None
        if mesh.normals_domain != 'FACE':
            loops = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
            mesh.loop_triangles.foreach_get("loops", loops)
            data = np.empty(len(mesh.loops) * 3, dtype=np.float32)
            mesh.corner_normals.foreach_get("vector", data)
            normals = data.reshape(-1, 3)[loops].reshape(-1, 3, 3)
            normals.setflags(write=False)
        return vertices.reshape(-1, 3), tris.reshape(-1, 3), uv, normals
    finally:
        evaluated_object.to_mesh_clear()


def first_material(evaluated_object):
    for slot in evaluated_object.material_slots:
        if slot.material is not None:
            return slot.material
    return None


def shading(evaluated_object, notes: list[str] | None = None) -> dict:
    """The mesh's ``color`` (its base colour) and ``surface`` (blender/surfaces.py) from its first
    material's surface shader; without one, the object's viewport colour, Lambertian."""
    data = evaluated_object.data
    texspace = None
    if hasattr(data, "texspace_location") and hasattr(data, "texspace_size"):
        texspace = (tuple(data.texspace_location), tuple(data.texspace_size))
    surface = surfaces.read_surface(first_material(evaluated_object), notes, texspace)
    if surface is None:
        return {"color": tuple(float(min(max(c, 0.0), 1.0)) for c in evaluated_object.color[:3]),
                "surface": None}
    return {"color": tuple(float(min(max(c, 0.0), 1.0)) for c in surface.base_color), "surface": surface}


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
