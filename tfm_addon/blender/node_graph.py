"""A material's volume node graph compiled into the engine's ``shading.ShaderGraph``.

The walk starts at the Cycles output's Volume socket and follows links backwards (through reroutes
and muted nodes' pass-throughs). Each node type the engine evaluates has a row in ``KINDS``: its
engine kind and how its parameters are read. A node without a row is named once in the graph's
notes and the socket it feeds reads its own default value, so the rest of the graph still renders.
Colour ramps and float curves are baked into 256-entry tables as Cycles bakes them.
"""

from __future__ import annotations

import numpy as np

from ..engine import shading
from ..engine.scene import _digest as digest
from ..engine.shading import Input, Link, Node, ShaderGraph
from . import files
from .materials import output_node

RAMP_TABLE_SIZE = 256    # Cycles' RAMP_TABLE_SIZE


def _ramp(node) -> tuple:
    ramp = node.color_ramp
    table = [tuple(ramp.evaluate(i / (RAMP_TABLE_SIZE - 1))) for i in range(RAMP_TABLE_SIZE)]
    return (("table", tuple(v for rgba in table for v in rgba)),
            ("interpolate", ramp.interpolation != 'CONSTANT'))


def _curve(node) -> tuple:
    mapping = node.mapping
    mapping.initialize()
    curve = mapping.curves[0]
    xs = [p.location[0] for p in curve.points]
    lo, hi = (min(xs), max(xs)) if xs and max(xs) > min(xs) else (0.0, 1.0)
    table = tuple(mapping.evaluate(curve, lo + (hi - lo) * i / (RAMP_TABLE_SIZE - 1))
                  for i in range(RAMP_TABLE_SIZE))
    return (("table", table), ("range", (lo, hi)))


def _strings(*names):
    def read(node):
        return tuple((n.lower().replace(" ", "_"), str(node.inputs[n].default_value))
                     for n in names if n in node.inputs)
    return read


def _props(*names):
    def read(node):
        return tuple((n, getattr(node, n)) for n in names)
    return read


