"""A material's surface shader read as the engine's ``Surface`` (engine/surface.py).

The walk starts at the Cycles output's Surface socket. Each shader node the engine shades has a row
in ``SHADERS``; Mix and Add Shader combine what their inputs give (``surface.mix``). An input of a
shader reads its constant value, or the value of the node graph feeding it (Value, RGB, Math, Mix,
Color Ramp, ... compiled by ``node_graph`` and evaluated by ``engine/shading.py``). What is not
read is named once in the report and rendered as said there.
"""

from __future__ import annotations

from dataclasses import replace

from ..engine import shading
from ..engine.surface import Surface, effective_ior, mix
from . import node_graph
from .materials import Unreadable, output_node, ray_value

FALLBACK = Surface.lambert((0.5, 0.5, 0.5))


class _Reader:
    def __init__(self, material, texspace=None):
        self.material = material
        self.texspace = texspace
        self.notes: dict[str, None] = {}
        self.textures: dict[str, object] = {}     # input name -> the graph of a varying one

    def note(self, line: str) -> None:
        self.notes.setdefault(f"Material '{self.material.name}': {line}", None)

    def value(self, node, name: str, varying: bool = False):
        """The input ``name`` of ``node``: its constant, or what the graph feeding it gives; a
        graph that varies over the surface (textures) is kept in ``textures`` when ``varying``
        (the constant returned is then the socket's own value), else named in the report."""
        socket = node.inputs[name]
        kind = "RGBA" if socket.type == 'RGBA' else "VECTOR" if socket.type == 'VECTOR' else "VALUE"
        graph = node_graph.compile_socket(socket, self.texspace)
        for line in graph.notes:
            self.note(line)
        v = socket.default_value
        own = tuple(float(x) for x in v[:3]) if kind != "VALUE" else float(v)
        if graph.output is None:
            return own
        if graph.reads_position or graph.grids:
            if varying:
                self.textures[name] = graph
            else:
                names = ", ".join(f"'{n.label}'" for n in graph.nodes if n.kind.startswith("TEX_"))
                self.note(f"'{name}' of '{node.name}' varies over the surface (from {names or 'its position'}"
                          f"), which is not rendered: it reads its own value")
            return own
        v = shading.evaluate_value(graph, kind, 1)[0]
        return tuple(float(x) for x in v) if kind != "VALUE" else float(v)

    def unread(self, node, names_defaults) -> None:
        """A line for each input of ``node`` set away from its default (None: linked at all)."""
        for name, default in names_defaults:
            if name not in node.inputs:
                continue
            changed = node.inputs[name].is_linked if default is None else self.value(node, name) != default
            if changed:
                self.note(f"'{name}' of '{node.name}' ({node.bl_label}) is not rendered")

    def shader(self, socket) -> Surface | None:
        """The surface the shader feeding ``socket`` gives (None: no shader)."""
        node, _ = node_graph.source(socket)
        if node is None:
            return None
        read = SHADERS.get(node.bl_idname)
        if read is None:
            self.note(f"its surface shader '{node.name}' ({node.bl_label}) is not read; rendered as a "
                      f"diffuse grey {FALLBACK.base_color[0]:g}")
            return FALLBACK
        return read(self, node)


def _principled(r: _Reader, node) -> Surface:
    r.unread(node, (("Subsurface Weight", 0.0), ("Transmission Weight", 0.0), ("Coat Weight", 0.0),
                    ("Sheen Weight", 0.0), ("Anisotropic", 0.0), ("Diffuse Roughness", 0.0),
                    ("Thin Film Thickness", 0.0), ("Normal", None)))
    try:        # the alpha shadow rays see (a surface hidden from camera rays is left out of the view)
        alpha = ray_value(node.inputs["Alpha"], camera_ray=False)
    except Unreadable:
        alpha = r.value(node, "Alpha")
    alpha = min(max(alpha, 0.0), 1.0)
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
                   multiscatter=node.distribution == 'MULTI_GGX', alpha=alpha)


def _diffuse(r: _Reader, node) -> Surface:
    if r.value(node, "Roughness") > 0.0:
        r.note(f"the Roughness of '{node.name}' (Oren-Nayar) is rendered as 0 (Lambert)")
    surface = Surface.lambert(tuple(max(c, 0.0) for c in r.value(node, "Color", varying=True)))
    return replace(surface, base_texture=r.textures.pop("Color", None))


def _glossy(r: _Reader, node) -> Surface:
    if node.distribution not in ('GGX', 'MULTI_GGX'):
        r.note(f"'{node.name}' uses the {node.distribution.replace('_', ' ').title()} distribution, "
               f"rendered as GGX")
    if r.value(node, "Anisotropy") != 0.0:
        r.note(f"the Anisotropy of '{node.name}' is not rendered")
    return Surface(base_color=tuple(max(c, 0.0) for c in r.value(node, "Color", varying=True)), metallic=1.0,
                   base_texture=r.textures.pop("Color", None),
                   roughness=min(max(r.value(node, "Roughness", varying=True), 0.0), 1.0), ior=1.0,
                   roughness_texture=r.textures.pop("Roughness", None),
                   multiscatter=node.distribution == 'MULTI_GGX', constant_fresnel=True)


def _emission(r: _Reader, node) -> Surface:
    strength = r.value(node, "Strength")
    return Surface(weight=0.0, emission=tuple(c * strength for c in r.value(node, "Color")))


def _combine(r: _Reader, parts) -> Surface:
    parts = [(f, s) for f, s in parts if s is not None]
    surface, exact = mix(parts)
    if not exact:
        r.note("mixes shaders whose settings differ: rendered as one surface of their weighted mean")
    return surface


def _mix_shader(r: _Reader, node) -> Surface:
    f = min(max(r.value(node, "Fac"), 0.0), 1.0)
    return _combine(r, [(1.0 - f, r.shader(node.inputs[1])), (f, r.shader(node.inputs[2]))])


def _add_shader(r: _Reader, node) -> Surface:
    return _combine(r, [(1.0, r.shader(node.inputs[0])), (1.0, r.shader(node.inputs[1]))])


SHADERS = {
    'ShaderNodeBsdfPrincipled': _principled,
    'ShaderNodeBsdfDiffuse': _diffuse,
    'ShaderNodeBsdfGlossy': _glossy,
    'ShaderNodeBsdfAnisotropic': _glossy,     # the Glossy BSDF's type since Blender 4.0
    'ShaderNodeEmission': _emission,
    'ShaderNodeMixShader': _mix_shader,
    'ShaderNodeAddShader': _add_shader,
}


def read_surface(material, notes: list[str] | None = None, texspace=None) -> Surface | None:
    """The material's surface, or None when it has no node surface (the caller shades the
    object's colour); lines for what is not read go to ``notes``. ``texspace``: (location, size)
    of the object's texture space (Generated coordinates)."""
    out = output_node(material)
    if out is None or not out.inputs["Surface"].is_linked:
        return None
    r = _Reader(material, texspace)
    surface = r.shader(out.inputs["Surface"])
    if surface is not None and max(surface.emission) > 0.0:
        r.note("its emission is seen but lights nothing around it (Cycles lights the scene with it)")
    if notes is not None:
        notes.extend(r.notes)
    return surface
