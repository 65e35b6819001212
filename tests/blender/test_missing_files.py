"""A file a frame reads that is missing (blender/files.py): the frame renders the rest, the image in
Cycles' missing-texture pink (1, 0, 1) as Cycles does, and one line names the node and its
material or world, the path as written and the absolute path tried; strict mode fails the frame.

Measured with this Blender's Cycles (16 samples, no denoising): a missing Environment Texture
lights the scene and is seen behind it as (1, 0, 1) x the Background's Strength (2, 0, 2 at
Strength 2), a missing Image Texture on a Principled BSDF's Base Color gives the base colour
(1, 0, 1) (a diffuse plane under that world: 1.99, 0, 1.99)."""

import importlib
import os
import subprocess
import sys

import bpy
import numpy as np
from blender_helpers import MODULE, ROOT, render_passes

PINK = "rendering without it: Cycles' missing-texture pink (1, 0, 1) instead"


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


def _warnings():
    return [m for level, m in _mod("final_render").last_messages if level == 'WARNING']


def _extracted_warnings():
    depsgraph = bpy.context.evaluated_depsgraph_get()
    return _mod("extract").extract(depsgraph).all_warnings


def _nodes(owner):
    if owner.node_tree is None:
        owner.use_nodes = True      # Blender < 5.0
    return owner.node_tree


def _scene(strength=1.0, color=(1.0, 1.0, 1.0)):
    """16x12 pixels, TFM, one sample; a camera looking down -Z and a uniform world."""
    scene = bpy.context.scene
    scene.render.engine = 'TFM'
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = 16, 12, 100
    scene.tfm.samples = 1
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    world = bpy.data.worlds.new("World")
    scene.world = world
    bg = next(n for n in _nodes(world).nodes if n.bl_idname == 'ShaderNodeBackground')
    bg.inputs["Color"].default_value = (*color, 1.0)
    bg.inputs["Strength"].default_value = strength
    return scene, bg


def _plane(name, x, size=1.0, z=-3.0):
    """A plane facing the camera, its material a Principled BSDF (rough, no specular)."""
    mesh = bpy.data.meshes.new(name)
    h = size / 2.0
    mesh.from_pydata([(x - h, -h, z), (x + h, -h, z), (x + h, h, z), (x - h, h, z)], [], [(0, 1, 2, 3)])
    mesh.uv_layers.new(name="UVMap")
    ob = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(ob)
    mat = bpy.data.materials.new(name)
    p = next(n for n in _nodes(mat).nodes if n.bl_idname == 'ShaderNodeBsdfPrincipled')
    p.inputs["Roughness"].default_value = 1.0
    p.inputs["Specular IOR Level"].default_value = 0.0
    mesh.materials.append(mat)
    return ob, mat, p


def _textured(mat, principled, image):
    tex = mat.node_tree.nodes.new('ShaderNodeTexImage')
    tex.image = image
    mat.node_tree.links.new(tex.outputs["Color"], principled.inputs["Base Color"])
    return tex


def _file_image(name, filepath):
    """An image data-block reading ``filepath`` (which need not exist)."""
    image = bpy.data.images.new(name, 4, 4)
    image.source = 'FILE'
    image.filepath = filepath
    return image