# bl_idname -> (engine kind, parameters read from the node)
KINDS = {
    'ShaderNodeAttribute': ("ATTRIBUTE", lambda n: (("name", n.attribute_name),)),
    'ShaderNodeVolumeInfo': ("VOLUME_INFO", None),
    'ShaderNodeValue': ("VALUE", lambda n: (("value", float(n.outputs[0].default_value)),)),
    'ShaderNodeRGB': ("RGB", lambda n: (("color", tuple(float(v) for v in n.outputs[0].default_value[:3])),)),
    'ShaderNodeMath': ("MATH", _props("operation", "use_clamp")),
    'ShaderNodeVectorMath': ("VECTOR_MATH", _props("operation")),
    'ShaderNodeMapRange': ("MAP_RANGE", _props("interpolation_type", "clamp")),
    'ShaderNodeClamp': ("CLAMP", _props("clamp_type")),
    'ShaderNodeValToRGB': ("COLOR_RAMP", _ramp),
    'ShaderNodeFloatCurve': ("FLOAT_CURVE", _curve),
    'ShaderNodeMix': ("MIX", _props("data_type", "blend_type", "clamp_factor", "clamp_result")),
    'ShaderNodeMixRGB': ("MIX", lambda n: (("data_type", "RGBA"), ("blend_type", n.blend_type),
                                           ("clamp_factor", True), ("clamp_result", n.use_clamp))),
    'ShaderNodeInvert': ("INVERT", None),
    'ShaderNodeGamma': ("GAMMA", None),
    'ShaderNodeRGBToBW': ("RGB_TO_BW", None),
    'ShaderNodeSeparateColor': ("SEPARATE", None),
    'ShaderNodeCombineColor': ("COMBINE", None),
    'ShaderNodeSeparateXYZ': ("SEPARATE", None),
    'ShaderNodeCombineXYZ': ("COMBINE", None),
    'ShaderNodeBlackbody': ("BLACKBODY", None),
    'ShaderNodeTexCoord': ("TEX_COORD", None),
    'ShaderNodeMapping': ("MAPPING", _props("vector_type")),
    'ShaderNodeTexNoise': ("TEX_NOISE", _props("noise_type", "normalize")),
    'ShaderNodeTexGradient': ("TEX_GRADIENT", _props("gradient_type")),
    'ShaderNodeTexWhiteNoise': ("TEX_WHITE_NOISE", None),
    'ShaderNodeTexVoronoi': ("TEX_VORONOI", _props("feature", "distance", "normalize")),
    'ShaderNodeTexWave': ("TEX_WAVE", _props("wave_type", "bands_direction", "rings_direction",
                                             "wave_profile")),
    'ShaderNodeTexChecker': ("TEX_CHECKER", None),
    'ShaderNodeTexImage': ("TEX_IMAGE", lambda n: (("image", image_key(n.image, n.image_user)),
                                                   ("interpolation", n.interpolation),
                                                   ("extension", n.extension))),
    'ShaderNodeUVMap': ("UV_MAP", None),
    'ShaderNodeTexEnvironment': ("TEX_ENVIRONMENT", lambda n: (
        ("image", image_key(n.image, n.image_user, ENVIRONMENT_WIDTH)), ("interpolation", n.interpolation))),
    'ShaderNodeVolumePrincipled': ("PRINCIPLED_VOLUME",
                                   _strings("Density Attribute", "Color Attribute", "Temperature Attribute")),
    'ShaderNodeVolumeScatter': ("VOLUME_SCATTER", None),
    'ShaderNodeVolumeAbsorption': ("VOLUME_ABSORPTION", None),
    'ShaderNodeVolumeCoefficients': ("VOLUME_COEFFICIENTS", None),
    'ShaderNodeEmission': ("EMISSION", None),
    'ShaderNodeBackground': ("BACKGROUND", None),    # the world's: radiance Color x Strength
    # a surface's closures (blender/surfaces.py reads them into engine/surface.Surface)
    'ShaderNodeBsdfPrincipled': ("PRINCIPLED_BSDF", _props("distribution")),
    'ShaderNodeBsdfDiffuse': ("DIFFUSE_BSDF", None),
    'ShaderNodeBsdfGlossy': ("GLOSSY_BSDF", _props("distribution")),
    'ShaderNodeBsdfAnisotropic': ("GLOSSY_BSDF", _props("distribution")),   # the Glossy BSDF's type since 4.0
    'ShaderNodeLightPath': ("LIGHT_PATH", None),
    'ShaderNodeAddShader': ("ADD_SHADER", None),
    'ShaderNodeMixShader': ("MIX_SHADER", None),
}


SURFACE_ONLY = {'ShaderNodeTexImage', 'ShaderNodeUVMap',   # they read UV coordinates
                'ShaderNodeBsdfPrincipled', 'ShaderNodeBsdfDiffuse', 'ShaderNodeBsdfGlossy',
                'ShaderNodeBsdfAnisotropic', 'ShaderNodeLightPath'}
WORLD_ONLY = {'ShaderNodeTexEnvironment'}                   # it reads the world's direction
IMAGE_NODES = {'ShaderNodeTexImage', 'ShaderNodeTexEnvironment'}
# the closures blender/surfaces.py reads, and their inputs it does not (kept as their own values, a
# link named by the closure's "linked" parameter)
CLOSURES = {"PRINCIPLED_BSDF", "DIFFUSE_BSDF", "GLOSSY_BSDF", "EMISSION", "MIX_SHADER"}
GEOMETRY_INPUTS = {"Normal", "Tangent", "Coat Normal"}
ENVIRONMENT_WIDTH = 4096    # an environment image is read averaged down to at most this wide: the
#                             widest the background is drawn from (environment.PANORAMA_WIDTHS)


MISSING_IMAGE = "missing image"    # the key of an image without pixels: never registered, so the
#                                    engine shades it in Cycles' missing-texture pink


