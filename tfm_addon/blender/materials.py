"""Node materials: which shaders a material's output has, and its volume read as the renderer's
numbers.

A volume material is read once, by the one node-graph reader (``node_graph.compile_volume``), into
a ``shading.ShaderGraph``; ``read_volume_material`` folds it into constants and one grid
(``engine/affine.py``, the fast path) where it can, else the graph is evaluated per voxel. Surfaces
are read by ``blender/surfaces.py``.
"""

from __future__ import annotations

from collections.abc import Collection

from ..engine.affine import AffineMedium, NotAffine, fold


class Unreadable(Exception):
    """A node set-up the engine cannot turn into numbers; the message says which node."""


def output_node(material):
    """The material's active output node for Cycles (what Cycles would render), or None."""
    if material is None or material.node_tree is None:
        return None
    return material.node_tree.get_output_node('CYCLES')


def _linked(socket):
    """(node, its output socket) feeding ``socket`` through reroutes, or (None, None)."""
    while socket.is_linked:
        link = socket.links[0]
        if link.is_muted:
            return None, None
        node = link.from_node
        if node.bl_idname == 'NodeReroute':
            socket = node.inputs[0]
            continue
        if node.mute:
            raise Unreadable(f"node '{node.name}' is muted")
        return node, link.from_socket
    return None, None


def _linked_node(socket):
    return _linked(socket)[0]


def volume_graph(material):
    """(the material's volume graph, "") or (None, why it has none, for the report and the panel)."""
    from .node_graph import compile_volume

    if material is None:
        return None, "No material: using the settings below"
    if output_node(material) is None:
        return None, f"Material '{material.name}' has no node output: using the settings below"
    graph = compile_volume(material)
    if graph is None:
        return None, f"Material '{material.name}' has no volume shader: using the settings below"
    if graph.output is None:
        why = "; ".join(graph.notes) or "its volume shader is not read"
        return None, f"Material '{material.name}': {why}; using the TFM settings instead"
    return graph, ""


def read_volume_material(material, available: Collection[str] | None = None
                         ) -> tuple[AffineMedium | None, str]:
    """The material's volume folded into constants and one grid (engine/affine.py), or (None, why
    not: no volume shader, or a graph that is evaluated per voxel). ``available``: the names of the
    volume's grids (None: take every grid the material names as present)."""
    graph, reason = volume_graph(material)
    if graph is None:
        return None, reason
    try:
        return fold(graph, available, material.name), ""
    except NotAffine as ex:
        return None, f"Material '{material.name}': {ex}; its node graph is evaluated per voxel"


def has_volume_only(material) -> bool:
    """Whether the material has a volume shader and no surface shader (a mesh that is a medium)."""
    out = output_node(material)
    if out is None:
        return False
    return out.inputs["Volume"].is_linked and not out.inputs["Surface"].is_linked


def has_surface_and_volume(material) -> bool:
    """Whether the material has both a surface and a volume shader."""
    out = output_node(material)
    return out is not None and out.inputs["Volume"].is_linked and out.inputs["Surface"].is_linked


def hidden_from_camera(material) -> bool:
    """Whether the surface is transparent to camera rays by a Light Path node: a Principled BSDF
    whose Alpha is 0 when "Is Camera Ray" is 1 (Blender's preview floor, seen only in
    reflections). Such a mesh is left out of what the camera sees; it still casts shadows."""
    out = output_node(material)
    if out is None:
        return False
    try:
        node = _linked_node(out.inputs["Surface"])
        if node is None or node.bl_idname != 'ShaderNodeBsdfPrincipled':
            return False
        return ray_value(node.inputs["Alpha"]) <= 0.0
    except (Unreadable, KeyError):
        return False


_MATH = {'ADD': lambda a, b: a + b, 'SUBTRACT': lambda a, b: a - b, 'MULTIPLY': lambda a, b: a * b,
         'MINIMUM': min, 'MAXIMUM': max}


def ray_value(socket, camera_ray: bool = True) -> float:
    """A float input's value on a camera ray (or, ``camera_ray`` False, on a shadow ray), through
    Light Path ("Is Camera Ray") and Math nodes; Unreadable for other nodes."""
    if not socket.is_linked:
        return float(socket.default_value)
    link = socket.links[0]
    node = _linked_node(socket)
    if node is None:
        return float(socket.default_value)
    if node.bl_idname == 'ShaderNodeLightPath':
        return 1.0 if link.from_socket.name == "Is Camera Ray" and camera_ray else 0.0
    if node.bl_idname == 'ShaderNodeMath' and node.operation in _MATH:
        a, b = (ray_value(node.inputs[i], camera_ray) for i in (0, 1))
        value = _MATH[node.operation](a, b)
        return min(max(value, 0.0), 1.0) if node.use_clamp else value
    raise Unreadable(f"input '{socket.name}' is driven by node '{node.name}'")
