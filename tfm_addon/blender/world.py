"""The world: its colour, used as constant ambient radiance, and the fog of its Volume output."""

from __future__ import annotations

import numpy as np

from ..engine import shading
from ..engine.scene import GridValue, Medium
from .materials import Unreadable, _constant, _linked_node, _rgb

RGB = tuple[float, float, float]


def background_node(world):
    """The Background node feeding the world's active output, or None."""
    if world is None or world.node_tree is None:
        return None
    out = world.node_tree.get_output_node('CYCLES')
    if out is None:
        return None
    try:
        node = _linked_node(out.inputs["Surface"])
    except Unreadable:
        return None
    if node is not None and node.bl_idname == 'ShaderNodeBackground':
        return node
    return None


def ambient_radiance(world) -> tuple[RGB, str | None]:
    """World radiance W/(sr m^2) per channel, and a warning when the world's nodes are not read."""
    if world is None:
        return (0.0, 0.0, 0.0), None
    node = background_node(world)
    if node is not None:
        try:
            color = _rgb(node.inputs["Color"])
            strength = float(_constant(node.inputs["Strength"]))
            return tuple(c * strength for c in color), None
        except Unreadable as ex:
            return tuple(world.color), f"World '{world.name}': {ex}; using the world's viewport colour"
    if world.node_tree is None:
        return tuple(world.color), None
    out = world.node_tree.get_output_node('CYCLES')
    if out is None or not out.inputs["Surface"].is_linked:
        return (0.0, 0.0, 0.0), None
    return tuple(world.color), (f"World '{world.name}' is not a plain Background node; "
                                f"using the world's viewport colour as ambient light")


def world_fog(world) -> tuple[Medium | None, list[str]]:
    """The World's Volume output as fog filling the scene (Cycles renders it everywhere, the camera
    inside it), or None; and report lines. The shader is evaluated once (the world has no grids:
    an Attribute node reads 0); a shader that varies in space is read at the world's origin, said
    once."""
    if world is None or world.node_tree is None:
        return None, []
    from .node_graph import compile_volume

    graph = compile_volume(world)
    if graph is None or graph.output is None:
        return None, []
    notes = [f"World '{world.name}': {n}" for n in graph.notes]
    position = np.zeros((1, 3)) if graph.reads_position else None
    if graph.reads_position:
        notes.append(f"World '{world.name}': its fog varies in space; it is rendered with its value at "
                     f"the world's origin")
    f = shading.evaluate(graph, {}, 1, position)
    sigma_s = tuple(float(x) for x in np.maximum(f.sigma_s[0], 0.0))
    sigma_a = tuple(float(x) for x in np.maximum(f.sigma_a[0], 0.0))
    emission = tuple(float(x) for x in np.maximum(f.emission[0], 0.0))
    if max(sigma_s + sigma_a + emission) <= 0.0:
        return None, notes
    strength = max(emission)
    fields = {} if strength <= 0.0 else dict(emission_color=tuple(e / strength for e in emission),
                                             emission_strength=GridValue(offset=float(strength)))
    return Medium(sigma_a=sigma_a, sigma_s=sigma_s, anisotropy=float(f.anisotropy[0]), box_to_world=None,
                  name=f"World '{world.name}' fog", **fields), notes

