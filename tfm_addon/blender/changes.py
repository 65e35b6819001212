"""Change flags: which parts of the scene a depsgraph update makes stale.

The viewport re-extracts only the flagged parts and keeps the others; the renderer then rebuilds
only the maps whose inputs (compared by key) differ. Pure Python, no bpy.
"""

from __future__ import annotations

import enum


class Change(enum.Flag):
    NONE = 0
    CAMERA = enum.auto()
    LIGHTS = enum.auto()
    MEDIUM = enum.auto()
    SOLIDS = enum.auto()
    WORLD = enum.auto()
    SETTINGS = enum.auto()
    GEOMETRY = LIGHTS | MEDIUM | SOLIDS
    ALL = CAMERA | LIGHTS | MEDIUM | SOLIDS | WORLD | SETTINGS


MESH_OBJECT_TYPES = {'MESH', 'CURVE', 'SURFACE', 'FONT', 'META'}

_BY_OBJECT_TYPE = {
    'CAMERA': Change.CAMERA,
    'LIGHT': Change.LIGHTS,
    'VOLUME': Change.MEDIUM,
    # A mesh may be a solid or, with a volume-only material, the medium.
    **{t: Change.SOLIDS | Change.MEDIUM for t in MESH_OBJECT_TYPES},
    # An empty may instance anything.
    'EMPTY': Change.GEOMETRY,
}

_BY_ID_TYPE = {
    'CAMERA': Change.CAMERA,
    'LIGHT': Change.LIGHTS,
    'IMAGE': Change.LIGHTS,  # projected textures
    'VOLUME': Change.MEDIUM,
    'MESH': Change.SOLIDS | Change.MEDIUM,
    'CURVE': Change.SOLIDS,
    'CURVES': Change.SOLIDS,
    'METABALL': Change.SOLIDS,
    'TEXT': Change.SOLIDS,
    'MATERIAL': Change.MEDIUM | Change.SOLIDS,
    'NODETREE': Change.MEDIUM | Change.SOLIDS | Change.WORLD,
    'WORLD': Change.WORLD,
    'COLLECTION': Change.GEOMETRY,
    # Scene updates carry render settings, visibility changes and object deletion.
    'SCENE': Change.ALL,
}


def change_for_update(id_type: str, object_type: str | None = None) -> Change:
    """What one depsgraph update of an ID of ``id_type`` (and object type, for objects) affects."""
    if id_type == 'OBJECT':
        return _BY_OBJECT_TYPE.get(object_type, Change.GEOMETRY)
    return _BY_ID_TYPE.get(id_type, Change.NONE)


def changes_from_depsgraph(depsgraph) -> Change:
    """Fold ``depsgraph.updates`` into one set of flags."""
    flags = Change.NONE
    for update in depsgraph.updates:
        ident = update.id
        object_type = ident.type if ident.id_type == 'OBJECT' else None
        flags |= change_for_update(ident.id_type, object_type)
    return flags
