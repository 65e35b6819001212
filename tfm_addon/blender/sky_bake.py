"""A world whose Background colour is a Sky Texture, baked by Cycles into a small equirectangular
image in a separate Blender process (a render engine may not start a render inside its own), and
read as the world's environment like an HDRI. Each bake is kept by the world's content, so that a
redraw, a camera move or a click never bakes again."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import threading

import numpy as np

from ..engine import caches
from ..engine.environment import Environment, from_image
from . import background

BAKE_SIZE = (512, 1024)     # (rows, columns) of the baked equirectangular image (the background)
BAKE_SAMPLES = 32           # the world alone converges in a few samples; the background shows the noise of 8
BAKE_TIMEOUT = 60.0         # seconds before a bake is given up

# Run in the child: append the world into an empty scene, look at it through a panoramic
# equirectangular camera at the origin with Cycles, write the radiance as an EXR.
CHILD = r"""
import json
import math
import math
import sys
import bpy
import numpy as np
blend, name, exr, w, h, samples = sys.argv[-6:]
bpy.ops.wm.read_factory_settings(use_empty=True)
with bpy.data.libraries.load(blend, link=False) as (src, dst):
    dst.worlds = [name]
world = dst.worlds[0]
scene = bpy.context.scene
scene.world = world
out = world.node_tree.get_output_node('CYCLES')
for link in list(world.node_tree.links):
    if link.to_node == out and link.to_socket.name == "Volume":
        world.node_tree.links.remove(link)
world.cycles_visibility.camera = True
scene.render.engine = 'CYCLES'
scene.cycles.device = 'CPU'
scene.cycles.samples = int(samples)
scene.cycles.use_adaptive_sampling = False
scene.cycles.use_denoising = False
scene.cycles.pixel_filter_type = 'BOX'
scene.cycles.filter_width = 1.0
scene.render.resolution_percentage = 100
scene.render.film_transparent = False
scene.view_settings.view_transform = 'Standard'
scene.view_settings.exposure = 0.0
scene.view_settings.gamma = 1.0
s = scene.render.image_settings
s.file_format = 'OPEN_EXR'
s.color_mode = 'RGB'
s.color_depth = '32'
cam = bpy.data.cameras.new("bake")
ob = bpy.data.objects.new("bake", cam)
scene.collection.objects.link(ob)
scene.camera = ob


def render(path, w, h):
    scene.render.resolution_x, scene.render.resolution_y = w, h
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(path, check_existing=False)
    px = np.empty(w * h * image.channels, np.float32)
    image.pixels.foreach_get(px)
    bpy.data.images.remove(image)
    return px.reshape(h, w, -1)[:, :, :3]


# A sun disc is far smaller than a pixel of the image: it is baked apart, through a narrow camera
# aimed at it, as the light it sends (radiance times solid angle), with and without the disc.
suns = [n for n in world.node_tree.nodes if n.bl_idname == 'ShaderNodeTexSky' and n.sun_disc
        and n.sky_type in {'SINGLE_SCATTERING', 'MULTIPLE_SCATTERING'}]
found = []
side = 32
for node in suns:
    e, r = node.sun_elevation, node.sun_rotation
    d = (-math.cos(e) * math.sin(r), math.cos(e) * math.cos(r), math.sin(e))
    cam.type = 'PERSP'
    cam.sensor_fit = 'HORIZONTAL'
    cam.angle = max(3.0 * node.sun_size, 1e-4)
    ob.rotation_euler = (0.5 * math.pi + e, 0.0, r)
    with_disc = render(exr + ".on.exr", side, side)
    node.sun_disc = False
    without = render(exr + ".off.exr", side, side)
    pixel = (2.0 * math.tan(0.5 * cam.angle) / side) ** 2
    light = (with_disc - without).sum(axis=(0, 1)) * pixel
    found.append({"direction": d, "light": [float(x) for x in light]})
