"""Volume shader graphs evaluated per voxel, as Cycles' SVM defines each node.

A material's node graph reaches the engine as a ``ShaderGraph``: plain data (node kinds, constant
parameters, input sockets that hold a constant or a ``Link`` to another node's output), compiled
from Blender's nodes by ``blender/node_graph.py``. ``evaluate`` runs it on numpy arrays over every
voxel of a medium's lattice at once and returns the volume coefficients and emission per voxel
(``VolumeFields``); ``medium_fields`` turns those into the renderer's ``Medium`` (a density, a
colour grid when the albedo varies, an emission grid when the emission does).

Cycles 5.0.1 evaluates the graph on the grids' trilinearly interpolated values at each sample
(measured: a 3D checker of 0/1 voxels whose Emission Strength is density squared renders 0.483 of
the per-voxel evaluation; trilinear interpolation then squaring predicts 0.485). Evaluating per
voxel and letting the texture filter blend the results is exact where the graph is affine in the
grids and an approximation where it is not (Color Ramp, Map Range, powers): its error shrinks
with the lattice spacing, so ``resolve`` can evaluate on a finer lattice (``supersample``).

Values flow as numpy arrays that broadcast: a float is shaped ``(n,)`` or ``()``, a colour or vector
``(n, 3)`` or ``(3,)``. Implicit conversions follow Cycles: colour to float is the Rec.709
luminance, vector to float the mean of its components, float to colour or vector a grey triple.

Each node kind is one function in ``NODES``; ``KINDS`` names them for the documentation table
(docs/blender.md). A kind the compiler does not know never reaches this module: the compiler
names it in ``ShaderGraph.notes`` and feeds its consumer the socket's own default value.
"""

from __future__ import annotations

import math
import threading
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from . import blackbody, caches
from .scene import GlowBlocks, Medium, Scene, _digest

LUMINANCE = np.array([0.2126729, 0.7151522, 0.0721750])   # Cycles' Rec.709 colour -> float
CUTOFF = 1e-5          # Cycles' CLOSURE_WEIGHT_CUTOFF
F = np.float32         # the values' type: what Cycles computes in, and half the memory of float64


@dataclass(frozen=True)
class Link:
    """The output ``output`` (of socket type ``kind``: VALUE, RGBA, VECTOR, SHADER) of node
    number ``node`` of the graph."""

    node: int
    output: str
    kind: str = "VALUE"


@dataclass(frozen=True)
class Input:
    """An input socket: ``kind`` its type, ``value`` a constant (float or 3-tuple) or a Link."""

    name: str
    kind: str
    value: float | tuple | Link


@dataclass(frozen=True)
class Node:
    """One node: ``kind`` (a key of NODES), its constant ``params`` as (name, value) pairs, its
    inputs, and ``label`` (the Blender node's name, for messages)."""

    kind: str
    params: tuple = ()
    inputs: tuple[Input, ...] = ()
    label: str = ""

    def param(self, name: str, default=None):
        for k, v in self.params:
            if k == name:
                return v
        return default


@dataclass(frozen=True)
class ShaderGraph:
    """A volume shader: ``nodes`` in any order, ``output`` the Link feeding the material output's
    Volume socket (None: no volume shader), ``notes`` what was not read (one line per node)."""

    nodes: tuple[Node, ...]
    output: Link | None
    notes: tuple[str, ...] = ()
    texspace: tuple[tuple[float, float, float], tuple[float, float, float]] = ((0.0, 0.0, 0.0),
                                                                              (1.0, 1.0, 1.0))

    @cached_property
    def key(self) -> str:
        return _digest(repr(self.nodes), repr(self.output), self.texspace)

    @cached_property
    def grids(self) -> tuple[str, ...]:
        """Every grid the graph reads."""
        names: list[str] = []
        for node in self.nodes:
            if node.kind == "ATTRIBUTE":
                names.append(node.param("name"))
            elif node.kind == "VOLUME_INFO":
                names.extend(VOLUME_INFO.values())
            elif node.kind == "PRINCIPLED_VOLUME":
                names.extend(node.param(p) for p in ("density_attribute", "color_attribute",
                                                     "temperature_attribute"))
        return tuple(dict.fromkeys(n for n in names if n))

    @cached_property
    def used(self) -> frozenset:
        """(node, output) pairs some input or the output reads."""
        links = [i.value for n in self.nodes for i in n.inputs if isinstance(i.value, Link)]
        links += [self.output] if self.output is not None else []
        return frozenset((lk.node, lk.output) for lk in links)

    @cached_property
    def reads_position(self) -> bool:
        """Whether the graph needs the voxels' positions (texture coordinates, textures)."""
        return any(node.kind in ("TEX_COORD", "UV_MAP") or node.kind.startswith("TEX_")
                   for node in self.nodes)


VOLUME_INFO = {"Color": "color", "Density": "density", "Flame": "flame", "Temperature": "temperature"}


@dataclass
class Closure:
    """Volume coefficients (1/m, per channel), emission (W/(sr m^2) per m) and the anisotropy
    weighted by the mean scattering coefficient, all broadcastable over the voxels."""

    sigma_s: np.ndarray = field(default_factory=lambda: np.zeros(3, F))
    sigma_a: np.ndarray = field(default_factory=lambda: np.zeros(3, F))
    emission: np.ndarray = field(default_factory=lambda: np.zeros(3, F))
    g_weighted: np.ndarray = field(default_factory=lambda: np.zeros((), F))

    def scaled(self, f) -> Closure:
        f = np.asarray(f, F)
        return Closure(self.sigma_s * f[..., None], self.sigma_a * f[..., None],
                       self.emission * f[..., None], self.g_weighted * f)

    def __add__(self, other: Closure) -> Closure:
        return Closure(self.sigma_s + other.sigma_s, self.sigma_a + other.sigma_a,
                       self.emission + other.emission, self.g_weighted + other.g_weighted)


@dataclass(frozen=True)
class VolumeFields:
    """A shader evaluated at n points: (n, 3) coefficients and emission, (n,) anisotropy."""

    sigma_s: np.ndarray
    sigma_a: np.ndarray
    emission: np.ndarray
    anisotropy: np.ndarray


class _Evaluation:
    def __init__(self, graph: ShaderGraph, grids: Mapping[str, np.ndarray], n: int,
                 position: np.ndarray | None):
        self.graph, self.grids, self.n, self.position = graph, grids, n, position
        self.memo: dict[int, dict] = {}
        self.uv: np.ndarray | None = None     # (n, 2) UV coordinates of surface points
        self.footprint = 0.0        # radians a direction stands for (a world's: evaluate)
        self.camera_ray = True      # the ray a Light Path node reads (a surface's: evaluate_value)
        self.current = -1           # the node being evaluated

    def reads(self, output: str) -> bool:
        """Whether the current node's ``output`` is read by another node or the graph's output."""
        return (self.current, output) in self.graph.used

    def outputs(self, index: int) -> dict:
        if index not in self.memo:
            node = self.graph.nodes[index]
            ins = {i.name: self.input(i) for i in node.inputs}
            self.current = index
            self.memo[index] = NODES[node.kind](node, ins, self)
        return self.memo[index]

    def input(self, i: Input):
        if isinstance(i.value, Link):
            value = self.outputs(i.value.node).get(i.value.output)
            if value is None:
                return _default(i.kind)
            return convert(value, i.value.kind, i.kind)
        if i.kind == "SHADER":
            return None
        return convert(np.asarray(i.value, F), "RGBA" if np.ndim(i.value) else "VALUE", i.kind)

    def grid(self, name: str) -> np.ndarray | None:
        g = self.grids.get(name)
        return None if g is None else np.asarray(g, F)


