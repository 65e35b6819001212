"""Mantaflow domains against Cycles: a cache written by code (baking is broken in the bpy module,
BLENDER.md) rendered by TFM as a fluid domain, and by Cycles as the Volume object Blender would hand
it (Cycles cannot load a domain's cache in this build either: the domain renders empty).

Each case runs in one subprocess that ends with os._exit (a process that evaluated a domain
aborts when it is freed): it builds the camera and a spot, the domain and its cache, renders TFM
(16 antialiasing samples), then adds the reference objects, renders Cycles (BLENDER.md's single
scattering settings) and writes both images."""

import os
import subprocess
import sys
import textwrap

import numpy as np
from blender_helpers import ROOT, read_passes

from tfm_addon.engine import metrics

W, H, SAMPLES = 96, 54, 512

SCRIPT = """
    import os, sys
    sys.path.insert(0, {root!r})
    import bpy, numpy as np
    import tfm_addon
    tfm_addon.register()
    from tfm_addon import scenes
    from tfm_addon.blender import scene_builder as sb
    from tfm_addon.engine import Medium, RenderSettings, Scene
    bpy.ops.wm.read_homefile(use_empty=True)
    tmp = {tmp!r}
    cache = os.path.join(tmp, "cache")
    base = scenes.fire_scene({w}, {h}, 16, kind="COLOR", with_light=True)
    sb.build(Scene(camera=base.camera, lights=base.lights), tmp, samples=16,
             settings=RenderSettings(view_steps=128, light_steps=128, map_resolution=256,
                                     coefficients=16, film_transparent=True))
    s = bpy.context.scene

    def render(name):
        bpy.ops.render.render()
        st = s.render.image_settings
        st.media_type = 'MULTI_LAYER_IMAGE'
        st.file_format = 'OPEN_EXR_MULTILAYER'
        st.color_depth = '32'
        bpy.data.images["Render Result"].save_render(os.path.join(tmp, name + ".exr"))

    def reference_volume(name, density, grids, index_to_world, material):
        m = np.asarray(index_to_world, np.float64)
        voxel = float(abs(np.linalg.det(m[:3, :3])) ** (1.0 / 3.0))
        path = sb.write_vdb(os.path.join(tmp, name + ".vdb"), density, voxel, extra_grids=grids)
        data = bpy.data.volumes.new(name)
        data.filepath = path
        data.render.precision = 'FULL'
        data.render.clipping = 0.0
        data.materials.append(material)
        ob = bpy.data.objects.new(name, data)
        s.collection.objects.link(ob)
        ob.matrix_world = sb.to_blender_matrix(m @ np.diag([1.0 / voxel] * 3 + [1.0]))
        return ob
{body}
{tfm}
    for ob in s.objects:     # the domain shows nothing to Cycles (it loads no cache in this build)
        if ob.modifiers.get("Fluid") is not None:
            ob.data.materials[0] = bpy.data.materials.new("Nothing")
{reference}
    sb.cycles_single_scattering(s, samples={samples})
    render("cycles")
    sys.stdout.flush()
    os._exit(0)   # freeing an evaluated domain aborts in the bpy module
"""


# TFM through Blender's render (the domain evaluated: the Fluid modifier on)
RENDER_TFM = """
    s.frame_set(s.frame_current)
    render("tfm")
"""

# TFM from the add-on's extraction of the domain called directly, without evaluating it: Mantaflow
# aborts evaluating an adaptive domain in the bpy module (BLENDER.md), so its modifier stays off
# and the engine renders the extracted medium (16 antialiasing samples, as the final render).
DIRECT_TFM = """
    from types import SimpleNamespace
    from tfm_addon.blender import extract, volumes
    from tfm_addon.engine import Renderer
    from tfm_addon.engine.sampling import render_samples
    notes = []
    instance = SimpleNamespace(object=domain, is_instance=False, parent=None,
                               matrix_world=domain.matrix_world)
    found = extract._fluid_medium(instance, s.frame_current, volumes.grid_cache, notes)
    print("notes:", notes)
    out = render_samples(Renderer(), Scene(camera=base.camera, lights=base.lights,
                                           media=(found,) if found is not None else ()),
                         RenderSettings(view_steps=128, light_steps=128, map_resolution=256,
                                        coefficients=16, film_transparent=True), 16)
    np.save(os.path.join(tmp, "tfm.npy"), out.combined)
"""


