"""The conformance suite: every Blender setting and node the engine reads, as a row rendered by
Cycles (the judge, single scattering) and by TFM.

Runs inside a process that imported ``bpy``. A row is a small scene built by code the way an artist
builds it (operators for objects and lights, so Blender's defaults apply to everything the row does
not set: Volume ▸ Render ▸ Space Object, clipping 0.001, precision Half, light radius and size, ...),
in an empty scene (``bpy.ops.wm.read_homefile(use_empty=True)``). Every scene has a camera at 64x48,
a World (black, unless the row lights with it), a dark grey (0.2) Diffuse ground that shows the
medium's shadow and,
unless the row says otherwise, a point light of 1000 W.

The manifest (``tests/data/conformance/manifest.toml``) gives every row its expected status:
'rendered' (within ``SSIM_MIN`` and ``BRIGHTNESS_TOL``, per channel for coloured media), 'reported'
(not rendered yet, with the exact substring of its render-report line, ``EXPECT``) or 'wrong'
(rendered wrongly without a word, ``WRONG``), each status but 'rendered' with its reason. Flipping
a row is changing its entry there.

References: ``scripts/make_conformance_refs.py`` stores ``tests/data/conformance/<id>.npz``;
``tests/blender/test_conformance.py`` checks the rows; ``python -m tfm_addon.bench --only
conformance`` writes docs/conformance.md.

Controls: every row has a negative control (``Row.control``), its scene with the row's subject set
back to Blender's default, which TFM must render outside the row's thresholds (unless the row is in
``WEAK_CONTROL``): ``scripts/make_conformance_refs.py --controls`` stores its figures as
``tests/data/conformance/<id>.control.json``; ``tests/blender/test_conformance_controls.py`` checks
them.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from . import readme

WIDTH, HEIGHT = 64, 48
SSIM_MIN = 0.98
BRIGHTNESS_TOL = 0.03
N = 24                      # grid voxels per side
VOXEL = 2.0 / N             # the grid spans 2 m in the base rows
REF_DIR = Path(__file__).resolve().parents[2] / "tests" / "data" / "conformance"

# TFM as the test renders it: the add-on's defaults (quality AUTO, Samples 0: 16 antialiasing samples).
TFM_SAMPLES = 0

# How each row is expected to fare, by id: tests/data/conformance/manifest.toml, one entry per row
# with its status and, for every status but 'rendered', its reason (the file's header says more).
MANIFEST = REF_DIR / "manifest.toml"


def manifest() -> dict[str, dict]:
    """The manifest's entries by row id."""
    import tomllib

    with open(MANIFEST, "rb") as f:
        return tomllib.load(f)


_EXPECTED = manifest()
# 'reported': TFM does not render the row yet and says so; the value is the exact substring of the
# render-report line the user sees (``final_render.last_messages``).
EXPECT: dict[str, str] = {k: v["report"] for k, v in _EXPECTED.items() if v["status"] == "reported"}
# 'wrong': TFM renders the row, wrongly, and says nothing: a defect this suite found. The value
# says what differs from Cycles.
WRONG: dict[str, str] = {k: v["reason"] for k, v in _EXPECTED.items() if v["status"] == "wrong"}
# Rows whose control (``Row.control``: the row's subject at Blender's default) does not fail the row
# because the setting barely changes the image in the row's scene. The value says why. Every other
# row's control must fail the row (tests/blender/test_conformance_controls.py).
WEAK_CONTROL: dict[str, str] = {k: v["control_reason"] for k, v in _EXPECTED.items()
                                if v.get("control") == "weak"}


@dataclasses.dataclass
class Row:
    id: str
    title: str
    build: Callable[[str], None]
    coloured: bool = False          # brightness compared per channel
    emissive: bool = False          # both renders: the medium lights nothing (``build``)
    bounces: int = 0                # Cycles reference at these volume bounces (the row sets them)
    transparent_bounces: int = 0    # Cycles reference at these transparent bounces (Blender's default 8)
    background: bool = False        # the world seen behind everything: Film ▸ Transparent off, both renders
    note: str = ""
    # The row's negative control, run after ``build``: the row's subject (the setting or node the
    # row is about) set back to Blender's default, or where it is the default already, the nearest
    # meaningful thing taken out. Rendered by TFM it must fail the row (``render_control``), unless
    # the row is in WEAK_CONTROL.
    control: Callable[[], None] | None = None
    control_note: str = ""          # the control's one-line description (default: its docstring)

    @property
    def control_text(self) -> str:
        """The control's one-line description: ``control_note``, else the control's docstring."""
        if self.control_note:
            return self.control_note
        doc = (self.control.__doc__ or "") if self.control is not None else ""
        return " ".join(doc.split())

    @property
    def expect(self) -> str:
        """'rendered', 'reported' or 'wrong' (see EXPECT and WRONG)."""
        return 'reported' if self.id in EXPECT else 'wrong' if self.id in WRONG else 'rendered'

    @property
    def report(self) -> str:
        """For a 'reported' row: the substring of its render-report line."""
        return EXPECT.get(self.id, "")

    @property
    def wrong(self) -> str:
        """For a 'wrong' row: what differs from Cycles."""
        return WRONG.get(self.id, "")

    @property
    def reported_image(self) -> dict:
        """For a 'reported' row, what its image must still be: ``{"same_as_control": True}`` where
        the engine ignores the row's setting (the image equals its control's, the setting left at
        its default), or ``{"ssim": s, "brightness": b}`` where it renders the setting in part (the
        documented approximation's floor against Cycles: SSIM >= s, brightness within b)."""
        entry = _EXPECTED.get(self.id, {})
        if entry.get("same_as_control"):
            return {"same_as_control": True}
        return {k: float(entry[k]) for k in ("ssim", "brightness") if k in entry}


# ---------------------------------------------------------------------------------------------
# Grids (deterministic)

def _smooth_noise(n: int, seed: int, cells: int = 5) -> np.ndarray:
    from scipy.ndimage import zoom

    rng = np.random.default_rng(seed)
    coarse = rng.standard_normal((cells, cells, cells))
    return zoom(coarse, n / cells, order=3, mode="reflect")[:n, :n, :n]


def _coords(n: int = N) -> np.ndarray:
    """(n, n, n, 3) voxel centres in [-1, 1] (x, y, z index order)."""
    i = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    return np.stack(np.meshgrid(i, i, i, indexing="ij"), axis=-1)


def density_grid(n: int = N) -> np.ndarray:
    """A lumpy smoke puff, 0 at the edges, peak about 2.5."""
    p = _coords(n)
    r = np.linalg.norm(p * np.array([1.0, 1.0, 1.15]), axis=-1)
    d = np.clip(1.0 - r / 0.92 + 0.22 * _smooth_noise(n, 7), 0.0, None) * 3.0
    d[d < 0.02] = 0.0
    return d.astype(np.float32)


def color_grid(n: int = N) -> np.ndarray:
    """A Vec3 colour varying across the puff (orange at -x, teal at +x)."""
    p = _coords(n)
    t = np.clip((p[..., 0] + 1.0) / 2.0, 0, 1)[..., None]
    c = (1 - t) * np.array([0.95, 0.45, 0.15]) + t * np.array([0.15, 0.7, 0.8])
    return (c * (density_grid(n) > 0)[..., None]).astype(np.float32)


def temperature_grid(n: int = N) -> np.ndarray:
    """Hot core (1.8, units of Temperature) cooling to 1.0 at the edge of the puff."""
    d = density_grid(n)
    return np.where(d > 0, 1.0 + 0.8 * np.clip(d / d.max(), 0, 1) ** 0.7, 0.0).astype(np.float32)


def write_grids(path: str, grids: dict[str, np.ndarray], voxel: float) -> str:
    from ..blender.scene_builder import write_vdb

    first = next(iter(grids))
    return write_vdb(path, grids[first], voxel, name=first,
                     extra_grids={k: v for k, v in grids.items() if k != first})


# ---------------------------------------------------------------------------------------------
# Scene pieces

def _world(color=(0.0, 0.0, 0.0)) -> None:
    import bpy

    world = bpy.data.worlds.new("World")
    bpy.context.scene.world = world
    if world.node_tree is None:
        world.use_nodes = True
    bg = next(n for n in world.node_tree.nodes if n.bl_idname == 'ShaderNodeBackground')
    bg.inputs["Color"].default_value = (*color, 1.0)
    world.color = color


def _camera() -> None:
    import bpy
    from mathutils import Vector

    bpy.ops.object.camera_add(location=(0.0, -7.0, 1.4))
    cam = bpy.context.object
    direction = Vector((0.0, 0.0, -0.1)) - cam.location
    cam.rotation_euler = direction.to_track_quat('-Z', 'Y').to_euler()
    scene = bpy.context.scene
    scene.camera = cam
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = WIDTH, HEIGHT, 100


def _aim(ob, target=(0.0, 0.0, 0.0)) -> None:
    from mathutils import Vector

    ob.rotation_euler = (Vector(target) - ob.location).to_track_quat('-Z', 'Y').to_euler()


def light(kind: str = 'POINT', location=(2.5, -2.5, 3.0), energy: float | None = None):
    """A light added as the Add menu adds it (Blender's default radius/size/angle), aimed at the
    origin."""
    import bpy

    bpy.ops.object.light_add(type=kind, location=location)
    ob = bpy.context.object
    ob.data.energy = energy if energy is not None else {'POINT': 1000.0, 'SPOT': 1000.0, 'SUN': 5.0,
                                                         'AREA': 1000.0}[kind]
    _aim(ob)
    return ob


