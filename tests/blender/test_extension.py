"""Packaging: the zip Blender's extension tool built holds no development code, installs, renders
(also in a Python that has only bpy, numpy and the zip's wheels), and leaves nothing behind."""

import ast
import importlib
import os
import posixpath
import subprocess
import sys
import threading
import tomllib
import zipfile

import bpy
import numpy as np
from blender_helpers import MODULE, SETTINGS, read_passes, render_passes, smoke

from tfm_addon.blender import scene_builder

# Development code the zip must not hold: benchmarks and the conformance suite, test scenes, the
# code that builds them in Blender, the numpy reference renderer and the scikit-image metrics.
EXCLUDED = ("tfm_addon/bench/", "tfm_addon/scenes.py", "tfm_addon/blender/scene_builder.py",
            "tfm_addon/engine/metrics.py", "tfm_addon/engine/reference.py")
# Imports no shipped module may make (Blender's Python has none of them, and ``tfm_addon`` is the
# repository's copy, not the installed package).
FOREIGN = {"skimage", "scipy", "matplotlib", "tfm_addon", "pytest"}

# Built-in panels the add-on shows for its engine (a sample of its list).
OPTED_IN = ("RENDER_PT_format", "RENDER_PT_output", "DATA_PT_lens", "DATA_PT_spot",
            "DATA_PT_volume_file")


def _tfm_engine_registered() -> bool:
    """Whether Blender accepts 'TFM' as the render engine (the engine enum is dynamic)."""
    render = bpy.context.scene.render
    before = render.engine
    try:
        render.engine = 'TFM'
    except TypeError:
        return False
    render.engine = before
    return True


def _tfm_classes():
    """Names of the add-on's classes Blender has registered."""
    names = {name for name in dir(bpy.types) if name.startswith("TFM")}
    for base in (bpy.types.PropertyGroup, bpy.types.Panel, bpy.types.RenderEngine, bpy.types.Operator):
        names |= {cls.__name__ for cls in base.__subclasses__()
                  if cls.__name__.startswith("TFM") and getattr(cls, "is_registered", False)}
    return sorted(names)


def _panel_engines() -> dict[str, frozenset]:
    """Every registered panel's COMPAT_ENGINES (those that have one), by class."""
    found, stack = {}, list(bpy.types.Panel.__subclasses__())
    while stack:
        panel = stack.pop()
        stack.extend(panel.__subclasses__())
        engines = getattr(panel, "COMPAT_ENGINES", None)
        if getattr(panel, "is_registered", False) and isinstance(engines, set):
            found[f"{panel.__module__}.{panel.__qualname__}"] = frozenset(engines)
    return found


def _gl_threads():
    return [t for t in threading.enumerate() if t.name == "tfm-gl" and t.is_alive()]


def test_zip_holds_the_extension_and_nothing_else(extension_zip):
    with zipfile.ZipFile(extension_zip) as z:
        names = z.namelist()
        manifest = tomllib.loads(z.read("blender_manifest.toml").decode())
    assert "__init__.py" in names
    assert "tfm_addon/blender/render_engine.py" in names
    assert any(n.startswith("tfm_addon/engine/shaders/") for n in names)
    stray = [n for n in names if n.split("/")[0] in {"tests", "docs", "scripts", ".venv", "build"}
             or "__pycache__" in n or n.startswith(EXCLUDED)]
    assert stray == []
    assert manifest["id"] == "tfm_volumes"
    assert manifest["license"] == ["SPDX:GPL-3.0-or-later"]
    assert "files" in manifest["permissions"]
    wheels = manifest.get("wheels", [])
    # Built for this platform: one wheel per bundled package, or none when offline.
    assert len(wheels) in (0, 3), wheels
    assert all(w[2:] in names for w in wheels)
    assert not any(w.split("/")[-1].startswith("numpy") for w in wheels)


def _import_problems(names: list[str], sources: dict[str, str]) -> list[str]:
    """Imports of the zip's modules that would fail in Blender: a relative import of a module the
    zip lacks, or an absolute import of a FOREIGN package (unless inside ``try: ... except
    ImportError``, an optional import with a fallback)."""
    problems = []
    for path, text in sources.items():
        package = posixpath.dirname(path).split("/") if posixpath.dirname(path) else []
        tree = ast.parse(text)
        optional = {id(inner) for node in ast.walk(tree) if isinstance(node, ast.Try)
                    and any(isinstance(h.type, ast.Name)
                            and h.type.id in ("ImportError", "ModuleNotFoundError")
                            for h in node.handlers)
                    for stmt in node.body for inner in ast.walk(stmt)}
        for node in ast.walk(tree):
            if id(node) in optional:
                continue
            if isinstance(node, ast.Import):
                problems += [f"{path}: import {a.name}" for a in node.names
                             if a.name.split(".")[0] in FOREIGN]
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                if node.module.split(".")[0] in FOREIGN:
                    problems.append(f"{path}: from {node.module} import ...")
            elif isinstance(node, ast.ImportFrom):
                base = package[:len(package) - (node.level - 1)]
                target = base + (node.module.split(".") if node.module else [])
                candidates = ([target + [a.name] for a in node.names] if not node.module
                              else [target])
                init = "/".join(target + ["__init__.py"])
                for parts in candidates:
                    stem = "/".join(parts)
                    if stem + ".py" in names or stem + "/__init__.py" in names:
                        continue
                    if not node.module and init in sources and parts[-1] in sources[init]:
                        continue  # a name defined by the package
                    problems.append(f"{path}: {'.' * node.level}{node.module or ''} -> {stem}")
    return problems