def image_key(image, image_user=None, max_width: int | None = None) -> str:
    """An image's key (the image, its name, size, dirty flag, file); its pixels are read once per key into
    ``shading.IMAGES`` (averaged down by a power of two to at most ``max_width`` wide). An image
    whose file is missing or gives no pixels (files.image_problem) has the key MISSING_IMAGE,
    which the engine renders in Cycles' missing-texture pink."""
    if image is None:
        return ""
    if files.image_problem("", image, files.scene_frame(), image_user) is not None:
        return MISSING_IMAGE
    w, h = image.size
    f = 1 if max_width is None or w <= max_width else 2 ** int(np.ceil(np.log2(w / max_width)))
    # the image itself (two images of one name and size, one freed and one made, are not one),
    # its name, size, dirty flag and file
    key = digest("image", image.as_pointer(), image.name, tuple(image.size), bool(image.is_dirty),
                 image.filepath, f)
    if key not in shading.IMAGES:
        px = np.empty(w * h * image.channels, np.float32)
        image.pixels.foreach_get(px)
        px = px.reshape(h, w, image.channels)
        if image.channels != 4:
            px = np.concatenate([px[..., :3] if image.channels >= 3 else np.repeat(px[..., :1], 3, -1),
                                 np.ones((h, w, 1), np.float32)], -1)
        srgb = not image.is_float and image.colorspace_settings.name == 'sRGB'
        if f > 1:       # averaged in linear light, as Cycles adds it up
            if srgb:
                px = np.concatenate([shading.srgb_to_linear(px[..., :3]), px[..., 3:]], axis=-1)
                srgb = False
            px = shading.area_resize(px, max(1, round(h / f)), max(1, round(w / f)))
        shading.register_image(key, px, srgb)
    return key


def _missing(node) -> bool:
    """Whether an image node's image is set but cannot give its pixels (image_key: MISSING_IMAGE)."""
    return node.image is not None and image_note(node) is not None


def image_note(node, owner: str = "") -> str | None:
    """The report line of an Image or Environment Texture ``node`` whose image cannot give its
    pixels this frame (files.image_problem; the owner is the material or world named by the
    caller, ``owner`` what goes between), else None."""
    image = getattr(node, "image", None)
    if image is None:
        return None
    return files.image_problem(f"{owner}node '{node.name}'", image, files.scene_frame(),
                               getattr(node, "image_user", None))


def _unsupported_setting(node, surface: bool = False, world: bool = False) -> str | None:
    """Why a node of a known type cannot be evaluated as set, or None. (An Image Texture whose
    image is missing is evaluated anywhere: Cycles' missing-texture pink, whatever the
    coordinates.)"""
    kind = node.bl_idname
    if kind in WORLD_ONLY and not world:
        return "outside a world"
    if kind in IMAGE_NODES and _missing(node):
        return None
    if kind in SURFACE_ONLY and not surface:
        return "in a volume" if not world else "in a world"
    if kind in IMAGE_NODES and node.image is None:
        return "without an image"
    if kind == 'ShaderNodeTexImage' and node.projection != 'FLAT':
        return f"with {node.projection.lower()} projection"
    if kind == 'ShaderNodeTexEnvironment' and node.projection != 'EQUIRECTANGULAR':
        return f"with {node.projection.replace('_', ' ').lower()} projection"
    if kind == 'ShaderNodeAttribute' and node.attribute_type != 'GEOMETRY':
        return f"of type {node.attribute_type}"
    if kind == 'ShaderNodeVectorMath' and node.operation in ('REFRACT',):
        return f"({node.operation.lower()})"
    if kind == 'ShaderNodeTexCoord' and node.object is not None:
        return f"relative to object '{node.object.name}'"
    if kind == 'ShaderNodeMapRange' and node.data_type != 'FLOAT':
        return "with vector values"
    if kind in ('ShaderNodeSeparateColor', 'ShaderNodeCombineColor') and node.mode != 'RGB':
        return f"in {node.mode} mode"
    if kind in ('ShaderNodeTexNoise', 'ShaderNodeTexWhiteNoise') and node.noise_dimensions != '3D':
        return f"in {node.noise_dimensions}"
    if kind == 'ShaderNodeTexVoronoi' and (node.voronoi_dimensions != '3D'
                                           or node.feature not in ('F1', 'F2')):
        return f"({node.voronoi_dimensions}, {node.feature.replace('_', ' ').lower()})"
    if kind == 'ShaderNodeMix' and node.data_type not in ('FLOAT', 'VECTOR', 'RGBA'):
        return f"with {node.data_type.lower()} values"
    if kind in ('ShaderNodeMix', 'ShaderNodeMixRGB') and node.blend_type in (
            'HUE', 'SATURATION', 'VALUE', 'COLOR'):
        return f"in {node.blend_type.lower()} mode"
    return None


