"""Helpers shared by the tests that run inside Blender."""

from __future__ import annotations

import dataclasses
import hashlib
import os
import re

import numpy as np

from tfm_addon import scenes
from tfm_addon.engine import RenderSettings, Scene

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# Where the tests install the extension: the add-on is the module bl_ext.<repo>.<id>.
REPO = "tfm_test"
EXTENSION_ID = "tfm_volumes"
MODULE = f"bl_ext.{REPO}.{EXTENSION_ID}"

# Small and quick on llvmpipe.
SETTINGS = RenderSettings(view_steps=64, light_steps=64, map_resolution=128, coefficients=8)


def read_passes(path: str) -> dict[str, np.ndarray]:
    """A multilayer EXR written by Blender (one part per pass) as {pass: (h, w, c) float32},
    top row first."""
    import OpenEXR

    out = {}
    with OpenEXR.File(path, separate_channels=True) as f:
        for part in f.parts:
            channels = part.channels
            names = sorted(channels, key=lambda k: "RGBA".index(k[-1]))
            out[part.name().split(".")[-1]] = np.stack(
                [np.asarray(channels[k].pixels, dtype=np.float32) for k in names], axis=-1)
    return out


def render_passes(directory, name: str = "render") -> dict[str, np.ndarray]:
    """bpy.ops.render.render() on the context scene; its Combined and passes as arrays. Cycles'
    renders come from CYCLES_RENDERS, where the scene's render was stored (a missing one fails the
    test with the command that makes it)."""
    import bpy

    scene = bpy.context.scene
    stored = None
    if scene.render.engine == 'CYCLES':
        stored = os.path.join(CYCLES_RENDERS, cycles_key(scene) + ".npz")
        if os.path.exists(stored):
            with np.load(stored) as f:
                return {k: f[k] for k in f.files}
        if os.environ.get(STORE_ENV) != "1":
            import pytest

            pytest.fail(f"no stored Cycles render {os.path.relpath(stored, ROOT)} for this scene: make it "
                        f"with `bash scripts/store_cycles_renders.sh <this test file>` and commit it",
                        pytrace=False)
    bpy.ops.render.render()
    settings = scene.render.image_settings
    settings.media_type = 'MULTI_LAYER_IMAGE'
    settings.file_format = 'OPEN_EXR_MULTILAYER'
    settings.color_depth = '32'
    path = os.path.join(str(directory), f"{name}.exr")
    bpy.data.images["Render Result"].save_render(path)
    passes = read_passes(path)
    if stored is not None and os.environ.get(STORE_ENV) == "1":
        os.makedirs(CYCLES_RENDERS, exist_ok=True)
        np.savez_compressed(stored, **passes)
    return passes


def crop_to_active(scene: Scene) -> Scene:
    """The scene with its density grid cropped to the non-zero voxels, as a .vdb file keeps it
    (zero voxels are inactive) and the add-on reads it back."""
    m = scene.media[0]
    nonzero = np.argwhere(m.density != 0)
    lo, hi = nonzero.min(axis=0), nonzero.max(axis=0) + 1
    shift = np.eye(4)
    shift[:3, 3] = lo
    medium = dataclasses.replace(m, density=m.density[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]],
                                 index_to_world=m.index_to_world @ shift)
    return dataclasses.replace(scene, media=(medium,))


def smoke(width=64, height=48, n=32, **kwargs) -> Scene:
    """The renderer's smoke test scene, cropped like a .vdb file crops it."""
    return crop_to_active(scenes.smoke_scene(width=width, height=height, n=n, **kwargs))


def against_cycles(directory, samples: int = 512) -> tuple[float, float, np.ndarray]:
    """The context scene rendered by TFM, then by Cycles with single scattering (``samples``):
    (SSIM, brightness ratio) of TFM against Cycles, and Cycles' Combined."""
    import bpy

    from tfm_addon.blender import scene_builder
    from tfm_addon.engine import metrics

    tfm = render_passes(directory, "tfm")["Combined"]
    scene_builder.cycles_single_scattering(bpy.context.scene, samples=samples)
    cycles = render_passes(directory, "cycles")["Combined"]
    return metrics.ssim(tfm, cycles), metrics.brightness_ratio(tfm, cycles), cycles


# Cycles' images of the tests' scenes, stored by what Cycles reads (``cycles_key``): a test's Cycles
# render is read from here when its scene is one already rendered, and rendered by Cycles when it is
# not (any change to the scene, its settings or Blender's version makes another key). With
# TFM_STORE_CYCLES=1, the renders the tests make are written here (scripts/store_cycles_renders.sh).
CYCLES_RENDERS = os.path.join(ROOT, "tests", "data", "cycles")
STORE_ENV = "TFM_STORE_CYCLES"
_PRIMITIVE = {'BOOLEAN', 'INT', 'FLOAT', 'STRING', 'ENUM'}
_UUID = re.compile(rb"[0-9A-Fa-f]{8}-[0-9A-Fa-f]{4}-[0-9A-Fa-f]{4}-[0-9A-Fa-f]{4}-[0-9A-Fa-f]{12}")


