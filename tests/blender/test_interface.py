"""At home in Blender's interface: the engine's flags, Blender's generic panels opened to TFM,
the Physics tab on a fluid domain, Simplify, object visibility, view layer passes in the
compositor (rendered from the command line)."""

import importlib
import os
import subprocess
import sys
import textwrap
from types import SimpleNamespace

import bpy
import numpy as np
import pytest
from blender_helpers import MODULE, ROOT, SETTINGS, read_passes, render_passes, smoke

from tfm_addon.blender import scene_builder
from tfm_addon.engine import metrics


def _module(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.{name}")


def test_engine_flags_are_those_of_an_engine_reading_blender_nodes(addon):
    engine = _module("blender.render_engine").TFMRenderEngine
    assert engine.bl_use_shading_nodes_custom is False   # the Shader Editor offers shader trees
    assert engine.bl_use_eevee_viewport is True          # Material Preview is EEVEE's
    assert engine.bl_use_preview is True
    assert engine.bl_use_postprocess is True             # the compositor runs (tested below)
    assert engine.bl_use_gpu_context is False
    assert engine.bl_use_spherical_stereo is False and engine.bl_use_stereo_viewport is False


def test_every_generic_panel_is_open_to_tfm_or_excluded_with_a_reason(addon):
    compat = _module("blender.panel_compat")
    generic = compat.generic_panels()
    assert len(generic) >= 250
    closed = [p.__name__ for p in generic if 'TFM' not in p.COMPAT_ENGINES]
    assert sorted(closed) == sorted(n for n in compat.EXCLUDED if getattr(bpy.types, n, None))
    assert all(len(reason) > 20 for reason in compat.EXCLUDED.values())
    for name in ("PHYSICS_PT_add", "PHYSICS_PT_fluid", "PARTICLE_PT_context_particles",
                 "DATA_PT_context_mesh", "TEXTURE_PT_context", "VIEWLAYER_PT_layer",
                 "RENDER_PT_simplify", "RENDER_PT_simplify_viewport", "DATA_PT_volume_render"):
        assert 'TFM' in getattr(bpy.types, name).COMPAT_ENGINES, name
    # EEVEE-only panels stay EEVEE's, except those whose settings TFM reads.
    assert 'TFM' not in bpy.types.RENDER_PT_eevee_volumes.COMPAT_ENGINES
    assert 'TFM' not in bpy.types.EEVEE_MATERIAL_PT_settings.COMPAT_ENGINES
    assert all('TFM' in getattr(bpy.types, n).COMPAT_ENGINES for n in compat.EEVEE_PANELS)
    # The add-on's own panels stand in for the excluded visibility panel and the passes.
    for name in ("TFM_PT_object_visibility", "TFM_PT_view_layer_passes"):
        assert getattr(bpy.types, name).is_registered


def test_physics_tab_sets_up_a_fluid_domain_under_tfm(blank):
    # A domain this Blender build simulates aborts the process when freed (BLENDER.md): the
    # modifier is switched off before it becomes a domain, which leaves the panels to test.
    blank.render.engine = 'TFM'
    mesh = bpy.data.meshes.new("Domain")
    mesh.from_pydata([(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)], [],
                     [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)])
    ob = bpy.data.objects.new("Domain", mesh)
    blank.collection.objects.link(ob)
    context = SimpleNamespace(object=ob, engine='TFM', fluid=None)
    assert bpy.types.PHYSICS_PT_add.poll(context)
    fluid = ob.modifiers.new("Fluid", 'FLUID')
    fluid.show_viewport = fluid.show_render = False    # never simulated, even if evaluated
    fluid.fluid_type = 'DOMAIN'
    context.fluid = fluid
    for name in ("PHYSICS_PT_add", "PHYSICS_PT_fluid", "PHYSICS_PT_settings", "PHYSICS_PT_smoke",
                 "PHYSICS_PT_cache"):
        assert getattr(bpy.types, name).poll(context), name
    assert not bpy.types.PHYSICS_PT_fluid.poll(SimpleNamespace(**{**vars(context), "engine": "NONE"}))