def _diffuse(name: str, color=(0.8, 0.8, 0.8)):
    import bpy

    mat = bpy.data.materials.new(name)
    nt = mat.node_tree
    bsdf = nt.nodes.get("Principled BSDF")
    if bsdf is not None:
        nt.nodes.remove(bsdf)
    node = nt.nodes.new('ShaderNodeBsdfDiffuse')
    node.inputs["Color"].default_value = (*color, 1.0)
    nt.links.new(node.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
    return mat


def _ground() -> None:
    import bpy

    bpy.ops.mesh.primitive_plane_add(size=8.0, location=(0.0, 0.0, -1.25))
    bpy.context.object.data.materials.append(_diffuse("Ground", (0.2, 0.2, 0.2)))


def base(*, lights: str | None = 'POINT', world=(0.0, 0.0, 0.0), ground: bool = True) -> None:
    """Camera, World, ground and the key light."""
    _camera()
    _world(world)
    if ground:
        _ground()
    if lights:
        light(lights)


def material(name: str = "Smoke"):
    """A new material as Blender makes it, emptied but for its Material Output: (mat, nodes, output)."""
    import bpy

    mat = bpy.data.materials.new(name)
    nt = mat.node_tree
    for n in list(nt.nodes):
        if n.bl_idname != 'ShaderNodeOutputMaterial':
            nt.nodes.remove(n)
    return mat, nt, nt.nodes["Material Output"]


def principled(nt, out=None, **inputs):
    """A Principled Volume (defaults but ``inputs``, by socket name) wired to ``out``'s Volume."""
    pv = nt.nodes.new('ShaderNodeVolumePrincipled')
    for k, v in inputs.items():
        pv.inputs[k.replace("_", " ").title() if k.islower() else k].default_value = v
    if out is not None:
        nt.links.new(pv.outputs[0], out.inputs["Volume"])
    return pv


def socket(sockets, identifier: str):
    """A node socket by identifier (names repeat on nodes like Mix)."""
    return next(s for s in sockets if s.identifier == identifier)


def attribute(nt, name: str = "density"):
    node = nt.nodes.new('ShaderNodeAttribute')
    node.attribute_name = name
    return node


def math_node(nt, operation: str, a, *rest, clamp: bool = False):
    """Math ``operation`` of a socket (or constant) ``a`` and constants/sockets ``rest``."""
    node = nt.nodes.new('ShaderNodeMath')
    node.operation = operation
    node.use_clamp = clamp
    for i, v in enumerate((a, *rest)):
        if hasattr(v, "links"):
            nt.links.new(v, node.inputs[i])
        else:
            node.inputs[i].default_value = v
    return node


def volume_object(tmpdir: str, name: str = "Smoke", grids: dict | None = None, mat=None,
                  voxel: float = VOXEL, scale=(1.0, 1.0, 1.0), location=(0.0, 0.0, 0.0)):
    """A Volume object (Add ▸ Volume ▸ Empty) reading a .vdb written here, centred at
    ``location``; ``mat`` its material (None: none)."""
    import bpy

    grids = grids or {"density": density_grid()}
    path = write_grids(os.path.join(tmpdir, f"{name}.vdb"), grids, voxel)
    bpy.ops.object.volume_add(location=location)
    ob = bpy.context.object
    ob.name = name
    ob.data.filepath = path
    ob.scale = scale
    n = next(iter(grids.values())).shape[0]
    # the grid's voxel centres sit at 0 .. n-1 voxels: centre them on ``location``
    half = (n - 1) * voxel / 2.0
    ob.location = [location[i] - half * scale[i] for i in range(3)]
    if mat is not None:
        ob.data.materials.append(mat)
    return ob


def smoke_with(tmpdir: str, mat, grids: dict | None = None, **kw):
    """The base scene and the puff with material ``mat``."""
    base()
    return volume_object(tmpdir, mat=mat, grids=grids, **kw)


def cube_medium(mat, location=(0.0, 0.0, 0.0), size: float = 2.0):
    """A cube mesh (Add ▸ Mesh ▸ Cube) with a volume-only material."""
    import bpy

    bpy.ops.mesh.primitive_cube_add(size=size, location=location)
    ob = bpy.context.object
    ob.data.materials.append(mat)
    return ob


# ---------------------------------------------------------------------------------------------
# Rows

ROWS: list[Row] = []


def row(id: str, title: str, **kw):
    def wrap(fn):
        ROWS.append(Row(id=id, title=title, build=fn, **kw))
        return fn
    return wrap


# ---------------------------------------------------------------------------------------------
# Controls: each changes a built row's scene back to Blender's default in the row's subject
# (``Row.control``); its docstring is its one-line description.

def _owners():
    """The materials, then the Worlds, that have node trees."""
    import bpy

    return [o for o in (*bpy.data.materials, *bpy.data.worlds) if o.node_tree is not None]


def node_of(label: str, material: str | None = None):
    """The first node of the type the Add menu calls ``label`` ('Principled Volume') in the
    materials, then the Worlds (only in the material or World named ``material`` when given)."""
    for owner in _owners():
        if material is None or owner.name == material:
            for node in owner.node_tree.nodes:
                if node.bl_label == label:
                    return node
    raise LookupError(f"no {label} node in the scene")


def _input(node, key: str):
    """``node``'s input by identifier, else by name."""
    return next((s for s in node.inputs if s.identifier == key), None) or node.inputs[key]


def input_at_default(node, key: str) -> None:
    """``node``'s input ``key`` (an identifier or a name) unlinked and at the value it has on a new
    node of the same type."""
    tree = node.id_data
    sock = _input(node, key)
    for link in list(sock.links):
        tree.links.remove(link)
    if hasattr(sock, "default_value"):
        fresh = tree.nodes.new(node.bl_idname)
        try:
            sock.default_value = socket(fresh.inputs, sock.identifier).default_value
        finally:
            tree.nodes.remove(fresh)


def at_default(label: str, *keys: str, material: str | None = None, doc: str = ""):
    """A control: inputs ``keys`` of the first ``label`` node (``node_of``) unlinked and at their
    defaults; ``doc`` its description (default: says so)."""
    def control():
        node = node_of(label, material)
        for key in keys:
            input_at_default(node, key)
    control.__doc__ = doc or f"{label} {' and '.join(keys)} at the default{'s' if len(keys) > 1 else ''}"
    return control


def assign(target: Callable[[], object], doc: str, **values):
    """A control: ``values`` (attribute: value) set on ``target()``; ``doc`` its description."""
    def control():
        ob = target()
        for k, v in values.items():
            setattr(ob, k, v)
    control.__doc__ = doc
    return control


def light_object():
    """The scene's (first) light object."""
    import bpy

    return next(ob for ob in bpy.context.scene.objects if ob.type == 'LIGHT')


def volume(name: str | None = None):
    """The scene's (first) Volume object, or the object ``name``."""
    import bpy

    if name is not None:
        return bpy.data.objects[name]
    return next(ob for ob in bpy.context.scene.objects if ob.type == 'VOLUME')


def active_scene():
    """The scene being built."""
    import bpy

    return bpy.context.scene


def wearing(material: str):
    """The scene's (first) object with the material ``material``."""
    return next(ob for ob in active_scene().objects
                if material in {m.name for m in getattr(ob.data, "materials", ()) if m is not None})


def volume_output_unlinked():
    """The Material Output's Volume unlinked: the medium taken out (the row's shader is at its
    defaults already)"""
    out = node_of("Material Output", "Smoke")
    for link in list(out.inputs["Volume"].links):
        out.id_data.links.remove(link)


# The density chains' control: Principled Volume reading `density` straight (Blender's default).
density_chain_out = at_default(
    "Principled Volume", "Density", "Density Attribute",
    doc="Principled Volume Density and Density Attribute at their defaults (1, `density`): the node "
        "chain into Density taken out")


def _pv_row(tmpdir, grids=None, **inputs):
    mat, nt, out = material()
    principled(nt, out, **inputs)
    smoke_with(tmpdir, mat, grids)


@row("principled_default", "Principled Volume (default values)",
     control=volume_output_unlinked)
def _(tmpdir):
    _pv_row(tmpdir)


@row("volume_scatter", "Volume Scatter (Density from Attribute `density`)",
     control=at_default("Volume Scatter", "Density", doc="Volume Scatter Density at the default (1, "
                        "unlinked: the shader reads no grid)"))
def _(tmpdir):
    mat, nt, out = material()
    node = nt.nodes.new('ShaderNodeVolumeScatter')
    nt.links.new(attribute(nt).outputs["Fac"], node.inputs["Density"])
    nt.links.new(node.outputs[0], out.inputs["Volume"])
    smoke_with(tmpdir, mat)


@row("volume_absorption", "Volume Absorption (Density from Attribute `density`)",
     control=at_default("Volume Absorption", "Density", doc="Volume Absorption Density at the default "
                        "(1, unlinked: the shader reads no grid)"))
def _(tmpdir):
    mat, nt, out = material()
    node = nt.nodes.new('ShaderNodeVolumeAbsorption')
    nt.links.new(attribute(nt).outputs["Fac"], node.inputs["Density"])
    nt.links.new(node.outputs[0], out.inputs["Volume"])
    smoke_with(tmpdir, mat)


@row("add_shader", "Add Shader: Principled Volume + Volume Absorption", coloured=True,
     control=at_default("Add Shader", "Shader_001", doc="Add Shader's second input unlinked (as a new "
                        "Add Shader has it): the Volume Absorption taken out"))
def _(tmpdir):
    mat, nt, out = material()
    pv = principled(nt)
    ab = nt.nodes.new('ShaderNodeVolumeAbsorption')
    ab.inputs["Color"].default_value = (0.9, 0.6, 0.3, 1.0)
    ab.inputs["Density"].default_value = 0.5
    nt.links.new(attribute(nt).outputs["Fac"], ab.inputs["Density"])
    add = nt.nodes.new('ShaderNodeAddShader')
    nt.links.new(pv.outputs[0], add.inputs[0])
    nt.links.new(ab.outputs[0], add.inputs[1])
    nt.links.new(add.outputs[0], out.inputs["Volume"])
    smoke_with(tmpdir, mat)


@row("mix_shader", "Mix Shader, constant factor 0.3 (Principled Volume, Volume Scatter)",
     coloured=True, control=at_default("Mix Shader", "Fac"))
def _(tmpdir):
    mat, nt, out = material()
    pv = principled(nt, Color=(0.9, 0.4, 0.2, 1.0))
    sc = nt.nodes.new('ShaderNodeVolumeScatter')
    sc.inputs["Color"].default_value = (0.3, 0.5, 0.9, 1.0)
    nt.links.new(attribute(nt).outputs["Fac"], sc.inputs["Density"])
    mix = nt.nodes.new('ShaderNodeMixShader')
    mix.inputs["Fac"].default_value = 0.3
    nt.links.new(pv.outputs[0], mix.inputs[1])
    nt.links.new(sc.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], out.inputs["Volume"])
    smoke_with(tmpdir, mat)


@row("anisotropy_pos", "Principled Volume Anisotropy +0.6",
     control=at_default("Principled Volume", "Anisotropy"))
def _(tmpdir):
    _pv_row(tmpdir, Anisotropy=0.6)


@row("anisotropy_neg", "Principled Volume Anisotropy −0.4",
     control=at_default("Principled Volume", "Anisotropy"))
def _(tmpdir):
    _pv_row(tmpdir, Anisotropy=-0.4)


@row("density_5", "Principled Volume Density 5 × Density Attribute `density`",
     control=at_default("Principled Volume", "Density"))
def _(tmpdir):
    _pv_row(tmpdir, Density=5.0)


@row("color", "Principled Volume Color (constant, orange)", coloured=True,
     control=at_default("Principled Volume", "Color"))
def _(tmpdir):
    _pv_row(tmpdir, Color=(0.9, 0.45, 0.15, 1.0))


@row("absorption_color", "Principled Volume Absorption Color (blue)", coloured=True,
     control=at_default("Principled Volume", "Absorption Color"))
def _(tmpdir):
    _pv_row(tmpdir, **{"Absorption Color": (0.2, 0.45, 0.9, 1.0)})


@row("color_attribute", "Principled Volume Color Attribute from a Vec3 grid `color`", coloured=True,
     control=at_default("Principled Volume", "Color Attribute"))
def _(tmpdir):
    _pv_row(tmpdir, grids={"density": density_grid(), "color": color_grid()},
            **{"Color Attribute": "color"})


@row("emission_constant", "Principled Volume Emission Strength constant (0.3)", emissive=True,
     control=at_default("Principled Volume", "Emission Strength"))
def _(tmpdir):
    _pv_row(tmpdir, **{"Emission Strength": 0.3})


@row("emission_attribute_math", "Emission Strength from Attribute `density` → Math Multiply 0.5",
     coloured=True, emissive=True,
     control=at_default("Principled Volume", "Emission Strength", doc="Principled Volume Emission "
                        "Strength at the default (0): the chain into it taken out"))
def _(tmpdir):
    mat, nt, out = material()
    pv = principled(nt, out, **{"Emission Color": (1.0, 0.5, 0.2, 1.0)})
    mul = math_node(nt, 'MULTIPLY', attribute(nt).outputs["Fac"], 0.5)
    nt.links.new(mul.outputs[0], pv.inputs["Emission Strength"])
    smoke_with(tmpdir, mat)


@row("blackbody_grid", "Principled Volume Blackbody Intensity 1, Temperature Attribute `temperature`",
     coloured=True, emissive=True, control=at_default("Principled Volume", "Blackbody Intensity"))
def _(tmpdir):
    _pv_row(tmpdir, grids={"density": density_grid(), "temperature": temperature_grid()},
            **{"Blackbody Intensity": 1.0, "Temperature Attribute": "temperature"})


# Space Object is Blender's default: the control is the other space.
@row("space_object_scaled", "Volume ▸ Render ▸ Space Object, object scaled 0.02 (grid in cm, "
     "Density 0.02)",
     control=assign(lambda: volume().data.render, "Volume ▸ Render ▸ Space World (Space Object, the "
                    "row's, is the default): the density per world metre", space='WORLD'))
def _(tmpdir):
    mat, nt, out = material()
    principled(nt, out, Density=0.02)
    smoke_with(tmpdir, mat, voxel=VOXEL * 50.0, scale=(0.02, 0.02, 0.02))


@row("space_world_half", "Volume ▸ Render ▸ Space World, object scaled 0.5",
     control=assign(lambda: volume().data.render, "Volume ▸ Render ▸ Space at the default (Object)",
                    space='OBJECT'))
def _(tmpdir):
    mat, nt, out = material()
    principled(nt, out)
    ob = smoke_with(tmpdir, mat, voxel=VOXEL * 2.0, scale=(0.5, 0.5, 0.5))
    ob.data.render.space = 'WORLD'


def _unscaled():
    """The Volume object's scale at the default (1, 1, 1), kept centred where it was"""
    ob = volume()
    ob.location = [loc / s for loc, s in zip(ob.location, ob.scale, strict=True)]
    ob.scale = (1.0, 1.0, 1.0)


@row("scale_nonuniform", "Object scaled non-uniformly (1.4, 1, 0.6), Space Object", control=_unscaled)
def _(tmpdir):
    _pv_row_scaled(tmpdir, (1.4, 1.0, 0.6))


def _pv_row_scaled(tmpdir, scale):
    mat, nt, out = material()
    principled(nt, out)
    smoke_with(tmpdir, mat, scale=scale)


def _clipped(tmpdir, clipping: float):
    mat, nt, out = material()
    principled(nt, out)
    ob = smoke_with(tmpdir, mat)
    ob.data.render.clipping = clipping


_default_clipping = assign(lambda: volume().data.render, "Volume ▸ Render ▸ Clipping at the default (0.001)",
                           clipping=0.001)


@row("clipping", "Volume ▸ Render ▸ Clipping 0.1", control=_default_clipping)
def _(tmpdir):
    _clipped(tmpdir, 0.1)


@row("clipping_strong", "Volume ▸ Render ▸ Clipping 0.4", control=_default_clipping)
def _(tmpdir):
    _clipped(tmpdir, 0.4)


def _empty_material():
    """A new material (Blender's: a Principled BSDF surface, nothing in Volume) on the Volume object,
    which has none in the row (the default of Add ▸ Volume): the medium taken out"""
    import bpy

    volume().data.materials.append(bpy.data.materials.new("New"))