def _compare(tmp_path, body: str, reference: str, label: str, tfm: str = RENDER_TFM):
    script = SCRIPT.format(root=ROOT, tmp=str(tmp_path), w=W, h=H, samples=SAMPLES,
                           tfm=textwrap.indent(textwrap.dedent(tfm), "    "),
                           body=textwrap.indent(textwrap.dedent(body), "    "),
                           reference=textwrap.indent(textwrap.dedent(reference), "    "))
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp_path / "user"))
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(script)], capture_output=True,
                          text=True, timeout=900, env=env, cwd=str(tmp_path))
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    if (tmp_path / "tfm.npy").exists():
        tfm = np.load(tmp_path / "tfm.npy")[..., :3]
    else:
        tfm = read_passes(str(tmp_path / "tfm.exr"))["Combined"][..., :3]
    cycles = read_passes(str(tmp_path / "cycles.exr"))["Combined"][..., :3]
    s = metrics.ssim(tfm, cycles)
    ratio = tfm.sum(axis=(0, 1)) / cycles.sum(axis=(0, 1))
    print(f"{label}: TFM vs Cycles ({W}x{H}, {SAMPLES} spp): SSIM {s:.4f}, brightness per channel "
          f"{np.round(ratio, 4)}")
    assert cycles.max() > 1e-2
    return s, ratio, tfm, cycles


# A 24^3 domain (-1, -1, 0) .. (1, 1, 2), resolution_max 24: voxel i at p0 + (i + 0.5) / 12 m.
DOMAIN = """
    nx = ny = nz = 24
    i, j, k = np.meshgrid(*[np.arange(n, dtype=np.float32) for n in (nx, ny, nz)], indexing="ij")
    d = np.exp(-((i - 11.5) ** 2 + (j - 12) ** 2) / 20.0 - (k - 11) ** 2 / 30.0).astype(np.float32)
    d[d < 0.02] = 0.0
    # a colour varying across the smoke (0 where there is no smoke, as Mantaflow's colours are)
    on = d > 0.0
    colors = dict(color_r=np.where(on, 0.95 - 0.7 * i / 23.0, 0.0),
                  color_g=np.where(on, 0.25 + 0.6 * k / 23.0, 0.0),
                  color_b=np.where(on, 0.2 + 0.7 * j / 23.0, 0.0))
    colors = {n: a.astype(np.float32) for n, a in colors.items()}
    # sigma_s = 2 c, sigma_a = 4 - 2 c per unit density (Principled Volume: Density 4, Color 0.5,
    # black Absorption Color), c the colour attribute
    medium = Medium(sigma_a=(2.0, 2.0, 2.0), sigma_s=(2.0, 2.0, 2.0), anisotropy=0.2, density=d,
                    index_to_world=np.eye(4), grids={"color": np.stack(
                        [colors[f"color_{c}"] for c in "rgb"], axis=-1)}, color_grid="color")
    material = sb.medium_material("Smoke", medium)
    domain = sb.fluid_domain("Domain", (-1, -1, 0), (1, 1, 2), 24, cache, material=material)
    sb.write_fluid_cache_frame(cache, s.frame_current, dict(density=d, **colors), cell_size=2.0 / 24)
"""

# Cycles' reference: the domain's grids as a Volume object, its colour the cache's colour (what
# Cycles shades with after un-premultiplying Blender's (c d, d)); voxel i at (-1, -1, 0) + (i + 0.5) / 12.
COLOR_REFERENCE = """
    to_world = np.diag([1.0 / 12, 1.0 / 12, 1.0 / 12, 1.0])
    to_world[:3, 3] = np.array([-1.0, -1.0, 0.0]) + 0.5 / 12
    reference_volume("Reference", d, {"color": medium.grids["color"]}, to_world, material)
"""


def test_a_mantaflow_colour_is_the_cache_s_colour_as_in_cycles(tmp_path):
    """Cycles un-premultiplies the (colour x density, density) Blender hands it: a coloured smoke
    shades with the cache's colours, not their product with the density (0.74-0.85 of Cycles)."""
    s, ratio, _tfm, _cycles = _compare(tmp_path, DOMAIN, COLOR_REFERENCE, "coloured smoke")
    assert s >= 0.98
    assert np.all(np.abs(ratio - 1.0) <= 0.03)


