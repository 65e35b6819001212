"""Volume materials as Cycles reads them, judged by Cycles (single scattering, rendered here):
node graphs evaluated per voxel (Map Range, Color Ramp, Math, an Attribute reading the density
grid into Emission Strength), Volume ▸ Render ▸ Space Object on a scaled-down volume, Cycles'
default volume shader for a volume without a material, and a shader that reads no grid."""

from __future__ import annotations

import importlib
import os
import time

import bpy
import numpy as np
import pytest
from blender_helpers import MODULE, render_passes, smoke

from tfm_addon.blender import scene_builder
from tfm_addon.engine import RenderSettings, metrics

SETTINGS = RenderSettings(view_steps=96, light_steps=96, map_resolution=192, coefficients=12)
CYCLES_SAMPLES = 512        # 64x48: a few seconds on 2 cores


def _smoke_scene(tmp_path, lights: bool = True):
    made = scene_builder.build(smoke(width=64, height=48, n=24), str(tmp_path), settings=SETTINGS, samples=16)
    if not lights:          # emission alone: no light, no bar
        for ob in made["lights"] + made["meshes"][:1]:
            bpy.data.objects.remove(ob)
    return made["medium"]


def _new_material(ob, name="Graph"):
    mat = bpy.data.materials.new(name)
    nt = mat.node_tree
    nt.nodes.clear()
    ob.data.materials.clear()
    ob.data.materials.append(mat)
    return nt, nt.nodes.new('ShaderNodeOutputMaterial')


def _compare(tmp_path, *, ssim_min=0.98, tolerance=0.03, per_channel=False):
    """TFM then Cycles on the context scene, compared; both images."""
    scene = bpy.context.scene
    tfm = render_passes(tmp_path, "tfm")["Combined"]
    scene_builder.cycles_single_scattering(scene, samples=CYCLES_SAMPLES)
    t0 = time.perf_counter()
    cycles = render_passes(tmp_path, "cycles")["Combined"]
    seconds = time.perf_counter() - t0
    ssim = metrics.ssim(tfm, cycles)
    if os.environ.get("TFM_SAVE_COMPARISONS"):
        np.savez(os.path.join(os.environ["TFM_SAVE_COMPARISONS"], f"{tmp_path.name}.npz"), tfm=tfm,
                 cycles=cycles)
    ratios = ([metrics.brightness_ratio(tfm[..., k:k + 1], cycles[..., k:k + 1]) for k in range(3)]
              if per_channel
              else [metrics.brightness_ratio(tfm, cycles)])
    print(f"TFM vs Cycles ({CYCLES_SAMPLES} spp, {seconds:.1f} s): SSIM {ssim:.4f}, brightness "
          + ", ".join(f"{r:.4f}" for r in ratios))
    assert float(cycles[..., :3].mean()) > 1e-4, "Cycles rendered nothing: the scene is wrong"
    assert ssim >= ssim_min
    for r in ratios:
        assert abs(r - 1.0) <= tolerance
    return tfm, cycles


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


def _link(nt, a, b):
    nt.links.new(a, b)


def test_map_range_and_color_ramp_graph_matches_cycles(blank, tmp_path):
    ob = _smoke_scene(tmp_path)
    nt, out = _new_material(ob)
    attr = nt.nodes.new('ShaderNodeAttribute')
    attr.attribute_name = "density"
    mr = nt.nodes.new('ShaderNodeMapRange')
    mr.interpolation_type = 'SMOOTHSTEP'
    mr.inputs["From Min"].default_value = 0.05
    mr.inputs["From Max"].default_value = 0.6
    mr.inputs["To Max"].default_value = 1.0
    mul = nt.nodes.new('ShaderNodeMath')
    mul.operation = 'MULTIPLY'
    mul.inputs[1].default_value = 3.0
    ramp = nt.nodes.new('ShaderNodeValToRGB')
    ramp.color_ramp.elements[0].color = (0.9, 0.3, 0.1, 1.0)
    ramp.color_ramp.elements[1].color = (0.2, 0.5, 0.95, 1.0)
    pv = nt.nodes.new('ShaderNodeVolumePrincipled')
    pv.inputs["Density Attribute"].default_value = ""
    _link(nt, attr.outputs["Fac"], mr.inputs["Value"])
    _link(nt, mr.outputs["Result"], mul.inputs[0])
    _link(nt, mul.outputs[0], pv.inputs["Density"])
    _link(nt, mr.outputs["Result"], ramp.inputs["Fac"])
    _link(nt, ramp.outputs["Color"], pv.inputs["Color"])
    _link(nt, pv.outputs[0], out.inputs["Volume"])
    _compare(tmp_path, per_channel=True)