@row("no_material", "Volume object without a material (Cycles' default volume shader)",
     control=_empty_material)
def _(tmpdir):
    smoke_with(tmpdir, None)


@row("no_grid_shader", "Volume shader that reads no grid (Density Attribute empty): Cycles renders "
     "nothing", control=at_default("Principled Volume", "Density Attribute"))
def _(tmpdir):
    _pv_row(tmpdir, **{"Density Attribute": ""})


def _density_chain(tmpdir, make, grids=None):
    """Principled Volume at defaults but Density Attribute '' and Density = make(nt, grid socket)."""
    mat, nt, out = material()
    pv = principled(nt, out, **{"Density Attribute": ""})
    src = make(nt, attribute(nt).outputs["Fac"])
    nt.links.new(src, pv.inputs["Density"])
    smoke_with(tmpdir, mat, grids)


for _op, _args in (('POWER', (2.0,)), ('MINIMUM', (1.2,)), ('SMOOTH_MIN', (1.2, 0.6)),
                   ('SQRT', ()), ('SUBTRACT', (0.5,)), ('MULTIPLY', (4.0,))):
    _clamp = _op in ('SUBTRACT', 'MULTIPLY')

    def _build(tmpdir, op=_op, args=_args, clamp=_clamp):
        _density_chain(tmpdir, lambda nt, g: math_node(nt, op, g, *args, clamp=clamp).outputs[0])

    # Minimum and Smooth Min cap the density at 1.2, inside the puff's opaque core: taking the node
    # out changes the image too little to fail the row, so their control sets the Math node's values
    # back to its defaults (0.5) instead.
    _control = density_chain_out if _op not in ('MINIMUM', 'SMOOTH_MIN') else at_default(
        "Math", "Value_001", "Value_002", doc=f"Math {_op.title().replace('_', ' ')} values at the "
                                              f"defaults (0.5 for the row's {', '.join(map(str, _args))})")
    ROWS.append(Row(id=f"math_{_op.lower()}", title=f"Math {_op.title().replace('_', ' ')}"
                    f"{' ' + ', '.join(map(str, _args)) if _args else ''}{' (Clamp)' if _clamp else ''}"
                    " on `density` → Density", build=_build, control=_control))


for _interp in ('LINEAR', 'STEPPED', 'SMOOTHSTEP', 'SMOOTHERSTEP'):
    def _build(tmpdir, interp=_interp):
        def make(nt, g):
            node = nt.nodes.new('ShaderNodeMapRange')
            node.interpolation_type = interp
            node.clamp = True
            nt.links.new(g, node.inputs["Value"])
            node.inputs["From Min"].default_value = 0.2
            node.inputs["From Max"].default_value = 2.0
            node.inputs["To Min"].default_value = 0.0
            node.inputs["To Max"].default_value = 3.0
            if interp == 'STEPPED':
                node.inputs["Steps"].default_value = 4.0
            return node.outputs["Result"]
        _density_chain(tmpdir, make)

    ROWS.append(Row(id=f"map_range_{_interp.lower()}",
                    title=f"Map Range {_interp.title()} (clamp) 0.2–2 → 0–3 on `density` → Density",
                    build=_build,
                    control=density_chain_out if _interp == 'LINEAR' else
                    assign(lambda: node_of("Map Range"), "Map Range interpolation at the default (Linear)",
                           interpolation_type='LINEAR')))


def _ramp(nt, g, interp: str, colours: bool):
    """A Color Ramp of ``g``; Ease's rows use two stops far apart (the whole of the density's range
    between them, where Ease and Linear differ most), the others three."""
    node = nt.nodes.new('ShaderNodeValToRGB')
    ramp = node.color_ramp
    ramp.interpolation = interp
    ramp.elements[0].position = 0.1
    ramp.elements[1].position = 0.9
    if interp == 'EASE':
        ramp.elements[0].position, ramp.elements[1].position = 0.0, 0.6
        ramp.elements[0].color = (0.9, 0.3, 0.1, 1.0) if colours else (0.0, 0.0, 0.0, 1.0)
        ramp.elements[1].color = (0.2, 0.6, 0.95, 1.0) if colours else (1.0, 1.0, 1.0, 1.0)
    elif colours:
        ramp.elements[0].color = (0.9, 0.3, 0.1, 1.0)
        ramp.elements[1].color = (0.2, 0.6, 0.95, 1.0)
        mid = ramp.elements.new(0.5)
        mid.color = (0.95, 0.9, 0.3, 1.0)
    else:
        ramp.elements[0].color = (0.0, 0.0, 0.0, 1.0)
        ramp.elements[1].color = (1.0, 1.0, 1.0, 1.0)
        mid = ramp.elements.new(0.5)
        mid.color = (0.6, 0.6, 0.6, 1.0)
    scaled = math_node(nt, 'MULTIPLY', g, 1.0 / 3.0)
    nt.links.new(scaled.outputs[0], node.inputs["Fac"])
    return node


for _interp in ('LINEAR', 'CONSTANT', 'EASE'):
    def _build_color(tmpdir, interp=_interp):
        mat, nt, out = material()
        pv = principled(nt, out)
        node = _ramp(nt, attribute(nt).outputs["Fac"], interp, True)
        nt.links.new(node.outputs["Color"], pv.inputs["Color"])
        smoke_with(tmpdir, mat)

    def _build_density(tmpdir, interp=_interp):
        def make(nt, g):
            node = _ramp(nt, g, interp, False)
            return math_node(nt, 'MULTIPLY', node.outputs["Color"], 3.0).outputs[0]
        _density_chain(tmpdir, make)

    _linear_ramp = assign(lambda: node_of("Color Ramp").color_ramp,
                          "Color Ramp interpolation at the default (Linear)", interpolation='LINEAR')
    ROWS.append(Row(id=f"ramp_{_interp.lower()}_color", title=f"Color Ramp {_interp.title()} "
                    "(`density`/3) → Color", build=_build_color, coloured=True,
                    control=_linear_ramp if _interp != 'LINEAR' else at_default(
                        "Principled Volume", "Color", doc="Principled Volume Color at the default: the "
                        "Color Ramp taken out (its interpolation, Linear, is the default)")))
    ROWS.append(Row(id=f"ramp_{_interp.lower()}_density", title=f"Color Ramp {_interp.title()} "
                    "(`density`/3) → ×3 → Density", build=_build_density,
                    control=_linear_ramp if _interp != 'LINEAR' else density_chain_out))


@row("float_curve", "Float Curve (`density`/3, an S curve) → ×3 → Density", control=density_chain_out)
def _(tmpdir):
    def make(nt, g):
        node = nt.nodes.new('ShaderNodeFloatCurve')
        curve = node.mapping.curves[0]
        curve.points[0].location = (0.0, 0.0)
        curve.points[1].location = (1.0, 1.0)
        curve.points.new(0.3, 0.1)
        curve.points.new(0.6, 0.85)
        node.mapping.update()
        nt.links.new(math_node(nt, 'MULTIPLY', g, 1.0 / 3.0).outputs[0], node.inputs["Value"])
        return math_node(nt, 'MULTIPLY', node.outputs[0], 3.0).outputs[0]
    _density_chain(tmpdir, make)


@row("mix_float", "Mix (Float, Mix) factor 0.5 of `density` and 2.0 → Density",
     control=at_default("Mix", "B_Float", doc="Mix B at the default (0)"))
def _(tmpdir):
    def make(nt, g):
        node = nt.nodes.new('ShaderNodeMix')
        node.data_type = 'FLOAT'
        socket(node.inputs, "Factor_Float").default_value = 0.5
        nt.links.new(g, socket(node.inputs, "A_Float"))
        socket(node.inputs, "B_Float").default_value = 2.0
        return socket(node.outputs, "Result_Float")
    _density_chain(tmpdir, make)


for _blend in ('MIX', 'MULTIPLY', 'ADD'):
    def _build(tmpdir, blend=_blend):
        mat, nt, out = material()
        pv = principled(nt, out)
        node = nt.nodes.new('ShaderNodeMix')
        node.data_type = 'RGBA'
        node.blend_type = blend
        socket(node.inputs, "Factor_Float").default_value = 0.6
        socket(node.inputs, "A_Color").default_value = (0.9, 0.5, 0.2, 1.0)
        nt.links.new(attribute(nt, "color").outputs["Color"], socket(node.inputs, "B_Color"))
        nt.links.new(socket(node.outputs, "Result_Color"), pv.inputs["Color"])
        smoke_with(tmpdir, mat, {"density": density_grid(), "color": color_grid()})

    ROWS.append(Row(id=f"mix_color_{_blend.lower()}", title=f"Mix (Color, {_blend.title()}) factor 0.6 of "
                    "orange and Attribute `color` → Color", build=_build, coloured=True,
                    control=assign(lambda: node_of("Mix"), "Mix blend type at the default (Mix)",
                                   blend_type='MIX') if _blend != 'MIX' else at_default(
                        "Mix", "A_Color", doc="The Mix's A at the default (0.5 grey, for the orange; the "
                        "blend type, Mix, is the default)")))


@row("clamp", "Clamp (Min Max 0.3–1.5) on `density` → Density", control=at_default("Clamp", "Min", "Max"))
def _(tmpdir):
    def make(nt, g):
        node = nt.nodes.new('ShaderNodeClamp')
        nt.links.new(g, node.inputs["Value"])
        node.inputs["Min"].default_value = 0.3
        node.inputs["Max"].default_value = 1.5
        return node.outputs[0]
    _density_chain(tmpdir, make)


# The Invert's factor 1 is the default: the control turns it to 0 (the colour passes uninverted).
@row("invert", "Invert (factor 1) of Attribute `color` → Color", coloured=True,
     control=assign(lambda: node_of("Invert Color").inputs["Fac"], "Invert factor 0 (the row's 1 is the "
                    "default): the colour passes uninverted", default_value=0.0))
def _(tmpdir):
    mat, nt, out = material()
    pv = principled(nt, out)
    node = nt.nodes.new('ShaderNodeInvert')
    nt.links.new(attribute(nt, "color").outputs["Color"], node.inputs["Color"])
    nt.links.new(node.outputs[0], pv.inputs["Color"])
    smoke_with(tmpdir, mat, {"density": density_grid(), "color": color_grid()})


def channels_straight(separate: str, combine: str):
    """A control: the ``separate`` node's outputs wired to the ``combine`` node's inputs in order
    (the row rotates the channels)."""
    def control():
        sep, comb = node_of(separate), node_of(combine)
        for i in range(3):
            sep.id_data.links.new(sep.outputs[i], comb.inputs[i])
    control.__doc__ = f"{separate} → {combine} wired straight (the channels not rotated)"
    return control


@row("separate_combine_color", "Separate Color → Combine Color (channels rotated) of `color` → Color",
     coloured=True, control=channels_straight("Separate Color", "Combine Color"))
def _(tmpdir):
    mat, nt, out = material()
    pv = principled(nt, out)
    sep = nt.nodes.new('ShaderNodeSeparateColor')
    comb = nt.nodes.new('ShaderNodeCombineColor')
    nt.links.new(attribute(nt, "color").outputs["Color"], sep.inputs[0])
    for i, j in ((0, 1), (1, 2), (2, 0)):
        nt.links.new(sep.outputs[i], comb.inputs[j])
    nt.links.new(comb.outputs[0], pv.inputs["Color"])
    smoke_with(tmpdir, mat, {"density": density_grid(), "color": color_grid()})


@row("separate_combine_xyz", "Separate XYZ of Vector `color` → Combine XYZ (Z, X, Y) → Color",
     coloured=True, control=channels_straight("Separate XYZ", "Combine XYZ"))
def _(tmpdir):
    mat, nt, out = material()
    pv = principled(nt, out)
    sep = nt.nodes.new('ShaderNodeSeparateXYZ')
    comb = nt.nodes.new('ShaderNodeCombineXYZ')
    nt.links.new(attribute(nt, "color").outputs["Vector"], sep.inputs[0])
    for i, j in ((2, 0), (0, 1), (1, 2)):
        nt.links.new(sep.outputs[i], comb.inputs[j])
    nt.links.new(comb.outputs[0], pv.inputs["Color"])
    smoke_with(tmpdir, mat, {"density": density_grid(), "color": color_grid()})


@row("blackbody_node", "Blackbody node (1500 K) → Emission Color; Emission Strength `density`×0.5",
     coloured=True, emissive=True, control=at_default("Blackbody", "Temperature"))
def _(tmpdir):
    mat, nt, out = material()
    pv = principled(nt, out)
    bb = nt.nodes.new('ShaderNodeBlackbody')
    bb.inputs["Temperature"].default_value = 1500.0
    nt.links.new(bb.outputs[0], pv.inputs["Emission Color"])
    nt.links.new(math_node(nt, 'MULTIPLY', attribute(nt).outputs["Fac"], 0.5).outputs[0],
                 pv.inputs["Emission Strength"])
    smoke_with(tmpdir, mat)