def test_simplify_volume_resolution_halves_the_viewport_grid(blank, tmp_path, direct_worker):
    extract = _module("blender.extract")
    scene_builder.build(smoke(width=80, height=48, n=64), str(tmp_path), settings=SETTINGS)
    depsgraph = bpy.context.evaluated_depsgraph_get()      # the viewport's (mode 'VIEWPORT')
    assert depsgraph.mode == 'VIEWPORT'
    full = extract.extract(depsgraph)
    blank.render.use_simplify = True
    blank.render.simplify_volumes = 0.5
    half = extract.extract(bpy.context.evaluated_depsgraph_get())
    n_full, n_half = np.array(full.media[0].density.shape), np.array(half.media[0].density.shape)
    np.testing.assert_array_equal(n_half, (n_full + 1) // 2)
    # The same world box: voxel size doubled, centres of the 2x2x2 blocks.
    np.testing.assert_allclose(np.diag(half.media[0].index_to_world)[:3],
                               2 * np.diag(full.media[0].index_to_world)[:3], rtol=1e-9)
    before = direct_worker.counters.get("grid_uploads", 0)
    image_full = direct_worker.render(full.scene(), full.settings).combined
    image_half = direct_worker.render(half.scene(), half.settings).combined
    assert direct_worker.counters["grid_uploads"] - before == 2
    ssim = metrics.ssim(image_half, image_full)
    print(f"Simplify 50 %: grid {tuple(n_full)} -> {tuple(n_half)}, SSIM {ssim:.4f} against full")
    assert ssim >= 0.98
    assert np.abs(image_half - image_full).max() > 1e-4     # it is another grid
    # A final render reads full grids, as Blender's simplify is a viewport setting.
    blank.render.use_simplify = False
    plain = render_passes(tmp_path, "plain")["Combined"]
    blank.render.use_simplify = True
    simplified = render_passes(tmp_path, "simplified")["Combined"]
    assert np.array_equal(plain, simplified)


def test_simplify_downsamples_the_attribute_grids_once_per_grid(addon, monkeypatch):
    """Re-extracting a simplified fire medium (a viewport edit that keeps the grids) downsamples
    its flame and colour grids once, not at every edit (each took ~0.1 s a 256^3 grid on
    Blender's thread)."""
    extract = _module("blender.extract")
    GridValue = _module("engine.scene").GridValue
    calls = []
    real = extract._downsample_channels
    monkeypatch.setattr(extract, "_downsample_channels", lambda a, f: calls.append(f) or real(a, f))
    density = np.random.default_rng(1).random((16, 16, 16), dtype=np.float32)
    grid = SimpleNamespace(density=density, index_to_object=np.eye(4), key="fire.vdb:1",
                           extras={"flame": density * 2.0, "color": np.ones((16, 16, 16, 3), np.float32)})
    read = {"constant": False, "fields": {"emission_strength": GridValue("flame", 1.0, 0.0),
                                          "color_grid": "color"}}
    media = [extract._grid_medium(np.eye(4), grid, read, "Fire", [], simplify=1) for _ in range(3)]
    assert calls == [2, 2]
    assert media[2].grids["flame"].shape == (8, 8, 8) and media[2].grids["color"].shape == (8, 8, 8, 3)
    np.testing.assert_allclose(media[0].grids["flame"], 2.0 * media[0].density, rtol=1e-6)
    grid.extras = {**grid.extras, "flame": density * 3.0}          # a new flame grid: redone
    extract._grid_medium(np.eye(4), grid, read, "Fire", [], simplify=1)
    assert calls == [2, 2, 2]


def test_hide_render_and_excluded_collections_leave_the_render(blank, tmp_path):
    made = scene_builder.build(smoke(width=48, height=32, n=16), str(tmp_path), settings=SETTINGS)
    bar = next(ob for ob in made["meshes"] if ob.name.startswith("Bar"))
    full = render_passes(tmp_path, "full")["Scattering"]
    bar.hide_render = True
    hidden = render_passes(tmp_path, "hidden")["Scattering"]
    bar.hide_render = False
    props = bpy.data.collections.new("Props")
    blank.collection.children.link(props)
    blank.collection.objects.unlink(bar)
    props.objects.link(bar)
    assert np.array_equal(render_passes(tmp_path, "linked")["Scattering"], full)
    blank.view_layers[0].layer_collection.children["Props"].exclude = True
    excluded = render_passes(tmp_path, "excluded")["Scattering"]
    assert np.abs(hidden - full).max() > 0.05 * full.max()     # the bar's shaft is gone ...
    assert np.array_equal(excluded, hidden)                     # ... the same way


def test_ignored_settings_get_one_report_line(blank, tmp_path):
    final_render = _module("blender.final_render")
    made = scene_builder.build(smoke(width=32, height=24, n=16), str(tmp_path), settings=SETTINGS)
    made["medium"].visible_shadow = False
    blank.render.use_multiview = True
    bpy.ops.render.render()
    messages = [m for _, m in final_render.last_messages]
    assert sum("stereoscopy" in m for m in messages) == 1, messages
    assert sum("casting no shadow" in m for m in messages) == 1, messages


def test_view_layer_passes_reach_the_compositor_from_the_command_line(blank, tmp_path):
    scene_builder.build(smoke(width=48, height=32, n=16), str(tmp_path), settings=SETTINGS)
    layer = blank.view_layers[0]
    layer.tfm.use_pass_surfaces = False
    tree = bpy.data.node_groups.new("Composite Scattering", 'CompositorNodeTree')
    tree.interface.new_socket("Image", in_out='OUTPUT', socket_type='NodeSocketColor')
    render_layers = tree.nodes.new('CompositorNodeRLayers')
    output = tree.nodes.new('NodeGroupOutput')
    blank.compositing_node_group = tree
    layer.update_render_passes()
    offered = {s.name for s in render_layers.outputs if s.enabled}
    assert {"Scattering", "Transmittance"} <= offered and "Surfaces" not in offered
    tree.links.new(render_layers.outputs["Scattering"], output.inputs[0])
    blank.render.filepath = str(tmp_path / "composite.exr")
    image_settings = blank.render.image_settings
    image_settings.file_format, image_settings.color_depth = 'OPEN_EXR', '32'
    blend = str(tmp_path / "composite.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)

    script = textwrap.dedent(f"""
        import os, sys
        sys.path.insert(0, {ROOT!r})
        import bpy, tfm_addon
        tfm_addon.register()
        bpy.ops.wm.open_mainfile(filepath={blend!r})
        bpy.ops.render.render(write_still=True)
        settings = bpy.context.scene.render.image_settings
        settings.media_type = 'MULTI_LAYER_IMAGE'
        settings.file_format, settings.color_depth = 'OPEN_EXR_MULTILAYER', '32'
        bpy.data.images["Render Result"].save_render({str(tmp_path / "passes.exr")!r})
        sys.stdout.flush()
        os._exit(0)
    """)
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp_path / "user"))
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=300, env=env, cwd=str(tmp_path))
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    passes = read_passes(str(tmp_path / "passes.exr"))
    assert "Surfaces" not in passes and {"Scattering", "Transmittance"} <= set(passes)
    (composite,) = read_passes(str(tmp_path / "composite.exr")).values()
    scattering = passes["Scattering"]
    assert scattering.max() > 0.05
    assert float(np.abs(composite[..., :3] - scattering).max()) <= 1e-5
    assert float(np.abs(composite[..., :3] - passes["Combined"][..., :3]).max()) > 1e-3


