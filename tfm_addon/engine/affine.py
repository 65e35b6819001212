"""The affine fast path: a volume's node graph folded into constants and one density grid.

Every volume material is read once, by ``blender/node_graph.py``, into a ``shading.ShaderGraph``.
Most materials artists make are, per channel, a constant times one density grid (and an emission
that is a grid scaled and offset): ``fold`` recognises them, as Cycles' ShaderGraph folds constant
nodes, and gives the renderer those numbers (``AffineMedium``), so that the medium is uploaded
as its grid (sparse where it is big) and its colours are uniforms. A graph that does not fold
(``NotAffine``: a texture, a colour ramp, two grids multiplied...) is evaluated per voxel
(``shading.resolve``) instead; both read the same graph, so both render the same material.

The shaders fold as Cycles' SVM defines them (per unit density, per metre):
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
Sockets fold from Value / RGB nodes, an Attribute node naming a grid, and Math nodes that
multiply, add, subtract, divide by or multiply-add constants. A grid the graph names but the
volume lacks reads zero, as in Cycles. Grid values below zero read as zero.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass, field, replace

from .shading import Input, Link, Node, ShaderGraph

RGB = tuple[float, float, float]


class NotAffine(Exception):
    """The graph is not constants times one grid; the message says which node."""


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
class AffineMedium:
    """What a folded volume graph gives the renderer.

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


@dataclass
class _Closure:
    """Volume coefficients (per unit density) and emission of part of a graph."""

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


class _Folder:
    def __init__(self, graph: ShaderGraph, available: Collection[str] | None):
        self.graph = graph
        self.available = None if available is None else set(available)

    def has(self, name: str) -> bool:
        return bool(name) and (self.available is None or name in self.available)

    def source(self, i: Input) -> tuple[Node, str] | tuple[None, None]:
        if isinstance(i.value, Link):
            return self.graph.nodes[i.value.node], i.value.output
        return None, None

    @staticmethod
    def _named(node: Node, what: str = "") -> NotAffine:
        return NotAffine(f"node '{node.label}' ({node.kind.replace('_', ' ').lower()}){what} does not fold "
                         f"into constants and one grid")

    # ---- values

    def scalar(self, i: Input) -> Expr:
        node, out = self.source(i)
        if node is None:
            v = i.value
            return Expr(offset=float(sum(v[:3]) / 3.0 if isinstance(v, tuple) else v))
        if node.kind == "VALUE":
            return Expr(offset=float(node.param("value")))
        if node.kind == "ATTRIBUTE":
            if out == "Alpha":
                return Expr(offset=1.0)
            name = node.param("name")
            return Expr(name, 1.0, 0.0) if self.has(name) else Expr(offset=0.0)   # missing: 0, as Cycles
        if node.kind == "MATH":
            return self._math(node)
        raise self._named(node, f", driving '{i.name}',")

    def _math(self, node: Node) -> Expr:
        if node.param("use_clamp"):
            raise self._named(node, " with Clamp")
        op = node.param("operation")
        ins = {i.name: i for i in node.inputs}
        a, b = self.scalar(ins["A"]), self.scalar(ins["B"])
        if op == 'MULTIPLY':
            return self._product(a, b, node)
        if op == 'ADD':
            return self._sum(a, b, node)
        if op == 'SUBTRACT':
            return self._sum(a, b.affine(-1.0), node)
        if op == 'DIVIDE' and b.is_constant and b.offset != 0.0:
            return a.affine(1.0 / b.offset)
        if op == 'MULTIPLY_ADD':
            return self._sum(self._product(a, b, node), self.scalar(ins["C"]), node)
        raise self._named(node, f" ({op.replace('_', ' ').lower()})")

    def _product(self, a: Expr, b: Expr, node: Node) -> Expr:
        if a.is_constant:
            return b.affine(a.offset)
        if b.is_constant:
            return a.affine(b.offset)
        raise NotAffine(f"node '{node.label}' multiplies two grids ('{a.grid}', '{b.grid}')")

    def _sum(self, a: Expr, b: Expr, node: Node) -> Expr:
        if not a.is_constant and not b.is_constant:
            if a.grid != b.grid:
                raise NotAffine(f"node '{node.label}' adds two grids ('{a.grid}', '{b.grid}')")
            return Expr(a.grid, a.scale + b.scale, a.offset + b.offset)
        grid_side, const = (a, b) if b.is_constant else (b, a)
        return grid_side.affine(1.0, const.offset)

    def constant(self, i: Input) -> float:
        e = self.scalar(i)
        if not e.is_constant:
            raise NotAffine(f"input '{i.name}' varies over the volume (grid '{e.grid}')")
        return e.offset

    def color(self, i: Input) -> ColorValue:
        node, out = self.source(i)
        if node is None:
            v = i.value
            return ColorValue(tuple(float(x) for x in v[:3]) if isinstance(v, tuple) else (float(v),) * 3)
        if node.kind == "RGB":
            return ColorValue(tuple(float(v) for v in node.param("color")[:3]))
        if node.kind == "VALUE":
            return ColorValue((float(node.param("value")),) * 3)
        if node.kind == "ATTRIBUTE":
            name = node.param("name")
            if not self.has(name):
                return ColorValue((0.0, 0.0, 0.0))
            if out == "Fac":
                raise NotAffine(f"the Fac of node '{node.label}' drives a colour")
            return ColorValue((1.0, 1.0, 1.0), name)
        raise self._named(node, f", driving '{i.name}',")

    def rgb(self, i: Input) -> RGB:
        c = self.color(i)
        if c.grid is not None:
            raise NotAffine(f"input '{i.name}' reads grid '{c.grid}' as a colour")
        return c.rgb

    # ---- shaders

    def closure(self, i: Input) -> _Closure | None:
        node, _ = self.source(i)
        if node is None:
            return None
        fold = _SHADERS.get(node.kind)
        if fold is None:
            raise self._named(node)
        return fold(self, node, {x.name: x for x in node.inputs})

    def density(self, i: Input, attribute: str = "") -> tuple[float, str | None]:
        """A Density input (times an optional attribute grid) as (factor, grid name or None)."""
        d = self.scalar(i)
        named = attribute if self.has(attribute) else None
        if d.is_constant:
            return d.offset, named
        if named:
            raise NotAffine(f"the density multiplies two grids ('{d.grid}', '{named}')")
        if d.offset != 0.0:
            raise NotAffine(f"the density is grid '{d.grid}' plus a constant")
        return d.scale, d.grid


