"""Node materials: which shaders a material's output has, its volume read as the renderer's
numbers, and whether camera rays see its surface.

A volume material is read once, by the one node-graph reader (``node_graph.compile_volume``), into
a ``shading.ShaderGraph``; ``read_volume_material`` folds it into constants and one grid
(``engine/affine.py``, the fast path) where it can, else the graph is evaluated per voxel. Surfaces
are read by ``blender/surfaces.py``.
"""

from __future__ import annotations

from collections.abc import Collection

from ..engine.affine import AffineMedium, NotAffine, fold


def output_node(material):
    """The material's active output node for Cycles (what Cycles would render), or None."""
    if material is None or material.node_tree is None:
        return None
    return material.node_tree.get_output_node('CYCLES')


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
    """Whether the surface is transparent to camera rays: a Principled BSDF whose Alpha is 0 on a
    camera ray (Blender's preview floor, a Light Path's "Is Camera Ray" driving it, seen only in
    reflections). Such a mesh is left out of what the camera sees; it still casts shadows."""
    from ..engine import shading
    from ..engine.shading import Link
    from .node_graph import compile_surface, subgraph

    graph = compile_surface(material)
    if graph is None:
        return False
    node = graph.nodes[graph.output.node]
    if node.kind != "PRINCIPLED_BSDF":
        return False
    alpha = next((i for i in node.inputs if i.name == "Alpha"), None)
    if alpha is None:
        return False
    if not isinstance(alpha.value, Link):
        return float(alpha.value) <= 0.0
    sub = subgraph(graph, alpha.value)
    if sub.reads_position or sub.grids:
        return False
    return float(shading.evaluate_value(sub, "VALUE", 1, camera_ray=True)[0]) <= 0.0