def _write_png(path, rgba=(1.0, 0.0, 0.0, 1.0), size=4):
    """A small PNG made by code."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    image = bpy.data.images.new("written", size, size)
    image.pixels.foreach_set(np.tile(np.asarray(rgba, np.float32), size * size))
    image.filepath_raw = path
    image.file_format = 'PNG'
    image.save()
    bpy.data.images.remove(image)
    return path


def _pinkness(rgb):
    """(red, green, blue) means of a region."""
    return tuple(float(v) for v in rgb.reshape(-1, rgb.shape[-1])[:, :3].mean(axis=0))


def test_a_missing_surface_texture_renders_pink_and_the_rest(blank, tmp_path):
    _scene()
    _, mat, p = _plane("Wall", 0.5)                     # right half of the frame: textured
    _, _, grey = _plane("Grey", -0.5)                   # left half: a plain grey surface
    grey.inputs["Base Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    tried = os.path.normpath(str(tmp_path / "textures" / "bricks.png"))
    _textured(mat, p, _file_image("Bricks", tried))

    combined = render_passes(tmp_path, "tfm")["Combined"]     # no exception: the frame renders
    r, g, b = _pinkness(combined[4:8, 10:14])
    assert r > 0.5 and abs(r - b) < 0.05 * r and g < 0.02 * r, (r, g, b)    # Cycles' pink, lit
    r, g, b = _pinkness(combined[4:8, 2:6])
    assert r > 0.2 and abs(r - g) < 0.02 and abs(g - b) < 0.02, (r, g, b)   # the rest renders
    assert (f"Material 'Wall': node 'Image Texture' reads image 'Bricks': file '{tried}' not found; "
            f"{PINK}") in _warnings(), _warnings()


def test_a_missing_hdri_lights_and_shows_pink_as_cycles_does(blank, tmp_path):
    _, bg = _scene(strength=2.0)
    world = bpy.context.scene.world
    env = world.node_tree.nodes.new('ShaderNodeTexEnvironment')
    env.image = _file_image("Sky", "//hdri/sky.exr")
    world.node_tree.links.new(env.outputs["Color"], bg.inputs["Color"])
    _plane("Ground", 0.5)
    blend = str(tmp_path / "shot.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    tried = os.path.normpath(str(tmp_path / "hdri" / "sky.exr"))

    combined = render_passes(tmp_path, "tfm")["Combined"]
    r, g, b = _pinkness(combined[0:3, 0:6])                  # the world seen behind: (2, 0, 2)
    assert abs(r - 2.0) < 0.05 and abs(b - 2.0) < 0.05 and g < 0.01, (r, g, b)
    r, g, b = _pinkness(combined[4:8, 10:14])               # a white-ish plane lit by it: pink
    assert r > 0.5 and abs(r - b) < 0.05 * r and g < 0.02 * r, (r, g, b)
    said = _warnings()
    assert (f"World 'World': node 'Environment Texture' reads image 'Sky': file '//hdri/sky.exr' not "
            f"found at '{tried}'; {PINK}") in said, said
    assert not any("viewport colour" in m for m in said), said


def test_relative_paths_resolve_against_the_saved_blend(blank, tmp_path, addon):
    _scene()
    _, mat, p = _plane("Wall", 0.5)
    _, other, q = _plane("Other", -0.5)
    _write_png(str(tmp_path / "tex" / "red.png"))
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    present = bpy.data.images.load("//tex/red.png")
    assert present.filepath == "//tex/red.png"
    _textured(mat, p, present)
    _textured(other, q, _file_image("Gone", "//tex/gone.png"))
    files = addon.blender.files
    assert files.missing_image(present) is None
    missing = files.missing_image(bpy.data.images["Gone"])
    tried = os.path.normpath(str(tmp_path / "tex" / "gone.png"))
    assert missing.tried == (tried,)

    line = (f"Material 'Other': node 'Image Texture' reads image 'Gone': file '//tex/gone.png' not found "
            f"at '{tried}'; {PINK}")
    said = _extracted_warnings()
    assert line in said and not any("'red.png'" in m or "tex/red" in m for m in said), said
    assert addon.blender.preflight.check(bpy.context.scene, gl=False).problems == [line]

    combined = render_passes(tmp_path, "tfm")["Combined"]
    r, g, b = _pinkness(combined[4:8, 10:14])           # the file found: red, not pink
    assert r > 0.3 and g < 0.02 * r and b < 0.02 * r, (r, g, b)


def test_a_linked_image_resolves_against_its_library(blank, tmp_path, addon):
    lib = str(tmp_path / "lib" / "assets.blend")
    _write_png(str(tmp_path / "lib" / "tex" / "red.png"))
    made = [_file_image("Red", "//tex/red.png"), _file_image("Gone", "//tex/gone.png")]
    bpy.data.libraries.write(lib, set(made), path_remap='NONE', fake_user=True)
    for image in made:
        bpy.data.images.remove(image)
    os.makedirs(tmp_path / "shot")
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot" / "shot.blend"))   # elsewhere
    with bpy.data.libraries.load(lib, link=True) as (_, into):
        into.images = ["Red", "Gone"]
    red, gone = into.images
    assert red.library is not None and red.filepath == "//tex/red.png"
    files = addon.blender.files
    assert files.missing_image(red) is None              # found next to the library, not the shot
    tried = os.path.normpath(str(tmp_path / "lib" / "tex" / "gone.png"))
    assert files.missing_image(gone).tried == (tried,)
    _scene()
    _, mat, p = _plane("Wall", 0.5)
    _textured(mat, p, gone)
    line = (f"Material 'Wall': node 'Image Texture' reads image 'Gone': file '//tex/gone.png' not found "
            f"at '{tried}'; {PINK}")
    assert addon.blender.preflight.check(bpy.context.scene, gl=False).problems == [line]
    assert line in _extracted_warnings()


def test_packed_and_generated_images_are_never_missing(blank, tmp_path, addon):
    _scene()
    _, mat, p = _plane("Packed", 0.5)
    _, other, q = _plane("Generated", -0.5)
    path = _write_png(str(tmp_path / "packed.png"))
    packed = bpy.data.images.load(path)
    packed.pack()
    os.remove(path)                                    # the packed copy is what renders
    generated = bpy.data.images.new("Made", 8, 8, float_buffer=True)
    assert generated.source == 'GENERATED'
    _textured(mat, p, packed)
    _textured(other, q, generated)
    files = addon.blender.files
    assert files.missing_image(packed) is None and files.missing_image(generated) is None
    said = _extracted_warnings()
    assert not any("rendering without it" in m for m in said), said
    assert addon.blender.preflight.check(bpy.context.scene, gl=False).problems == []


def test_a_udim_image_with_one_tile_missing_names_the_tile(blank, tmp_path, addon):
    _scene()
    _, mat, p = _plane("Tiled", 0.5)
    first = _write_png(str(tmp_path / "udim" / "skin.1001.png"))
    image = bpy.data.images.load(first)
    image.source = 'TILED'
    image.tiles.new(1002)
    assert image.filepath.endswith("skin.<UDIM>.png")
    _textured(mat, p, image)
    gone = os.path.normpath(str(tmp_path / "udim" / "skin.1002.png"))
    written = image.filepath
    missing = addon.blender.files.missing_image(image)
    assert missing.tried == (gone,) and missing.total == 2

    line = (f"Material 'Tiled': node 'Image Texture' reads image '{image.name}': 1 of its 2 files "
            f"'{written}' not found, the first '{gone}'; {PINK}")
    assert line in _extracted_warnings(), (line, _extracted_warnings())
    assert addon.blender.preflight.check(bpy.context.scene, gl=False).problems == [line]
    _write_png(gone)                                   # every tile there: nothing said
    assert addon.blender.files.missing_image(image) is None
    assert addon.blender.preflight.check(bpy.context.scene, gl=False).problems == []


def test_a_missing_gobo_projects_pink(blank, tmp_path):
    _scene()
    spot = bpy.data.objects.new("Spot", bpy.data.lights.new("Spot", 'SPOT'))
    bpy.context.scene.collection.objects.link(spot)
    tried = os.path.normpath(str(tmp_path / "gobo.png"))
    spot.data.tfm.gobo = _file_image("Gobo", tried)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    extraction = _mod("extract").extract(depsgraph)
    light = next(li for li in extraction.lights if li.name == "Spot")
    assert np.allclose(light.gobo, (1.0, 0.0, 1.0))
    assert (f"Light 'Spot': its projected texture reads image 'Gobo': file '{tried}' not found; "
            f"{PINK}") in extraction.all_warnings, extraction.all_warnings


def test_an_image_sequence_reads_the_frames_file(blank, tmp_path, addon):
    scene, _ = _scene()
    _, mat, p = _plane("Film", 0.5)
    for n in (1, 3):                                   # frame 2's file is missing
        _write_png(str(tmp_path / "seq" / f"shot_{n:03d}.png"))
    image = bpy.data.images.load(str(tmp_path / "seq" / "shot_001.png"))
    image.source = 'SEQUENCE'
    tex = _textured(mat, p, image)
    tex.image_user.frame_duration, tex.image_user.frame_start = 3, 1
    files = addon.blender.files
    for frame in (1, 2, 3):
        want = os.path.normpath(str(tmp_path / "seq" / f"shot_{frame:03d}.png"))
        assert files.image_files(image, frame, tex.image_user) == [want]
    scene.frame_set(1)                  # its file there (bpy gives no sequence's pixels: said, pink)
    said = _extracted_warnings()
    assert not any("not found" in m for m in said), said
    assert not any("IndexError" in m for m in said), said
    scene.frame_set(2)
    gone = os.path.normpath(str(tmp_path / "seq" / "shot_002.png"))
    said = _extracted_warnings()
    assert any(f"file '{gone}' not found; {PINK}" in m for m in said), said
    scene.frame_start, scene.frame_end = 1, 3
    problems = addon.blender.preflight.check(scene, gl=False).problems
    assert len(problems) == 1 and f"the first '{gone}'" in problems[0], problems


# One render-farm worker: Blender with the add-on, rendering frame 1 of a saved file (test_farm.py).
WORKER = """
import sys
import bpy
import tfm_addon