@row("value_rgb", "Value node (2.0) → Density, RGB node → Color", coloured=True,
     control=at_default("Principled Volume", "Density", "Color", doc="Principled Volume Density and Color "
                        "at their defaults: the Value and RGB nodes taken out"))
def _(tmpdir):
    mat, nt, out = material()
    pv = principled(nt, out)
    v = nt.nodes.new('ShaderNodeValue')
    v.outputs[0].default_value = 2.0
    c = nt.nodes.new('ShaderNodeRGB')
    c.outputs[0].default_value = (0.3, 0.8, 0.5, 1.0)
    nt.links.new(v.outputs[0], pv.inputs["Density"])
    nt.links.new(c.outputs[0], pv.inputs["Color"])
    smoke_with(tmpdir, mat)


@row("volume_info", "Volume Info Density → Principled Volume Density (Density Attribute empty)",
     control=at_default("Principled Volume", "Density", doc="Principled Volume Density at the default "
                        "(1): the Volume Info taken out (Density Attribute stays empty: no grid is read)"))
def _(tmpdir):
    _density_chain(tmpdir, lambda nt, g: nt.nodes.new('ShaderNodeVolumeInfo').outputs["Density"])


@row("volume_coefficients", "Volume Coefficients: absorption (0.4, 0.5, 0.7) and scatter "
     "(0.6, 0.5, 0.3), each Vector Math Scale by `density`", coloured=True,
     control=at_default("Volume Coefficients", "Absorption Coefficients", "Scatter Coefficients"))
def _(tmpdir):
    mat, nt, out = material()
    node = nt.nodes.new('ShaderNodeVolumeCoefficients')
    node.inputs["Emission Coefficients"].default_value = (0.0, 0.0, 0.0)
    g = attribute(nt).outputs["Fac"]
    for name, value in (("Absorption Coefficients", (0.4, 0.5, 0.7)),
                        ("Scatter Coefficients", (0.6, 0.5, 0.3))):
        scale = nt.nodes.new('ShaderNodeVectorMath')
        scale.operation = 'SCALE'
        scale.inputs[0].default_value = value
        nt.links.new(g, scale.inputs["Scale"])
        nt.links.new(scale.outputs["Vector"], node.inputs[name])
    nt.links.new(node.outputs[0], out.inputs["Volume"])
    smoke_with(tmpdir, mat)


@row("volume_coefficients_mesh", "Volume Coefficients, constant (absorption 0.3, 0.35, 0.5; scatter "
     "0.5, 0.4, 0.25), on a 2 m cube mesh", coloured=True,
     control=at_default("Volume Coefficients", "Absorption Coefficients", "Scatter Coefficients"))
def _(tmpdir):
    mat, nt, out = material("Fog")
    node = nt.nodes.new('ShaderNodeVolumeCoefficients')
    node.inputs["Absorption Coefficients"].default_value = (0.3, 0.35, 0.5)
    node.inputs["Scatter Coefficients"].default_value = (0.5, 0.4, 0.25)
    node.inputs["Emission Coefficients"].default_value = (0.0, 0.0, 0.0)
    nt.links.new(node.outputs[0], out.inputs["Volume"])
    base()
    cube_medium(mat)


@row("emission_shader", "Emission shader (Strength `density`×0.5, orange) into the Volume output",
     coloured=True, emissive=True, control=at_default("Emission", "Color"))
def _(tmpdir):
    mat, nt, out = material()
    node = nt.nodes.new('ShaderNodeEmission')
    node.inputs["Color"].default_value = (1.0, 0.5, 0.2, 1.0)
    nt.links.new(math_node(nt, 'MULTIPLY', attribute(nt).outputs["Fac"], 0.5).outputs[0],
                 node.inputs["Strength"])
    nt.links.new(node.outputs[0], out.inputs["Volume"])
    smoke_with(tmpdir, mat)


def _texture_cube(tmpdir, texture: str):
    mat, nt, out = material("Cloud")
    pv = principled(nt, out, **{"Density Attribute": ""})
    coords = nt.nodes.new('ShaderNodeTexCoord')
    tex = nt.nodes.new(texture)
    nt.links.new(coords.outputs["Object"], tex.inputs["Vector"])
    mr = nt.nodes.new('ShaderNodeMapRange')
    if texture == 'ShaderNodeTexNoise':
        mr.inputs["From Min"].default_value = 0.45
        mr.inputs["From Max"].default_value = 0.7
        mr.inputs["To Max"].default_value = 3.0
    else:
        mr.inputs["To Max"].default_value = 2.0
    nt.links.new(tex.outputs["Fac"], mr.inputs["Value"])
    nt.links.new(mr.outputs["Result"], pv.inputs["Density"])
    base()
    cube_medium(mat)


@row("noise_cloud", "Noise Texture (Object) → Map Range → Density, 2 m cube, volume-only material",
     control=at_default("Noise Texture", "Vector", doc="Noise Texture Vector at the default (unlinked: "
                        "Generated coordinates)"))
def _(tmpdir):
    _texture_cube(tmpdir, 'ShaderNodeTexNoise')


@row("gradient_texture", "Gradient Texture (Object, linear) → Map Range → Density, 2 m cube",
     control=at_default("Gradient Texture", "Vector", doc="Gradient Texture Vector at the default "
                        "(unlinked: Generated coordinates)"))
def _(tmpdir):
    _texture_cube(tmpdir, 'ShaderNodeTexGradient')


def _default_surface():
    """The cube's material with a new material's surface (a Principled BSDF into Surface): not
    volume-only, the cube opaque (Density 1 for 0.8 changes the image too little to fail the row)"""
    out = node_of("Material Output", "Fog")
    bsdf = out.id_data.nodes.new('ShaderNodeBsdfPrincipled')
    out.id_data.links.new(bsdf.outputs[0], out.inputs["Surface"])


@row("mesh_medium", "Mesh medium: 2 m cube with a volume-only Principled Volume (Density 0.8)",
     control=_default_surface)
def _(tmpdir):
    mat, nt, out = material("Fog")
    principled(nt, out, Density=0.8)
    base()
    cube_medium(mat)


@row("two_volumes", "Two overlapping Volume objects (grey and orange)", coloured=True,
     control=assign(lambda: volume("Smoke B"), "The second Volume object (orange) hidden from the render: "
                    "one volume, no overlap", hide_render=True))
def _(tmpdir):
    base()
    for name, loc, colour in (("Smoke A", (-0.45, 0.0, 0.0), (0.5, 0.5, 0.5, 1.0)),
                              ("Smoke B", (0.45, 0.3, 0.1), (0.9, 0.45, 0.15, 1.0))):
        mat, nt, out = material(name)
        principled(nt, out, Color=colour)
        volume_object(tmpdir, name=name, mat=mat, location=loc, scale=(0.7, 0.7, 0.7))


for _kind, _loc in (('SPOT', (2.5, -2.5, 3.0)), ('POINT', (-1.8, -1.5, 2.2)), ('SUN', (3.0, -1.0, 3.0)),
                    ('AREA', (2.0, -2.0, 2.5))):
    def _build(tmpdir, kind=_kind, loc=_loc):
        mat, nt, out = material()
        principled(nt, out)
        base(lights=None)
        light(kind, loc)
        volume_object(tmpdir, mat=mat)

    # Point is the Add ▸ Light operator's default type: the point light's control puts it at the
    # operator's default location instead (the 3D cursor, the origin, inside the smoke).
    ROWS.append(Row(id=f"light_{_kind.lower()}", title=f"{_kind.title()} light (Add menu defaults) "
                    "with the smoke", build=_build,
                    control=assign(lambda: light_object().data, f"The {_kind.title()} light's type at the "
                                   "Add ▸ Light operator's default (Point), its power kept", type='POINT')
                    if _kind != 'POINT' else
                    assign(light_object, "The point light at the Add ▸ Light operator's default location "
                           "(the 3D cursor: the origin, inside the smoke; Point is the default type)",
                           location=(0.0, 0.0, 0.0))))


for _flag, _what in (('visible_volume_scatter', "Volume Scatter"), ('visible_diffuse', "Diffuse")):
    def _build(tmpdir, flag=_flag):
        mat, nt, out = material()
        principled(nt, out)
        base(lights=None)
        setattr(light('SPOT'), flag, False)
        volume_object(tmpdir, mat=mat)

    ROWS.append(Row(id=f"light_{_flag}_off", title=f"Spot light, Object ▸ Visibility ▸ Ray Visibility ▸ "
                    f"{_what} off", build=_build,
                    control=assign(light_object, f"The light's Ray Visibility ▸ {_what} at the default (on)",
                                   **{_flag: True})))


@row("area_normalize_off", "Area light 1.5 × 1.5 m, Normalize off (its power grows with its area)",
     control=assign(lambda: light_object().data, "Area light Normalize at the default (on)", normalize=True))
def _(tmpdir):
    mat, nt, out = material()
    principled(nt, out)
    base(lights=None)
    area = light('AREA', (2.0, -2.0, 2.5), energy=200.0)
    area.data.size = 1.5
    area.data.normalize = False
    volume_object(tmpdir, mat=mat)


@row("light_volume_factor", "Spot light, Light ▸ Influence ▸ Volume factor 0.3 (Cycles' direct light in "
     "the medium is unchanged by it)",
     control=assign(lambda: light_object().data, "Light ▸ Influence ▸ Volume factor at the default (1)",
                    volume_factor=1.0))
def _(tmpdir):
    mat, nt, out = material()
    principled(nt, out)
    base(lights=None)
    light('SPOT').data.volume_factor = 0.3
    volume_object(tmpdir, mat=mat)


def linking_collection(lamp, role: str, objects, state: str = 'INCLUDE') -> None:
    """A collection of ``objects`` (each with link ``state``) set as ``lamp``'s Light Linking
    receiver collection (``role`` 'receiver') or Shadow Linking blocker collection ('blocker')."""
    import bpy

    collection = bpy.data.collections.new(role.title() + "s")
    for ob in objects:
        collection.objects.link(ob)
    setattr(lamp.light_linking, f"{role}_collection", collection)
    for entry in collection.collection_objects:
        entry.light_linking.link_state = state


def _no_link_collection(role: str):
    """A control: the light's Light Linking receiver (``role`` 'receiver') or Shadow Linking blocker
    ('blocker') collection at the default (none)."""
    kind = 'Light' if role == 'receiver' else 'Shadow'
    return assign(lambda: light_object().light_linking, f"The light's {kind} Linking {role} collection at "
                  "the default (none)", **{f"{role}_collection": None})


@row("light_linking_excludes_smoke", "Spot light whose Light Linking receiver collection excludes the smoke "
     "(the smoke dark, the ground lit)", control=_no_link_collection("receiver"))
def _(tmpdir):
    mat, nt, out = material()
    principled(nt, out)
    base(lights=None)
    spot = light('SPOT')
    linking_collection(spot, "receiver", [volume_object(tmpdir, mat=mat)], 'EXCLUDE')


@row("light_linking_one_of_two_volumes", "Point light whose Light Linking receiver collection includes one "
     "of two Volume objects (the other dark)", control=_no_link_collection("receiver"))
def _(tmpdir):
    import bpy

    base()
    smokes = []
    # Apart on screen: where a camera ray crosses both, Cycles lights the samples of both by the
    # linking of one of them.
    for name, loc in (("Smoke A", (-0.95, 0.0, 0.0)), ("Smoke B", (0.95, 0.3, 0.1))):
        mat, nt, out = material(name)
        principled(nt, out)
        smokes.append(volume_object(tmpdir, name=name, mat=mat, location=loc, scale=(0.6, 0.6, 0.6)))
    linking_collection(bpy.data.objects["Point"], "receiver", smokes[:1])


@row("light_linking_excludes_a_cube", "Point light whose Light Linking receiver collection excludes a cube "
     "beside the smoke (the cube dark, the ground and smoke lit)", control=_no_link_collection("receiver"))
def _(tmpdir):
    import bpy

    mat, nt, out = material()
    principled(nt, out)
    base()
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(1.4, -0.6, -0.85))
    cube = bpy.context.object
    cube.data.materials.append(_diffuse("Cube", (0.7, 0.7, 0.7)))
    volume_object(tmpdir, mat=mat)
    linking_collection(bpy.data.objects["Point"], "receiver", [cube], 'EXCLUDE')


def _shadow_linked_spot(tmpdir, excluded: str | None) -> None:
    """A spot past a 6 cm bar into the smoke; its Shadow Linking blocker collection excludes the
    bar or the smoke (``excluded``: 'bar' or 'smoke'; None: no collection), which then casts no
    shadow from it."""
    import bpy

    mat, nt, out = material()
    principled(nt, out)
    base(lights=None)
    spot = light('SPOT', (0.0, -0.4, 3.2))
    _bar(1.8)
    bar = bpy.context.object
    smoke = volume_object(tmpdir, mat=mat)
    if excluded is not None:
        linking_collection(spot, "blocker", [bar if excluded == 'bar' else smoke], 'EXCLUDE')


