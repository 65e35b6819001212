"""Blender lights (spot, point, sun, area; a spot's projected texture) as the renderer's Light."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..engine.scene import Light
from . import files
from .camera import without_scale


def light_color(light) -> tuple[float, float, float]:
    """Colour as Cycles uses it: the colour, tinted by the blackbody temperature when enabled."""
    color = np.asarray(light.color[:3], dtype=np.float64)
    if getattr(light, "use_temperature", False):
        color = color * np.asarray(light.temperature_color[:3], dtype=np.float64)
    return tuple(float(c) for c in color)


def light_power_w(light) -> float:
    """Power in watts as Cycles uses it: energy times 2^exposure."""
    return float(light.energy) * 2.0 ** float(getattr(light, "exposure", 0.0))


def image_pixels(image) -> np.ndarray:
    """An image's pixels as an (h, w, 3) float32 array, top row first, scene-linear (an image
    ``files.image_problem`` finds fault with has none: the caller asks it first)."""
    w, h = image.size
    flat = np.empty(w * h * image.channels, dtype=np.float32)
    image.pixels.foreach_get(flat)
    rgba = flat.reshape(h, w, image.channels)
    rgb = rgba[:, :, :3] if image.channels >= 3 else np.repeat(rgba[:, :, :1], 3, axis=2)
    if not image.is_float and image.colorspace_settings.name in ("sRGB", "sRGB Display"):
        rgb = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    return np.ascontiguousarray(rgb[::-1], dtype=np.float32)


def cone_scale(matrix_world, name: str, warnings: list[str]) -> tuple[float, float]:
    """(sx / sz, sy / sz) of the object's scale: Cycles scales a spot's cone by it (an ellipse
    for a non-uniform scale); a zero scale renders a round cone with a warning."""
    m = np.array(matrix_world, dtype=np.float64).reshape(4, 4)
    sx, sy, sz = np.linalg.norm(m[:3, :3], axis=0)
    if min(sx, sy, sz) <= 1e-12 * max(sx, sy, sz, 1e-300):
        warnings.append(f"Light '{name}': a zero scale axis; rendered as a round cone")
        return 1.0, 1.0
    return float(sx / sz), float(sy / sz)


def spot_light(light_object, matrix_world, warnings: list[str]) -> Light:
    """The renderer's Light for an evaluated spot light object placed at ``matrix_world``."""
    light = light_object.data
    settings = getattr(light, "tfm", None)
    gobo = None
    if settings is not None and settings.gobo is not None:
        problem = files.image_problem(f"Light '{light_object.name}': its projected texture",
                                      settings.gobo, files.scene_frame())
        if problem is None:
            gobo = image_pixels(settings.gobo)
        else:       # projected in Cycles' missing-texture pink, as Cycles shows a missing image
            warnings.append(problem)
            gobo = np.full((2, 2, 3), files.MISSING_PINK, np.float32)
    return Light(
        matrix_world=without_scale(matrix_world),
        color=light_color(light),
        power_w=light_power_w(light),
        spot_size_rad=float(light.spot_size),
        spot_blend=float(light.spot_blend),
        gobo=gobo,
        use_tfm=True if settings is None else bool(settings.use_tfm),
        name=light_object.name,
        cone_scale=cone_scale(matrix_world, light_object.name, warnings),
        cast_shadow=bool(getattr(light, "use_shadow", True)),
        radius_m=float(getattr(light, "shadow_soft_size", 0.0)),
        **ray_visibility(light_object),
    )


def ray_visibility(light_object) -> dict:
    """What the light object's Ray Visibility lets it light, as Cycles reads it: Volume Scatter
    the media, Diffuse the (diffuse) surfaces. (The light's Volume factor changes nothing in
    Cycles' single scattering: its conformance row.)"""
    return dict(lights_medium=bool(getattr(light_object, "visible_volume_scatter", True)),
                lights_surfaces=bool(getattr(light_object, "visible_diffuse", True)))


