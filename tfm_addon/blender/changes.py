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


_UNKNOWN = object()


def change_for_update(id_type: str, object_type: str | None = None, is_medium: bool | None = None) -> Change:
    """What one depsgraph update of an ID of ``id_type`` (and object type, for objects) affects.

    ``is_medium``: for a mesh-like object or mesh data, whether it is (or may have become) the
    medium; None when unknown, which flags the medium too (the conservative answer)."""
    if id_type == 'OBJECT':
        flags = _BY_OBJECT_TYPE.get(object_type, Change.GEOMETRY)
        if object_type in MESH_OBJECT_TYPES and is_medium is False:
            flags &= ~Change.MEDIUM
        return flags
    flags = _BY_ID_TYPE.get(id_type, Change.NONE)
    if id_type == 'MESH' and is_medium is False:
        flags &= ~Change.MEDIUM
    return flags


def _may_be_medium(ob, medium_source) -> bool:
    """Whether a mesh-like object is a medium now or may have become one: it is (or instances)
    an extracted medium (``medium_source``: a label, a tuple of labels or None), a smoke / fire
    domain, or one of its materials has a volume shader."""
    sources = (medium_source,) if isinstance(medium_source, str) else tuple(medium_source or ())
    for source in sources:
        if source == ob.name or source.endswith(f"(instanced by {ob.name})") \
                or source.startswith(f"{ob.name} (instanced by "):
            return True
    from . import fluid, materials

    if fluid.domain_modifier(ob) is not None:
        return True

    for slot in getattr(ob, "material_slots", ()):
        out = materials.output_node(slot.material) if slot.material is not None else None
        if out is not None and out.inputs["Volume"].is_linked:
            return True
    return False


def changes_from_depsgraph(depsgraph, medium_source=_UNKNOWN, scene: Change = Change.ALL) -> Change:
    """Fold ``depsgraph.updates`` into one set of flags.

    ``medium_source``: the label of the object the current medium comes from
    (the first of ``Extraction.medium_sources``, None without a medium). Given, an edit of a mesh that is not
    the medium and has no volume shader flags the solids alone, so the grid is not re-read; a
    mesh data update is then the solids' (Blender sends its object's update with it). Not given,
    every mesh update flags the medium too. ``scene``: what the Scene's own update made stale
    (a selection click, an active object change leave nothing: the viewport compares the scene's
    settings, world, frame and visible objects before and after, ``extract.scene_changes``);
    everything when not given."""
    known = medium_source is not _UNKNOWN
    flags = Change.NONE
    for update in depsgraph.updates:
        ident = update.id
        if ident.id_type == 'SCENE':
            flags |= scene
            continue
        object_type = ident.type if ident.id_type == 'OBJECT' else None
        is_medium = None
        if known and ident.id_type == 'MESH':
            is_medium = False
        elif known and object_type in MESH_OBJECT_TYPES:
            is_medium = _may_be_medium(ident, medium_source)
        flags |= change_for_update(ident.id_type, object_type, is_medium)
    return flags
