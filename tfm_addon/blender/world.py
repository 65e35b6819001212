"""The world: its colour, used as constant ambient radiance, and the fog of its Volume output."""

from __future__ import annotations

import numpy as np

from ..engine import caches, shading
from ..engine.scene import GridValue, Medium
from . import files
from .materials import Unreadable, _constant, _linked_node, _rgb
from .sky_bake import sky_environment, sky_node

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


ENVIRONMENT_SIDE = 128      # an environment image is averaged down to at most this many pixels wide


def environment(world, wait: bool = True) -> tuple[np.ndarray | None, str | None]:
    """The world's radiance by direction when its Background colour is an Environment Texture
    (equirectangular, unmapped) times the Strength: an (h, w, 3) image, top row first, averaged down
    to at most ENVIRONMENT_SIDE wide (its light, not its sharpness, is what lights the media); a
    world with a Sky Texture baked by Cycles (sky_bake.py; ``wait`` False: in the background);
    and a note for a set-up read only in part."""
    if sky_node(world) is not None:
        return sky_environment(world, wait)
    node = background_node(world)
    if node is None or not node.inputs["Color"].is_linked:
        return None, None
    try:
        tex = _linked_node(node.inputs["Color"])
        strength = float(_constant(node.inputs["Strength"]))
    except Unreadable:
        return graph_environment(world)
    if tex is None or tex.bl_idname != 'ShaderNodeTexEnvironment' or tex.image is None:
        return graph_environment(world)
    note = None
    if tex.projection != 'EQUIRECTANGULAR':
        return None, f"World '{world.name}': a {tex.projection.lower()} environment is not read"
    if tex.inputs["Vector"].is_linked:
        note = (f"World '{world.name}': the environment's mapping (its Vector input) is not read; it "
                f"is placed as unmapped")
    image = tex.image
    missing = files.image_problem(f"World '{world.name}': node '{tex.name}'", image, files.scene_frame(),
                                  tex.image_user)
    if missing is not None:      # Cycles renders a missing HDRI in its missing-texture pink
        note = missing if note is None else f"{missing}; {note}"
        return missing_environment(strength), note
    return _image_radiance(image) * np.float32(strength), note


MISSING_SIZE = (8, 16)      # (rows, columns) of the environment of a missing image


def missing_environment(strength: float) -> np.ndarray:
    """The environment of a world whose HDRI is missing: Cycles' missing-texture pink times the
    Background's Strength, in every direction."""
    out = np.empty(MISSING_SIZE + (3,), np.float32)
    out[...] = np.asarray(files.MISSING_PINK, np.float32) * np.float32(strength)
    out.setflags(write=False)
    return out


GRAPH_SIZE = (32, 64)       # (rows, columns) of the image a world's node graph is evaluated into


def graph_environment(world) -> tuple[np.ndarray | None, str | None]:
    """The world's radiance by direction when its Background's Color is made by nodes (a Gradient
    Texture, a Mix by direction...): the Surface graph compiled by the volumes' node mechanism
    (node_graph.py; the Background as an emission) and evaluated over the directions of a
    GRAPH_SIZE equirectangular image, its Generated and Object coordinates the direction as in
    Cycles; and a note naming the nodes not read."""
    from ..engine.world_light import environment_directions
    from .node_graph import compile_volume

    h, w = GRAPH_SIZE
    graph = compile_volume(world, texspace=((0.5, 0.5, 0.5), (0.5, 0.5, 0.5)), output="Surface")
    if graph is None or graph.output is None:
        return None, None
    dirs, _ = environment_directions(np.zeros((h, w, 3)))
    fields = shading.evaluate(graph, {}, h * w, dirs)
    rgb = np.ascontiguousarray(np.maximum(np.broadcast_to(fields.emission, (h * w, 3)), 0.0), np.float32)
    note = "; ".join(f"World '{world.name}': {n}" for n in graph.notes) or None
    return rgb.reshape(h, w, 3), note


_images = caches.memo("world.images", 4)      # image signature -> its radiance averaged down


def _image_radiance(image) -> np.ndarray:
    """An image's RGB averaged down to at most ENVIRONMENT_SIDE wide, top row first; kept by the
    image's identity, size, file and dirty flag, so that a scene update (a click) does not read an
    HDRI's pixels again."""
    w, h = image.size
    key = (image.as_pointer(), image.name_full, w, h, image.channels, image.filepath_raw, image.is_dirty)
    hit = _images.get(key)
    if hit is not None:
        return hit
    px = np.empty(w * h * image.channels, np.float32)
    image.pixels.foreach_get(px)
    rgb = px.reshape(h, w, image.channels)[::-1, :, :3]        # Blender's rows are bottom first
    f = max(1, int(np.ceil(w / ENVIRONMENT_SIDE)))
    hh, ww = (h // f) * f, (w // f) * f
    if f > 1 and hh > 0 and ww > 0:
        rgb = rgb[:hh, :ww].reshape(hh // f, f, ww // f, f, 3).mean(axis=(1, 3))
    out = np.ascontiguousarray(rgb, np.float32)
    out.setflags(write=False)
    return _images.put(key, out)


def ambient_radiance(world, wait: bool = True) -> tuple[RGB, str | None]:
    """World radiance W/(sr m^2) per channel, and a warning when the world's nodes are not read."""
    if world is None:
        return (0.0, 0.0, 0.0), None
    env, note = environment(world, wait)
    if env is not None:
        from ..engine.world_light import mean_radiance

        return mean_radiance(env), note
    if sky_node(world) is not None:
        return tuple(world.color), note
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

