"""Node materials read as the renderer's numbers, with Cycles' conventions.

Reading a material evaluates its node graph backwards from the active output. Each supported node
type has one small function in a table: value nodes (``_SCALAR_NODES``, ``_COLOR_NODES``) turn
their inputs into an expression, a constant or ``scale * grid + offset`` (``Expr``); shader nodes
(``_VOLUME_NODES``) turn theirs into volume coefficients and emission (``_Closure``). A node that
has no row ends the walk with one message naming it, and the caller falls back.

Volume shaders (per unit density, per metre), as Cycles' SVM defines them:
- Volume Scatter: sigma_s = density * color;
- Volume Absorption: sigma_a = density * (1 - color);
- Principled Volume: density = Density * Density Attribute grid, colour c = Color * Color
  Attribute grid, sigma_s = density * c, sigma_a = density * max(1 - c, 0) * max(1 - sqrt(absorption), 0);
  emission Emission Strength * Emission Color (not scaled by density) plus the blackbody term
  Blackbody Tint * sigma_SB * 1e-6 / pi * mix(1, T^4, Blackbody Intensity) * blackbody(T), with
  T = Temperature * Temperature Attribute grid (kelvin);
- Volume Coefficients: sigma_a, sigma_s and a constant emission as given;
- Emission into the Volume output: Color * Strength;
- Add Shader sums them, Mix Shader with a constant factor blends them; the anisotropy is the
  Henyey-Greenstein g (the scattering-weighted mean where several scatter).
Sockets may be driven by Value / RGB nodes, an Attribute node naming a grid, and Math nodes that
multiply, add, subtract, divide by or multiply-add constants (how artists scale a grid into
Emission Strength or Density). A grid a material names but the volume lacks is ignored, as in
Cycles. Grid values below zero read as zero.

Surfaces are read by ``blender/surfaces.py``; this module says which shaders an output has.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection
from dataclasses import dataclass, field, replace

RGB = tuple[float, float, float]



class Unreadable(Exception):
    """A node set-up the engine cannot turn into numbers; the message says which node."""


@dataclass(frozen=True)
class Expr:
    """A scalar over the volume: ``scale * max(grid, 0) + offset`` (``grid`` None: ``offset``)."""

    grid: str | None = None
    scale: float = 0.0
    offset: float = 0.0

    @property
    def is_constant(self) -> bool:
        return self.grid is None

    def affine(self, k: float, c: float = 0.0) -> Expr:
        """k * self + c."""
        return Expr(self.grid, k * self.scale if self.grid else 0.0, k * self.offset + c)


@dataclass(frozen=True)
class ColorValue:
    """A colour over the volume: ``rgb`` times the colour grid ``grid`` (None: constant)."""

    rgb: RGB
    grid: str | None = None


@dataclass(frozen=True)
class MediumSigma:
    """What a volume material gives the renderer.

    ``sigma_a``/``sigma_s``: 1/m per unit density, per channel; ``grid``: the grid the density is
    read from (None: constant density, which Cycles renders throughout the volume's active region);
    ``color_grid``: an RGB grid scaling sigma_s. Emission: ``emission_color`` times
    ``emission_strength`` (an Expr), the blackbody term from ``blackbody_intensity``,
    ``blackbody_tint`` and ``temperature`` (kelvin). ``source``: which node it came from, for the
    user; ``notes``: parts rendered approximately or not at all.
    """

    sigma_a: RGB
    sigma_s: RGB
    anisotropy: float
    grid: str | None
    source: str
    notes: tuple[str, ...] = ()
    color_grid: str | None = None
    emission_color: RGB = (0.0, 0.0, 0.0)
    emission_strength: Expr = Expr()
    blackbody_intensity: Expr = Expr()
    blackbody_tint: RGB = (1.0, 1.0, 1.0)
    temperature: Expr = Expr(offset=1000.0)

    @property
    def grids(self) -> tuple[str, ...]:
        """Every grid the material reads."""
        names = [self.grid, self.color_grid, self.emission_strength.grid, self.blackbody_intensity.grid,
                 self.temperature.grid]
        return tuple(dict.fromkeys(n for n in names if n))


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


def _unsupported(node, what: str = "") -> Unreadable:
    return Unreadable(f"node '{node.name}' ({node.bl_label}){what} is not read by the engine")


# ---- value nodes: scalars ---------------------------------------------------------------------

class _Context:
    """The grids the volume has (None: assume every named grid exists)."""

    def __init__(self, available: Collection[str] | None):
        self.available = None if available is None else set(available)

    def has(self, name: str) -> bool:
        return bool(name) and (self.available is None or name in self.available)


def scalar(socket, ctx: _Context) -> Expr:
    """A float socket as an Expr."""
    node, out = _linked(socket)
    if node is None:
        value = socket.default_value
        if hasattr(value, "__len__"):
            value = sum(value[:3]) / 3.0
        return Expr(offset=float(value))
    handler = _SCALAR_NODES.get(node.bl_idname)
    if handler is None:
        raise _unsupported(node, f", driving '{socket.name}',")
    return handler(node, out, ctx)


def _constant(socket, ctx: _Context | None = None) -> float:
    e = scalar(socket, ctx or _Context(None))
    if not e.is_constant:
        raise Unreadable(f"input '{socket.name}' varies over the volume (grid '{e.grid}'), "
                         f"which the engine reads as a constant only")
    return e.offset


def _value_node(node, out, ctx) -> Expr:
    return Expr(offset=float(node.outputs[0].default_value))


def _attribute_node(node, out, ctx) -> Expr:
    if node.attribute_type != 'GEOMETRY':
        raise _unsupported(node, f" of type {node.attribute_type}")
    if out is not None and out.name == "Alpha":
        return Expr(offset=1.0)
    if not ctx.has(node.attribute_name):
        return Expr(offset=0.0)   # Cycles reads a missing attribute as zero
    return Expr(node.attribute_name, 1.0, 0.0)


def _product(a: Expr, b: Expr, node) -> Expr:
    if a.is_constant:
        return b.affine(a.offset)
    if b.is_constant:
        return a.affine(b.offset)
    raise Unreadable(f"node '{node.name}' multiplies two grids ('{a.grid}', '{b.grid}')")


def _sum(a: Expr, b: Expr, node) -> Expr:
    if not a.is_constant and not b.is_constant:
        if a.grid != b.grid:
            raise Unreadable(f"node '{node.name}' adds two grids ('{a.grid}', '{b.grid}')")
        return Expr(a.grid, a.scale + b.scale, a.offset + b.offset)
    grid_side, const = (a, b) if b.is_constant else (b, a)
    return grid_side.affine(1.0, const.offset)


def _math_node(node, out, ctx) -> Expr:
    if node.use_clamp:
        raise _unsupported(node, " with Clamp")
    op = node.operation
    ins = list(node.inputs)
    a = scalar(ins[0], ctx)
    b = scalar(ins[1], ctx)
    if op == 'MULTIPLY':
        return _product(a, b, node)
    if op == 'ADD':
        return _sum(a, b, node)
    if op == 'SUBTRACT':
        return _sum(a, b.affine(-1.0), node)
    if op == 'DIVIDE' and b.is_constant and b.offset != 0.0:
        return a.affine(1.0 / b.offset)
    if op == 'MULTIPLY_ADD':
        return _sum(_product(a, b, node), scalar(ins[2], ctx), node)
    raise _unsupported(node, f" ({op.replace('_', ' ').lower()})")


_SCALAR_NODES: dict[str, Callable] = {
    'ShaderNodeValue': _value_node,
    'ShaderNodeAttribute': _attribute_node,
    'ShaderNodeMath': _math_node,
}


# ---- value nodes: colours ---------------------------------------------------------------------

def color(socket, ctx: _Context) -> ColorValue:
    """A colour socket as a ColorValue."""
    node, out = _linked(socket)
    if node is None:
        value = socket.default_value
        if not hasattr(value, "__len__"):
            return ColorValue((float(value),) * 3)
        return ColorValue(tuple(float(v) for v in value[:3]))
    handler = _COLOR_NODES.get(node.bl_idname)
    if handler is None:
        raise _unsupported(node, f", driving '{socket.name}',")
    return handler(node, out, ctx)


def _rgb_node(node, out, ctx) -> ColorValue:
    return ColorValue(tuple(float(v) for v in node.outputs[0].default_value[:3]))


def _value_as_color(node, out, ctx) -> ColorValue:
    return ColorValue((float(node.outputs[0].default_value),) * 3)


def _attribute_color(node, out, ctx) -> ColorValue:
    if node.attribute_type != 'GEOMETRY':
        raise _unsupported(node, f" of type {node.attribute_type}")
    if not ctx.has(node.attribute_name):
        return ColorValue((0.0, 0.0, 0.0))
    if out is not None and out.name == "Fac":
        raise Unreadable(f"the Fac of node '{node.name}' drives a colour; use its Color output")
    return ColorValue((1.0, 1.0, 1.0), node.attribute_name)


_COLOR_NODES: dict[str, Callable] = {
    'ShaderNodeRGB': _rgb_node,
    'ShaderNodeValue': _value_as_color,
    'ShaderNodeAttribute': _attribute_color,
}


def _rgb(socket, ctx: _Context | None = None) -> RGB:
    c = color(socket, ctx or _Context(None))
    if c.grid is not None:
        raise Unreadable(f"input '{socket.name}' reads grid '{c.grid}', which the engine reads "
                         f"as a constant only")
    return c.rgb


# ---- shader nodes -----------------------------------------------------------------------------

@dataclass
class _Closure:
    """Volume coefficients (per unit density) and emission of part of a shader graph."""

    sigma_a: tuple = (0.0, 0.0, 0.0)
    sigma_s: tuple = (0.0, 0.0, 0.0)
    g_weighted: float = 0.0  # sum of g * mean(sigma_s)
    grid: str | None = None
    uses_constant: bool = True
    color_grid: str | None = None
    emission: tuple[RGB, Expr] | None = None
    blackbody: tuple[RGB, Expr, Expr] | None = None   # tint, intensity, temperature
    notes: list = field(default_factory=list)

    def scaled(self, f: float) -> _Closure:
        emission = None if self.emission is None else (tuple(f * c for c in self.emission[0]),
                                                       self.emission[1])
        blackbody = None if self.blackbody is None else (tuple(f * c for c in self.blackbody[0]),
                                                         *self.blackbody[1:])
        return replace(self, sigma_a=tuple(f * v for v in self.sigma_a),
                       sigma_s=tuple(f * v for v in self.sigma_s), g_weighted=f * self.g_weighted,
                       emission=emission, blackbody=blackbody, notes=list(self.notes))


def _density(socket, ctx: _Context, attribute: str = "") -> tuple[float, str | None]:
    """A Density input (times an optional attribute grid) as (factor, grid name or None)."""
    d = scalar(socket, ctx)
    named = attribute if ctx.has(attribute) else None
    if d.is_constant:
        return d.offset, named
    if named:
        raise Unreadable(f"the density multiplies two grids ('{d.grid}', '{named}')")
    if d.offset != 0.0:
        raise Unreadable(f"the density is grid '{d.grid}' plus a constant, which the engine cannot "
                         f"render")
    return d.scale, d.grid


def _hg_only(node) -> None:
    if getattr(node, "phase", 'HENYEY_GREENSTEIN') != 'HENYEY_GREENSTEIN':
        raise Unreadable(f"'{node.name}' uses the {node.phase} phase function, "
                         f"only Henyey-Greenstein is rendered")


def _principled(node, ctx: _Context) -> _Closure:
    ins = node.inputs
    c = color(ins["Color"], ctx)
    attribute_color = ins["Color Attribute"].default_value
    color_grid = c.grid
    if ctx.has(attribute_color):
        if color_grid:
            raise Unreadable(f"'{node.name}' multiplies two colour grids")
        color_grid = attribute_color
    absorption = _rgb(ins["Absorption Color"], ctx)
    d, grid = _density(ins["Density"], ctx, ins["Density Attribute"].default_value)
    s = tuple(d * v for v in c.rgb)
    k = tuple(max(1.0 - math.sqrt(max(a, 0.0)), 0.0) for a in absorption)
    a = tuple(d * max(1.0 - v, 0.0) * kk for v, kk in zip(c.rgb, k, strict=True))
    notes = []
    if color_grid and (any(kk < 1.0 for kk in k) or any(v > 1.0 for v in c.rgb)):
        notes.append(f"'{node.name}': with a colour grid, the extinction is read without it "
                     f"(exact for a black Absorption Color and colours up to 1)")
    g = _constant(ins["Anisotropy"], ctx)
    out = _Closure(a, s, g * sum(s) / 3.0, grid, grid is None, color_grid, notes=notes)
    strength = scalar(ins["Emission Strength"], ctx)
    if strength.grid or strength.offset > 0.0:
        out.emission = (_rgb(ins["Emission Color"], ctx), strength)
    intensity = scalar(ins["Blackbody Intensity"], ctx)
    if intensity.grid or intensity.offset > 0.0:
        temperature = scalar(ins["Temperature"], ctx)
        t_attribute = ins["Temperature Attribute"].default_value
        if ctx.has(t_attribute):
            if not temperature.is_constant:
                raise Unreadable(f"'{node.name}': the temperature multiplies two grids "
                                 f"('{temperature.grid}', '{t_attribute}')")
            temperature = Expr(t_attribute, temperature.offset, 0.0)
        out.blackbody = (_rgb(ins["Blackbody Tint"], ctx), intensity, temperature)
    return out


def _scatter(node, ctx: _Context) -> _Closure:
    _hg_only(node)
    c = _rgb(node.inputs["Color"], ctx)
    d, grid = _density(node.inputs["Density"], ctx)
    s = tuple(d * v for v in c)
    g = _constant(node.inputs["Anisotropy"], ctx)
    return _Closure((0.0, 0.0, 0.0), s, g * sum(s) / 3.0, grid, grid is None)


def _absorption(node, ctx: _Context) -> _Closure:
    c = _rgb(node.inputs["Color"], ctx)
    d, grid = _density(node.inputs["Density"], ctx)
    return _Closure(tuple(d * max(1.0 - v, 0.0) for v in c), (0.0, 0.0, 0.0), 0.0, grid, grid is None)


def _coefficients(node, ctx: _Context) -> _Closure:
    _hg_only(node)
    a = _rgb(node.inputs["Absorption Coefficients"], ctx)
    s = _rgb(node.inputs["Scatter Coefficients"], ctx)
    g = _constant(node.inputs["Anisotropy"], ctx)
    out = _Closure(a, s, g * sum(s) / 3.0)
    e = _rgb(node.inputs["Emission Coefficients"], ctx)
    if any(v > 0.0 for v in e):
        out.emission = (e, Expr(offset=1.0))
    return out


def _emission(node, ctx: _Context) -> _Closure:
    strength = scalar(node.inputs["Strength"], ctx)
    return _Closure(emission=(_rgb(node.inputs["Color"], ctx), strength))


def _merge_emission(a, b, what: str):
    if a is None or b is None:
        return a or b
    if a[1:] != b[1:]:
        raise Unreadable(f"two {what} terms with different strengths or temperatures")
    return (tuple(x + y for x, y in zip(a[0], b[0], strict=True)), *a[1:])


def _combine(a: _Closure | None, b: _Closure | None) -> _Closure | None:
    if a is None or b is None:
        return a or b
    a_scatters = any(a.sigma_a) or any(a.sigma_s)
    b_scatters = any(b.sigma_a) or any(b.sigma_s)
    if a_scatters and b_scatters and a.grid != b.grid and not (a.uses_constant and b.uses_constant):
        raise Unreadable("the shaders read different density grids")
    if a.color_grid and b.color_grid and a.color_grid != b.color_grid:
        raise Unreadable("the shaders read different colour grids")
    return _Closure(
        tuple(x + y for x, y in zip(a.sigma_a, b.sigma_a, strict=True)),
        tuple(x + y for x, y in zip(a.sigma_s, b.sigma_s, strict=True)),
        a.g_weighted + b.g_weighted, a.grid or b.grid, a.uses_constant and b.uses_constant,
        a.color_grid or b.color_grid, _merge_emission(a.emission, b.emission, "emission"),
        _merge_emission(a.blackbody, b.blackbody, "blackbody"), a.notes + b.notes,
    )


def _add(node, ctx: _Context) -> _Closure | None:
    return _combine(volume_closure(node.inputs[0], ctx), volume_closure(node.inputs[1], ctx))


def _mix(node, ctx: _Context) -> _Closure | None:
    f = min(max(_constant(node.inputs[0], ctx), 0.0), 1.0)
    a = volume_closure(node.inputs[1], ctx)
    b = volume_closure(node.inputs[2], ctx)
    return _combine(a.scaled(1.0 - f) if a else None, b.scaled(f) if b else None)


_VOLUME_NODES: dict[str, Callable] = {
    'ShaderNodeVolumePrincipled': _principled,
    'ShaderNodeVolumeScatter': _scatter,
    'ShaderNodeVolumeAbsorption': _absorption,
    'ShaderNodeVolumeCoefficients': _coefficients,
    'ShaderNodeEmission': _emission,
    'ShaderNodeAddShader': _add,
    'ShaderNodeMixShader': _mix,
}


def volume_closure(socket, ctx: _Context) -> _Closure | None:
    """The volume shader graph feeding ``socket``, or None when nothing is linked."""
    node = _linked_node(socket)
    if node is None:
        return None
    handler = _VOLUME_NODES.get(node.bl_idname)
    if handler is None:
        raise Unreadable(f"node '{node.name}' ({node.bl_label}) is not a volume shader the engine reads")
    return handler(node, ctx)


def read_volume_material(material, available: Collection[str] | None = None
                         ) -> tuple[MediumSigma | None, str]:
    """What a material's volume shader gives, or (None, why it cannot be read). ``available``:
    the names of the volume's grids (None: take every grid the material names as present)."""
    if material is None:
        return None, "No material: using the settings below"
    out = output_node(material)
    if out is None:
        return None, f"Material '{material.name}' has no node output: using the settings below"
    ctx = _Context(available)
    try:
        node = _linked_node(out.inputs["Volume"])
        c = volume_closure(out.inputs["Volume"], ctx)
    except Unreadable as ex:
        return None, f"Material '{material.name}': {ex}; using the TFM settings instead"
    if c is None:
        return None, f"Material '{material.name}' has no volume shader: using the settings below"
    mean_s = sum(c.sigma_s) / 3.0
    g = c.g_weighted / mean_s if mean_s > 0.0 else 0.0
    fields: dict = {}
    if c.emission is not None:
        fields.update(emission_color=tuple(c.emission[0]), emission_strength=c.emission[1])
    if c.blackbody is not None:
        fields.update(blackbody_tint=tuple(c.blackbody[0]), blackbody_intensity=c.blackbody[1],
                      temperature=c.blackbody[2])
    return MediumSigma(
        sigma_a=tuple(c.sigma_a), sigma_s=tuple(c.sigma_s), anisotropy=max(-0.99, min(0.99, g)),
        grid=c.grid, source=f"{node.bl_label} '{node.name}' of '{material.name}'",
        notes=tuple(c.notes), color_grid=c.color_grid, **fields,
    ), ""


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