def test_density_attribute_into_emission_strength_beside_principled_density(blank, tmp_path):
    """The Attribute node reads the density grid into Emission Strength beside the Principled
    Volume's own Density Attribute (the grid is found for both). The smoke absorbs and does not
    scatter: Cycles lights a scattering medium with its own emission even with no bounces (0.973
    of Cycles at albedo 0.5, 0.948 at 1 measured here), which the engine does not render."""
    ob = _smoke_scene(tmp_path, lights=False)
    nt, out = _new_material(ob)
    attr = nt.nodes.new('ShaderNodeAttribute')
    attr.attribute_name = "density"
    mul = nt.nodes.new('ShaderNodeMath')
    mul.operation = 'MULTIPLY'
    mul.inputs[1].default_value = 4.0
    pv = nt.nodes.new('ShaderNodeVolumePrincipled')       # its Density Attribute reads "density"
    pv.inputs["Emission Color"].default_value = (1.0, 0.5, 0.2, 1.0)
    pv.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    _link(nt, attr.outputs["Fac"], mul.inputs[0])
    _link(nt, mul.outputs[0], pv.inputs["Emission Strength"])
    _link(nt, pv.outputs[0], out.inputs["Volume"])
    ob.visible_diffuse = ob.visible_volume_scatter = False   # the emission alone (see docs)
    _compare(tmp_path, per_channel=True)


def test_fire_colour_from_temperature_ramp(blank, tmp_path):
    """Map Range -> Color Ramp (ease, three stops) into Emission Color: nonlinear in the grid, so
    evaluated on a lattice twice as fine (per channel 1.019/1.037/1.033 of Cycles on the grid's
    own lattice, 0.997/0.995/0.995 on the finer one)."""
    ob = _smoke_scene(tmp_path, lights=False)
    nt, out = _new_material(ob)
    attr = nt.nodes.new('ShaderNodeAttribute')
    attr.attribute_name = "density"
    mr = nt.nodes.new('ShaderNodeMapRange')
    mr.inputs["From Min"].default_value = 0.1
    mr.inputs["From Max"].default_value = 0.8
    ramp = nt.nodes.new('ShaderNodeValToRGB')
    ramp.color_ramp.interpolation = 'EASE'
    ramp.color_ramp.elements[0].color = (0.0, 0.0, 0.0, 1.0)
    ramp.color_ramp.elements[1].color = (4.0, 1.5, 0.3, 1.0)
    mid = ramp.color_ramp.elements.new(0.5)
    mid.color = (1.5, 0.2, 0.05, 1.0)
    em = nt.nodes.new('ShaderNodeEmission')
    em.inputs["Strength"].default_value = 2.0
    _link(nt, attr.outputs["Fac"], mr.inputs["Value"])
    _link(nt, mr.outputs["Result"], ramp.inputs["Fac"])
    _link(nt, ramp.outputs["Color"], em.inputs["Color"])
    add = nt.nodes.new('ShaderNodeAddShader')
    absorb = nt.nodes.new('ShaderNodeVolumeAbsorption')
    da = nt.nodes.new('ShaderNodeAttribute')
    da.attribute_name = "density"
    _link(nt, da.outputs["Fac"], absorb.inputs["Density"])
    _link(nt, em.outputs[0], add.inputs[0])
    _link(nt, absorb.outputs[0], add.inputs[1])
    _link(nt, add.outputs[0], out.inputs["Volume"])
    ob.visible_diffuse = ob.visible_volume_scatter = False   # the emission alone (see docs)
    _compare(tmp_path, per_channel=True)


def test_space_object_scaled_volume_matches_cycles(blank, tmp_path):
    """A volume scaled down on import (a .vdb in centimetres at scale 0.02 here, its voxels 50x
    larger): with Space Object (the default) Cycles divides the density by the scale."""
    scene = smoke(width=64, height=48, n=24)
    made = scene_builder.build(scene, str(tmp_path), settings=SETTINGS, samples=16)
    ob = made["medium"]
    assert ob.data.render.space == 'OBJECT'
    m = np.asarray(scene.media[0].index_to_world, np.float64)
    voxel = float(abs(np.linalg.det(m[:3, :3])) ** (1.0 / 3.0)) * 50.0
    path = str(tmp_path / "centimetres.vdb")
    scene_builder.write_vdb(path, scene.media[0].density, voxel)
    ob.data.filepath = path
    ob.matrix_world = scene_builder.to_blender_matrix(m @ np.diag([1.0 / voxel] * 3 + [1.0]))
    assert ob.scale[0] == pytest.approx(0.02, rel=1e-3)
    _compare(tmp_path)


def test_volume_without_material_renders_cycles_default_shader(blank, tmp_path):
    ob = _smoke_scene(tmp_path)
    ob.data.materials.clear()
    _compare(tmp_path)


def test_shader_reading_no_grid_renders_nothing(blank, tmp_path):
    ob = _smoke_scene(tmp_path)
    nt, out = _new_material(ob)
    scatter = nt.nodes.new('ShaderNodeVolumeScatter')
    _link(nt, scatter.outputs[0], out.inputs["Volume"])
    extract = _mod("extract")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    found = extract.extract(depsgraph)
    assert found.media == ()
    assert any("reads no grid" in w for w in found.all_warnings)


