"""A material's surface shader read as the engine's ``Surface`` (engine/surface.py).

The material is read once, by the one node-graph reader (``node_graph.compile_surface``). Each
closure the engine shades has a row in ``SHADERS``; Mix and Add Shader combine what their inputs
give (``surface.mix``). An input of a closure reads its constant value, or the value of the part
of the graph feeding it (Value, RGB, Math, Mix, Color Ramp, Light Path, ... evaluated by
``engine/shading.py``); a part that varies over the surface (a texture) is kept as its graph where
the engine renders it. What is not read is named once in the report and rendered as said there.
"""

from __future__ import annotations

from dataclasses import replace

from ..engine import shading
from ..engine.shading import Link, Node, ShaderGraph
from ..engine.surface import Surface, effective_ior, mix
from . import node_graph

FALLBACK = Surface.lambert((0.5, 0.5, 0.5))


class _Reader:
    def __init__(self, material, graph: ShaderGraph):
        self.material = material
        self.graph = graph
        self.notes: dict[str, None] = {}
        self.textures: dict[str, object] = {}     # input name -> the graph of a varying one
        for line in graph.notes:
            self.note(line)

    def note(self, line: str) -> None:
        self.notes.setdefault(f"Material '{self.material.name}': {line}", None)

    def input(self, node: Node, name: str):
        return next((i for i in node.inputs if i.name == name), None)

    def value(self, node: Node, name: str, varying: bool = False, camera_ray: bool = True):
        """The input ``name`` of ``node``: its constant, or what the graph feeding it gives; a
        graph that varies over the surface (textures) is kept in ``textures`` when ``varying``
        (the constant returned is then the socket's own value), else named in the report."""
        inp = self.input(node, name)
        own = inp.value
        if not isinstance(own, Link):
            return tuple(float(x) for x in own) if isinstance(own, tuple) else float(own)
        sub = node_graph.subgraph(self.graph, own)
        kind = inp.kind if inp.kind in ("RGBA", "VECTOR") else "VALUE"
        if sub.reads_position or sub.grids:
            if varying:
                self.textures[name] = sub
            else:
                names = ", ".join(f"'{n.label}'" for n in sub.nodes if n.kind.startswith("TEX_"))
                self.note(f"'{name}' of '{node.label}' varies over the surface (from "
                          f"{names or 'its position'}), which is not rendered: it reads its own value")
            return self.default(node, name)
        v = shading.evaluate_value(sub, kind, 1, camera_ray=camera_ray)[0]
        return tuple(float(x) for x in v) if kind != "VALUE" else float(v)

    def default(self, node: Node, name: str):
        """A linked socket's own value (the compiler keeps a closure's as ``own_values``)."""
        return dict(node.param("own_values", ())).get(name, 0.0)

    def unread(self, node: Node, names_defaults) -> None:
        """A line for each input of ``node`` set away from its default (None: linked at all)."""
        for name, default in names_defaults:
            inp = self.input(node, name)
            if inp is None:
                continue
            linked = isinstance(inp.value, Link) or name in node.param("linked", ())
            changed = linked if default is None else self.value(node, name) != default
            if changed:
                self.note(f"'{name}' of '{node.label}' ({_TITLES.get(node.kind, node.kind)}) is not rendered")

    def shader(self, inp) -> Surface | None:
        """The surface the closure feeding input ``inp`` (or Link) gives (None: no shader)."""
        link = inp.value if hasattr(inp, "value") else inp
        if not isinstance(link, Link):
            return None
        node = self.graph.nodes[link.node]
        read = SHADERS.get(node.kind)
        if read is None:        # an unknown shader, a volume shader, a colour plugged into a shader socket
            label = node.param("label") or node.kind.replace("_", " ").title()
            self.note(f"its surface shader '{node.label}' ({label}) is not read; rendered as a "
                      f"diffuse grey {FALLBACK.base_color[0]:g}")
            return FALLBACK
        return read(self, node)


_TITLES = {"PRINCIPLED_BSDF": "Principled BSDF", "DIFFUSE_BSDF": "Diffuse BSDF", "GLOSSY_BSDF": "Glossy BSDF"}