cam.type = 'PANO'
cam.panorama_type = 'EQUIRECTANGULAR'
# Looking along +X with +Z up: the image's centre column is the +X direction, as an HDRI's.
ob.rotation_euler = (0.5 * math.pi, 0.0, -0.5 * math.pi)
np.save(exr + ".npy", render(exr, int(w), int(h))[::-1])     # top row first
print("TFM_SUNS " + json.dumps(found))
"""


class BakeFailed(Exception):
    pass


def _command(script: str, args: list[str]) -> list[str]:
    """Blender's own executable when this is one, else this Python with bpy as a module."""
    import bpy

    binary = bpy.app.binary_path
    if binary and os.path.basename(binary).lower().startswith("blender"):
        return [binary, "-b", "--factory-startup", "--python-expr", script, "--", *args]
    return [sys.executable, "-c", "import bpy\n" + script, *args]


def bake(world, size: tuple[int, int] = BAKE_SIZE, samples: int = BAKE_SAMPLES,
         timeout: float = BAKE_TIMEOUT) -> tuple[np.ndarray, tuple]:
    """The world's Background radiance by direction, rendered by Cycles: an (h, w, 3) float32
    image, top row first, its centre column the +X direction, without its sun discs; and the discs
    (``_discs``). Raises BakeFailed."""
    return _run(*_prepare(world, size, samples), timeout)


def _prepare(world, size, samples) -> tuple[tempfile.TemporaryDirectory, list[str], str]:
    """The world written to a temporary .blend, and the command that bakes it (read from
    Blender's data: call on the main thread)."""
    import bpy

    h, w = size
    tmp = tempfile.TemporaryDirectory(prefix="tfm_sky_")
    blend = os.path.join(tmp.name, "world.blend")
    exr = os.path.join(tmp.name, "sky.exr")
    bpy.data.libraries.write(blend, {world}, path_remap='ABSOLUTE', fake_user=True)
    return tmp, _command(CHILD, [blend, world.name, exr, str(w), str(h), str(samples)]), exr


def _run(tmp, cmd: list[str], exr: str, timeout: float) -> tuple[np.ndarray, tuple]:
    """Run a prepared bake (touches no Blender data: any thread)."""
    with tmp:
        try:
            process = background.child(subprocess.Popen(
                cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                env={**os.environ, "PYTHONPATH": ""}))
        except OSError as ex:
            raise BakeFailed(f"Blender could not be started ({ex})") from None
        try:
            stdout, stderr = process.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            process.kill()
            process.communicate()
            raise BakeFailed(f"it took longer than {timeout:.0f} s") from None
        finally:
            background.finished(process)
        if process.returncode != 0 or not os.path.exists(exr + ".npy"):
            tail = (stderr or stdout or "").strip().splitlines()[-1:] or ["no output"]
            raise BakeFailed(f"Cycles failed ({tail[0]})")
        image = np.load(exr + ".npy").astype(np.float32)
        image.setflags(write=False)
        return image, _discs(stdout)


def sky_node(world):
    """A Sky Texture whose colour is used in the world's node tree, or None."""
    tree = world.node_tree if world is not None else None
    if tree is None:
        return None
    return next((n for n in tree.nodes if n.bl_idname == 'ShaderNodeTexSky' and not n.mute
                 and any(o.is_linked for o in n.outputs)), None)


_LAYOUT = {"location", "location_absolute", "width", "height", "dimensions", "select", "show_options",
           "show_preview", "hide", "show_texture", "color", "use_custom_color", "color_tag", "label",
           "warning_propagation", "name", "bl_idname", "bl_label", "bl_description", "bl_icon",
           "bl_static_type", "type"}


def _values(struct) -> tuple:
    out = []
    for prop in struct.bl_rna.properties:
        if prop.identifier in _LAYOUT or prop.type not in {'BOOLEAN', 'INT', 'FLOAT', 'ENUM'}:
            continue
        v = getattr(struct, prop.identifier)
        out.append((prop.identifier, tuple(v) if hasattr(v, "__len__") and not isinstance(v, str)
                    else v if not isinstance(v, set) else tuple(sorted(v))))
    return tuple(out)


