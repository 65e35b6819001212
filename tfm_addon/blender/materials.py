"""Node materials read as the renderer's numbers, with Cycles' conventions.

Volume shaders (per unit density, per metre):
- Volume Scatter: sigma_s = density * color;
- Volume Absorption: sigma_a = density * (1 - color);
- Principled Volume: sigma_s = density * color,
  sigma_a = density * max(1 - color, 0) * max(1 - sqrt(absorption_color), 0);
- Volume Coefficients: sigma_a and sigma_s as given;
- Add Shader sums them, Mix Shader with a constant factor blends them; the anisotropy is the
  Henyey-Greenstein g (the scattering-weighted mean where several scatter).
Density is a constant, or an Attribute node naming a grid (times a constant through a Math
Multiply node); Principled Volume multiplies by its Density Attribute grid.
Surfaces: the base colour of a Principled BSDF or the colour of a Diffuse BSDF.
Anything else (textures, ramps, other nodes) is not read: the caller falls back to the add-on's
own settings and tells the user why.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

RGB = tuple[float, float, float]


class Unreadable(Exception):
    """A node set-up the engine cannot turn into numbers; the message says which node."""


@dataclass(frozen=True)
class MediumSigma:
    """Coefficients per unit density, 1/m per channel.

    ``grid``: the grid the material reads density from (None: constant density, which Cycles
    renders throughout the volume's active region). ``notes``: parts that are not rendered.
    ``source``: which node it came from, for the user.
    """

    sigma_a: RGB
    sigma_s: RGB
    anisotropy: float
    grid: str | None
    source: str
    notes: tuple[str, ...] = ()


def output_node(material):
    """The material's active output node for Cycles (what Cycles would render), or None."""
    if material is None or material.node_tree is None:
        return None
    return material.node_tree.get_output_node('CYCLES')


def _linked_node(socket):
    """The node feeding ``socket`` (through reroutes), or None if unlinked."""
    while socket.is_linked:
        link = socket.links[0]
        if link.is_muted:
            return None
        node = link.from_node
        if node.bl_idname == 'NodeReroute':
            socket = node.inputs[0]
            continue
        if node.mute:
            raise Unreadable(f"node '{node.name}' is muted")
        return node
    return None


def _constant(socket) -> float | tuple:
    node = _linked_node(socket)
    if node is None:
        value = socket.default_value
        return tuple(value) if hasattr(value, "__len__") else float(value)
    if node.bl_idname in ('ShaderNodeValue', 'ShaderNodeRGB'):
        value = node.outputs[0].default_value
        return tuple(value) if hasattr(value, "__len__") else float(value)
    raise Unreadable(f"input '{socket.name}' is driven by node '{node.name}'")


def _rgb(socket) -> RGB:
    value = _constant(socket)
    if isinstance(value, float):
        return (value, value, value)
    return tuple(float(v) for v in value[:3])


def _density(socket) -> tuple[float, str | None]:
    """A Density input as (factor, grid name or None)."""
    node = _linked_node(socket)
    if node is None:
        return float(socket.default_value), None
    if node.bl_idname == 'ShaderNodeAttribute' and node.attribute_type == 'GEOMETRY':
        return 1.0, node.attribute_name
    if node.bl_idname == 'ShaderNodeMath' and node.operation == 'MULTIPLY' and not node.use_clamp:
        factor, grid = 1.0, None
        for inp in list(node.inputs)[:2]:
            sub = _linked_node(inp)
            if sub is not None and sub.bl_idname == 'ShaderNodeAttribute' and grid is None:
                grid = sub.attribute_name
            else:
                factor *= float(_constant(inp))
        return factor, grid
    if node.bl_idname == 'ShaderNodeValue':
        return float(node.outputs[0].default_value), None
    raise Unreadable(f"the density comes from node '{node.name}'")


@dataclass
class _Coefficients:
    sigma_a: tuple
    sigma_s: tuple
    g_weighted: float  # sum of g * mean(sigma_s)
    grid: str | None
    uses_constant: bool
    notes: list

    def scaled(self, f):
        return _Coefficients(tuple(f * v for v in self.sigma_a), tuple(f * v for v in self.sigma_s),
                             f * self.g_weighted, self.grid, self.uses_constant, self.notes)


def _combine(a: _Coefficients | None, b: _Coefficients | None) -> _Coefficients | None:
    if a is None or b is None:
        return a or b
    if a.grid != b.grid and not (a.uses_constant and b.uses_constant):
        raise Unreadable("the shaders read different density grids")
    return _Coefficients(
        tuple(x + y for x, y in zip(a.sigma_a, b.sigma_a, strict=True)),
        tuple(x + y for x, y in zip(a.sigma_s, b.sigma_s, strict=True)),
        a.g_weighted + b.g_weighted, a.grid or b.grid,
        a.uses_constant and b.uses_constant, a.notes + b.notes,
    )


def _volume_shader(node) -> _Coefficients | None:
    if node is None:
        return None
    kind = node.bl_idname
    if kind == 'ShaderNodeVolumePrincipled':
        color = _rgb(node.inputs["Color"])
        absorption = _rgb(node.inputs["Absorption Color"])
        d, linked_grid = _density(node.inputs["Density"])
        attribute = node.inputs["Density Attribute"].default_value
        if linked_grid and attribute:
            raise Unreadable(f"'{node.name}' multiplies two density grids")
        grid = linked_grid or attribute or None
        s = tuple(d * c for c in color)
        a = tuple(d * max(1.0 - c, 0.0) * max(1.0 - math.sqrt(max(k, 0.0)), 0.0)
                  for c, k in zip(color, absorption, strict=True))
        g = float(_constant(node.inputs["Anisotropy"]))
        notes = []
        if float(_constant(node.inputs["Emission Strength"])) > 0.0:
            notes.append("emission")
        if float(_constant(node.inputs["Blackbody Intensity"])) > 0.0:
            notes.append("blackbody emission")
        return _Coefficients(a, s, g * sum(s) / 3.0, grid, grid is None, notes)
    if kind == 'ShaderNodeVolumeScatter':
        if getattr(node, "phase", 'HENYEY_GREENSTEIN') != 'HENYEY_GREENSTEIN':
            raise Unreadable(f"'{node.name}' uses the {node.phase} phase function, "
                             f"only Henyey-Greenstein is rendered")
        color = _rgb(node.inputs["Color"])
        d, grid = _density(node.inputs["Density"])
        s = tuple(d * c for c in color)
        g = float(_constant(node.inputs["Anisotropy"]))
        return _Coefficients((0.0, 0.0, 0.0), s, g * sum(s) / 3.0, grid, grid is None, [])
    if kind == 'ShaderNodeVolumeAbsorption':
        color = _rgb(node.inputs["Color"])
        d, grid = _density(node.inputs["Density"])
        a = tuple(d * max(1.0 - c, 0.0) for c in color)
        return _Coefficients(a, (0.0, 0.0, 0.0), 0.0, grid, grid is None, [])
    if kind == 'ShaderNodeVolumeCoefficients':
        if getattr(node, "phase", 'HENYEY_GREENSTEIN') != 'HENYEY_GREENSTEIN':
            raise Unreadable(f"'{node.name}' uses the {node.phase} phase function, "
                             f"only Henyey-Greenstein is rendered")
        a = _rgb(node.inputs["Absorption Coefficients"])
        s = _rgb(node.inputs["Scatter Coefficients"])
        g = float(_constant(node.inputs["Anisotropy"]))
        notes = ["emission"] if any(_rgb(node.inputs["Emission Coefficients"])) else []
        return _Coefficients(a, s, g * sum(s) / 3.0, None, True, notes)
    if kind == 'ShaderNodeAddShader':
        return _combine(_volume_shader(_linked_node(node.inputs[0])),
                        _volume_shader(_linked_node(node.inputs[1])))
    if kind == 'ShaderNodeMixShader':
        f = float(_constant(node.inputs[0]))
        a = _volume_shader(_linked_node(node.inputs[1]))
        b = _volume_shader(_linked_node(node.inputs[2]))
        return _combine(a.scaled(1.0 - f) if a else None, b.scaled(f) if b else None)
    raise Unreadable(f"node '{node.name}' ({node.bl_label}) is not a volume shader the engine reads")


def read_volume_material(material) -> tuple[MediumSigma | None, str]:
    """Sigma of a material's volume shader, or (None, why it cannot be read)."""
    if material is None:
        return None, "No material: using the settings below"
    out = output_node(material)
    if out is None:
        return None, f"Material '{material.name}' has no node output: using the settings below"
    try:
        node = _linked_node(out.inputs["Volume"])
        if node is None:
            return None, f"Material '{material.name}' has no volume shader: using the settings below"
        c = _volume_shader(node)
    except Unreadable as ex:
        return None, f"Material '{material.name}': {ex}; using the TFM settings instead"
    if c is None:
        return None, f"Material '{material.name}' has no volume shader: using the settings below"
    mean_s = sum(c.sigma_s) / 3.0
    g = c.g_weighted / mean_s if mean_s > 0.0 else 0.0
    return MediumSigma(
        sigma_a=tuple(c.sigma_a), sigma_s=tuple(c.sigma_s), anisotropy=max(-0.99, min(0.99, g)),
        grid=c.grid, source=f"{node.bl_label} '{node.name}' of '{material.name}'",
        notes=tuple(c.notes),
    ), ""


def has_volume_only(material) -> bool:
    """Whether the material has a volume shader and no surface shader (a mesh that is a medium)."""
    out = output_node(material)
    if out is None:
        return False
    return out.inputs["Volume"].is_linked and not out.inputs["Surface"].is_linked


def surface_color(material) -> RGB | None:
    """Diffuse colour of a material's surface shader, or None when it cannot be read."""
    out = output_node(material)
    if out is None:
        return None
    try:
        node = _linked_node(out.inputs["Surface"])
        if node is None:
            return None
        if node.bl_idname == 'ShaderNodeBsdfPrincipled':
            return _rgb(node.inputs["Base Color"])
        if node.bl_idname == 'ShaderNodeBsdfDiffuse':
            return _rgb(node.inputs["Color"])
    except Unreadable:
        return None
    return None


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
        return _camera_ray_value(node.inputs["Alpha"]) <= 0.0
    except (Unreadable, KeyError):
        return False


_MATH = {'ADD': lambda a, b: a + b, 'SUBTRACT': lambda a, b: a - b, 'MULTIPLY': lambda a, b: a * b,
         'MINIMUM': min, 'MAXIMUM': max}


def _camera_ray_value(socket) -> float:
    """A float input's value on a camera ray, through Light Path and Math nodes."""
    if not socket.is_linked:
        return float(socket.default_value)
    link = socket.links[0]
    node = _linked_node(socket)
    if node is None:
        return float(socket.default_value)
    if node.bl_idname == 'ShaderNodeLightPath':
        return 1.0 if link.from_socket.name == "Is Camera Ray" else 0.0
    if node.bl_idname == 'ShaderNodeMath' and node.operation in _MATH:
        value = _MATH[node.operation](_camera_ray_value(node.inputs[0]), _camera_ray_value(node.inputs[1]))
        return min(max(value, 0.0), 1.0) if node.use_clamp else value
    raise Unreadable(f"input '{socket.name}' is driven by node '{node.name}'")