def _mean3(x):
    """The mean of the last axis of length 3 (faster than ``mean(axis=-1)`` on long arrays)."""
    x = np.asarray(x)
    return (x[..., 0] + x[..., 1] + x[..., 2]) * np.float32(1.0 / 3.0)


def _default(kind: str):
    return None if kind == "SHADER" else (np.zeros(3, F) if kind in ("RGBA", "VECTOR") else np.zeros((), F))


def convert(value, src: str, dst: str):
    """A socket value of type ``src`` as type ``dst``, as Cycles converts across a link."""
    if value is None or dst == "SHADER" or src == "SHADER":
        return value
    v = np.asarray(value, F)
    src_vec = v.ndim >= 1 and v.shape[-1] == 3 and src in ("RGBA", "VECTOR")
    if dst in ("VALUE", "INT", "BOOLEAN"):
        if not src_vec:
            return v
        return v @ LUMINANCE if src == "RGBA" else v.mean(axis=-1)
    if src_vec:
        return v
    return np.repeat(v[..., None], 3, axis=-1)


def evaluate(graph: ShaderGraph, grids: Mapping[str, np.ndarray], n: int,
             position: np.ndarray | None = None, footprint: float = 0.0) -> VolumeFields:
    """The volume shader at ``n`` points: ``grids`` maps names to (n,) or (n, 3) values there
    (a grid the graph names but ``grids`` lacks reads 0, as in Cycles); ``position`` (n, 3) the
    points in object space (for Texture Coordinate). ``footprint``: the angle (radians) each point
    stands for, where the points are a world's directions: an Environment Texture is read from
    its image averaged down to that size (0: the image itself)."""
    ev = _Evaluation(graph, grids, n, position)
    ev.footprint = float(footprint)
    c = None
    if graph.output is not None:
        c = ev.outputs(graph.output.node).get(graph.output.output)
    c = c if c is not None else Closure()
    shape = (n, 3)
    s = np.broadcast_to(c.sigma_s, shape)
    a = np.broadcast_to(c.sigma_a, shape)
    e = np.broadcast_to(c.emission, shape)
    mean_s = _mean3(s)
    g = np.where(mean_s > 0.0, np.broadcast_to(c.g_weighted, (n,)) / np.maximum(mean_s, 1e-30), 0.0)
    return VolumeFields(s, a, e, np.clip(g, -0.99, 0.99))


def evaluate_value(graph: ShaderGraph, kind: str, n: int, position: np.ndarray | None = None,
                   uv: np.ndarray | None = None, camera_ray: bool = True):
    """The value ``graph.output`` links to, as socket type ``kind`` (VALUE: (n,), RGBA or VECTOR:
    (n, 3)), at ``n`` points of a surface: ``position`` (n, 3) in object space, ``uv`` (n, 2);
    ``camera_ray``: the ray a Light Path node reads (False: a shadow ray)."""
    ev = _Evaluation(graph, {}, n, position)
    ev.uv = uv
    ev.camera_ray = camera_ray
    value = ev.input(Input("value", kind, graph.output))
    shape = (n, 3) if kind in ("RGBA", "VECTOR") else (n,)
    return np.broadcast_to(np.asarray(value, F), shape)


# ---- value nodes --------------------------------------------------------------------------------

def _attribute(node, ins, ev):
    name = node.param("name")
    g = ev.grid(name) if name else None
    if g is None:
        zero = np.zeros((), F)
        return {"Color": np.zeros(3, F), "Vector": np.zeros(3, F), "Fac": zero, "Alpha": zero}
    if g.ndim >= 2 and g.shape[-1] == 3:
        return {"Color": g, "Vector": g, "Fac": g.mean(axis=-1), "Alpha": np.ones((), F)}
    rgb = np.repeat(g[..., None], 3, axis=-1)
    return {"Color": rgb, "Vector": rgb, "Fac": g, "Alpha": np.ones((), F)}


def _volume_info(node, ins, ev):
    out = {}
    for socket, name in VOLUME_INFO.items():
        g = ev.grid(name)
        if socket == "Color":
            if g is None:
                out[socket] = np.zeros(3, F)
            else:
                out[socket] = g if g.ndim >= 2 and g.shape[-1] == 3 else np.repeat(g[..., None], 3, -1)
        else:
            out[socket] = np.zeros((), F) if g is None else (g.mean(axis=-1) if g.ndim >= 2 else g)
    return out


def _value(node, ins, ev):
    return {"Value": np.asarray(node.param("value"), F)}


def _rgb(node, ins, ev):
    return {"Color": np.asarray(node.param("color"), F)}


def _safe_divide(a, b):
    b = np.asarray(b, F)
    return np.where(b != 0.0, a / np.where(b != 0.0, b, 1.0), 0.0)


def _smoothmin(a, b, c):
    c = np.asarray(c, F)
    h = np.maximum(c - np.abs(a - b), 0.0) / np.where(c != 0.0, c, 1.0)
    return np.where(c != 0.0, np.minimum(a, b) - h * h * h * c * (1.0 / 6.0), np.minimum(a, b))


def _wrap(v, hi, lo):
    r = hi - lo
    return np.where(r != 0.0, v - r * np.floor((v - lo) / np.where(r != 0.0, r, 1.0)), lo)


def _power(a, b):
    ok = (a >= 0.0) | (np.floor(b) == b)
    with np.errstate(all="ignore"):
        out = np.power(a, b)
    return np.where(ok & np.isfinite(out), out, 0.0)


def _log(a, b):
    ok = (a > 0.0) & (b > 0.0)
    with np.errstate(all="ignore"):
        out = np.log(np.where(ok, a, 1.0)) / np.log(np.where(ok, b, 2.0))
    return np.where(ok & np.isfinite(out), out, 0.0)


def _pingpong(a, b):
    with np.errstate(all="ignore"):
        x = (a - b) / np.where(b != 0.0, b * 2.0, 1.0)
        out = np.abs((x - np.floor(x)) * b * 2.0 - b)
    return np.where(b != 0.0, out, 0.0)


