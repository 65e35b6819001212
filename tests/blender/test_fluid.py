"""Mantaflow smoke/fire domains rendered from their baked OpenVDB cache.

Mantaflow is broken inside the bpy module (BLENDER.md): baking crashes and a process that has
evaluated a domain aborts when the domain is freed. So this test writes a cache folder in
Mantaflow's layout with Blender's openvdb module, and every Blender that evaluates the domain runs
in a subprocess that ends with os._exit after writing its results. The test process itself never
creates or evaluates a domain."""

import glob
import json
import os
import subprocess
import sys
import textwrap

import numpy as np
from blender_helpers import ROOT, read_passes

N = (16, 16, 24)   # the domain's base resolution: resolution_max 24 on a 2 x 2 x 3 m box


def _run(script: str, tmp_path, timeout=300):
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp_path / "user"))
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(script)], capture_output=True,
                          text=True, timeout=timeout, env=env, cwd=str(tmp_path))
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return done


BUILD = """
    import os, sys
    sys.path.insert(0, {root!r})
    import bpy, numpy as np
    import tfm_addon
    tfm_addon.register()
    from tfm_addon import scenes
    from tfm_addon.blender import scene_builder as sb
    from tfm_addon.engine import RenderSettings, Scene, Light
    bpy.ops.wm.read_homefile(use_empty=True)
    base = scenes.fire_scene(64, 36, 16, kind="FIRE", with_light=True, with_occluder=False,
                             with_ground=True)
    sb.build(Scene(camera=base.camera, lights=base.lights, meshes=base.meshes), {tmp!r},
             settings=RenderSettings(view_steps=64, light_steps=64, map_resolution=128))
    fire = sb.medium_material("Fire", base.media[0])
    pv = next(n for n in fire.node_tree.nodes if n.bl_idname == 'ShaderNodeVolumePrincipled')
    pv.inputs["Temperature"].default_value = 1000.0
    pv.inputs["Temperature Attribute"].default_value = "temperature"
    domain = sb.fluid_domain("Domain", (-1, -1, 0), (1, 1, 3), 24, {cache!r}, material=fire)
    # Mantaflow's cache, written after the domain's set-up (changing cache settings empties it).
    nx, ny, nz = {n!r}
    i, j, k = np.meshgrid(*[np.arange(m, dtype=np.float32) for m in (nx, ny, nz)], indexing="ij")
    for frame in {frames!r}:
        cx = 4.0 + 3.0 * frame
        d = np.exp(-((i - cx) ** 2 + (j - 8) ** 2) / 6.0 - (k - 10) ** 2 / 30.0).astype(np.float32)
        d[d < 0.02] = 0.0
        flame = np.where(k < 12, d, 0.0).astype(np.float32)
        sb.write_fluid_cache_frame({cache!r}, frame, dict(density=d, flame=flame,
                                   temperature=0.5 * flame), cell_size=1.0 / 24)
    s = bpy.context.scene
    s.frame_start, s.frame_end = 1, 3
    s.render.filepath = os.path.join({tmp!r}, "frames", "frame_")
    s.render.image_settings.media_type = 'MULTI_LAYER_IMAGE'
    s.render.image_settings.file_format = 'OPEN_EXR_MULTILAYER'
    s.render.image_settings.color_depth = '32'
    bpy.ops.wm.save_as_mainfile(filepath={blend!r})
    sys.stdout.flush()
    os._exit(0)
"""


def _build(tmp_path, frames=(1, 2, 3)):
    cache = str(tmp_path / "cache_fire")
    blend = str(tmp_path / "fluid.blend")
    _run(BUILD.format(root=ROOT, tmp=str(tmp_path), cache=cache, blend=blend, n=N, frames=frames),
         tmp_path)
    return cache, blend