def _principled(f: _Folder, node: Node, ins: dict) -> _Closure:
    c = f.color(ins["Color"])
    color_grid = c.grid
    attribute_color = node.param("color_attribute", "")
    if f.has(attribute_color):
        if color_grid:
            raise NotAffine(f"'{node.label}' multiplies two colour grids")
        color_grid = attribute_color
    absorption = f.rgb(ins["Absorption Color"])
    d, grid = f.density(ins["Density"], node.param("density_attribute", ""))
    s = tuple(d * v for v in c.rgb)
    k = tuple(max(1.0 - math.sqrt(max(a, 0.0)), 0.0) for a in absorption)
    a = tuple(d * max(1.0 - v, 0.0) * kk for v, kk in zip(c.rgb, k, strict=True))
    notes = []
    if color_grid and (any(kk < 1.0 for kk in k) or any(v > 1.0 for v in c.rgb)):
        notes.append(f"'{node.label}': with a colour grid, the extinction is read without it "
                     f"(exact for a black Absorption Color and colours up to 1)")
    g = f.constant(ins["Anisotropy"]) if "Anisotropy" in ins else 0.0   # a phase without one: 0
    out = _Closure(a, s, g * sum(s) / 3.0, grid, grid is None, color_grid, notes=notes)
    strength = f.scalar(ins["Emission Strength"])
    if strength.grid or strength.offset > 0.0:
        out.emission = (f.rgb(ins["Emission Color"]), strength)
    intensity = f.scalar(ins["Blackbody Intensity"])
    if intensity.grid or intensity.offset > 0.0:
        temperature = f.scalar(ins["Temperature"])
        t_attribute = node.param("temperature_attribute", "")
        if f.has(t_attribute):
            if not temperature.is_constant:
                raise NotAffine(f"'{node.label}': the temperature multiplies two grids "
                                f"('{temperature.grid}', '{t_attribute}')")
            temperature = Expr(t_attribute, temperature.offset, 0.0)
        out.blackbody = (f.rgb(ins["Blackbody Tint"]), intensity, temperature)
    return out


def _scatter(f: _Folder, node: Node, ins: dict) -> _Closure:
    c = f.rgb(ins["Color"])
    d, grid = f.density(ins["Density"])
    s = tuple(d * v for v in c)
    g = f.constant(ins["Anisotropy"]) if "Anisotropy" in ins else 0.0   # a phase without one: 0
    return _Closure((0.0, 0.0, 0.0), s, g * sum(s) / 3.0, grid, grid is None)


def _absorption(f: _Folder, node: Node, ins: dict) -> _Closure:
    c = f.rgb(ins["Color"])
    d, grid = f.density(ins["Density"])
    return _Closure(tuple(d * max(1.0 - v, 0.0) for v in c), (0.0, 0.0, 0.0), 0.0, grid, grid is None)