for _what in ('bar', 'smoke'):
    ROWS.append(Row(id=f"shadow_linking_excludes_{_what}",
                    title=f"Spot light past a bar into the smoke, its Shadow Linking blocker collection "
                          f"excluding the {_what} (no shadow from it)",
                    build=lambda tmpdir, what=_what: _shadow_linked_spot(tmpdir, what),
                    control=_no_link_collection("blocker")))


@row("area_spread", "Area light 1 m, Spread 60° (Cycles' soft-box grid)",
     control=assign(lambda: light_object().data, "Area light Spread at the default (180°)", spread=math.pi))
def _(tmpdir):
    mat, nt, out = material()
    principled(nt, out)
    base(lights=None)
    area = light('AREA', (1.4, -1.4, 2.0))
    area.data.spread = np.radians(60.0)
    volume_object(tmpdir, mat=mat)


def _bar(z: float = 1.8, width: float = 0.06, along_y: bool = False, y: float = 0.0) -> None:
    """A bar (``width`` square, 3 m long, along x or y, at height ``z``): the shadow the rows soften."""
    import bpy

    scale = (width, 3.0, width) if along_y else (3.0, width, width)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, y, z), scale=scale)
    bpy.context.object.data.materials.append(_diffuse("Bar", (0.5, 0.5, 0.5)))


# The sun's bar: 50 cm wide, 10 m above the smoke's centre on the ray toward the sun, along the
# view: its 3-degree penumbra (about 52 cm across the smoke, 59 cm on the ground) is wider than the
# bar, so that a sharp sun's shadow (as dark as the bar is wide) differs from the soft one.
SUN_BAR = dict(z=10.0, width=0.5, along_y=True, y=-0.8)

# The lights' sizes as the Add ▸ Light operator makes them: (in words, the settings).
_DEFAULT_SIZE = {'AREA': ("1 m square", dict(size=1.0, size_y=1.0, shape='SQUARE')),
                 'SPOT': ("radius 0", dict(shadow_soft_size=0.0)),
                 'SUN': ("angle 0.526°", dict(angle=math.radians(0.526)))}

for _id, _kind, _title, _size, _bar_at in (
        ("soft_area", 'AREA', "Area light 0.6 × 0.3 m past a 6 cm bar into the smoke (soft shadow)",
         dict(size=0.6, size_y=0.3, shape='RECTANGLE'), dict(z=1.8)),
        ("soft_spot", 'SPOT', "Spot light of radius 0.25 m past a 6 cm bar into the smoke (soft shadow)",
         dict(shadow_soft_size=0.25), dict(z=1.8)),
        ("soft_sun", 'SUN', "Sun of angle 3° past a 50 cm bar 10 m above the smoke (soft shadow: a sharp "
         "sun fails the row)", dict(angle=np.radians(3.0)), SUN_BAR)):
    def _build(tmpdir, kind=_kind, size=_size, bar_at=_bar_at):
        mat, nt, out = material()
        principled(nt, out)
        base(lights=None)
        lamp = light(kind, (0.0, -0.4, 3.2) if kind != 'SUN' else (0.0, -0.4, 5.0))
        for k, v in size.items():
            setattr(lamp.data, k, v)
        _bar(**bar_at)
        volume_object(tmpdir, mat=mat)

    ROWS.append(Row(id=_id, title=_title, build=_build,
                    control=assign(lambda: light_object().data, f"The {_kind.title()} light's size at "
                                   f"the Add ▸ Light operator's default ({_DEFAULT_SIZE[_kind][0]})",
                                   **_DEFAULT_SIZE[_kind][1])))


def _world_lit_smoke():
    """The smoke's Principled Volume material, the base scene without a lamp, and the World's node
    tree with its Background node: (material, world nodes, Background)."""
    import bpy

    mat, nt, out = material()
    principled(nt, out)
    base(lights=None)
    wt = bpy.context.scene.world.node_tree
    return mat, wt, next(n for n in wt.nodes if n.bl_idname == 'ShaderNodeBackground')


@row("world_hdri", "World ▸ Environment Texture (an equirectangular image made by code) lighting the "
     "smoke, no lamp", coloured=True,
     control=at_default("Background", "Color", doc="World Background Color at the default (a new "
                        "Background node's grey 0.8): the Environment Texture taken out"))
def _(tmpdir):
    mat, wt, bg = _world_lit_smoke()
    env = wt.nodes.new('ShaderNodeTexEnvironment')
    env.image = _sky_image()
    wt.links.new(env.outputs["Color"], bg.inputs["Color"])
    volume_object(tmpdir, mat=mat)


def _sky_image(width: int = 64, height: int = 32, bands: bool = False):
    """A blue sky over a dark ground with a small warm patch of high radiance 30 degrees up (an
    equirectangular float image, Blender's rows bottom first); ``bands``: the sky and the ground
    brighter and darker in three bands around the horizon (what turns with the image)."""
    import bpy

    v = (np.arange(height) + 0.5) / height
    u = (np.arange(width) + 0.5) / width
    vv, uu = np.meshgrid(v, u, indexing="ij")
    theta, phi = np.pi * (1.0 - vv), np.pi - 2.0 * np.pi * uu
    d = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)
    rgb = np.where((d[..., 2] > 0)[..., None], [0.25, 0.45, 0.9], [0.05, 0.04, 0.03]).astype(np.float32)
    if bands:
        rgb *= (1.0 + 0.6 * np.sin(3.0 * phi))[..., None].astype(np.float32)
    sun = np.array([0.6, -0.6, 0.5]) / np.linalg.norm([0.6, -0.6, 0.5])
    rgb[(d @ sun) > 0.96] = (40.0, 30.0, 20.0)
    image = bpy.data.images.new("Sky", width, height, float_buffer=True)
    image.pixels.foreach_set(np.concatenate([rgb, np.ones((height, width, 1), np.float32)], -1).ravel())
    return image


@row("mesh_shadow", "A mesh (Diffuse plane) casting its shadow into the smoke",
     control=assign(lambda: wearing("Occluder"), "The occluding plane's Ray Visibility ▸ Shadow "
                    "off (on, the row's, is the default): it casts no shadow", visible_shadow=False))
def _(tmpdir):
    import bpy

    mat, nt, out = material()
    principled(nt, out)
    smoke_with(tmpdir, mat)
    bpy.ops.mesh.primitive_plane_add(size=0.6, location=(1.6, -1.0, 1.5))
    occluder = bpy.context.object
    _aim(occluder, (2.5, -2.5, 3.0))
    occluder.data.materials.append(_diffuse("Occluder", (0.5, 0.5, 0.5)))


def _new_world_colour():
    """The World colour at a new World's default (0.05 grey)"""
    _world((0.05, 0.05, 0.05))


@row("world_color", "World colour (0.3, 0.4, 0.6) lighting the smoke, no lamp", coloured=True,
     control=_new_world_colour)
def _(tmpdir):
    mat, nt, out = material()
    principled(nt, out)
    base(lights=None, world=(0.3, 0.4, 0.6))
    volume_object(tmpdir, mat=mat)


def _black_world():
    """The World colour black: the default grey world's light and background taken out"""
    _world((0.0, 0.0, 0.0))


@row("world_default_sun", "Blender's default grey World (0.05) lighting the smoke and the ground beside a "
     "sun (its light shadowed by the smoke, from the world's directions)", control=_black_world)
def _(tmpdir):
    mat, nt, out = material()
    principled(nt, out)
    base(lights='SUN', world=(0.05, 0.05, 0.05))
    volume_object(tmpdir, mat=mat)


def _room() -> None:
    """A closed room around the camera, 5 x 10 x 3.5 m inside, of 20 cm walls (Diffuse 0.8), with
    a 1.5 x 1.2 m window in its +x wall: the world's light comes in through the window alone."""
    import bpy

    wall = _diffuse("Wall", (0.8, 0.8, 0.8))
    x0, x1, y0, y1, z0, z1, t = -2.5, 2.5, -8.0, 2.0, -1.25, 2.25, 0.2
    wy0, wy1, wz0, wz1 = -1.0, 0.5, 0.5, 1.7

    def slab(lo, hi):
        bpy.ops.mesh.primitive_cube_add(size=1.0, location=[(a + b) / 2 for a, b in zip(lo, hi, strict=True)],
                                        scale=[b - a for a, b in zip(lo, hi, strict=True)])
        bpy.context.object.data.materials.append(wall)

    slab((x0 - t, y0 - t, z0 - t), (x1 + t, y1 + t, z0))       # floor
    slab((x0 - t, y0 - t, z1), (x1 + t, y1 + t, z1 + t))       # ceiling
    slab((x0 - t, y0 - t, z0), (x0, y1 + t, z1))               # the walls
    slab((x0, y0 - t, z0), (x1, y0, z1))
    slab((x0, y1, z0), (x1, y1 + t, z1))
    slab((x1, y0 - t, z0), (x1 + t, y1 + t, wz0))              # the window's wall, around it
    slab((x1, y0 - t, wz1), (x1 + t, y1 + t, z1))
    slab((x1, y0 - t, wz0), (x1 + t, wy0, wz1))
    slab((x1, wy1, wz0), (x1 + t, y1 + t, wz1))


@row("world_room_window", "A closed room lit by a sun through its one window, a fog box (Volume Scatter, "
     "density 0.15) inside, Blender's default grey World: the world's light comes in through the window "
     "alone", control=_black_world)
def _(tmpdir):
    import bpy

    mat, nt, out = material("Fog")
    node = nt.nodes.new('ShaderNodeVolumeScatter')
    node.inputs["Density"].default_value = 0.15
    nt.links.new(node.outputs[0], out.inputs["Volume"])
    base(lights=None, world=(0.05, 0.05, 0.05), ground=False)
    _room()
    light('SUN', (3.0, -0.25, 3.0))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, -1.75, 0.5), scale=(4.6, 6.5, 3.4))
    bpy.context.object.data.materials.append(mat)


@row("world_gradient", "World ▸ Background Color from nodes: Texture Coordinate Generated → Separate XYZ Z → "
     "Map Range (−0.2–1 → 0–1) → Mix (Color) ground → sky, Strength 1.5", coloured=True,
     control=at_default("Mix", "Factor_Float", doc="The Mix's Factor at the default (0.5, unlinked): the "
                        "gradient taken out, one colour halfway between ground and sky"))
def _(tmpdir):
    mat, wt, bg = _world_lit_smoke()
    bg.inputs["Strength"].default_value = 1.5
    coords, xyz = wt.nodes.new('ShaderNodeTexCoord'), wt.nodes.new('ShaderNodeSeparateXYZ')
    ramp, mix = wt.nodes.new('ShaderNodeMapRange'), wt.nodes.new('ShaderNodeMix')
    ramp.inputs["From Min"].default_value = -0.2
    mix.data_type = 'RGBA'
    socket(mix.inputs, "A_Color").default_value = (0.05, 0.04, 0.03, 1.0)
    socket(mix.inputs, "B_Color").default_value = (0.3, 0.5, 1.0, 1.0)
    wt.links.new(coords.outputs["Generated"], xyz.inputs[0])
    wt.links.new(xyz.outputs["Z"], ramp.inputs["Value"])
    wt.links.new(ramp.outputs["Result"], socket(mix.inputs, "Factor_Float"))
    wt.links.new(socket(mix.outputs, "Result_Color"), bg.inputs["Color"])
    volume_object(tmpdir, mat=mat)


@row("world_sky", "World ▸ Background Color from a Sky Texture (Multiple Scattering, Blender's default)",
     coloured=True, control=at_default("Background", "Color", doc="World Background Color at the default "
                                       "(a new Background node's grey 0.8): the Sky Texture taken out"))
def _(tmpdir):
    mat, wt, bg = _world_lit_smoke()
    sky = wt.nodes.new('ShaderNodeTexSky')
    bg.inputs["Strength"].default_value = 0.1
    wt.links.new(sky.outputs["Color"], bg.inputs["Color"])
    volume_object(tmpdir, mat=mat)


@row("world_hdri_mapping_seen", "World ▸ Environment Texture (an image made by code) turned 100° about Z by "
     "a Mapping node (Texture Coordinate Generated → Mapping → Environment), seen behind the smoke (Film ▸ "
     "Transparent off) and lighting it", coloured=True, background=True,
     control=at_default("Mapping", "Rotation", doc="The Mapping's Rotation at the default (0): the image "
                        "unturned"))
def _(tmpdir):
    mat, wt, bg = _world_lit_smoke()
    coords, mapping = wt.nodes.new('ShaderNodeTexCoord'), wt.nodes.new('ShaderNodeMapping')
    env = wt.nodes.new('ShaderNodeTexEnvironment')
    env.image = _sky_image(256, 128, bands=True)
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(100.0))
    wt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    wt.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    wt.links.new(env.outputs["Color"], bg.inputs["Color"])
    volume_object(tmpdir, mat=mat)


@row("world_sky_seen", "World ▸ Sky Texture (Multiple Scattering, Blender's default) seen behind the smoke "
     "(Film ▸ Transparent off) and lighting it", coloured=True, background=True,
     control=at_default("Background", "Color", doc="World Background Color at the default (a new "
                        "Background node's grey 0.8): the Sky Texture taken out"))