def test_node_edit_reevaluates_once_off_blenders_thread_and_camera_move_not_at_all(blank, tmp_path):
    """Extraction never evaluates a graph (Blender's thread): the render thread does, once per
    edit of the graph; a camera move evaluates nothing."""
    ob = _smoke_scene(tmp_path)
    nt, out = _new_material(ob)
    attr = nt.nodes.new('ShaderNodeAttribute')
    attr.attribute_name = "density"
    mr = nt.nodes.new('ShaderNodeMapRange')
    pv = nt.nodes.new('ShaderNodeVolumePrincipled')
    _link(nt, attr.outputs["Fac"], mr.inputs["Value"])
    _link(nt, mr.outputs["Result"], pv.inputs["Density"])
    _link(nt, pv.outputs[0], out.inputs["Volume"])
    extract = _mod("extract")
    counts = importlib.import_module(MODULE + ".tfm_addon.engine.shading").EVALUATIONS
    n0, main0 = counts["count"], counts["MainThread"]
    first = extract.extract(bpy.context.evaluated_depsgraph_get())
    assert counts["count"] == n0 and first.media[0].shader is not None     # not evaluated here
    render_passes(tmp_path, "first")
    assert counts["count"] == n0 + 1
    assert counts["MainThread"] == main0        # evaluated by the render worker's thread
    bpy.context.scene.camera.location.x += 0.3
    render_passes(tmp_path, "orbit")
    assert counts["count"] == n0 + 1            # the same graph and grids: nothing evaluated
    mr.inputs["To Max"].default_value = 2.0
    edited = extract.extract(bpy.context.evaluated_depsgraph_get())
    assert edited.media[0].source_key != first.media[0].source_key
    render_passes(tmp_path, "edited")
    assert counts["count"] == n0 + 2


def test_procedural_noise_cloud_in_a_cube_matches_cycles(blank, tmp_path):
    """The standard procedural cloud: a 2 m cube, its volume-only material's Principled Density
    Noise Texture (Object coordinates) -> Map Range -> x4, lit by a spot."""
    made = scene_builder.build(smoke(width=64, height=48, n=24), str(tmp_path), settings=SETTINGS, samples=16)
    bpy.data.objects.remove(made["medium"])
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0.0, 0.0, 1.2))
    cube = bpy.context.active_object
    nt, out = _new_material(cube, "Cloud")
    coords = nt.nodes.new('ShaderNodeTexCoord')
    noise = nt.nodes.new('ShaderNodeTexNoise')
    noise.inputs["Scale"].default_value = 1.5
    noise.inputs["Detail"].default_value = 2.0
    mr = nt.nodes.new('ShaderNodeMapRange')
    mr.inputs["From Min"].default_value = 0.45
    mr.inputs["From Max"].default_value = 0.7
    mul = nt.nodes.new('ShaderNodeMath')
    mul.operation = 'MULTIPLY'
    mul.inputs[1].default_value = 4.0
    pv = nt.nodes.new('ShaderNodeVolumePrincipled')
    _link(nt, coords.outputs["Object"], noise.inputs["Vector"])
    _link(nt, noise.outputs["Fac"], mr.inputs["Value"])
    _link(nt, mr.outputs["Result"], mul.inputs[0])
    _link(nt, mul.outputs[0], pv.inputs["Density"])
    _link(nt, pv.outputs[0], out.inputs["Volume"])
    _compare(tmp_path)


def test_render_report_says_what_auto_chose(blank, tmp_path):
    scene_builder.build(smoke(width=64, height=48, n=24), str(tmp_path))     # the add-on's defaults: Auto
    assert bpy.context.scene.tfm.quality == 'AUTO'
    render_passes(tmp_path, "auto")
    final = importlib.import_module(MODULE + ".tfm_addon.blender.final_render")
    lines = [m for level, m in final.last_messages if m.startswith("Auto quality:")]
    assert len(lines) == 1, final.last_messages
    assert all(f" {name} " in lines[0] for name in ("Steps", "Shadow Steps", "Coefficients",
                                                      "Volume Shadow Maps up to"))


def test_a_node_not_read_in_a_volume_is_said_once_with_its_reason(blank, tmp_path):
    from tfm_addon.bench import conformance

    def build(tmpdir):
        mat, nt, out = conformance.material()
        pv = conformance.principled(nt, out)
        image = bpy.data.images.new("Tex", 8, 8)
        image.filepath_raw, image.file_format = os.path.join(tmpdir, "tex.png"), 'PNG'
        image.save()
        tex = nt.nodes.new('ShaderNodeTexImage')
        tex.image = image
        nt.links.new(tex.outputs["Color"], pv.inputs["Color"])
        conformance.smoke_with(tmpdir, mat)

    result = conformance.render_tfm(conformance.Row(id="volume_image", title="", build=build), str(tmp_path))
    about = [m for m in result.messages if "'Image Texture'" in m]
    assert about == ["Volume 'Smoke': node 'Image Texture' (Image Texture) in a volume is not read by the "
                     "engine; what it feeds reads its own value"], result.messages