def test_three_cached_frames_render_three_frames_from_the_command_line(tmp_path):
    cache, blend = _build(tmp_path)
    assert sorted(os.listdir(os.path.join(cache, "data"))) == [
        "fluid_data_0001.vdb", "fluid_data_0002.vdb", "fluid_data_0003.vdb"]
    _run(f"""
        import os, sys
        sys.path.insert(0, {ROOT!r})
        import bpy, tfm_addon
        tfm_addon.register()
        bpy.ops.wm.open_mainfile(filepath={blend!r})
        bpy.ops.render.render(animation=True)
        sys.stdout.flush()
        os._exit(0)   # freeing an evaluated domain aborts in the bpy module
    """, tmp_path)
    frames = sorted(glob.glob(str(tmp_path / "frames" / "frame_*.exr")))
    assert [os.path.basename(f) for f in frames] == ["frame_0001.exr", "frame_0002.exr",
                                                    "frame_0003.exr"]
    images = [read_passes(f)["Scattering"] for f in frames]
    for a, b in ((0, 1), (1, 2), (0, 2)):
        assert float(np.abs(images[a] - images[b]).max()) > 0.02
    # The burning blob moves along +x by 3 voxels (0.375 m) a frame: right in the image.
    xs = []
    for image in images:
        w = image.sum(axis=2)
        xs.append(float((w * np.arange(w.shape[1])[None, :]).sum() / w.sum()))
    assert xs[0] < xs[1] < xs[2], xs
    # Emission: the flame glows orange (red above blue) where the spot light is white.
    assert all(float(im[..., 0].sum()) > 1.3 * float(im[..., 2].sum()) for im in images)


def test_domain_voxels_sit_where_blender_puts_them_and_a_missing_frame_names_the_folder(tmp_path):
    cache, blend = _build(tmp_path, frames=(1,))
    out = tmp_path / "result.json"
    _run(f"""
        import json, os, sys
        sys.path.insert(0, {ROOT!r})
        import bpy, numpy as np, tfm_addon
        tfm_addon.register()
        from tfm_addon.blender import extract
        from tfm_addon.engine import Renderer, RenderSettings
        bpy.ops.wm.open_mainfile(filepath={blend!r})
        result = {{}}
        s = bpy.context.scene
        s.frame_set(1)
        ex = extract.extract(bpy.context.evaluated_depsgraph_get())
        m = ex.media[0]
        result["shape"] = list(m.density.shape)
        peak = np.unravel_index(np.argmax(m.density), m.density.shape)
        result["peak_world"] = (m.index_to_world @ np.array([*peak, 1.0]))[:3].tolist()
        result["grids"] = sorted(m.grids)
        result["emits"] = m.has_emission
        result["t_max"] = float(m.grids["temperature"].max())
        # Where a constant emission would glow: the domain's cube, as Cycles draws a domain.
        from tfm_addon.blender import fluid, volumes
        ob = [o for o in bpy.data.objects if fluid.domain_modifier(o) is not None][0]
        g, _a, _w = fluid.read_domain(ob, 1, volumes.grid_cache, (), "domain")
        corners = np.array([v.co[:] for v in ob.data.vertices])
        result["cube"] = [corners.min(axis=0).tolist(), corners.max(axis=0).tolist()]
        result["bounds"] = [(g.index_to_object @ np.array([*c, 1.0]))[:3].tolist() for c in g.bounds]
        s.frame_set(2)
        ex = extract.extract(bpy.context.evaluated_depsgraph_get())
        result["missing_medium"] = not ex.media
        result["missing_warnings"] = ex.all_warnings
        image = Renderer().render(ex.scene(), RenderSettings(view_steps=32, light_steps=32,
                                                             map_resolution=64)).combined
        result["ground_lit"] = float(image[..., :3].max())
        json.dump(result, open({str(out)!r}, "w"))
        sys.stdout.flush()
        os._exit(0)
    """, tmp_path)
    r = json.loads(out.read_text())
    # The blob's peak voxel (7, 8, 10) of frame 1 at p0 + (i + 0.5) * cell, cell = 2/16 = 3/24 m.
    np.testing.assert_allclose(r["peak_world"], [-1 + 7.5 * 0.125, -1 + 8.5 * 0.125, 10.5 * 0.125],
                               atol=1e-6)
    assert r["shape"][2] <= N[2] and r["emits"] and r["grids"] == ["flame", "temperature"]
    # Blender's temperature attribute: ignition 1.5 + flame * (3 - 1.5), in units of 1000 K.
    assert 2.9 < r["t_max"] <= 3.0
    np.testing.assert_allclose(r["bounds"], r["cube"], atol=1e-6)     # the glow region of a domain
    assert r["missing_medium"]
    notes = [w for w in r["missing_warnings"] if "frame 2" in w]
    assert len(notes) == 1 and cache in notes[0], r["missing_warnings"]
    assert r["ground_lit"] > 0.05   # the rest of the scene renders