def _canon(value):
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, str):       # paths: the tests' files sit in a new folder every run
        return os.path.basename(value) if os.sep in value else value
    if isinstance(value, (set, frozenset)):
        return sorted(value)
    if isinstance(value, (bool, int)) or value is None:
        return value
    return [_canon(v) for v in value]


def _walk(struct, depth: int, out: list) -> list:
    """The settable values of an RNA struct, and (``depth`` levels down) of the structs and
    collections it holds; an ID it points to by name."""
    import bpy

    for prop in struct.bl_rna.properties:
        ident = prop.identifier
        if ident in ("rna_type", "use_nodes"):     # use_nodes: deprecated, always on
            continue
        if prop.type in _PRIMITIVE:
            if not prop.is_readonly:
                out.append((ident, _canon(getattr(struct, ident))))
        elif depth > 0 and prop.type == 'POINTER':
            value = getattr(struct, ident)
            if isinstance(value, bpy.types.ID) or value is None:
                out.append((ident, None if value is None else value.name))
            else:
                out.append((ident, _walk(value, depth - 1, [])))
        elif depth > 0 and prop.type == 'COLLECTION':
            out.append((ident, [_walk(item, depth - 1, []) for item in list(getattr(struct, ident))[:64]]))
    return out


def _image(image) -> list:
    pixels = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(pixels)
    return [image.name, list(image.size), hashlib.sha1(pixels.tobytes()).hexdigest()]


def _node_tree(tree, out: list, seen: set) -> list:
    if tree is None or tree.as_pointer() in seen:     # node groups once; a material's own tree
        return out                                     # and the world's share a name
    seen.add(tree.as_pointer())
    for node in sorted(tree.nodes, key=lambda n: n.name):
        entry = [node.bl_idname, _walk(node, 3, [])]
        entry.append([_canon(s.default_value) if hasattr(s, "default_value") else None for s in node.inputs])
        if getattr(node, "image", None) is not None:
            entry.append(_image(node.image))
        if getattr(node, "node_tree", None) is not None:
            entry.append(_node_tree(node.node_tree, [], seen))
        out.append(entry)
    out.append(sorted((lk.from_node.name, lk.from_socket.identifier, lk.to_node.name, lk.to_socket.identifier,
                       lk.is_muted) for lk in tree.links))
    return out


def _geometry(mesh) -> str:
    """A mesh's shape, whatever the order of its vertices and faces (a UV sphere's face order
    differs from one process to the next): its points, face centres and areas, each sorted."""
    found = []
    for items, name, width in ((mesh.vertices, "co", 3), (mesh.polygons, "center", 3),
                               (mesh.polygons, "area", 1)):
        values = np.empty(width * len(items), np.float32)
        items.foreach_get(name, values)
        rows = values.reshape(-1, width).round(5)
        found.append(rows[np.lexsort(rows.T[::-1])].tobytes())
    return hashlib.sha1(b"|".join(found)).hexdigest()


def _file(path: str) -> str:
    """A volume file's content, but for the identifier OpenVDB writes anew into every file."""
    import bpy

    try:
        with open(bpy.path.abspath(path), "rb") as f:
            data = f.read()
    except OSError:
        return "missing"
    return hashlib.sha1(_UUID.sub(b"", data, count=1)).hexdigest()


def _layer_collections(layer, out: list) -> list:
    out.append((layer.name, layer.exclude, layer.holdout, layer.indirect_only, layer.collection.hide_render))
    for child in layer.children:
        _layer_collections(child, out)
    return out