# An adaptive domain: the cache holds the 12^3 voxels res_min (4, 6, 3) .. res_max (16, 18, 15) of
# the 24^3 domain; its configuration file gives p0 as Blender writes it for a domain that does not
# move (dp0 + cell / 2, fluid.cc adaptive_domain_adjust). The domain reads its cache 2 frames back
# (cache_frame_offset 2): scene frame 3 reads cache frame 1. The material glows with a constant
# emission, which Cycles adds over the domain's evaluated mesh: the adaptive box.
ADAPTIVE = """
    from tfm_addon.blender import fluid
    from tfm_addon.engine.scene import GridValue
    n = 12
    res_min, res_max = np.array([4, 6, 3]), np.array([16, 18, 15])
    cell = 2.0 / 24
    p0 = np.array([-1.0, -1.0, 0.0]) + 0.5 * cell
    i, j, k = np.meshgrid(*[np.arange(n, dtype=np.float32)] * 3, indexing="ij")
    d = np.exp(-((i - 5.5) ** 2 + (j - 6) ** 2) / 10.0 - (k - 6) ** 2 / 12.0).astype(np.float32)
    d[d < 0.02] = 0.0
    smoke = Medium(sigma_a=(2.0, 2.0, 2.0), sigma_s=(2.0, 2.0, 2.0), anisotropy=0.2, density=d,
                   index_to_world=np.eye(4))
    glow = dict(emission_color=(1.0, 0.5, 0.2), emission_strength=GridValue(offset=0.3))
    import dataclasses
    material = sb.medium_material("Smoke", dataclasses.replace(smoke, **glow))
    domain = sb.fluid_domain("Domain", (-1, -1, 0), (1, 1, 2), 24, cache, material=material,
                             enabled=False)
    ds = domain.modifiers["Fluid"].domain_settings
    ds.use_adaptive_domain = True
    ds.cache_frame_offset = 2
    s.frame_current = 3
    sb.write_fluid_cache_frame(cache, 1, dict(density=d), cell_size=cell)
    fluid.write_config(fluid.config_file(cache, 1), res=(n, n, n), p0=p0, p1=p0 + 24 * cell,
                       dp0=(-1.0, -1.0, 0.0), base_res=(24, 24, 24), res_min=res_min, res_max=res_max)
"""

# Cycles' reference: the cache's voxels at p0 + cell (res_min + i + 0.5) as a Volume object (no
# emission), and the constant emission in a cube over the adaptive box (Principled Volume, Density 0).
ADAPTIVE_REFERENCE = """
    to_world = np.diag([cell, cell, cell, 1.0])
    to_world[:3, 3] = p0 + cell * (res_min + 0.5)
    ref = reference_volume("Reference", d, {}, to_world, sb.medium_material("Ref Smoke", smoke))
    lo, hi = p0 + cell * res_min, p0 + cell * res_max
    box = bpy.data.meshes.new("Glow")
    box.from_pydata([(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])],
                    [], [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4),
                         (1, 5, 7, 3)])
    glow_mat = bpy.data.materials.new("Glow")
    glow_mat.use_nodes = True
    nt = glow_mat.node_tree
    nt.nodes.clear()
    pv = nt.nodes.new('ShaderNodeVolumePrincipled')
    pv.inputs["Density"].default_value = 0.0
    pv.inputs["Emission Strength"].default_value = 0.3
    pv.inputs["Emission Color"].default_value = (1.0, 0.5, 0.2, 1.0)
    nt.links.new(pv.outputs[0], nt.nodes.new('ShaderNodeOutputMaterial').inputs["Volume"])
    box.materials.append(glow_mat)
    glow_ob = bpy.data.objects.new("Glow", box)
    s.collection.objects.link(glow_ob)
    for ob in (ref, glow_ob):   # the emission alone: keep Cycles' from lighting the smoke
        ob.visible_diffuse = False
        ob.visible_volume_scatter = False
"""


def test_an_adaptive_domain_is_placed_and_glows_over_its_adaptive_box_as_in_cycles(tmp_path):
    """An adaptive domain's smoke sits at res_min of the domain (it was read at the domain's corner,
    1.25 m off), a constant emission glows over the adaptive box only (it glowed over the whole
    domain cube), and the frame read is the scene's frame less cache_frame_offset."""
    s, ratio, _tfm, _cycles = _compare(tmp_path, ADAPTIVE, ADAPTIVE_REFERENCE, "adaptive domain",
                                       DIRECT_TFM)
    assert s >= 0.98
    assert np.all(np.abs(ratio - 1.0) <= 0.03)