def _(tmpdir):
    ROW_BY_ID["world_sky"].build(tmpdir)


@row("world_sky_sun_seen", "World ▸ Sky Texture (Multiple Scattering, Blender's default) seen behind the "
     "smoke (Film ▸ Transparent off), a Sun lamp (3 W/m²) along the sky's sun", coloured=True,
     background=True,
     control=at_default("Background", "Color", doc="World Background Color at the default (a new "
                        "Background node's grey 0.8): the Sky Texture taken out"))
def _(tmpdir):
    ROW_BY_ID["world_sky"].build(tmpdir)
    sky = node_of("Sky Texture")
    e, r = sky.sun_elevation, sky.sun_rotation
    toward = np.array([-math.cos(e) * math.sin(r), math.cos(e) * math.cos(r), math.sin(e)])
    light('SUN', tuple(10.0 * toward), energy=3.0)


@row("world_gradient_seen", "World ▸ Background Color from nodes (world_gradient's gradient) seen behind the "
     "smoke (Film ▸ Transparent off) and lighting it", coloured=True, background=True,
     control=at_default("Mix", "Factor_Float", doc="The Mix's Factor at the default (0.5, unlinked): the "
                        "gradient taken out, one colour halfway between ground and sky"))
def _(tmpdir):
    ROW_BY_ID["world_gradient"].build(tmpdir)


for _flag, _what in (("scatter", "Volume Scatter"), ("diffuse", "Diffuse")):
    def _build(tmpdir, flag=_flag):
        import bpy

        mat, nt, out = material()
        principled(nt, out)
        base(lights=None, world=(0.3, 0.4, 0.6))
        setattr(bpy.context.scene.world.cycles_visibility, flag, False)
        volume_object(tmpdir, mat=mat)

    ROWS.append(Row(id=f"world_{_flag}_off", title=f"World colour (0.3, 0.4, 0.6), World ▸ Settings ▸ Ray "
                    f"Visibility ▸ {_what} off", build=_build, coloured=True,
                    control=assign(lambda: active_scene().world.cycles_visibility, f"World ▸ Settings ▸ Ray "
                                   f"Visibility ▸ {_what} at the default (on)", **{_flag: True})))


def _world_volume(node_type: str, density: float) -> None:
    import bpy

    nt = bpy.context.scene.world.node_tree
    out = next(n for n in nt.nodes if n.bl_idname == 'ShaderNodeOutputWorld')
    node = nt.nodes.new(node_type)
    node.inputs["Density"].default_value = density
    nt.links.new(node.outputs[0], out.inputs["Volume"])


@row("world_fog", "World ▸ Volume: Volume Scatter (density 0.08) filling the scene, spot light and ground",
     control=at_default("Volume Scatter", "Density"))
def _(tmpdir):
    base(lights='SPOT')
    _world_volume('ShaderNodeVolumeScatter', 0.08)


@row("world_fog_principled", "World ▸ Volume: Principled Volume (density 0.05) filling the scene, point",
     control=at_default("Principled Volume", "Density"))
def _(tmpdir):
    base()
    _world_volume('ShaderNodeVolumePrincipled', 0.05)


@row("world_fog_beside_smoke", "World ▸ Volume: Volume Scatter fog beside a smoke volume",
     control=at_default("Volume Scatter", "Density"))
def _(tmpdir):
    mat, nt, out = material()
    principled(nt, out)
    base()
    volume_object(tmpdir, mat=mat)
    _world_volume('ShaderNodeVolumeScatter', 0.05)


def _resolution(width: int, height: int) -> None:
    import bpy

    r = bpy.context.scene.render
    r.resolution_x, r.resolution_y = width, height


@row("dof", "Camera ▸ Depth of Field: focus 3 m (the smoke at 7 m), f/0.25, 160x90",
     control=assign(lambda: active_scene().camera.data.dof, "Camera ▸ Depth of Field at the default (off)",
                    use_dof=False))
def _(tmpdir):
    import bpy

    _pv_row(tmpdir)
    _resolution(160, 90)
    dof = bpy.context.scene.camera.data.dof
    dof.use_dof, dof.focus_distance, dof.aperture_fstop = True, 3.0, 0.25


@row("dof_blades", "Depth of Field: focus on an object 2.5 m away, f/0.2, 5 blades turned 20°, ratio 2, "
     "160x90",
     control=assign(lambda: active_scene().camera.data.dof, "Depth of Field ▸ Aperture blades, rotation and "
                    "ratio at the defaults (0: a round aperture, 0°, 1)", aperture_blades=0,
                    aperture_rotation=0.0, aperture_ratio=1.0))
def _(tmpdir):
    import math

    import bpy

    _pv_row(tmpdir)
    _resolution(160, 90)
    bpy.ops.object.empty_add(location=(0.3, -4.5, 0.8))
    dof = bpy.context.scene.camera.data.dof
    dof.use_dof, dof.focus_object, dof.aperture_fstop = True, bpy.context.object, 0.2
    dof.aperture_blades, dof.aperture_rotation, dof.aperture_ratio = 5, math.radians(20.0), 2.0


def _moving(ob, step=(0.8, 0.0, 0.0)) -> None:
    """Keys ``ob`` at frames 0, 1, 2, moving by ``step`` a frame (linear), the scene at frame 1."""
    import bpy

    bpy.context.preferences.edit.keyframe_new_interpolation_type = 'LINEAR'
    here = ob.location.copy()
    for frame in (0, 1, 2):
        ob.location = [here[i] + (frame - 1) * step[i] for i in range(3)]
        ob.keyframe_insert("location", frame=frame)
    bpy.context.scene.frame_set(1)


_no_motion_blur = assign(lambda: active_scene().render, "Render ▸ Motion Blur at the default (off)",
                         use_motion_blur=False)


@row("motion_blur_volume", "Render ▸ Motion Blur (shutter 0.5, centre): the smoke moving 0.8 m a frame",
     control=_no_motion_blur)
def _(tmpdir):
    import bpy

    mat, nt, out = material()
    principled(nt, out)
    ob = smoke_with(tmpdir, mat)
    _moving(ob)
    bpy.context.scene.render.use_motion_blur = True


@row("motion_blur_camera", "Render ▸ Motion Blur (shutter 1, start): the camera moving 0.4 m a frame",
     control=_no_motion_blur)
def _(tmpdir):
    import bpy

    _pv_row(tmpdir)
    scene = bpy.context.scene
    _moving(scene.camera, (0.4, 0.0, 0.0))
    r = scene.render
    r.use_motion_blur, r.motion_blur_shutter, r.motion_blur_position = True, 1.0, 'START'


# The fire lights the ground by Blender's default (Ray Visibility ▸ Diffuse on): the control turns
# that off.
@row("fire_lights_ground", "A fire (Emission shader + Volume Absorption) lighting the ground, no lamp",
     coloured=True, control=assign(lambda: volume("Fire"), "The fire's Ray Visibility ▸ Diffuse off (on, the "
                                   "row's, is the default): it lights no surface", visible_diffuse=False))
def _(tmpdir):
    mat, nt, out = material("Fire")
    emission = nt.nodes.new('ShaderNodeEmission')
    emission.inputs["Color"].default_value = (1.0, 0.45, 0.12, 1.0)
    nt.links.new(math_node(nt, 'MULTIPLY', attribute(nt).outputs["Fac"], 2.0).outputs[0],
                 emission.inputs["Strength"])
    absorb = nt.nodes.new('ShaderNodeVolumeAbsorption')
    absorb.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    nt.links.new(attribute(nt).outputs["Fac"], absorb.inputs["Density"])
    add = nt.nodes.new('ShaderNodeAddShader')
    nt.links.new(emission.outputs[0], add.inputs[0])
    nt.links.new(absorb.outputs[0], add.inputs[1])
    nt.links.new(add.outputs[0], out.inputs["Volume"])
    base(lights=None)
    import bpy

    bpy.data.materials["Ground"].node_tree.nodes["Diffuse BSDF"].inputs["Color"].default_value = \
        (0.8, 0.8, 0.8, 1.0)
    volume_object(tmpdir, name="Fire", mat=mat)


# Surfaces: the ground's shader, seen low over it (the view grazes the far ground) --------------

def _grazing_view() -> None:
    import bpy

    cam = bpy.context.scene.camera
    cam.location = (0.0, -6.0, -0.65)
    _aim(cam, (0.0, 0.0, -1.0))


def surface_ground(shader: str | None = None, **inputs):
    """The ground, 8 m, with a new material (Blender's default Principled BSDF), its shader
    replaced by ``shader`` (a node type) when given; ``inputs`` set by socket name: (mat, node)."""
    import bpy

    bpy.ops.mesh.primitive_plane_add(size=8.0, location=(0.0, 0.0, -1.25))
    mat = bpy.data.materials.new("Ground")
    nt = mat.node_tree
    node = nt.nodes["Principled BSDF"]
    if shader is not None:
        nt.nodes.remove(node)
        node = nt.nodes.new(shader)
        nt.links.new(node.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
    for k, v in inputs.items():
        node.inputs[k].default_value = v
    bpy.context.object.data.materials.append(mat)
    return mat, node


def _ground_without_material():
    """The ground's material taken out (Cycles' default surface, a grey diffuse): its Principled BSDF
    is at Blender's defaults already"""
    wearing("Ground").data.materials.clear()


@row("surface_principled_default", "Ground: Blender's default Principled BSDF at a grazing view, point light",
     control=_ground_without_material)
def _(tmpdir):
    base(ground=False)
    _grazing_view()
    surface_ground()


@row("surface_principled_metal", "Ground: Principled BSDF Metallic 1, Roughness 0.3, copper colour, under "
     "the smoke", coloured=True, control=at_default("Principled BSDF", "Metallic"))
def _(tmpdir):
    mat, nt, out = material()
    principled(nt, out)
    base(ground=False)
    _grazing_view()
    surface_ground(**{"Base Color": (0.95, 0.64, 0.54, 1.0), "Metallic": 1.0, "Roughness": 0.3})
    volume_object(tmpdir, mat=mat)


def _default_specular():
    """Principled BSDF Specular IOR Level, Specular Tint and distribution at the defaults (0.5, white,
    Multiscatter GGX)"""
    node = node_of("Principled BSDF")
    for key in ("Specular IOR Level", "Specular Tint"):
        input_at_default(node, key)
    node.distribution = 'MULTI_GGX'


@row("surface_principled_specular", "Ground: Principled BSDF blue, Roughness 0.2, Specular IOR Level 1, "
     "Specular Tint orange, plain GGX", coloured=True, control=_default_specular)
def _(tmpdir):
    base(ground=False)
    _grazing_view()
    _, node = surface_ground(**{"Base Color": (0.1, 0.3, 0.8, 1.0), "Roughness": 0.2,
                                "Specular IOR Level": 1.0, "Specular Tint": (1.0, 0.7, 0.4, 1.0)})
    node.distribution = 'GGX'


@row("surface_glossy", "Ground: Glossy BSDF (0.8, 0.7, 0.5), Roughness 0.3", coloured=True,
     control=at_default("Glossy BSDF", "Color", "Roughness"))
def _(tmpdir):
    base(ground=False)
    _grazing_view()
    surface_ground('ShaderNodeBsdfGlossy', Color=(0.8, 0.7, 0.5, 1.0), Roughness=0.3)


@row("surface_mix_shader", "Ground: Mix Shader 0.3 of two Principled BSDFs (red, green) from an RGB node",
     coloured=True, control=at_default("Mix Shader", "Fac"))
def _(tmpdir):
    base(ground=False)
    _grazing_view()
    mat, mix = surface_ground('ShaderNodeMixShader', Fac=0.3)
    nt = mat.node_tree
    rgb = nt.nodes.new('ShaderNodeRGB')
    rgb.outputs[0].default_value = (0.8, 0.1, 0.1, 1.0)
    for i, colour in ((1, None), (2, (0.1, 0.7, 0.2, 1.0))):
        p = nt.nodes.new('ShaderNodeBsdfPrincipled')
        if colour is None:
            nt.links.new(rgb.outputs[0], p.inputs["Base Color"])
        else:
            p.inputs["Base Color"].default_value = colour
        nt.links.new(p.outputs[0], mix.inputs[i])


def _test_image(width: int = 32, height: int = 16):
    """An 8-bit sRGB image made by code: a warm-to-cool ramp across, dark stripes along."""
    import bpy

    img = bpy.data.images.new("Tiles", width, height)
    u = (np.arange(width) + 0.5) / width
    rgb = np.stack([0.9 - 0.7 * u, 0.3 + 0.3 * u, 0.1 + 0.8 * u], -1)[None].repeat(height, 0)
    rgb[::4] *= 0.25
    px = np.concatenate([rgb, np.ones((height, width, 1))], -1).astype(np.float32)
    img.pixels.foreach_set(px.ravel())
    return img


@row("surface_checker_smoke", "Ground: Checker Texture (Generated coordinates) → Principled Base Color, "
     "behind the smoke", coloured=True, control=at_default("Checker Texture", "Scale", "Color1"))
def _(tmpdir):
    mat, nt, out = material()
    principled(nt, out)
    base(ground=False)
    ground, bsdf = surface_ground()
    checker = ground.node_tree.nodes.new('ShaderNodeTexChecker')
    checker.inputs["Scale"].default_value = 4.0
    checker.inputs["Color1"].default_value = (0.9, 0.7, 0.3, 1.0)
    ground.node_tree.links.new(checker.outputs["Color"], bsdf.inputs["Base Color"])
    volume_object(tmpdir, mat=mat)


@row("surface_image_smoke", "Ground: Image Texture (UV map, 8-bit sRGB) → Color Ramp-free Mix (Multiply) → "
     "Diffuse, behind the smoke", coloured=True,
     control=at_default("Mix", "A_Color", doc="The Mix's A at the default (0.5 grey, unlinked): the Image "
                        "Texture taken out"))
def _(tmpdir):
    mat, nt, out = material()
    principled(nt, out)
    base(ground=False)
    ground, bsdf = surface_ground('ShaderNodeBsdfDiffuse')
    gnt = ground.node_tree
    tex = gnt.nodes.new('ShaderNodeTexImage')
    tex.image = _test_image()
    mix = gnt.nodes.new('ShaderNodeMix')
    mix.data_type, mix.blend_type = 'RGBA', 'MULTIPLY'
    mix.inputs["Factor"].default_value = 1.0
    socket(mix.inputs, "B_Color").default_value = (1.0, 0.9, 0.8, 1.0)
    gnt.links.new(tex.outputs["Color"], socket(mix.inputs, "A_Color"))
    gnt.links.new(socket(mix.outputs, "Result_Color"), bsdf.inputs["Color"])
    volume_object(tmpdir, mat=mat)


@row("surface_noise_ramp", "Ground: Noise Texture (Generated, scale 3) → Color Ramp → Principled Base "
     "Color", coloured=True, control=at_default("Noise Texture", "Scale"))
def _(tmpdir):
    base(ground=False)
    ground, bsdf = surface_ground()
    gnt = ground.node_tree
    noise = gnt.nodes.new('ShaderNodeTexNoise')
    noise.inputs["Scale"].default_value = 3.0
    ramp = gnt.nodes.new('ShaderNodeValToRGB')
    ramp.color_ramp.elements[0].color = (0.05, 0.15, 0.4, 1.0)
    ramp.color_ramp.elements[1].color = (0.9, 0.8, 0.6, 1.0)
    ramp.color_ramp.elements[0].position, ramp.color_ramp.elements[1].position = 0.35, 0.65
    gnt.links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
    gnt.links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])