# Cycles' svm_math (intern/cycles/kernel/svm/math_util.h), safe versions where it has them.
MATH: dict[str, Callable] = {
    'ADD': lambda a, b, c: a + b,
    'SUBTRACT': lambda a, b, c: a - b,
    'MULTIPLY': lambda a, b, c: a * b,
    'DIVIDE': lambda a, b, c: _safe_divide(a, b),
    'MULTIPLY_ADD': lambda a, b, c: a * b + c,
    'POWER': lambda a, b, c: _power(a, b),
    'LOGARITHM': lambda a, b, c: _log(a, b),
    'SQRT': lambda a, b, c: np.sqrt(np.maximum(a, 0.0)),
    'INVERSE_SQRT': lambda a, b, c: np.where(a > 0.0, 1.0 / np.sqrt(np.maximum(a, 1e-300)), 0.0),
    'ABSOLUTE': lambda a, b, c: np.abs(a),
    'EXPONENT': lambda a, b, c: np.exp(np.minimum(a, 700.0)),
    'MINIMUM': lambda a, b, c: np.minimum(a, b),
    'MAXIMUM': lambda a, b, c: np.maximum(a, b),
    'LESS_THAN': lambda a, b, c: (a < b).astype(F),
    'GREATER_THAN': lambda a, b, c: (a > b).astype(F),
    'SIGN': lambda a, b, c: np.sign(a),
    'COMPARE': lambda a, b, c: ((a == b) | (np.abs(a - b) <= np.maximum(c, np.finfo(F).eps))).astype(F),
    'SMOOTH_MIN': lambda a, b, c: _smoothmin(a, b, c),
    'SMOOTH_MAX': lambda a, b, c: -_smoothmin(-a, -b, c),
    'ROUND': lambda a, b, c: np.floor(a + 0.5),
    'FLOOR': lambda a, b, c: np.floor(a),
    'CEIL': lambda a, b, c: np.ceil(a),
    'TRUNC': lambda a, b, c: np.trunc(a),
    'FRACT': lambda a, b, c: a - np.floor(a),
    'MODULO': lambda a, b, c: np.where(b != 0.0, np.fmod(a, np.where(b != 0.0, b, 1.0)), 0.0),
    'FLOORED_MODULO': lambda a, b, c: np.where(
        b != 0.0, a - np.floor(a / np.where(b != 0.0, b, 1.0)) * b, 0.0),
    'WRAP': lambda a, b, c: _wrap(a, b, c),
    'SNAP': lambda a, b, c: np.where(b != 0.0, np.floor(a / np.where(b != 0.0, b, 1.0)) * b, 0.0),
    'PINGPONG': lambda a, b, c: _pingpong(a, b),
    'SINE': lambda a, b, c: np.sin(a),
    'COSINE': lambda a, b, c: np.cos(a),
    'TANGENT': lambda a, b, c: np.tan(a),
    'ARCSINE': lambda a, b, c: np.where(np.abs(a) <= 1.0, np.arcsin(np.clip(a, -1.0, 1.0)), 0.0),
    'ARCCOSINE': lambda a, b, c: np.where(np.abs(a) <= 1.0, np.arccos(np.clip(a, -1.0, 1.0)), 0.0),
    'ARCTANGENT': lambda a, b, c: np.arctan(a),
    'ARCTAN2': lambda a, b, c: np.arctan2(a, b),
    'SINH': lambda a, b, c: np.sinh(np.clip(a, -700.0, 700.0)),
    'COSH': lambda a, b, c: np.cosh(np.clip(a, -700.0, 700.0)),
    'TANH': lambda a, b, c: np.tanh(a),
    'RADIANS': lambda a, b, c: np.radians(a),
    'DEGREES': lambda a, b, c: np.degrees(a),
}


def _math(node, ins, ev):
    a, b, c = (ins.get(k, np.zeros((), F)) for k in ("A", "B", "C"))
    out = MATH[node.param("operation")](a, b, c)
    if node.param("use_clamp"):
        out = np.clip(out, 0.0, 1.0)
    return {"Value": out}


def _norm(v):
    return np.sqrt((np.asarray(v) ** 2).sum(axis=-1))


def _dot(a, b):
    return (np.asarray(a) * np.asarray(b)).sum(axis=-1)


def _normalize(v):
    n = _norm(v)[..., None]
    return np.where(n > 0.0, v / np.where(n > 0.0, n, 1.0), 0.0)


# Cycles' svm_vector_math: (a, b, c, scale) -> (vector, value); the elementwise operations reuse MATH.
VECTOR_MATH: dict[str, Callable] = {
    'CROSS_PRODUCT': lambda a, b, c, k: (np.cross(a, b), None),
    'DOT_PRODUCT': lambda a, b, c, k: (None, (a * b).sum(axis=-1)),
    'DISTANCE': lambda a, b, c, k: (None, _norm(a - b)),
    'LENGTH': lambda a, b, c, k: (None, _norm(a)),
    'SCALE': lambda a, b, c, k: (a * np.asarray(k)[..., None], None),
    'NORMALIZE': lambda a, b, c, k: (_normalize(a), None),
    'PROJECT': lambda a, b, c, k: (b * _safe_divide(_dot(a, b), _dot(b, b))[..., None], None),
    'REFLECT': lambda a, b, c, k: (a - 2.0 * _dot(_normalize(b), a)[..., None] * _normalize(b), None),
    'FACEFORWARD': lambda a, b, c, k: (np.where(((c * b).sum(axis=-1) < 0.0)[..., None], a, -a), None),
    'FRACTION': lambda a, b, c, k: (a - np.floor(a), None),
}
_ELEMENTWISE = {'ADD', 'SUBTRACT', 'MULTIPLY', 'DIVIDE', 'MULTIPLY_ADD', 'ABSOLUTE', 'POWER', 'SIGN',
                'MINIMUM', 'MAXIMUM', 'FLOOR', 'CEIL', 'MODULO', 'WRAP', 'SNAP', 'SINE', 'COSINE', 'TANGENT'}


def _vector_math(node, ins, ev):
    op = node.param("operation")
    a, b, c = (np.asarray(ins.get(k, np.zeros(3, F))) for k in ("Vector", "Vector_001", "Vector_002"))
    if op in _ELEMENTWISE:
        vector, value = MATH[op](a, b, c), None
    else:
        vector, value = VECTOR_MATH[op](a, b, c, ins.get("Scale", np.ones((), F)))
    out = {}
    if vector is not None:
        out["Vector"] = vector
        out["Value"] = np.zeros((), F)
    if value is not None:
        out["Value"] = value
        out["Vector"] = np.zeros(3, F)
    return out