_MIX_SOCKETS = {'FLOAT': ("Factor_Float", "A_Float", "B_Float"),
                'VECTOR': ("Factor_Float", "A_Vector", "B_Vector"),
                'RGBA': ("Factor_Float", "A_Color", "B_Color")}


def _inputs(node):
    """(engine socket name, Blender socket) for the node's inputs the engine reads."""
    kind = node.bl_idname
    if kind == 'ShaderNodeMath':
        return list(zip(("A", "B", "C"), node.inputs, strict=False))
    if kind == 'ShaderNodeMix':
        f, a, b = _MIX_SOCKETS[node.data_type]
        if node.data_type == 'VECTOR' and node.factor_mode == 'NON_UNIFORM':
            f = "Factor_Vector"
        by_id = {s.identifier: s for s in node.inputs}
        return [("Factor", by_id[f]), ("A", by_id[a]), ("B", by_id[b])]
    if kind == 'ShaderNodeMixRGB':
        return [("Factor", node.inputs["Fac"]), ("A", node.inputs["Color1"]), ("B", node.inputs["Color2"])]
    texture = node.bl_idname.startswith('ShaderNodeTex')
    return [(s.identifier, s) for s in node.inputs if s.enabled and s.type != 'STRING'
            and not (texture and s.identifier == "Vector" and not s.is_linked)]   # unlinked: Generated


def _output_name(node, socket) -> str:
    """The engine's name of an output: its identifier (the Mix node's typed results are "Result")."""
    if node.bl_idname == 'ShaderNodeMix' and socket.identifier.startswith("Result"):
        return "Result"
    return socket.identifier


def _constant(socket):
    v = getattr(socket, "default_value", 0.0)
    if hasattr(v, "__len__"):
        return tuple(float(x) for x in v[:3])
    return float(v)