def test_zip_holds_no_development_code(extension_zip):
    with zipfile.ZipFile(extension_zip) as z:
        names = z.namelist()
        sources = {n: z.read(n).decode() for n in names if n.endswith(".py")}
    for path in EXCLUDED:
        assert not any(n == path or n.startswith(path) for n in names), path
    assert "tfm_addon/blender/final_render.py" in names
    # Every import of every shipped module resolves inside the zip or outside the repository.
    assert _import_problems(names, sources) == []
    # The check sees a missing module: a shipped file importing scene_builder would fail it.
    broken = dict(sources)
    broken["tfm_addon/blender/viewport.py"] += "\nfrom . import scene_builder\nfrom ..scenes import x\n"
    assert len(_import_problems(names, broken)) == 2


# Run by test_installed_zip_renders_with_bpy_alone in a Python started with -S -E -s: no
# site-packages, no PYTHONPATH, the repository nowhere on sys.path, only links to bpy and numpy
# (and the wheels' packages when the zip bundles none) next to this script.
BARE_RENDER = """
import os
import sys

import bpy

zip_path, blend, out = sys.argv[-3:]
repo_dir = os.path.join(out, "repo")
os.makedirs(repo_dir)
bpy.context.preferences.extensions.repos.new(name="Bare", module="bare", custom_directory=repo_dir,
                                             source='USER')
assert bpy.ops.extensions.package_install_files(filepath=zip_path, repo="bare",
                                                enable_on_install=True) == {'FINISHED'}
bpy.ops.wm.open_mainfile(filepath=blend)
scene = bpy.context.scene
assert scene.render.engine == 'TFM', scene.render.engine
bpy.ops.render.render()
settings = scene.render.image_settings
settings.media_type = 'MULTI_LAYER_IMAGE'
settings.file_format = 'OPEN_EXR_MULTILAYER'
settings.color_depth = '32'
bpy.data.images["Render Result"].save_render(os.path.join(out, "render.exr"))
print("LOADED", " ".join(sorted(n for n in sys.modules if n.startswith("bl_ext.bare."))))
print("FOREIGN", " ".join(sorted(n for n in sys.modules if n.split(".")[0] in
                                 ("tfm_addon", "skimage", "scipy", "matplotlib"))))
"""