@row("surface_image_generated", "Ground: Image Texture on Generated coordinates (Texture Coordinate) → "
     "Principled Base Color, Closest interpolation", coloured=True,
     control=assign(lambda: node_of("Image Texture"), "Image Texture interpolation at the default (Linear)",
                    interpolation='Linear'))
def _(tmpdir):
    base(ground=False)
    ground, bsdf = surface_ground()
    gnt = ground.node_tree
    tex = gnt.nodes.new('ShaderNodeTexImage')
    tex.image = _test_image()
    tex.interpolation = 'Closest'
    coords = gnt.nodes.new('ShaderNodeTexCoord')
    gnt.links.new(coords.outputs["Generated"], tex.inputs["Vector"])
    gnt.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])


@row("surface_roughness_texture", "Ground: copper Principled BSDF, Checker Fac → Map Range → Roughness "
     "(0.15 and 0.6), Metallic 1, at a grazing view", coloured=True,
     control=at_default("Principled BSDF", "Roughness", doc="Principled BSDF Roughness at the default (0.5, "
                        "unlinked): the checker taken out"))
def _(tmpdir):
    base(ground=False)
    _grazing_view()
    ground, bsdf = surface_ground(**{"Base Color": (0.95, 0.64, 0.54, 1.0), "Metallic": 1.0})
    gnt = ground.node_tree
    checker = gnt.nodes.new('ShaderNodeTexChecker')
    checker.inputs["Scale"].default_value = 3.0
    ranged = gnt.nodes.new('ShaderNodeMapRange')
    ranged.inputs["To Min"].default_value, ranged.inputs["To Max"].default_value = 0.15, 0.6
    gnt.links.new(checker.outputs["Fac"], ranged.inputs["Value"])
    gnt.links.new(ranged.outputs["Result"], bsdf.inputs["Roughness"])


def _shade_flat():
    """The sphere's faces flat-shaded, as Add ▸ Mesh ▸ UV Sphere makes them"""
    mesh = wearing("Ball").data
    mesh.polygons.foreach_set("use_smooth", [False] * len(mesh.polygons))
    mesh.update()


@row("surface_smooth_sphere", "A smooth-shaded coarse UV sphere (10 segments, 6 rings, Shade Smooth), "
     "Principled BSDF red, Roughness 0.3, on the ground", coloured=True, control=_shade_flat)
def _(tmpdir):
    import bpy

    base()
    bpy.ops.mesh.primitive_uv_sphere_add(segments=10, ring_count=6, radius=0.9, location=(0.0, 0.0, -0.35))
    bpy.ops.object.shade_smooth()
    mat = bpy.data.materials.new("Ball")
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.8, 0.1, 0.05, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.3
    bpy.context.object.data.materials.append(mat)


@row("surface_alpha_smoke", "A vertical plane, Principled BSDF orange, Alpha 0.4, in front of the smoke "
     "(its shadow falls out of view), Cycles at 8 transparent bounces", coloured=True, transparent_bounces=8,
     control=at_default("Principled BSDF", "Alpha", material="Veil"))
def _(tmpdir):
    import bpy

    mat, nt, out = material()
    principled(nt, out)
    base(ground=False)
    bpy.ops.mesh.primitive_plane_add(size=1.6, location=(-0.6, -2.0, 0.0), rotation=(math.pi / 2, 0.0, 0.0))
    glass = bpy.data.materials.new("Veil")
    bsdf = glass.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.35, 0.18, 0.07, 1.0)
    bsdf.inputs["Alpha"].default_value = 0.4
    bpy.context.object.data.materials.append(glass)
    volume_object(tmpdir, mat=mat)


@row("surface_alpha_shadow", "A horizontal plane, Principled BSDF orange, Alpha 0.4, over the ground "
     "(its shadow lets 60 % of the light through), Cycles at 8 transparent bounces", coloured=True,
     transparent_bounces=8, control=at_default("Principled BSDF", "Alpha", material="Veil"))
def _(tmpdir):
    import bpy

    base()
    bpy.ops.mesh.primitive_plane_add(size=1.2, location=(-0.3, -1.0, -0.5))
    veil = bpy.data.materials.new("Veil")
    bsdf = veil.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.35, 0.18, 0.07, 1.0)
    bsdf.inputs["Alpha"].default_value = 0.4
    bpy.context.object.data.materials.append(veil)


@row("surface_alpha_smoke_shadow", "A plane, Principled BSDF Alpha 0.4, between the light and the smoke "
     "(its corner seen at the top right): the smoke and the ground in its shadow, Cycles at 8 "
     "transparent bounces", transparent_bounces=8,
     control=at_default("Principled BSDF", "Alpha", material="Veil"))
def _(tmpdir):
    import bpy

    mat, nt, out = material()
    principled(nt, out)
    base()
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(1.6, -1.6, 1.9))
    _aim(bpy.context.object, (2.5 * 2, -2.5 * 2, 3.0 * 2))
    veil = bpy.data.materials.new("Veil")
    veil.node_tree.nodes["Principled BSDF"].inputs["Alpha"].default_value = 0.4
    bpy.context.object.data.materials.append(veil)
    volume_object(tmpdir, mat=mat)


@row("spot_grazing_floor", "Spot light low over a Diffuse floor (the light grazes it)",
     control=assign(lambda: light_object().data, "Spot light Spot Size at the default (45°)",
                    spot_size=math.pi / 4))
def _(tmpdir):
    base(lights=None, ground=False)
    _grazing_view()
    surface_ground('ShaderNodeBsdfDiffuse', Color=(0.8, 0.8, 0.8, 1.0))
    spot = light('SPOT', (-3.0, 1.0, -0.85), energy=2000.0)
    _aim(spot, (1.5, 1.0, -1.25))
    spot.data.spot_size = 1.2


@row("volume_bounces_16", "Light Paths ▸ Max Bounces ▸ Volume 16: white smoke (Density 1.5, Color 1), "
     "Cycles reference at 16 volume bounces", bounces=16,
     control=assign(lambda: active_scene().cycles, "Light Paths ▸ Max Bounces ▸ Volume at the default (0)",
                    volume_bounces=0))
def _(tmpdir):
    import bpy

    _pv_row(tmpdir, Density=1.5, Color=(1.0, 1.0, 1.0, 1.0))
    bpy.context.scene.cycles.volume_bounces = 16


@row("emission_scattered", "Object ▸ Visibility ▸ Volume Scatter on (the default): smoke lit by its "
     "glowing core alone (Emission Strength `density` through Map Range 1.6–2.6 → 0–6), no lamp; "
     "Cycles scatters the emission with no bounces", coloured=True,
     control=assign(volume, "The smoke's Ray Visibility ▸ Volume Scatter off (on, the row's, is the "
                    "default): its emission lights no volume", visible_volume_scatter=False))
def _(tmpdir):
    from . import bounces

    bounces.MEDIA["glowing_smoke"][0](tmpdir)


ROW_BY_ID = {r.id: r for r in ROWS}


# ---------------------------------------------------------------------------------------------
# Rendering