def _coefficients(f: _Folder, node: Node, ins: dict) -> _Closure:
    a = f.rgb(ins["Absorption Coefficients"])
    s = f.rgb(ins["Scatter Coefficients"])
    g = f.constant(ins["Anisotropy"]) if "Anisotropy" in ins else 0.0   # a phase without one: 0
    out = _Closure(a, s, g * sum(s) / 3.0)
    e = f.rgb(ins["Emission Coefficients"])
    if any(v > 0.0 for v in e):
        out.emission = (e, Expr(offset=1.0))
    return out


def _emission(f: _Folder, node: Node, ins: dict) -> _Closure:
    return _Closure(emission=(f.rgb(ins["Color"]), f.scalar(ins["Strength"])))


def _merge_emission(a, b, what: str):
    if a is None or b is None:
        return a or b
    if a[1:] != b[1:]:
        raise NotAffine(f"two {what} terms with different strengths or temperatures")
    return (tuple(x + y for x, y in zip(a[0], b[0], strict=True)), *a[1:])


def _combine(a: _Closure | None, b: _Closure | None) -> _Closure | None:
    if a is None or b is None:
        return a or b
    a_scatters = any(a.sigma_a) or any(a.sigma_s)
    b_scatters = any(b.sigma_a) or any(b.sigma_s)
    if a_scatters and b_scatters and a.grid != b.grid and not (a.uses_constant and b.uses_constant):
        raise NotAffine("the shaders read different density grids")
    if a.color_grid and b.color_grid and a.color_grid != b.color_grid:
        raise NotAffine("the shaders read different colour grids")
    return _Closure(
        tuple(x + y for x, y in zip(a.sigma_a, b.sigma_a, strict=True)),
        tuple(x + y for x, y in zip(a.sigma_s, b.sigma_s, strict=True)),
        a.g_weighted + b.g_weighted, a.grid or b.grid, a.uses_constant and b.uses_constant,
        a.color_grid or b.color_grid, _merge_emission(a.emission, b.emission, "emission"),
        _merge_emission(a.blackbody, b.blackbody, "blackbody"), a.notes + b.notes,
    )


def _add(f: _Folder, node: Node, ins: dict) -> _Closure | None:
    return _combine(f.closure(ins["Shader"]), f.closure(ins["Shader_001"]))


def _mix(f: _Folder, node: Node, ins: dict) -> _Closure | None:
    t = min(max(f.constant(ins["Fac"]), 0.0), 1.0)
    a, b = f.closure(ins["Shader"]), f.closure(ins["Shader_001"])
    return _combine(a.scaled(1.0 - t) if a else None, b.scaled(t) if b else None)


_SHADERS = {"PRINCIPLED_VOLUME": _principled, "VOLUME_SCATTER": _scatter, "VOLUME_ABSORPTION": _absorption,
            "VOLUME_COEFFICIENTS": _coefficients, "EMISSION": _emission, "ADD_SHADER": _add,
            "MIX_SHADER": _mix}


def fold(graph: ShaderGraph, available: Collection[str] | None = None, owner: str = "") -> AffineMedium:
    """``graph`` (a volume's, its output the shader) folded into an AffineMedium, or NotAffine
    saying why not. ``available``: the volume's grid names (None: every grid the graph names is
    taken as present); ``owner``: the material's name, for ``source``."""
    if graph.output is None:
        raise NotAffine("no volume shader")
    f = _Folder(graph, available)
    c = f.closure(Input("Volume", "SHADER", graph.output))
    if c is None:
        raise NotAffine("no volume shader")
    mean_s = sum(c.sigma_s) / 3.0
    g = c.g_weighted / mean_s if mean_s > 0.0 else 0.0
    fields: dict = {}
    if c.emission is not None:
        fields.update(emission_color=tuple(c.emission[0]), emission_strength=c.emission[1])
    if c.blackbody is not None:
        fields.update(blackbody_tint=tuple(c.blackbody[0]), blackbody_intensity=c.blackbody[1],
                      temperature=c.blackbody[2])
    top = graph.nodes[graph.output.node]
    label = top.kind.replace("_", " ").title()
    return AffineMedium(
        sigma_a=tuple(c.sigma_a), sigma_s=tuple(c.sigma_s), anisotropy=max(-0.99, min(0.99, g)),
        grid=c.grid, source=f"{label} '{top.label}'" + (f" of '{owner}'" if owner else ""),
        notes=tuple(graph.notes) + tuple(c.notes), color_grid=c.color_grid, **fields,
    )