def test_installed_zip_renders_with_bpy_alone(extension_zip, blank, tmp_path):
    """The zip installed and enabled in a fresh Python that has bpy and numpy and nothing of the
    repository or its development tools renders a saved smoke scene."""
    scene_builder.build(smoke(width=48, height=32, n=16), str(tmp_path), settings=SETTINGS)
    blend = str(tmp_path / "smoke.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    with zipfile.ZipFile(extension_zip) as z:
        bundles_wheels = bool(tomllib.loads(z.read("blender_manifest.toml").decode()).get("wheels"))
    site = os.path.dirname(os.path.dirname(np.__file__))  # site-packages: bpy, numpy
    bare = tmp_path / "bare"
    bare.mkdir()
    keep = ["bpy", "numpy", "numpy.libs", "zstandard"]
    if not bundles_wheels:  # built offline: the packages the wheels would have brought
        keep += ["moderngl", "_moderngl.py", "glcontext", "Imath.py"]
        keep += [n for n in os.listdir(site) if n.startswith("OpenEXR") and n.endswith(".so")]
    for name in keep:
        if os.path.exists(os.path.join(site, name)):
            os.symlink(os.path.join(site, name), bare / name)
    (bare / "bare_render.py").write_text(BARE_RENDER)
    out = tmp_path / "out"
    out.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env["BLENDER_USER_RESOURCES"] = str(tmp_path / "user")
    done = subprocess.run([sys.executable, "-S", "-E", "-s", str(bare / "bare_render.py"),
                           extension_zip, blend, str(out)],
                          cwd=str(tmp_path), env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    lines = dict(line.split(" ", 1) if " " in line else (line, "")
                 for line in done.stdout.splitlines() if line.startswith(("LOADED", "FOREIGN")))
    assert "bl_ext.bare.tfm_volumes.tfm_addon.blender.final_render" in lines["LOADED"].split()
    assert lines["FOREIGN"] == ""
    image = read_passes(str(out / "render.exr"))
    assert image["Scattering"].max() > 0.05
    assert np.isfinite(image["Combined"]).all()


def test_installed_extension_renders(blank, tmp_path):
    assert _tfm_engine_registered()
    scene = smoke(width=48, height=32)
    scene_builder.build(
        scene, str(tmp_path), settings=SETTINGS)
    image = render_passes(tmp_path)
    # The smoke scatters the spot light toward the camera, and the ground is lit.
    assert image["Scattering"].max() > 0.05
    assert image["Surfaces"].max() > 0.05
    assert np.isfinite(image["Combined"]).all()


def test_enable_disable_twenty_times_leaves_nothing(addon, tmp_path):
    import addon_utils

    running = addon.blender.render_worker._worker  # the GL thread of the previous test's render
    addon_utils.disable(MODULE, default_set=True)
    assert running is None or not running.alive
    baseline_threads = len(_gl_threads())  # other GL threads of this process (not the add-on's)
    baseline_panels = _panel_engines()
    assert len(baseline_panels) > 300
    addon_utils.enable(MODULE, default_set=True, handle_error=_raise)
    for i in range(20):
        addon_utils.disable(MODULE, default_set=True)
        assert not _tfm_engine_registered()
        assert _tfm_classes() == []
        assert not hasattr(bpy.types.Scene, "tfm")
        assert [p for p in OPTED_IN if 'TFM' in getattr(bpy.types, p).COMPAT_ENGINES] == []
        assert _panel_engines() == baseline_panels, f"panels changed after disable #{i + 1}"
        assert len(_gl_threads()) == baseline_threads, f"GL thread left after disable #{i + 1}"
        addon_utils.enable(MODULE, default_set=True, handle_error=_raise)
        assert _tfm_engine_registered()
        assert all('TFM' in getattr(bpy.types, p).COMPAT_ENGINES for p in OPTED_IN)
        if i % 5 == 0:  # start the GL thread now and then, so that disabling must stop it
            bpy.ops.wm.read_homefile(use_empty=True)
            pkg = importlib.import_module(MODULE + ".tfm_addon")
            scene_builder.build(
                smoke(width=16, height=12, n=16), str(tmp_path), settings=SETTINGS)
            bpy.ops.render.render()
            assert pkg.blender.render_worker.is_running()
            assert len(_gl_threads()) == baseline_threads + 1
    assert set(_tfm_classes()) >= {"TFM_PT_volumes", "TFM_SceneSettings", "TFMRenderEngine"}


def test_a_second_register_starts_from_nothing(addon, tmp_path):
    """Register, render (a smoke under a Sky Texture world, baked by Cycles), start a bake in the
    background as the viewport does, unregister: every memo of the registry is empty and no
    background work (thread, timer, child process) runs on. Registered again, the same render
    gives the same image."""
    import addon_utils

    bpy.ops.wm.read_homefile(use_empty=True)
    scene_builder.build(smoke(width=32, height=24, n=16), str(tmp_path), settings=SETTINGS)
    sky_world = bpy.data.worlds.new("Sky")
    bpy.context.scene.world = sky_world
    background_node = next(n for n in sky_world.node_tree.nodes if n.bl_idname == 'ShaderNodeBackground')
    sky = sky_world.node_tree.nodes.new('ShaderNodeTexSky')
    sky_world.node_tree.links.new(sky.outputs["Color"], background_node.inputs["Color"])
    first = render_passes(tmp_path, "first")["Combined"]
    caches = importlib.import_module(MODULE + ".tfm_addon.engine.caches")
    background = importlib.import_module(MODULE + ".tfm_addon.blender.background")
    world = importlib.import_module(MODULE + ".tfm_addon.blender.world")
    kept = caches.REGISTRY.sizes()
    assert kept["sky_bake.bakes"] == 1 and kept["volumes.density grids"] >= 1, kept
    sky.sun_elevation += 0.2
    assert "is being baked" in world.environment(sky_world, wait=False)[1]
    assert background.running() >= 2                 # its thread, its process, its timer
    addon_utils.disable(MODULE, default_set=True)
    assert set(caches.REGISTRY.sizes().values()) == {0}, caches.REGISTRY.sizes()
    assert background.running() == 0
    addon_utils.enable(MODULE, default_set=True, handle_error=_raise)
    sky.sun_elevation -= 0.2
    second = render_passes(tmp_path, "second")["Combined"]
    assert np.abs(second - first).max() <= 1e-6 * max(float(first.max()), 1.0)


def _raise(ex):
    raise ex