@pytest.fixture(autouse=True)
def _reset_simplify_state(addon):
    yield
    _module("engine.caches").REGISTRY.clear()


def test_visibility_flags_reach_the_meshes(blank, tmp_path):
    extract = _module("blender.extract")
    made = scene_builder.build(smoke(width=32, height=24, n=16), str(tmp_path), settings=SETTINGS)
    bar, ground = sorted(made["meshes"], key=lambda ob: ob.name)
    bar.visible_shadow = False
    ground.visible_camera = False
    masks = bpy.data.collections.new("Masks")
    blank.collection.children.link(masks)
    blank.collection.objects.unlink(ground)
    masks.objects.link(ground)
    blank.view_layers[0].layer_collection.children["Masks"].holdout = True
    ground.modifiers.new("Hair", 'PARTICLE_SYSTEM').particle_system.settings.type = 'HAIR'
    found = extract.extract(bpy.context.evaluated_depsgraph_get())
    flags = {m.name.split(".")[0]: (m.visible_camera, m.cast_shadow, m.holdout) for m in found.meshes}
    assert flags == {"Bar": (True, False, False), "Ground": (False, True, True)}
    assert any(w.startswith("Hair particles are not rendered") for w in found.all_warnings)


def test_a_pass_toggle_updates_its_own_view_layer(blank):
    blank.render.engine = 'TFM'
    second = blank.view_layers.new("Second")
    assert bpy.context.view_layer != second
    tree = bpy.data.node_groups.new("Layers", 'CompositorNodeTree')
    render_layers = tree.nodes.new('CompositorNodeRLayers')
    render_layers.layer = "Second"
    blank.compositing_node_group = tree
    second.update_render_passes()
    assert "Scattering" in {s.name for s in render_layers.outputs if s.enabled}
    second.tfm.use_pass_scattering = False      # the update callback re-registers Second's passes
    offered = {s.name for s in render_layers.outputs if s.enabled}
    assert "Scattering" not in offered and {"Surfaces", "Transmittance"} <= offered
