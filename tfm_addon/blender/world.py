"""The world colour, used as constant ambient radiance."""

from __future__ import annotations

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