class _Compiler:
    def __init__(self, surface: bool = False, owner: str = "", world: bool = False):
        self.surface = surface       # a surface's graph: UV coordinates exist
        self.world = world           # a world's graph: the coordinates are the direction
        self.owner = owner           # what the notes of a missing image name before the node
        self.nodes: list[Node] = []
        self.index: dict = {}        # Blender node -> its number in ``nodes``
        self.notes: dict[str, None] = {}
        self.explained: set[int] = set()     # nodes whose note says why they are not read

    def source(self, socket):
        """(node, output socket) feeding ``socket``, through reroutes and muted nodes."""
        while socket.is_linked:
            link = socket.links[0]
            if link.is_muted or not link.is_valid:
                return None, None
            node, out = link.from_node, link.from_socket
            if node.bl_idname == 'NodeReroute':
                socket = node.inputs[0]
                continue
            if node.mute:
                through = [lk.from_socket for lk in node.internal_links if lk.to_socket == out]
                if not through:
                    return None, None
                socket = through[0]
                continue
            return node, out
        return None, None

    def input(self, name: str, socket) -> Input:
        node, out = self.source(socket)
        kind = socket.type
        if node is None:
            return Input(name, kind, 0.0 if kind == 'SHADER' else _constant(socket))
        index = self.node(node)
        if index is None and self.surface and kind == 'SHADER':     # a surface's unknown closure
            return Input(name, kind, Link(self.unread_shader(node), "Shader", "SHADER"))
        if index is None:
            if node.as_pointer() not in self.explained:      # one line a node, its reason when known
                self.notes.setdefault(f"node '{node.name}' ({node.bl_label}) is not read by the engine; "
                                      f"'{socket.name}' of '{socket.node.name}' reads its own value", None)
            return Input(name, kind, 0.0 if kind == 'SHADER' else _constant(socket))
        known = ("Object", "Generated", "UV") if self.surface else ("Object", "Generated")
        if node.bl_idname == 'ShaderNodeTexCoord' and out.identifier not in known:
            where = 'on a surface' if self.surface else 'in a volume'
            self.notes.setdefault(f"the {out.name} output of '{node.name}' (Texture Coordinate) has no "
                                  f"meaning {where} here; '{socket.name}' "
                                  f"reads its own value", None)
            return Input(name, kind, _constant(socket))
        return Input(name, kind, Link(index, _output_name(node, out), out.type))

    def unread_shader(self, node) -> int:
        """A surface's shader node the engine does not read, kept as UNREAD_SHADER (its name and
        label) for blender/surfaces.py to name and stand in for."""
        self.nodes.append(Node("UNREAD_SHADER", (("label", node.bl_label),), (), node.name))
        return len(self.nodes) - 1

    def node(self, node) -> int | None:
        key = node.as_pointer()
        if key in self.index:
            return self.index[key]
        row = KINDS.get(node.bl_idname)
        why = _unsupported_setting(node, self.surface, self.world) if row is not None else None
        if row is None or why:
            missing = image_note(node, self.owner)      # e.g. an Environment Texture in a graph
            if missing is not None:
                self.notes.setdefault(missing, None)
                self.explained.add(key)
            if why:
                self.explained.add(key)
                self.notes.setdefault(f"node '{node.name}' ({node.bl_label}) {why} is not read by the "
                                      f"engine; what it feeds reads its own value", None)
            self.index[key] = None
            return None
        kind, params = row
        self.index[key] = None       # a cycle reads defaults (Blender marks such links invalid)
        phase = getattr(node, "phase", 'HENYEY_GREENSTEIN')
        if node.bl_idname in ('ShaderNodeVolumeScatter', 'ShaderNodeVolumeCoefficients') \
                and phase != 'HENYEY_GREENSTEIN':
            self.notes.setdefault(f"'{node.name}' uses the {node.phase.replace('_', ' ').title()} phase "
                                  f"function, rendered as Henyey-Greenstein with its anisotropy (0 where "
                                  f"it has none)", None)
        if kind in ("TEX_IMAGE", "TEX_ENVIRONMENT"):
            missing = image_note(node, self.owner)
            if missing is not None:
                self.notes.setdefault(missing, None)
        closure = self.surface and kind in CLOSURES
        inputs = tuple(Input(name, s.type, _constant(s)) if closure and name in GEOMETRY_INPUTS
                       else self.input(name, s) for name, s in _inputs(node))
        if kind.startswith("TEX_") and kind != "TEX_CHECKER" and not (
                node.bl_idname in IMAGE_NODES and _missing(node)):
            varying = [i.name for i in inputs if i.name != "Vector" and isinstance(i.value, Link)]
            if varying:
                self.notes.setdefault(f"'{node.name}' ({node.bl_label}): a linked {', '.join(varying)} "
                                      f"is read as its mean over the volume", None)
        values = params(node) if params else ()
        if closure:     # the sockets' own values (a linked one's beside its link), the shading normal's link
            values += (("own_values", tuple((name, _constant(s)) for name, s in _inputs(node)
                                            if s.type != 'SHADER')),
                       ("linked", tuple(name for name, s in _inputs(node)
                                        if name in GEOMETRY_INPUTS and self.source(s)[0] is not None)))
        self.nodes.append(Node(kind, values, inputs, node.name))
        self.index[key] = len(self.nodes) - 1
        return self.index[key]