def light(light_object, matrix_world, warnings: list[str]) -> Light:
    """The renderer's Light for any evaluated light object placed at ``matrix_world``; what it
    renders differently from Cycles goes into ``warnings`` (one line per light)."""
    data = light_object.data
    name = light_object.name
    if getattr(data, "use_nodes", False):
        warnings.append(f"Light '{name}': light nodes (an IES profile among them) are not rendered (its "
                        f"colour and power are used)")
    kind = data.type
    if kind == 'SPOT':
        return spot_light(light_object, matrix_world, warnings)
    common = dict(matrix_world=without_scale(matrix_world), color=light_color(data),
                  power_w=light_power_w(data), name=name,
                  cast_shadow=bool(getattr(data, "use_shadow", True)), **ray_visibility(light_object))
    if kind == 'POINT':
        return Light(kind="POINT", radius_m=float(getattr(data, "shadow_soft_size", 0.0)), **common)
    if kind == 'SUN':
        return Light(kind="SUN", angle_rad=float(getattr(data, "angle", 0.0)), **common)
    if kind == 'AREA':
        scale = np.linalg.norm(np.array(matrix_world, dtype=np.float64).reshape(4, 4)[:3, :3], axis=0)
        size = float(data.size) * float(scale[0])
        size_y = (float(data.size_y) if data.shape in ('RECTANGLE', 'ELLIPSE') else float(data.size))
        size_y *= float(scale[1])
        if not getattr(data, "normalize", True):
            # Normalize off: Cycles keeps the radiance of a 1 m² light, so the power grows with the area
            area = size * size_y * (math.pi / 4.0 if data.shape in ('DISK', 'ELLIPSE') else 1.0)
            common["power_w"] *= area
        return Light(kind="AREA", size_m=(size, size_y), round_shape=data.shape in ('DISK', 'ELLIPSE'),
                     spread_rad=float(getattr(data, "spread", math.pi)), **common)
    raise ValueError(f"light type {kind!r} is not known")


def link_states(collection, state: str = 'INCLUDE', states: dict | None = None) -> dict:
    """Object name -> 'INCLUDE' or 'EXCLUDE' in a light-linking collection (an object in a linked
    child collection takes that collection's state)."""
    states = {} if states is None else states
    for ob, entry in zip(collection.objects, collection.collection_objects, strict=False):
        states.setdefault(ob.name, entry.light_linking.link_state if state == 'INCLUDE' else state)
    for child, entry in zip(collection.children, collection.collection_children, strict=False):
        link_states(child, entry.light_linking.link_state if state == 'INCLUDE' else state, states)
    return states


def receives(states: dict, name: str) -> bool:
    """Whether the object ``name`` receives a light whose receiver collection has ``states``
    (Cycles: an included object does, an excluded one does not, any other one only where the
    collection includes none)."""
    if name in states:
        return states[name] == 'INCLUDE'
    return 'INCLUDE' not in states.values()


def linked(light_object, light: Light, media: list[str], solids: list[str], warnings: list[str]) -> Light:
    """``light`` as its Object ▸ Shading ▸ Light Linking and Shadow Linking collections have it.
    Receivers: the media (object names) it lights (``Light.lights_medium`` False where none,
    ``lit_media`` where some) and the solids it does not (``lights_surfaces`` False where none is
    lit, ``unlit_solids`` where some are not). Blockers: the
    solids (object names) that shadow it (``Light.shadow_solids``); a collection that leaves out
    every medium: the media shadow no surface from it (``Light.media_shadow_surfaces``), one
    that leaves out some is said in ``warnings``."""
    linking = getattr(light_object, "light_linking", None)
    receivers = None if linking is None else getattr(linking, "receiver_collection", None)
    blockers = None if linking is None else getattr(linking, "blocker_collection", None)
    flags = {}
    if receivers is not None:
        states = link_states(receivers)
        lit_media = tuple(n for n in media if receives(states, n))
        unlit_solids = tuple(n for n in solids if not receives(states, n))
        if media and not lit_media:
            flags["lights_medium"] = False
        elif len(lit_media) < len(media):
            flags["lit_media"] = lit_media
        if solids and len(unlit_solids) == len(solids):
            flags["lights_surfaces"] = False
        elif unlit_solids:
            flags["unlit_solids"] = unlit_solids
    if blockers is not None:
        states = link_states(blockers)      # a blocker collection's states read as a receiver one's
        shadowing = tuple(n for n in solids if receives(states, n))
        if len(shadowing) < len(solids):
            flags["shadow_solids"] = shadowing
        shadowing = [n for n in media if receives(states, n)]
        if media and not shadowing:
            flags["media_shadow_surfaces"] = False
            if len(media) > 1:
                warnings.append(f"Light '{light_object.name}': shadow linking that leaves out the media: "
                                f"they still shadow one another from it (not the surfaces)")
        elif len(shadowing) < len(media):
            warnings.append(f"Light '{light_object.name}': shadow linking that leaves out some media and "
                            f"not others is not rendered (they all shadow it)")
    return replace(light, **flags) if flags else light