def content_key(world) -> tuple:
    """What the bake depends on: every node's settings and input values, and the links."""
    tree = world.node_tree
    nodes = tuple((n.name, n.bl_idname, n.mute, _values(n),
                   tuple(_values(i) for i in n.inputs if hasattr(i, "default_value"))) for n in tree.nodes)
    links = tuple(sorted((k.from_node.name, k.from_socket.identifier, k.to_node.name, k.to_socket.identifier)
                         for k in tree.links if not k.is_muted))
    return nodes, links


_baked = caches.memo("sky_bake.bakes", 8)      # content key -> (Environment or None, report line)
_latest = caches.memo("sky_bake.latest", 16)    # world name -> its last bake's (Environment or None, line)
_running: dict = {}     # content key -> the thread baking it (ended with the memos: background.end)
caches.REGISTRY.on_clear(_running.clear)


def sky_environment(world, wait: bool) -> tuple[Environment | None, str]:
    """The world baked by Cycles (kept by its content) as an environment with its sun discs, and
    its report line. With ``wait`` False
    (the viewport) a bake not done yet runs in the background, one at a time (a dragged slider
    bakes its last value, not each one), and the world's previous bake, or None, comes back
    meanwhile with a line saying so; the world is tagged for an update when a bake is done."""
    label = f"World '{world.name}'"
    key = content_key(world)
    hit = _baked.get(key)
    if hit is not None:
        _latest.put(world.name, hit)
        return hit
    thread = _running.get(key)
    if thread is None and (wait or not _running):
        try:
            job = _prepare(world, BAKE_SIZE, BAKE_SAMPLES)
        except (OSError, RuntimeError) as ex:
            return None, (f"{label}: its Sky Texture could not be baked ({ex}); using the world's "
                          f"viewport colour")

        def work():
            try:
                image, discs = _run(*job, BAKE_TIMEOUT)
                env = from_image(image, discs=discs)
                h, w = BAKE_SIZE
                result = env, f"{label}: its Sky Texture is baked with Cycles ({w}x{h}, {BAKE_SAMPLES} " \
                              f"samples)"
            except BakeFailed as ex:
                result = None, f"{label}: its Sky Texture could not be baked with Cycles ({ex}); using " \
                               f"the world's viewport colour"
            _baked.put(key, result)
            _running.pop(key, None)

        thread = threading.Thread(target=work, name="TFM sky bake", daemon=True)
        _running[key] = thread
        background.start(thread)
        if not wait:
            _tag_when_done(thread, world.name)
    if wait:
        thread.join()
        result = _baked.get(key, (None, f"{label}: its Sky Texture bake was stopped; using the world's "
                                        f"viewport colour"))
        _latest.put(world.name, result)
        return result
    previous = _latest.get(world.name, (None, None))[0]
    if previous is not None:
        return previous, f"{label}: its Sky Texture is being baked again with Cycles; its previous bake " \
                         f"lights the scene meanwhile"
    return None, f"{label}: its Sky Texture is being baked with Cycles; the world's viewport colour " \
                 f"lights the scene meanwhile"


def _tag_when_done(thread: threading.Thread, name: str) -> None:
    """Tag the world for an update once its bake is done, so that the viewport reads it."""
    import bpy

    def poll():
        if thread.is_alive():
            return 0.25
        world = bpy.data.worlds.get(name)
        if world is not None:
            world.update_tag()
        return None

    background.timer(poll, first_interval=0.25)


def _discs(stdout: str) -> tuple:
    """Each sun disc baked apart: (direction toward it, the irradiance it sends, RGB)
    (environment.Environment.discs)."""
    line = next((x for x in stdout.splitlines() if x.startswith("TFM_SUNS ")), None)
    if line is None:
        raise BakeFailed("Cycles gave no sun")
    return tuple((tuple(float(v) for v in sun["direction"]), tuple(max(float(v), 0.0) for v in sun["light"]))
                 for sun in json.loads(line[len("TFM_SUNS "):]))