def compile_volume(material, texspace=None, output: str = "Volume") -> ShaderGraph | None:
    """The material's volume shader as a ShaderGraph, or None when its output has no volume
    shader. ``texspace``: (location, size) of the object's texture space (Generated coordinates).
    ``output``: the output socket read ('Surface': a world's Background, as emission)."""
    out = output_node(material)
    if out is None:
        return None
    material_owner = getattr(material, "id_type", "") == 'MATERIAL'     # a world names itself
    c = _Compiler(owner=f"material '{material.name}', " if material_owner else "",
                  world=output == "Surface")
    node, socket = c.source(out.inputs[output])
    if node is None:
        return None
    index = c.node(node)
    if index is None:
        c.notes.setdefault(f"node '{node.name}' ({node.bl_label}) is not a volume shader the engine "
                           f"reads", None)
    link = None if index is None else Link(index, _output_name(node, socket), socket.type)
    kw = {} if texspace is None else {"texspace": tuple(tuple(float(x) for x in v) for v in texspace)}
    return ShaderGraph(tuple(c.nodes), link, tuple(c.notes), **kw)


WORLD_TEXSPACE = ((0.5, 0.5, 0.5), (0.5, 0.5, 0.5))     # a world's Generated coordinates: the direction


def compile_world(world) -> ShaderGraph | None:
    """The world's Surface (its Background read as an emission) as a ShaderGraph whose Generated
    and Object coordinates are the direction, as Cycles evaluates a world shader; None when its
    output has no Surface shader (engine/environment.py evaluates it)."""
    return compile_volume(world, texspace=WORLD_TEXSPACE, output="Surface")


def compile_surface(material, texspace=None) -> ShaderGraph | None:
    """The material's surface shader as a ShaderGraph (its output the Link to the closure feeding
    the output's Surface socket; a shader node the engine does not read is an UNREAD_SHADER node),
    or None when the Surface socket is not linked. Its closures are read by blender/surfaces.py,
    the values feeding them evaluated by engine/shading.py (``subgraph``)."""
    out = output_node(material)
    if out is None:
        return None
    c = _Compiler(surface=True)      # blender/surfaces.py names the material in its notes
    node, socket = c.source(out.inputs["Surface"])
    if node is None:
        return None
    index = c.node(node)
    link = (Link(c.unread_shader(node), "Shader", "SHADER") if index is None
            else Link(index, _output_name(node, socket), socket.type))
    kw = {} if texspace is None else {"texspace": tuple(tuple(float(x) for x in v) for v in texspace)}
    return ShaderGraph(tuple(c.nodes), link, tuple(c.notes), **kw)


def subgraph(graph: ShaderGraph, link: Link) -> ShaderGraph:
    """The part of ``graph`` that ``link`` reads (its nodes renumbered), with ``link`` its output."""
    order: list[int] = []

    def visit(i: int) -> None:
        if i in order:
            return
        for inp in graph.nodes[i].inputs:
            if isinstance(inp.value, Link):
                visit(inp.value.node)
        order.append(i)

    visit(link.node)
    new = {old: k for k, old in enumerate(order)}

    def renumber(inp: Input) -> Input:
        v = inp.value
        return Input(inp.name, inp.kind, Link(new[v.node], v.output, v.kind)) if isinstance(v, Link) else inp

    nodes = tuple(Node(n.kind, n.params, tuple(renumber(i) for i in n.inputs), n.label)
                  for n in (graph.nodes[i] for i in order))
    return ShaderGraph(nodes, Link(new[link.node], link.output, link.kind), (), graph.texspace)


def compile_socket(socket, texspace=None) -> ShaderGraph:
    """The graph feeding an input ``socket`` (of a surface shader): its output is the Link to the
    value (None when unlinked or unreadable: the socket reads its own value), evaluated by
    ``shading.evaluate_value``."""
    c = _Compiler(surface=True)
    link = None
    node, out = c.source(socket)
    if node is not None:
        value = c.input(socket.name, socket)
        link = value.value if isinstance(value.value, Link) else None
    kw = {} if texspace is None else {"texspace": tuple(tuple(float(x) for x in v) for v in texspace)}
    return ShaderGraph(tuple(c.nodes), link, tuple(c.notes), **kw)


def source(socket):
    """(node, output socket) feeding ``socket``, through reroutes and muted nodes, or (None, None)."""
    return _Compiler().source(socket)
