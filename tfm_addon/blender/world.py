"""The world: its radiance (a constant, or by direction: engine/environment.py), its Ray Visibility
and the fog of its Volume output."""

from __future__ import annotations

import numpy as np

from ..engine import shading
from ..engine.environment import Environment, of_graph
from ..engine.scene import GridValue, Medium
from .sky_bake import sky_environment, sky_node

RGB = tuple[float, float, float]


def background_node(world):
    """The Background node feeding the world's active output, or None."""
    if world is None or world.node_tree is None:
        return None
    out = world.node_tree.get_output_node('CYCLES')
    if out is None:
        return None
    from .node_graph import source

    node, _ = source(out.inputs["Surface"])
    if node is not None and node.bl_idname == 'ShaderNodeBackground':
        return node
    return None


def _radiance(world) -> tuple[shading.ShaderGraph | None, str | None]:
    """The world's Background compiled by the one node-graph reader (node_graph.py; the Background
    read as an emission, the direction as its Generated and Object coordinates), and a note naming
    what is not read; None where the output is not a Background node."""
    if background_node(world) is None:
        return None, None
    from .node_graph import compile_world

    graph = compile_world(world)
    if graph is None or graph.output is None:
        return None, None
    return graph, "; ".join(f"World '{world.name}': {n}" for n in graph.notes) or None


def environment(world, wait: bool = True) -> tuple[Environment | None, str | None]:
    """The world's radiance by direction where it varies with it (an Environment Texture, aimed or
    not by a Mapping node; a gradient made of nodes), or None (a constant); a world with a Sky
    Texture baked by Cycles (sky_bake.py; ``wait`` False: in the background); and a note naming
    what is read only in part."""
    if sky_node(world) is not None:
        return sky_environment(world, wait)
    graph, note = _radiance(world)
    if graph is None or not graph.reads_position:
        return None, note
    return of_graph(graph), note


def ambient_radiance(world, wait: bool = True) -> tuple[RGB, str | None]:
    """World radiance W/(sr m^2) per channel (an environment's mean), and a warning when the
    world's nodes are not read."""
    if world is None:
        return (0.0, 0.0, 0.0), None
    env, note = environment(world, wait)
    if env is not None:
        return env.mean, note
    if sky_node(world) is not None:
        return tuple(world.color), note
    graph, note = _radiance(world)
    if graph is not None:       # the same in every direction: evaluated once
        fields = shading.evaluate(graph, {}, 1, np.zeros((1, 3)))
        return tuple(float(c) for c in np.maximum(fields.emission[0], 0.0)), note
    if world.node_tree is None:
        return tuple(world.color), None
    out = world.node_tree.get_output_node('CYCLES')
    if out is None or not out.inputs["Surface"].is_linked:
        return (0.0, 0.0, 0.0), None
    return tuple(world.color), (f"World '{world.name}' is not a plain Background node; "
                                f"using the world's viewport colour as ambient light")


def world_visibility(world) -> tuple[bool, bool, bool]:
    """The World's Ray Visibility as Cycles reads it for this engine's media and surfaces:
    (Camera: the world seen behind everything, Volume Scatter: its light on the media, Diffuse: its
    light on the surfaces, their specular layer included; Glossy is not read). Transmission and
    Shadow change nothing (measured against Cycles 5.0)."""
    v = getattr(world, "cycles_visibility", None) if world is not None else None
    if v is None:
        return True, True, True
    return bool(v.camera), bool(v.scatter), bool(v.diffuse)


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