def test_noise_cache_is_read_at_its_resolution_over_the_domain(tmp_path):
    """With Noise on, Blender renders the noise cache (noise/fluid_noise_####.vdb: density_noise,
    flame_noise, ... at noise_scale times the resolution): the engine reads it, placed over the
    same cube with voxels noise_scale times smaller; without the file it says so and renders the
    base resolution."""
    cache, blend = _build(tmp_path, frames=(1,))
    out = tmp_path / "noise.json"
    _run(f"""
        import json, os, sys
        sys.path.insert(0, {ROOT!r})
        import bpy, numpy as np, tfm_addon
        tfm_addon.register()
        from tfm_addon.blender import extract, fluid, scene_builder as sb, volumes
        bpy.ops.wm.open_mainfile(filepath={blend!r})
        ob = [o for o in bpy.data.objects if fluid.domain_modifier(o) is not None][0]
        settings = fluid.domain_modifier(ob).domain_settings
        settings.use_noise = True
        settings.noise_scale = 2
        result = {{}}
        g, _a, w = fluid.read_domain(ob, 1, volumes.grid_cache, (), "domain")
        result["missing"] = w
        n = np.array({N!r}) * 2
        d = np.zeros(tuple(n), np.float32)
        d[13, 17, 21] = 1.0
        d[12:15, 16:19, 20:23] = np.maximum(d[12:15, 16:19, 20:23], 0.5)
        sb.write_vdb(fluid.noise_file({cache!r}, 1), d, voxel_size_m=1.0 / 48, name="density_noise",
                     extra_grids=dict(flame_noise=d))
        g, attributes, w = fluid.read_domain(ob, 1, volumes.grid_cache, ("flame",), "domain")
        peak = np.unravel_index(np.argmax(g.density), g.density.shape)
        result["peak_object"] = (g.index_to_object @ np.array([*peak, 1.0]))[:3].tolist()
        corners = np.array([v.co[:] for v in ob.data.vertices])
        result["cube"] = [corners.min(axis=0).tolist(), corners.max(axis=0).tolist()]
        result["bounds"] = [(g.index_to_object @ np.array([*c, 1.0]))[:3].tolist() for c in g.bounds]
        result["extras"] = sorted(g.extras)
        result["warnings"] = w
        json.dump(result, open({str(out)!r}, "w"))
        sys.stdout.flush()
        os._exit(0)
    """, tmp_path)
    r = json.loads(out.read_text())
    assert any("no noise cache" in x for x in r["missing"]), r["missing"]
    # voxel (13, 17, 21) of the 2x grid at p0 + (i + 0.5) * cell / 2, cell = 0.125 m
    np.testing.assert_allclose(r["peak_object"], [-1 + 13.5 * 0.0625, -1 + 17.5 * 0.0625, 21.5 * 0.0625],
                               atol=1e-6)
    np.testing.assert_allclose(r["bounds"], r["cube"], atol=1e-6)
    assert r["extras"] == ["flame"] and not r["warnings"]