tfm_addon.register()
blend, out = sys.argv[-2:]
bpy.ops.wm.open_mainfile(filepath=blend)
scene = bpy.context.scene
scene.frame_start = scene.frame_end = 1
scene.render.filepath = out + "/frame_####"
bpy.ops.render.render(animation=True)
"""


def test_strict_mode_fails_a_frame_with_a_missing_image(blank, tmp_path):
    scene, bg = _scene()
    _, mat, p = _plane("Wall", 0.5)
    _textured(mat, p, _file_image("Bricks", "//textures/bricks.png"))
    env = scene.world.node_tree.nodes.new('ShaderNodeTexEnvironment')
    env.image = _file_image("Sky", "//hdri/sky.exr")
    scene.world.node_tree.links.new(env.outputs["Color"], bg.inputs["Color"])
    scene.tfm.strict = True
    blend = str(tmp_path / "shot.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    tried = os.path.normpath(str(tmp_path / "textures" / "bricks.png"))

    done = subprocess.run([sys.executable, "-c", WORKER, blend, str(tmp_path / "out")],
                          env=dict(os.environ, PYTHONPATH=ROOT), capture_output=True, text=True,
                          timeout=300)
    said = done.stdout + done.stderr
    assert done.returncode != 0, said[-2000:]
    assert (f"Strict mode: Material 'Wall': node 'Image Texture' reads image 'Bricks': file "
            f"'//textures/bricks.png' not found at '{tried}'") in said, said[-2000:]
    sky = os.path.normpath(str(tmp_path / "hdri" / "sky.exr"))
    assert (f"World 'World': node 'Environment Texture' reads image 'Sky': file '//hdri/sky.exr' not "
            f"found at '{sky}'") in said, said[-2000:]
    assert not os.path.exists(tmp_path / "out") or os.listdir(tmp_path / "out") == []