def _smoothstep(e0, e1, x):
    t = np.clip(_safe_divide(x - e0, e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _smootherstep(e0, e1, x):
    t = np.clip(_safe_divide(x - e0, e1 - e0), 0.0, 1.0)
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


def _map_range(node, ins, ev):
    v, fmin, fmax = ins["Value"], ins["From Min"], ins["From Max"]
    tmin, tmax, steps = ins["To Min"], ins["To Max"], ins.get("Steps", np.asarray(4.0))
    kind = node.param("interpolation_type", "LINEAR")
    if kind in ("LINEAR", "STEPPED"):
        f = _safe_divide(v - fmin, fmax - fmin)
        if kind == "STEPPED":
            f = np.where(steps > 0.0, np.floor(f * (steps + 1.0)) / np.where(steps > 0.0, steps, 1.0), 0.0)
    else:
        step = _smoothstep if kind == "SMOOTHSTEP" else _smootherstep
        f = np.where(fmin > fmax, 1.0 - step(fmax, fmin, v), step(fmin, fmax, v))
    out = np.where(fmax != fmin, tmin + f * (tmax - tmin), 0.0)
    if node.param("clamp") and kind in ("LINEAR", "STEPPED"):
        out = np.clip(out, np.minimum(tmin, tmax), np.maximum(tmin, tmax))
    return {"Result": out}


def _clamp(node, ins, ev):
    v, lo, hi = ins["Value"], ins["Min"], ins["Max"]
    if node.param("clamp_type", "MINMAX") == "RANGE":
        lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    return {"Result": np.minimum(np.maximum(v, lo), hi)}


def _table_lookup(table: np.ndarray, f, interpolate: bool):
    """Cycles' rgb_ramp_lookup: ``table`` (size, c) sampled at i / (size - 1), f clamped to [0, 1]."""
    size = len(table)
    x = np.clip(np.nan_to_num(np.asarray(f, F)), 0.0, 1.0) * (size - 1)
    i = np.clip(x.astype(np.int64), 0, size - 1)
    t = x - i
    a = table[i]
    if interpolate:
        b = table[np.minimum(i + 1, size - 1)]
        a = np.where((t > 0.0)[..., None], (1.0 - t)[..., None] * a + t[..., None] * b, a)
    return a


def _color_ramp(node, ins, ev):
    table = np.asarray(node.param("table"), F).reshape(-1, 4)
    rgba = _table_lookup(table, ins["Fac"], node.param("interpolate", True))
    return {"Color": rgba[..., :3], "Alpha": rgba[..., 3]}


def _float_curve(node, ins, ev):
    table = np.asarray(node.param("table"), F).reshape(-1, 1)
    lo, hi = node.param("range", (0.0, 1.0))
    v, fac = ins["Value"], ins["Factor"]
    x = _safe_divide(v - lo, hi - lo)
    y = _table_lookup(table, x, True)[..., 0]
    # Cycles extrapolates the curve's end slopes beyond its range (float_curve_lookup)
    n = len(table) - 1
    d0 = (table[1, 0] - table[0, 0]) * n
    d1 = (table[n, 0] - table[n - 1, 0]) * n
    y = np.where(x < 0.0, table[0, 0] + x * d0, np.where(x > 1.0, table[n, 0] + (x - 1.0) * d1, y))
    return {"Value": (1.0 - fac) * v + fac * y}


def _blend(kind: str, f, a, b):
    """Cycles' svm_mix for colours (a, b: (..., 3); f: (..., 1))."""
    if kind == "MIX":
        return a + f * (b - a)
    if kind == "ADD":
        return a + f * b
    if kind == "MULTIPLY":
        return a * (1.0 - f + f * b)
    if kind == "SUBTRACT":
        return a - f * b
    if kind == "SCREEN":
        return 1.0 - (1.0 - f + f * (1.0 - b)) * (1.0 - a)
    if kind == "DIVIDE":
        return np.where(b != 0.0, (1.0 - f) * a + f * a / np.where(b != 0.0, b, 1.0), a)
    if kind == "DIFFERENCE":
        return a + f * (np.abs(a - b) - a)
    if kind == "EXCLUSION":
        return np.maximum(a + f * (a + b - 2.0 * a * b - a), 0.0)
    if kind == "DARKEN":
        return a + f * (np.minimum(a, b) - a)
    if kind == "LIGHTEN":
        return a + f * (np.maximum(a, b) - a)
    if kind == "OVERLAY":
        return np.where(a < 0.5, a * (1.0 - f + 2.0 * f * b),
                        1.0 - (1.0 - f + 2.0 * f * (1.0 - b)) * (1.0 - a))
    if kind == "LINEAR_LIGHT":
        return a + f * (2.0 * b - 1.0)
    if kind == "SOFT_LIGHT":
        scr = 1.0 - (1.0 - b) * (1.0 - a)
        return (1.0 - f) * a + f * ((1.0 - a) * b * a + a * scr)
    if kind == "DODGE":
        tmp = 1.0 - f * b
        dodged = np.where(tmp > 0.0, np.minimum(a / np.where(tmp > 0.0, tmp, 1.0), 1.0), 1.0)
        return np.where(a != 0.0, dodged, a)
    if kind == "BURN":
        tmp = (1.0 - f) + f * b
        out = np.where(tmp > 0.0, 1.0 - (1.0 - a) / np.where(tmp > 0.0, tmp, 1.0), 0.0)
        return np.clip(out, 0.0, 1.0)
    raise KeyError(kind)


BLENDS = ("MIX", "ADD", "MULTIPLY", "SUBTRACT", "SCREEN", "DIVIDE", "DIFFERENCE", "EXCLUSION",
          "DARKEN", "LIGHTEN", "OVERLAY", "LINEAR_LIGHT", "SOFT_LIGHT", "DODGE", "BURN")


def _mix(node, ins, ev):
    data = node.param("data_type", "RGBA")
    f = ins["Factor"]
    if node.param("clamp_factor", True):
        f = np.clip(f, 0.0, 1.0)
    a, b = ins["A"], ins["B"]
    if data == "FLOAT":
        return {"Result": a + f * (b - a)}
    if data == "VECTOR":
        f = f if np.ndim(f) and np.shape(f)[-1] == 3 else np.asarray(f)[..., None]
        return {"Result": a + f * (b - a)}
    out = _blend(node.param("blend_type", "MIX"), np.asarray(f)[..., None], a, b)
    if node.param("clamp_result"):
        out = np.clip(out, 0.0, 1.0)
    return {"Result": out}


def _invert(node, ins, ev):
    f, c = np.asarray(ins["Fac"])[..., None], ins["Color"]
    return {"Color": c + f * ((1.0 - c) - c)}


def _gamma(node, ins, ev):
    c, g = ins["Color"], np.asarray(ins["Gamma"])[..., None]
    return {"Color": np.where(c > 0.0, _power(np.maximum(c, 0.0), g), c)}


def _rgb_to_bw(node, ins, ev):
    return {"Val": ins["Color"] @ LUMINANCE}


def _separate(node, ins, ev):
    v = ins["Color"] if "Color" in ins else ins["Vector"]
    names = ("Red", "Green", "Blue") if "Color" in ins else ("X", "Y", "Z")
    return {n: v[..., k] for k, n in enumerate(names)}


def _combine(node, ins, ev):
    names = ("Red", "Green", "Blue") if "Red" in ins else ("X", "Y", "Z")
    parts = np.broadcast_arrays(*(np.asarray(ins[n], F) for n in names))
    out = np.stack(parts, axis=-1)
    return {"Color": out, "Vector": out}


def _blackbody(node, ins, ev):
    return {"Color": np.maximum(blackbody.color_rec709(ins["Temperature"]), 0.0)}


def _tex_coord(node, ins, ev):
    out = {}
    if ev.uv is not None:
        out["UV"] = np.concatenate([ev.uv, np.zeros((len(ev.uv), 1))], axis=-1)
    if ev.position is None:
        return out
    lo, size = (np.asarray(x, np.float64) for x in ev.graph.texspace)
    generated = (ev.position - (lo - size)) / np.where(size != 0.0, 2.0 * size, 1.0)
    return {**out, "Object": ev.position, "Generated": generated}


def _light_path(node, ins, ev):
    """Light Path: Is Camera Ray on a camera ray, Is Shadow Ray on a shadow ray; every other output
    reads 0."""
    return {"Is Camera Ray": np.asarray(float(ev.camera_ray), F),
            "Is Shadow Ray": np.asarray(float(not ev.camera_ray), F)}


def _uv_map(node, ins, ev):
    return {"UV": _tex_coord(node, ins, ev).get("UV", np.zeros(3, F))}


# Images the graphs read (Image Texture), by the key their node holds: (pixels (h, w, 4) float32,
# bottom row first; whether they are sRGB-encoded bytes, decoded after interpolation as Cycles
# does). Registered once per content by the Blender side (blender/node_graph.py), the last
# IMAGES_KEPT kept.
IMAGES_KEPT = 32
IMAGES = caches.memo("shading.images", IMAGES_KEPT)


def register_image(key: str, pixels: np.ndarray, srgb: bool) -> None:
    IMAGES.put(key, (pixels, srgb))


def srgb_to_linear(c):
    c = np.asarray(c, np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((np.maximum(c, 0.04045) + 0.055) / 1.055) ** 2.4)


def _sample_image(pixels: np.ndarray, srgb: bool, u: np.ndarray, v: np.ndarray, interpolation: str,
                  extension: str) -> tuple[np.ndarray, np.ndarray]:
    """An image (h, w, 4), bottom row first, read at texture coordinates (u, v) as Cycles reads it
    (texel centres at (i + 0.5) / size; sRGB decoded after interpolation): (RGB (n, 3), alpha (n,)).
    ``extension``: REPEAT, EXTEND or CLIP, or EQUIRECTANGULAR (u repeats, v extends)."""
    h, w = pixels.shape[:2]
    x, y = u * w - 0.5, v * h - 0.5

    def wrap(i, n, repeat):
        return np.mod(i, n) if repeat else np.clip(i, 0, n - 1)

    def wrap_x(i):
        return wrap(i, w, extension in ("REPEAT", "EQUIRECTANGULAR"))

    def wrap_y(i):
        return wrap(i, h, extension == "REPEAT")

    flat = pixels.reshape(h * w, -1)
    if interpolation == "Closest":
        xi, yi = np.floor(x + 0.5).astype(np.int64), np.floor(y + 0.5).astype(np.int64)
        rgba = flat.take(wrap_y(yi) * w + wrap_x(xi), axis=0)
    else:
        x0, y0 = np.floor(x), np.floor(y)
        tx, ty = (x - x0).astype(F)[:, None], (y - y0).astype(F)[:, None]
        x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
        xa, xb, ya, yb = wrap_x(x0), wrap_x(x0 + 1), wrap_y(y0) * w, wrap_y(y0 + 1) * w
        rgba = ((flat.take(ya + xa, axis=0) * (1 - tx) + flat.take(ya + xb, axis=0) * tx) * (1 - ty)
                + (flat.take(yb + xa, axis=0) * (1 - tx) + flat.take(yb + xb, axis=0) * tx) * ty)
    if extension == "CLIP":
        outside = (u < 0) | (u > 1) | (v < 0) | (v > 1)
        rgba = np.where(outside[:, None], 0.0, rgba)
    rgb = srgb_to_linear(rgba[:, :3]) if srgb else rgba[:, :3]
    return np.asarray(rgb, F), np.asarray(rgba[:, 3], F)


MISSING = {"Color": np.array([1.0, 0.0, 1.0], F), "Alpha": np.ones((), F)}     # Cycles' missing image


def _tex_image(node, ins, ev):
    entry = IMAGES.get(node.param("image", ""))
    v = ins.get("Vector")
    if v is None:        # unlinked: the active UV map
        v = _tex_coord(node, {}, ev).get("UV", np.zeros(3, F))
    if entry is None:
        return MISSING
    pixels, srgb = entry
    uv = np.broadcast_to(np.asarray(v, np.float64), (ev.n, 3))[:, :2]
    rgb, alpha = _sample_image(pixels, srgb, uv[:, 0], uv[:, 1], node.param("interpolation", "Linear"),
                               node.param("extension", "REPEAT"))
    return {"Color": rgb, "Alpha": alpha}


_levels = caches.memo("shading.image_levels", 8)    # (image key, level) -> the image averaged down


def area_resize(pixels: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """``pixels`` (h, w, c) averaged down to (rows, cols): each new pixel the exact area mean of the
    part of the image it covers (fractions of pixels included), so that the image still spans the
    same extent and its mean is kept."""
    out = np.asarray(pixels)
    for axis, n in ((0, rows), (1, cols)):
        a = np.moveaxis(out, axis, 0)
        size = a.shape[0]
        if n != size and size % n == 0:         # whole blocks: their means
            a = a.reshape((n, size // n) + a.shape[1:]).mean(axis=1)
        elif n != size:
            total = np.concatenate([np.zeros((1,) + a.shape[1:]), np.cumsum(a, axis=0, dtype=np.float64)])
            edges = np.linspace(0.0, size, n + 1)
            i = np.minimum(np.floor(edges).astype(np.int64), size - 1)
            t = (edges - i).reshape((-1,) + (1,) * (a.ndim - 1))
            at = total[i] + (total[i + 1] - total[i]) * t          # the running sum at each edge
            a = np.diff(at, axis=0) / (size / n)
        out = np.moveaxis(a, 0, axis)
    return np.ascontiguousarray(out, np.float32)


def image_level(key: str, entry, level: int) -> tuple[np.ndarray, bool]:
    """Registered image ``key`` (its ``entry``: pixels, sRGB-encoded) averaged down by 2^level on
    each side (``area_resize``; an sRGB image decoded first, as Cycles adds up linear light):
    (pixels, whether they are still sRGB-encoded)."""
    if level <= 0:
        return entry

    def average():
        pixels, srgb = entry
        if srgb:
            pixels = np.concatenate([srgb_to_linear(pixels[..., :3]), pixels[..., 3:]], axis=-1)
        h, w = pixels.shape[:2]
        out = area_resize(pixels, max(1, round(h / 2 ** level)), max(1, round(w / 2 ** level)))
        out.setflags(write=False)
        return out, False

    return _levels.made((key, level), average)


def equirectangular(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Directions (n, 3) as an equirectangular image's texture coordinates, Cycles'
    direction_to_equirectangular: u = 0.5 - atan2(y, x) / 2 pi, v = 1 - acos(z) / pi (v up)."""
    d = np.asarray(d, np.float64)
    length = np.maximum(np.linalg.norm(d, axis=-1), 1e-30)
    u = 0.5 - np.arctan2(d[:, 1], d[:, 0]) / (2.0 * math.pi)
    v = 1.0 - np.arccos(np.clip(d[:, 2] / length, -1.0, 1.0)) / math.pi
    return u, v


def _tex_environment(node, ins, ev):
    """An Environment Texture (equirectangular) read in the directions of its Vector input (unlinked:
    the world's direction, its Generated coordinates), from the image averaged down to the
    evaluation's footprint (``evaluate``)."""
    key = node.param("image", "")
    entry = IMAGES.get(key)
    if entry is None:
        return MISSING
    d = _texture_vector(ins, ev)
    w = entry[0].shape[1]
    level = 0
    if ev.footprint > 0.0:
        level = max(0, int(round(math.log2(max(ev.footprint * w / (2.0 * math.pi), 1.0)))))
    pixels, srgb = image_level(key, entry, level)
    u, v = equirectangular(d)
    rgb, alpha = _sample_image(pixels, srgb, u, v, node.param("interpolation", "Linear"),
                               "EQUIRECTANGULAR")
    return {"Color": rgb, "Alpha": alpha}


def _euler(r) -> np.ndarray:
    """Blender's XYZ Euler rotation matrix."""
    x, y, z = (float(v) for v in np.asarray(r, np.float64).reshape(3))
    cx, sx, cy, sy, cz, sz = math.cos(x), math.sin(x), math.cos(y), math.sin(y), math.cos(z), math.sin(z)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _mapping(node, ins, ev):
    v = ins["Vector"]
    loc = np.asarray(ins.get("Location", np.zeros(3, F)))
    rot = _euler(ins.get("Rotation", np.zeros(3, F)))
    scale = np.asarray(ins.get("Scale", np.ones(3)))
    kind = node.param("vector_type", "POINT")
    if kind == "POINT":
        out = (v * scale) @ rot.T + loc
    elif kind == "TEXTURE":
        out = ((v - loc) @ rot) / np.where(scale != 0.0, scale, 1.0)
    elif kind == "VECTOR":
        out = (v * scale) @ rot.T
    else:
        out = (v / np.where(scale != 0.0, scale, 1.0)) @ rot.T
        out = out / np.maximum(np.linalg.norm(out, axis=-1, keepdims=True), 1e-30)
    return {"Vector": out}


def _texture_vector(ins, ev):
    """A texture's coordinates: its Vector input, or Generated where the compiler left an unlinked
    Vector out (as Cycles' texture nodes read Generated coordinates by default)."""
    v = ins.get("Vector")
    if v is None:
        v = _tex_coord(None, {}, ev).get("Generated", np.zeros(3, F))
    return np.broadcast_to(np.asarray(v, np.float64), (ev.n, 3))


def _tex_noise(node, ins, ev):
    from . import textures
    p = _texture_vector(ins, ev)
    kw = _scalar_params(ins, (("scale", "Scale"), ("detail", "Detail"), ("roughness", "Roughness"),
                              ("lacunarity", "Lacunarity"), ("distortion", "Distortion"),
                              ("offset", "Offset"), ("gain", "Gain")))
    fac, color = textures.noise(p, normalize=bool(node.param("normalize", True)),
                                noise_type=node.param("noise_type", "FBM"), color=ev.reads("Color"), **kw)
    return {"Fac": fac, "Color": color}


def _tex_gradient(node, ins, ev):
    from . import textures
    fac = textures.gradient(_texture_vector(ins, ev), node.param("gradient_type", "LINEAR"))
    return {"Fac": fac, "Color": np.repeat(np.asarray(fac)[..., None], 3, -1)}


def _tex_white_noise(node, ins, ev):
    from . import textures
    value, color = textures.white_noise(_texture_vector(ins, ev))
    return {"Value": value, "Color": color}


def _scalar_params(ins, names) -> dict:
    """Texture parameters as the scalars textures.py takes (a linked, varying one: its mean, which
    the compiler names)."""
    return {k: float(np.asarray(ins[s], np.float64).mean()) for k, s in names if s in ins}


def _tex_voronoi(node, ins, ev):
    from . import textures
    kw = _scalar_params(ins, (("scale", "Scale"), ("randomness", "Randomness"), ("exponent", "Exponent"),
                              ("detail", "Detail"), ("roughness", "Roughness"), ("lacunarity", "Lacunarity")))
    distance, color, position = textures.voronoi(
        _texture_vector(ins, ev), feature=node.param("feature", "F1"),
        distance=node.param("distance", "EUCLIDEAN"), normalize=bool(node.param("normalize", False)), **kw)
    return {"Distance": distance, "Color": color, "Position": position}


def _tex_wave(node, ins, ev):
    from . import textures
    kw = _scalar_params(ins, (("scale", "Scale"), ("distortion", "Distortion"), ("detail", "Detail"),
                              ("detail_scale", "Detail Scale"), ("detail_roughness", "Detail Roughness"),
                              ("phase_offset", "Phase Offset")))
    fac, color = textures.wave(_texture_vector(ins, ev), wave_type=node.param("wave_type", "BANDS"),
                               bands_direction=node.param("bands_direction", "X"),
                               rings_direction=node.param("rings_direction", "X"),
                               wave_profile=node.param("wave_profile", "SIN"), **kw)
    return {"Fac": fac, "Color": color}


def _tex_checker(node, ins, ev):
    from . import textures
    fac, _ = textures.checker(_texture_vector(ins, ev), **_scalar_params(ins, (("scale", "Scale"),)))
    on = np.asarray(fac)[..., None] > 0.5
    return {"Fac": fac, "Color": np.where(on, ins["Color1"], ins["Color2"])}


# ---- shader nodes -------------------------------------------------------------------------------

def _principled(node, ins, ev):
    density = ins["Density"]
    attr = ev.grid(node.param("density_attribute", ""))
    if attr is not None:
        density = density * (attr.mean(axis=-1) if attr.ndim >= 2 else attr)
    density = np.maximum(density, 0.0)
    color = ins["Color"]
    cattr = ev.grid(node.param("color_attribute", ""))
    if cattr is not None:
        color = color * (cattr if cattr.ndim >= 2 and cattr.shape[-1] == 3 else cattr[..., None])
    k = np.maximum(1.0 - np.sqrt(np.maximum(ins["Absorption Color"], 0.0)), 0.0)
    absorption = np.maximum(1.0 - color, 0.0) * k
    d = np.asarray(density)[..., None]
    sigma_s = color * d
    out = Closure(sigma_s, absorption * d, np.zeros(3, F), ins.get("Anisotropy", 0.0) * _mean3(sigma_s))
    strength = ins["Emission Strength"]
    out.emission = np.where((np.asarray(strength) > CUTOFF)[..., None],
                            ins["Emission Color"] * np.asarray(strength)[..., None], 0.0)
    intensity = np.asarray(ins["Blackbody Intensity"])
    if np.any(intensity > CUTOFF):
        t = ins["Temperature"]
        tattr = ev.grid(node.param("temperature_attribute", ""))
        if tattr is not None:
            t = t * (tattr.mean(axis=-1) if tattr.ndim >= 2 else tattr)
        term = blackbody.radiance(np.maximum(t, 0.0), np.where(intensity > CUTOFF, intensity, 0.0))
        out.emission = out.emission + ins["Blackbody Tint"] * term
    return {"Volume": out}


def _scatter(node, ins, ev):
    d = np.maximum(ins["Density"], 0.0)[..., None]
    s = ins["Color"] * d
    return {"Volume": Closure(s, np.zeros(3, F), np.zeros(3, F), ins.get("Anisotropy", 0.0) * _mean3(s))}


def _absorption(node, ins, ev):
    d = np.maximum(ins["Density"], 0.0)[..., None]
    return {"Volume": Closure(np.zeros(3, F), np.maximum(1.0 - ins["Color"], 0.0) * d)}


def _coefficients(node, ins, ev):
    s = np.maximum(ins["Scatter Coefficients"], 0.0)
    a = np.maximum(ins["Absorption Coefficients"], 0.0)
    e = np.maximum(ins.get("Emission Coefficients", np.zeros(3, F)), 0.0)
    return {"Volume": Closure(s, a, e, ins.get("Anisotropy", 0.0) * _mean3(s))}


def _emission(node, ins, ev):
    strength = np.asarray(ins["Strength"])[..., None]
    return {"Emission": Closure(emission=ins["Color"] * strength)}


def _background(node, ins, ev):
    """A world's Background: its radiance, as an emission."""
    return {"Background": _emission(node, ins, ev)["Emission"]}


def _add_shader(node, ins, ev):
    a, b = ins.get("Shader"), ins.get("Shader_001")
    parts = [c for c in (a, b) if c is not None]
    return {"Shader": sum(parts[1:], parts[0]) if parts else None}


def _mix_shader(node, ins, ev):
    f = np.clip(ins["Fac"], 0.0, 1.0)
    a, b = ins.get("Shader"), ins.get("Shader_001")
    parts = ([a.scaled(1.0 - f)] if a is not None else []) + ([b.scaled(f)] if b is not None else [])
    return {"Shader": sum(parts[1:], parts[0]) if parts else None}


NODES: dict[str, Callable] = {
    "ATTRIBUTE": _attribute, "VOLUME_INFO": _volume_info, "VALUE": _value, "RGB": _rgb,
    "MATH": _math, "VECTOR_MATH": _vector_math, "MAP_RANGE": _map_range, "CLAMP": _clamp,
    "COLOR_RAMP": _color_ramp,
    "FLOAT_CURVE": _float_curve, "MIX": _mix, "INVERT": _invert, "GAMMA": _gamma,
    "RGB_TO_BW": _rgb_to_bw, "SEPARATE": _separate, "COMBINE": _combine, "BLACKBODY": _blackbody,
    "TEX_COORD": _tex_coord, "MAPPING": _mapping, "TEX_NOISE": _tex_noise,
    "TEX_GRADIENT": _tex_gradient, "TEX_WHITE_NOISE": _tex_white_noise, "TEX_VORONOI": _tex_voronoi,
    "TEX_WAVE": _tex_wave, "TEX_CHECKER": _tex_checker, "TEX_IMAGE": _tex_image, "UV_MAP": _uv_map,
    "TEX_ENVIRONMENT": _tex_environment, "LIGHT_PATH": _light_path,
    "PRINCIPLED_VOLUME": _principled, "VOLUME_SCATTER": _scatter, "VOLUME_ABSORPTION": _absorption,
    "VOLUME_COEFFICIENTS": _coefficients, "EMISSION": _emission, "BACKGROUND": _background,
    "ADD_SHADER": _add_shader,
    "MIX_SHADER": _mix_shader,
}


# ---- from per-voxel fields to the renderer's medium ---------------------------------------------

CHUNK = 1 << 20         # voxels evaluated at once (bounds the evaluation's memory)


@dataclass(frozen=True)
class Resolved:
    """A shader evaluated over a lattice as the renderer's Medium fields: ``density`` (nx, ny, nz)
    the extinction's mean over the channels, ``sigma_a``/``sigma_s`` per unit density,
    ``color`` (nx, ny, nz, 3) the scattering colour relative to them where it varies (else None),
    ``emission`` (nx, ny, nz, 3) the emitted radiance per metre (None: none), ``anisotropy``,
    ``notes`` what is approximated."""

    density: np.ndarray
    sigma_a: tuple
    sigma_s: tuple
    anisotropy: float
    color: np.ndarray | None
    emission: np.ndarray | None
    notes: tuple[str, ...] = ()


def _voxel_positions(shape, index_to_object: np.ndarray, start: int, stop: int) -> np.ndarray:
    idx = np.stack(np.unravel_index(np.arange(start, stop), shape), axis=-1).astype(np.float64)
    m = np.asarray(index_to_object, np.float64)
    return idx @ m[:3, :3].T + m[:3, 3]


def upsample(a: np.ndarray, factor: int) -> np.ndarray:
    """A grid (nx, ny, nz[, c]) trilinearly interpolated onto a lattice ``factor`` times finer: fine
    voxel i of an axis sits at coarse index (i + 0.5) / factor - 0.5, and the grid is 0 one voxel
    beyond its outermost centres (as the renderer's textures are)."""
    out = np.asarray(a, F)
    for axis in range(3):
        n = out.shape[axis]
        x = (np.arange(n * factor, dtype=np.float64) + 0.5) / factor - 0.5
        i0 = np.floor(x).astype(np.int64)
        w = (x - i0).astype(F)
        pad = [(0, 0)] * out.ndim
        pad[axis] = (1, 1)
        padded = np.pad(out, pad)               # coarse index j at j + 1
        lo = np.take(padded, i0 + 1, axis=axis)
        hi = np.take(padded, i0 + 2, axis=axis)
        shape = [1] * out.ndim
        shape[axis] = len(w)
        w = w.reshape(shape)
        out = lo + w * (hi - lo)
    return out


def fine_to_coarse(factor: int) -> np.ndarray:
    """The matrix from a ``factor`` times finer lattice's indices to the coarse one's (upsample)."""
    m = np.diag([1.0 / factor] * 3 + [1.0])
    m[:3, 3] = 0.5 / factor - 0.5
    return m


def resolve(graph: ShaderGraph, grids: Mapping[str, np.ndarray], shape: tuple[int, int, int],
            index_to_object: np.ndarray | None = None, mask: np.ndarray | None = None,
            label: str = "", supersample: int = 1) -> Resolved:
    """Evaluate ``graph`` at every voxel of a lattice of ``shape`` whose grids (on that lattice)
    are ``grids``; ``index_to_object`` places voxel centres in object space (Texture Coordinate);
    ``mask`` (shape, bool): where the volume is (Cycles renders nothing outside its volume mesh).
    ``supersample`` > 1 evaluates on a lattice that many times finer per axis, the grids
    interpolated onto it as Cycles interpolates them before its nodes (the result is on that
    lattice: ``fine_to_coarse``; ``mask`` may be given on either). Evaluated ``CHUNK`` voxels at
    a time."""
    if supersample > 1:
        f = int(supersample)
        grids = {k: upsample(v, f) for k, v in grids.items()}
        if mask is not None and np.shape(mask) == tuple(shape):     # a coarse mask: nearest voxel
            mask = np.asarray(mask, bool).repeat(f, 0).repeat(f, 1).repeat(f, 2)
        index_to_object = (np.eye(4) if index_to_object is None else index_to_object) @ fine_to_coarse(f)
        shape = tuple(int(n) * f for n in shape)
    n = int(np.prod(shape))
    flat = {k: np.asarray(v).reshape(n, -1) for k, v in grids.items()}
    flat = {k: (v[:, 0] if v.shape[1] == 1 else v[:, :3]) for k, v in flat.items()}
    m = np.eye(4) if index_to_object is None else index_to_object
    t = np.empty((n, 3), np.float32)
    s = np.empty((n, 3), np.float32)
    e = np.empty((n, 3), np.float32)
    g_sum = 0.0
    g_lo, g_hi = np.inf, -np.inf
    for start in range(0, n, CHUNK):
        stop = min(n, start + CHUNK)
        pos = _voxel_positions(shape, m, start, stop) if graph.reads_position else None
        f = evaluate(graph, {k: v[start:stop] for k, v in flat.items()}, stop - start, pos)
        t[start:stop] = np.maximum(f.sigma_a + f.sigma_s, 0.0)
        s[start:stop] = np.maximum(f.sigma_s, 0.0)
        e[start:stop] = f.emission
        w = _mean3(f.sigma_s)
        g_sum += float((f.anisotropy * w).sum())
        if (w > 0).any():
            g_lo = min(g_lo, float(f.anisotropy[w > 0].min()))
            g_hi = max(g_hi, float(f.anisotropy[w > 0].max()))
    if mask is not None:
        out = ~np.asarray(mask, bool).reshape(n)
        t[out], s[out], e[out] = 0.0, 0.0, 0.0
    notes = []
    density = _mean3(t)
    total = float(density.sum(dtype=np.float64))
    k = np.ones(3) if total <= 0.0 else t.sum(axis=0, dtype=np.float64) / total
    d_max = float(density.max(initial=0.0))
    live = density > 1e-3 * d_max
    grey = float(np.abs(t - density[:, None] * k.astype(np.float32)).max(initial=0.0)) <= 0.01 * d_max
    if not grey:
        notes.append(f"{label}the extinction's colour varies over the volume; it is rendered with its "
                     f"mean colour")
    albedo = np.zeros_like(s)
    np.divide(s, density[:, None] * k.astype(np.float32), out=albedo, where=live[:, None])
    lo = np.where(live[:, None], albedo, np.float32(np.inf)).min(axis=0)
    hi = np.where(live[:, None], albedo, np.float32(-np.inf)).max(axis=0)
    color = None
    if live.any() and float((hi - lo).max()) > 1e-4:
        sigma_s, sigma_a = tuple(k), (0.0, 0.0, 0.0)
        color = albedo.reshape(*shape, 3)
    else:
        c = (albedo.sum(axis=0, dtype=np.float64) / max(int(live.sum()), 1)) if live.any() else np.zeros(3)
        sigma_s, sigma_a = tuple(k * c), tuple(k * (1.0 - c))
    s_total = float(_mean3(s).sum(dtype=np.float64))
    g = g_sum / s_total if s_total > 0.0 else 0.0
    if g_hi - g_lo > 1e-3:
        notes.append(f"{label}the anisotropy varies over the volume ({g_lo:.2f} to {g_hi:.2f}); it is "
                     f"rendered with its mean {g:.2f}")
    emission = e.reshape(*shape, 3) if np.any(e != 0.0) else None
    if emission is not None and np.any(e < 0.0):
        emission = np.maximum(emission, 0.0)
    if emission is not None and not live.any():
        # emission alone: the renderer draws a medium where its density is, so the emitting
        # voxels get an extinction of 1e-9 per metre (a transmittance change below 1e-8)
        density = np.where(np.any(e > 0.0, axis=1), np.float32(1e-9), np.float32(0.0))
        sigma_s, sigma_a = (0.0, 0.0, 0.0), (1.0, 1.0, 1.0)
    return Resolved(density.reshape(shape), tuple(float(x) for x in sigma_a),
                    tuple(float(x) for x in sigma_s), float(np.clip(g, -0.99, 0.99)), color, emission,
                    tuple(notes))


# ---- media whose graph is evaluated on the render thread ----------------------------------------

@dataclass(frozen=True, eq=False)
class ShaderSource:
    """What a medium's node graph is evaluated from, handed to the renderer unevaluated so that the
    evaluation runs on the render thread, not the host's: ``grids`` (by name, on one lattice of
    ``grid_shape``), ``pad`` zero voxels (before, after) per axis that widen it to the lattice the
    graph fills (Cycles' volume bounds), ``index_to_object`` the widened lattice's indices to
    object space, ``bounds`` where the volume is in the widened lattice's index space (None:
    everywhere), ``coverage`` (a mesh medium: the fraction of each voxel inside, multiplying the
    result), ``clip`` (grid name, value) grid values below which read 0, ``supersample`` the finer
    lattice's factor, ``key`` what all that depends on (the grids' source, the graph, the
    settings), ``label`` the medium's name for the report, ``density_scale`` a factor on the
    coefficients and the emission (Volume ▸ Render ▸ Space Object)."""

    graph: ShaderGraph
    grids: Mapping[str, np.ndarray]
    grid_shape: tuple[int, int, int]
    key: str
    index_to_object: np.ndarray = field(default_factory=lambda: np.eye(4))
    pad: tuple = ((0, 0), (0, 0), (0, 0))
    bounds: GlowBlocks | None = None
    coverage: np.ndarray | None = None
    clip: tuple[str, float] | None = None
    supersample: int = 1
    label: str = ""
    density_scale: float = 1.0

    @property
    def shape(self) -> tuple[int, int, int]:
        return tuple(int(n + a + b) for n, (a, b) in zip(self.grid_shape, self.pad, strict=True))


def pending_medium(source: ShaderSource, matrix_world: np.ndarray, name: str = "Medium") -> Medium:
    """A medium to be evaluated by ``resolve_scene``: a one-voxel stand-in placed on the lattice."""
    return Medium(density=np.zeros((1, 1, 1), np.float32), name=name, shader=source,
                  index_to_world=np.asarray(matrix_world, np.float64) @ source.index_to_object,
                  source_key=source.key)


RESOLVED_KEPT = 8
_RESOLVED = caches.memo("shading.evaluated graphs", RESOLVED_KEPT)   # ShaderSource.key -> Resolved
EVALUATIONS: Counter = Counter()             # "count" and the threads that evaluated (tests)


def _evaluate_source(src: ShaderSource) -> Resolved:
    grids = dict(src.grids)
    if src.clip is not None and src.clip[0] in grids:
        g = np.asarray(grids[src.clip[0]])
        grids[src.clip[0]] = np.where(g < src.clip[1], np.float32(0.0), g)
    if any(a or b for a, b in src.pad):
        grids = {k: np.pad(np.asarray(g), list(src.pad) + [(0, 0)] * (np.ndim(g) - 3))
                 for k, g in grids.items()}
    f = max(1, int(src.supersample))
    shape = src.shape
    mask = None
    if src.bounds is not None:
        axes = [(np.arange(n * f) + 0.5) / f - 0.5 for n in shape]
        idx = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
        mask = src.bounds.contains(idx).reshape(tuple(n * f for n in shape))
    label = f"{src.label}: " if src.label else ""
    r = resolve(src.graph, grids, shape, src.index_to_object, mask, label=label, supersample=f)
    if src.coverage is not None:
        c = upsample(src.coverage, f) if f > 1 else np.asarray(src.coverage, F)
        emission = None if r.emission is None else r.emission * c[..., None]
        r = replace(r, density=r.density * c, emission=emission)
    return r


def resolve_medium(medium: Medium) -> Medium:
    """``medium`` with its node graph evaluated (itself when it has none); the evaluation is kept
    by the source's key, so a frame that follows an edit of anything else evaluates nothing."""
    src = getattr(medium, "shader", None)
    if src is None:
        return medium
    r = _RESOLVED.get(src.key)
    if r is None:
        r = _evaluate_source(src)
        EVALUATIONS["count"] += 1
        EVALUATIONS[threading.current_thread().name] += 1
        _RESOLVED.put(src.key, r)
    f = max(1, int(src.supersample))
    to_world = medium.index_to_world @ (fine_to_coarse(f) if f > 1 else np.eye(4))
    grids, fields = {}, {}
    if r.color is not None:
        grids["__color"] = r.color
        fields["color_grid"] = "__color"
    if r.emission is not None:
        grids["__emission"] = r.emission
        fields["emission_grid"] = "__emission"
    k = float(src.density_scale)
    return Medium(density=r.density, index_to_world=to_world, grids=grids,
                  sigma_a=tuple(k * c for c in r.sigma_a), sigma_s=tuple(k * c for c in r.sigma_s),
                  blackbody_tint=(k, k, k), anisotropy=r.anisotropy, name=medium.name,
                  source_key=src.key, lights_surfaces=medium.lights_surfaces,
                  lights_medium=medium.lights_medium, **fields)


def resolve_scene(scene: Scene) -> Scene:
    """The scene with every medium's node graph evaluated (the same object when none has one)."""
    if not any(getattr(m, "shader", None) is not None for m in scene.media):
        return scene
    return replace(scene, media=tuple(resolve_medium(m) for m in scene.media))


def notes(scene: Scene) -> list[str]:
    """What the evaluations of the scene's media approximated, one line each (for the report)."""
    out = []
    for m in scene.media:
        r = _RESOLVED.get(m.source_key) if m.source_key is not None else None
        if r is not None:
            out.extend(r.notes)
    return out