def _principled(r: _Reader, node: Node) -> Surface:
    r.unread(node, (("Subsurface Weight", 0.0), ("Transmission Weight", 0.0), ("Coat Weight", 0.0),
                    ("Sheen Weight", 0.0), ("Anisotropic", 0.0), ("Diffuse Roughness", 0.0),
                    ("Thin Film Thickness", 0.0), ("Normal", None)))
    # the alpha shadow rays see (a surface hidden from camera rays is left out of the view)
    alpha = min(max(r.value(node, "Alpha", camera_ray=False), 0.0), 1.0)
    strength = r.value(node, "Emission Strength")
    emission = tuple(c * strength for c in r.value(node, "Emission Color"))
    return Surface(base_color=tuple(max(c, 0.0) for c in r.value(node, "Base Color", varying=True)),
                   base_texture=r.textures.pop("Base Color", None),
                   metallic=min(max(r.value(node, "Metallic", varying=True), 0.0), 1.0),
                   metallic_texture=r.textures.pop("Metallic", None),
                   roughness=min(max(r.value(node, "Roughness", varying=True), 0.0), 1.0),
                   roughness_texture=r.textures.pop("Roughness", None),
                   ior=effective_ior(r.value(node, "IOR"), r.value(node, "Specular IOR Level")),
                   specular_tint=tuple(max(c, 0.0) for c in r.value(node, "Specular Tint")),
                   emission=emission if strength > 1e-5 else (0.0, 0.0, 0.0),
                   multiscatter=node.param("distribution") == 'MULTI_GGX', alpha=alpha)


def _diffuse(r: _Reader, node: Node) -> Surface:
    if r.value(node, "Roughness") > 0.0:
        r.note(f"the Roughness of '{node.label}' (Oren-Nayar) is rendered as 0 (Lambert)")
    surface = Surface.lambert(tuple(max(c, 0.0) for c in r.value(node, "Color", varying=True)))
    return replace(surface, base_texture=r.textures.pop("Color", None))


def _glossy(r: _Reader, node: Node) -> Surface:
    distribution = node.param("distribution")
    if distribution not in ('GGX', 'MULTI_GGX'):
        r.note(f"'{node.label}' uses the {distribution.replace('_', ' ').title()} distribution, "
               f"rendered as GGX")
    if r.value(node, "Anisotropy") != 0.0:
        r.note(f"the Anisotropy of '{node.label}' is not rendered")
    return Surface(base_color=tuple(max(c, 0.0) for c in r.value(node, "Color", varying=True)), metallic=1.0,
                   base_texture=r.textures.pop("Color", None),
                   roughness=min(max(r.value(node, "Roughness", varying=True), 0.0), 1.0), ior=1.0,
                   roughness_texture=r.textures.pop("Roughness", None),
                   multiscatter=distribution == 'MULTI_GGX', constant_fresnel=True)


def _emission(r: _Reader, node: Node) -> Surface:
    strength = r.value(node, "Strength")
    return Surface(weight=0.0, emission=tuple(c * strength for c in r.value(node, "Color")))


def _combine(r: _Reader, parts) -> Surface:
    parts = [(f, s) for f, s in parts if s is not None]
    surface, exact = mix(parts)
    if not exact:
        r.note("mixes shaders whose settings differ: rendered as one surface of their weighted mean")
    return surface


def _mix_shader(r: _Reader, node: Node) -> Surface:
    f = min(max(r.value(node, "Fac"), 0.0), 1.0)
    a, b = (r.shader(r.input(node, name)) for name in ("Shader", "Shader_001"))
    return _combine(r, [(1.0 - f, a), (f, b)])


def _add_shader(r: _Reader, node: Node) -> Surface:
    return _combine(r, [(1.0, r.shader(r.input(node, name))) for name in ("Shader", "Shader_001")])


SHADERS = {
    "PRINCIPLED_BSDF": _principled,
    "DIFFUSE_BSDF": _diffuse,
    "GLOSSY_BSDF": _glossy,
    "EMISSION": _emission,
    "MIX_SHADER": _mix_shader,
    "ADD_SHADER": _add_shader,
}


def read_surface(material, notes: list[str] | None = None, texspace=None) -> Surface | None:
    """The material's surface, or None when it has no node surface (the caller shades the
    object's colour); lines for what is not read go to ``notes``. ``texspace``: (location, size)
    of the object's texture space (Generated coordinates)."""
    graph = node_graph.compile_surface(material, texspace)
    if graph is None:
        return None
    r = _Reader(material, graph)
    surface = r.shader(graph.output)
    if surface is not None and max(surface.emission) > 0.0:
        r.note("its emission is seen but lights nothing around it (Cycles lights the scene with it)")
    if notes is not None:
        notes.extend(r.notes)
    return surface