def reset() -> None:
    """An empty scene (as the tests' ``blank`` fixture makes it): File ▸ New with nothing in it."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)


def build(r: Row, tmpdir: str) -> None:
    """Row ``r``'s scene; an emissive row's volumes light nothing (Object ▸ Visibility ▸ Ray
    Visibility: Diffuse and Volume Scatter off), in both renders, so that the row compares the
    emission alone (the light a medium casts on the ground has its own row)."""
    import bpy

    reset()
    os.makedirs(tmpdir, exist_ok=True)
    r.build(tmpdir)
    if r.emissive:
        for ob in bpy.context.scene.objects:
            if ob.type == 'VOLUME':
                ob.visible_diffuse = False
                ob.visible_volume_scatter = False


def _read_render(tmpdir: str, name: str) -> np.ndarray:
    """The Render Result as a (h, w, 4) float32 array, top row first."""
    import bpy

    s = bpy.context.scene.render.image_settings
    s.file_format = 'OPEN_EXR'
    s.color_depth = '32'
    s.color_mode = 'RGBA'
    path = os.path.join(tmpdir, f"{name}.exr")
    bpy.data.images["Render Result"].save_render(path)
    img = bpy.data.images.load(path)
    try:
        w, h = img.size
        px = np.empty(w * h * 4, dtype=np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    return px.reshape(h, w, 4)[::-1].copy()


def render_cycles(r: Row, tmpdir: str, samples: int = 2048, seed: int = 0) -> tuple[np.ndarray, float]:
    """Row ``r`` rendered by Cycles with single scattering (BLENDER.md), or at the row's volume
    bounces: (RGBA, seconds)."""
    import bpy

    from ..blender.scene_builder import cycles_single_scattering

    build(r, tmpdir)
    scene = bpy.context.scene
    cycles_single_scattering(scene, samples=samples)
    scene.render.film_transparent = not r.background
    scene.cycles.volume_bounces = scene.cycles.max_bounces = r.bounces
    scene.cycles.transparent_max_bounces = r.transparent_bounces
    scene.cycles.seed = seed
    t0 = time.perf_counter()
    bpy.ops.render.render()
    seconds = time.perf_counter() - t0
    return _read_render(tmpdir, f"{r.id}_cycles_{seed}"), seconds


def final_render_module():
    """The registered TFM engine's ``final_render`` module (the repository's add-on or the
    installed extension, whichever registered the engine)."""
    import importlib

    import bpy

    for cls in bpy.types.RenderEngine.__subclasses__():
        if getattr(cls, "bl_idname", "") == 'TFM' and getattr(cls, "is_registered", True):
            package = cls.__module__.rsplit(".", 1)[0]
            return importlib.import_module(package + ".final_render")
    raise RuntimeError("the TFM engine is not registered")


@dataclasses.dataclass
class TfmResult:
    image: np.ndarray
    seconds: float
    messages: list[str]


def render_tfm(r: Row, tmpdir: str, samples: int = TFM_SAMPLES, control: bool = False) -> TfmResult:
    """Row ``r`` rendered by TFM (the add-on's settings at their defaults but ``samples``); with
    ``control``, the row's control applied after its build."""
    import bpy

    build(r, tmpdir)
    if control:
        r.control()
    scene = bpy.context.scene
    scene.render.engine = 'TFM'
    scene.render.film_transparent = not r.background
    scene.tfm.samples = samples
    fr = final_render_module()
    t0 = time.perf_counter()
    bpy.ops.render.render()
    seconds = time.perf_counter() - t0
    messages = [m for _, m in fr.last_messages]
    return TfmResult(_read_render(tmpdir, f"{r.id}_{'control' if control else 'tfm'}"), seconds, messages)


def render_control(r: Row, tmpdir: str) -> TfmResult:
    """Row ``r``'s control (``Row.control``) rendered by TFM as ``render_tfm`` renders the row."""
    return render_tfm(r, tmpdir, control=True)


# ---------------------------------------------------------------------------------------------
# References and comparison

def load_reference(row_id: str, directory: Path = REF_DIR) -> tuple[np.ndarray, dict]:
    """The stored Cycles reference: (h, w, 3) float32 and its metadata; a missing one raises
    FileNotFoundError naming the command that makes it."""
    path = directory / f"{row_id}.npz"
    if not path.exists():
        raise FileNotFoundError(f"no stored Cycles reference {path}: make it with `.venv/bin/python "
                                f"scripts/make_conformance_refs.py {row_id}` and commit it")
    with np.load(path) as z:
        image = z["rgb"].astype(np.float32)
        meta = {k: z[k].item() for k in z.files if k != "rgb"}
    return image, meta


def save_reference(row_id: str, image: np.ndarray, directory: Path = REF_DIR, **meta) -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"{row_id}.npz"
    np.savez_compressed(path, rgb=np.asarray(image[..., :3], dtype=np.float16), **meta)
    return path


@dataclasses.dataclass
class Comparison:
    ssim: float
    ratios: tuple[float, ...]     # total brightness TFM / Cycles: one, or per channel

    def passes(self) -> bool:
        return self.ssim >= SSIM_MIN and all(abs(q - 1.0) <= BRIGHTNESS_TOL for q in self.ratios)

    def ratio_text(self) -> str:
        return " / ".join(f"{q:.3f}" for q in self.ratios)


def compare(r: Row, tfm: np.ndarray, cycles: np.ndarray) -> Comparison:
    from ..engine import metrics

    tfm, cycles = np.asarray(tfm, np.float32)[..., :3], np.asarray(cycles, np.float32)[..., :3]
    ssim = metrics.ssim(tfm, cycles)
    if r.coloured:
        ratios = tuple(metrics.brightness_ratio(tfm[..., c:c + 1].repeat(3, -1),
                                                cycles[..., c:c + 1].repeat(3, -1)) for c in range(3))
    else:
        ratios = (metrics.brightness_ratio(tfm, cycles),)
    return Comparison(ssim, ratios)


def reference_sha1(row_id: str, directory: Path = REF_DIR) -> str:
    """The SHA-1 of the stored reference file ``<id>.npz``."""
    return hashlib.sha1((directory / f"{row_id}.npz").read_bytes()).hexdigest()


def save_control(row_id: str, comparison: Comparison, directory: Path = REF_DIR, **meta) -> Path:
    """The row's control against its reference, stored beside it as ``<id>.control.json``: the
    control's description, SSIM, brightness ratios, whether it fails the row, the reference's SHA-1
    (the figures hold for that reference) and ``meta``."""
    data = {"row": row_id, "control": ROW_BY_ID[row_id].control_text,
            "ssim": float(comparison.ssim), "ratios": [float(q) for q in comparison.ratios],
            "fails": not comparison.passes(),
            "reference_sha1": reference_sha1(row_id, directory), **meta}
    path = directory / f"{row_id}.control.json"
    path.write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n")
    return path


def load_control(row_id: str, directory: Path = REF_DIR) -> dict:
    """The stored figures of the row's control (``save_control``)."""
    return json.loads((directory / f"{row_id}.control.json").read_text())


def report_lines(messages: list[str], row: Row) -> list[str]:
    """The render-report lines that hold the row's expected substring."""
    return [m for m in messages if row.report and row.report in m]


def rows(names: list[str] | None = None) -> list[Row]:
    if not names:
        return list(ROWS)
    unknown = [n for n in names if n not in ROW_BY_ID]
    if unknown:
        raise KeyError(f"unknown rows: {', '.join(unknown)}")
    return [ROW_BY_ID[n] for n in names]



# ---------------------------------------------------------------------------------------------
# The page: python -m tfm_addon.bench.conformance [--out docs] (inside bpy; the bench's
# ``--only conformance`` runs it in a subprocess)

def _display(image: np.ndarray, white: float) -> np.ndarray:
    return np.clip(np.asarray(image, np.float64)[..., :3] / white, 0.0, 1.0) ** (1 / 2.2)


def strip_png(path: Path, cycles: np.ndarray, tfm: np.ndarray) -> Path:
    """Cycles | TFM | difference (|TFM - Cycles| x 4 in display values) as one small PNG; both
    images scaled by the Cycles image's white, as ``metrics`` does."""
    from PIL import Image

    white = float(np.percentile(cycles[..., :3].max(axis=-1), 99.9)) or 1.0
    a, b = _display(cycles, white), _display(tfm, white)
    diff = np.clip(np.abs(b - a) * 4.0, 0, 1)
    gap = np.ones((a.shape[0], 2, 3))
    strip = np.concatenate([a, gap, b, gap, diff], axis=1)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray((strip * 255 + 0.5).astype(np.uint8)).save(path, optimize=True)
    return path


@dataclasses.dataclass
class PageRow:
    row: Row
    status: str
    comparison: Comparison | None = None
    seconds: float = 0.0
    messages: list[str] = dataclasses.field(default_factory=list)
    reference: dict = dataclasses.field(default_factory=dict)


def status_of(row: Row, comparison: Comparison, messages: list[str]) -> str:
    """'pass' / 'FAIL' for a 'rendered' row; 'reported' (or 'report gone') for a 'reported' one;
    'wrong' (or 'now passes') for a 'wrong' one."""
    if row.expect == 'rendered':
        return 'pass' if comparison.passes() else 'FAIL'
    if row.expect == 'reported':
        if report_lines(messages, row):
            return 'reported'
        return 'report gone, passes: flip it' if comparison.passes() else 'report gone, FAIL'
    return 'now passes: flip it' if comparison.passes() else 'wrong'


def run_rows(names: list[str] | None, png_dir: Path, tmp: str, log=print) -> list[PageRow]:
    """Render every row with TFM, compare with its reference, write its PNG strip."""
    out = []
    for r in rows(names):
        if not (REF_DIR / f"{r.id}.npz").exists():
            out.append(PageRow(r, "no reference"))
            log(f"{r.id}: no reference")
            continue
        cycles, meta = load_reference(r.id)
        result = render_tfm(r, os.path.join(tmp, r.id))
        comparison = compare(r, result.image, cycles)
        strip_png(png_dir / f"{r.id}.png", cycles, result.image)
        page_row = PageRow(r, status_of(r, comparison, result.messages), comparison, result.seconds,
                           result.messages, meta)
        out.append(page_row)
        log(f"{r.id}: {page_row.status}, SSIM {comparison.ssim:.4f}, brightness "
            f"{comparison.ratio_text()}, TFM {result.seconds:.2f} s")
    return out


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def write_page(page_rows: list[PageRow], md: Path, png_dir: Path, blender: str, seconds: float) -> str:
    refs = [p.reference for p in page_rows if p.reference]
    ref_seconds = sum(float(m.get("seconds", 0.0)) for m in refs)
    samples = sorted({int(m["samples"]) for m in refs if "samples" in m})
    seed_ssim = min((float(m["seed_ssim"]) for m in refs if "seed_ssim" in m), default=float("nan"))
    counts: dict[str, int] = {}
    for p in page_rows:
        counts[p.status] = counts.get(p.status, 0) + 1
    rel = os.path.relpath(png_dir, md.parent)
    lines = [
        "# Conformance against Cycles",
        "",
        "Every Blender setting and node the engine reads, as a row: a small scene built by code "
        "(`tfm_addon/bench/conformance.py`), a stored converged Cycles reference "
        "(`tests/data/conformance/<id>.npz`, `scripts/make_conformance_refs.py`) and a test "
        "(`tests/blender/test_conformance.py`). Regenerate this page with "
        "`python -m tfm_addon.bench --only conformance`.",
        "",
        f"- Thresholds: SSIM ≥ {SSIM_MIN} and total brightness within {BRIGHTNESS_TOL:.0%} of Cycles "
        "(per channel, R / G / B, for coloured media), `tfm_addon.engine.metrics`.",
        f"- Cycles references: Blender {refs[0].get('blender', '?') if refs else '?'}, single scattering "
        "(volume_bounces 0, max_bounces 0, BLENDER.md's film settings; a row at N volume bounces sets "
        "volume_bounces = max_bounces = N; a row with a surface of Alpha below 1 sets Blender's default "
        "8 transparent bounces, which the engine does not limit), "
        f"{'/'.join(map(str, samples))} samples each (the mean of two seeds), "
        f"{ref_seconds / 60:.1f} min of Cycles in all on this machine; the two seeds agree to SSIM ≥ "
        f"{seed_ssim:.4f}.",
        "- TFM: the add-on's defaults (quality AUTO, Samples 0: 16 antialiasing samples), "
        f"{WIDTH}x{HEIGHT}, Blender {blender}; {seconds:.0f} s for every row, scenes built included.",
        "- Scenes: Blender's defaults for everything a row does not set (Space Object, clipping 0.001, "
        "Add-menu light sizes), a black World unless the row lights with it, a grey ground, a point "
        "light of 1000 W unless the row sets the light; emissive rows turn the volume's diffuse and "
        "volume-scatter visibility off in both renders (they compare the emission alone; a fire "
        "lighting the ground has its own row).",
        "- Expectation: **rendered** must pass; **reported** rows are not rendered yet and must "
        "say their line in the render report; **wrong** rows render wrongly without a word; each row's "
        "status and, but for rendered rows, its reason are in `tests/data/conformance/manifest.toml`.",
        "- Images: Cycles | TFM | difference (×4, display values, both scaled by the Cycles image's "
        "white).",
        "",
        "Today: " + counts_text(counts) + ".",
        "",
        "| row | setting / node | expected | status | SSIM | brightness | TFM (s) | report / note | "
        "Cycles \\| TFM \\| diff |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for p in page_rows:
        r, c = p.row, p.comparison
        note = r.wrong or "; ".join(p.messages)
        image = f'<img src="{rel}/{r.id}.png" width="392">' if c is not None else ""
        lines.append(
            f"| `{r.id}` | {_cell(r.title)} | {r.expect} | {p.status} | "
            f"{f'{c.ssim:.4f}' if c else ''} | {c.ratio_text() if c else ''} | "
            f"{f'{p.seconds:.2f}' if c else ''} | {_cell(note)} | {image} |")
    failing = [p for p in page_rows if p.comparison is not None and not p.comparison.passes()]
    lines += ["", f"## Rows that do not match Cycles today ({len(failing)})", ""]
    for p in failing:
        c = p.comparison
        lines.append(f"- `{p.row.id}` ({p.row.expect}): SSIM {c.ssim:.4f}, brightness "
                     f"{c.ratio_text()}" + (f"; {p.row.wrong}" if p.row.wrong else
                                            f"; report: {'; '.join(p.messages) or 'none'}"))
    text = "\n".join(lines) + "\n"
    md.parent.mkdir(parents=True, exist_ok=True)
    md.write_text(text)
    readme.write_block("conformance counts", f"{len(page_rows)} rows: {counts_text(counts)}")
    return text


def counts_text(counts: dict[str, int]) -> str:
    """'101 pass, 2 reported, 1 wrong': the rows per status, as the page and the README say it."""
    return ", ".join(f"{v} {k}" for k, v in sorted(counts.items()))


def main(argv: list[str] | None = None) -> int:
    import argparse
    import tempfile

    parser = argparse.ArgumentParser(prog="python -m tfm_addon.bench.conformance",
                                     description="Render every conformance row with TFM and write "
                                                 "the page (inside bpy).")
    root = Path(__file__).resolve().parents[2]
    parser.add_argument("rows", nargs="*", help="row ids (default: every row)")
    parser.add_argument("--md", type=Path, default=root / "docs" / "conformance.md")
    parser.add_argument("--png-dir", type=Path, default=root / "docs" / "conformance")
    args = parser.parse_args(argv)

    import bpy

    import tfm_addon

    tfm_addon.register()
    try:
        t0 = time.perf_counter()
        with tempfile.TemporaryDirectory(prefix="tfm_conformance_") as tmp:
            page_rows = run_rows(args.rows or None, args.png_dir, tmp,
                                 log=lambda s: print(s, flush=True))
        text = write_page(page_rows, args.md, args.png_dir, bpy.app.version_string,
                          time.perf_counter() - t0)
        print(text.split("\n| row |")[0])
        print(f"wrote {args.md}")
    finally:
        tfm_addon.unregister()
    return 0


if __name__ == "__main__":
    import sys

    sys.exit(main())
