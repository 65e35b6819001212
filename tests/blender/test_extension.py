"""Packaging: the zip Blender's extension tool built installs, renders, and leaves nothing behind."""

import importlib
import threading
import tomllib
import zipfile

import bpy
import numpy as np
from blender_helpers import MODULE, SETTINGS, render_passes, smoke

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
             or "__pycache__" in n or n.startswith("tfm_addon/bench/")]
    assert stray == []
    assert manifest["id"] == "tfm_volumes"
    assert manifest["license"] == ["SPDX:GPL-3.0-or-later"]
    assert "files" in manifest["permissions"]
    wheels = manifest.get("wheels", [])
    # Built for this platform: one wheel per bundled package, or none when offline.
    assert len(wheels) in (0, 3), wheels
    assert all(w[2:] in names for w in wheels)
    assert not any(w.split("/")[-1].startswith("numpy") for w in wheels)


def test_installed_extension_renders(blank, tmp_path):
    assert _tfm_engine_registered()
    scene = smoke(width=48, height=32)
    importlib.import_module(MODULE + ".tfm_addon.blender.scene_builder").build(
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
            importlib.import_module(MODULE + ".tfm_addon.blender.scene_builder").build(
                smoke(width=16, height=12, n=16), str(tmp_path), settings=SETTINGS)
            bpy.ops.render.render()
            assert pkg.blender.render_worker.is_running()
            assert len(_gl_threads()) == baseline_threads + 1
    assert set(_tfm_classes()) >= {"TFM_PT_render", "TFM_SceneSettings", "TFMRenderEngine"}


def _raise(ex):
    raise ex