def cycles_key(scene) -> str:
    """A digest of what Cycles reads to render ``scene``: Blender's version, the render, Cycles,
    colour and view layer settings, every object (its settings, its evaluated geometry, its data,
    lights, cameras and volumes with their files), materials and the world with their node trees
    and images."""
    import bpy

    depsgraph = bpy.context.evaluated_depsgraph_get()
    parts: list = [bpy.app.version_string, scene.frame_current, scene.camera and scene.camera.name,
                   _walk(scene.render, 0, []), _walk(scene.cycles, 0, []), _walk(scene.view_settings, 0, []),
                   _layer_collections(bpy.context.view_layer.layer_collection, [])]
    seen: set = set()
    materials = set()
    for ob in sorted(scene.objects, key=lambda o: o.name):
        entry = [ob.name, ob.type, _walk(ob, 1, [])]
        if ob.type in ('MESH', 'CURVE', 'SURFACE', 'META', 'FONT'):
            evaluated = ob.evaluated_get(depsgraph)
            mesh = evaluated.to_mesh()
            entry.append(_geometry(mesh))
            evaluated.to_mesh_clear()
        elif ob.data is not None:
            entry.append(_walk(ob.data, 2, []))
            if ob.type == 'VOLUME':
                entry.append(_file(ob.data.filepath))
            if ob.type == 'LIGHT' and ob.data.node_tree is not None:
                entry.append(_node_tree(ob.data.node_tree, [], seen))
        materials.update(slot.material for slot in ob.material_slots if slot.material is not None)
        parts.append(entry)
    for material in sorted(materials, key=lambda m: m.name):
        parts.append([material.name, _walk(material, 0, []), _node_tree(material.node_tree, [], seen)])
    world = scene.world
    if world is not None:
        parts.append([world.name, _walk(world, 0, []), _node_tree(world.node_tree, [], seen)])
    return hashlib.sha1(repr(parts).encode()).hexdigest()[:20]


def default_sigint() -> None:
    """A subprocess's ``preexec_fn``: SIGINT at its default, as a shell starts a program (a test run
    by a pytest-xdist worker inherits the worker's ignored SIGINT, and Python then installs no
    KeyboardInterrupt handler)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)


class FakeEngine:
    """What final_render uses of a RenderEngine, recorded; ``test_break`` (Esc in Blender) answers
    ``on_break()`` from its ``break_at``-th check on (never without ``break_at``)."""

    is_preview = False
    camera_override = None

    def __init__(self, width, height, break_at=None, on_break=lambda: True):
        self.resolution_x, self.resolution_y = width, height
        self.break_at, self.on_break, self.checks = break_at, on_break, 0
        self.progress, self.reports, self.errors, self.results = [], [], [], 0

    def test_break(self):
        self.checks += 1
        return self.break_at is not None and self.checks >= self.break_at and self.on_break()

    def update_progress(self, fraction):
        self.progress.append(fraction)

    def update_stats(self, stats, info):
        pass

    def report(self, levels, message):
        self.reports.append((set(levels), message))

    def error_set(self, message):
        self.errors.append(message)

    def add_pass(self, *args, **kwargs):
        pass

    def begin_result(self, *args, **kwargs):
        from types import SimpleNamespace

        self.results += 1
        return SimpleNamespace(layers=[SimpleNamespace(passes=[])])

    def end_result(self, result, cancel=False):
        pass


def read_exr(path) -> np.ndarray:
    """The first part of an EXR file as an (h, w, c) array, channels in RGBA order."""
    import OpenEXR

    with OpenEXR.File(str(path), separate_channels=True) as f:
        channels = f.parts[0].channels
        names = sorted(channels, key=lambda k: "RGBA".index(k[-1]))
        return np.stack([np.asarray(channels[k].pixels) for k in names], axis=-1)


def moving_light_shot(tmp_path, width: int, height: int, samples: int, frames: int = 4, n: int = 24) -> str:
    """The smoke scene as an animation of ``frames`` frames (the light moves: every frame builds
    its light maps anew) written as EXR files, saved to ``tmp_path``/shot.blend; its path."""
    import bpy

    from tfm_addon.blender import scene_builder

    made = scene_builder.build(smoke(width=width, height=height, n=n), str(tmp_path), settings=SETTINGS,
                               samples=samples)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, frames
    light = made["lights"][0]
    for frame in range(1, frames + 1):
        light.location.x += 0.3
        light.keyframe_insert("location", frame=frame)
    settings = scene.render.image_settings
    settings.file_format = 'OPEN_EXR'
    settings.color_depth = '32'
    blend = str(tmp_path / "shot.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    return blend


def farm_shot(tmp_path) -> str:
    """The farm tests' 4-frame animation (the camera moves and the light's power is animated:
    every frame differs; 16 samples, adaptive) written as EXR files, saved to ``tmp_path``/
    shot.blend; its path."""
    import bpy

    from tfm_addon.blender import scene_builder

    made = scene_builder.build(smoke(width=32, height=24, n=16), str(tmp_path), settings=SETTINGS,
                               samples=16)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 4
    camera = scene.camera
    for frame, dx in ((1, 0.0), (4, 0.6)):
        camera.location.x += dx
        camera.keyframe_insert("location", frame=frame)
    light = made["lights"][0].data
    for frame, power in ((1, light.energy), (4, 2.0 * light.energy)):
        light.energy = power
        light.keyframe_insert("energy", frame=frame)
    settings = scene.render.image_settings
    settings.file_format = 'OPEN_EXR'
    settings.color_depth = '32'
    settings.exr_codec = 'ZIP'
    blend = str(tmp_path / "shot.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    return blend
