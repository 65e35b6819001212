"""Reading fire materials (node graphs into emission, blackbody, colour grids), the fallbacks that
name what they cannot read, and what a re-extraction re-reads and re-hashes."""

import importlib

import bpy
import numpy as np
import pytest
from blender_helpers import MODULE

from tfm_addon import scenes
from tfm_addon.blender import scene_builder


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


def _resolved(medium):
    """The medium with its node graph evaluated, as the render thread evaluates it."""
    return importlib.import_module(f"{MODULE}.tfm_addon.engine.shading").resolve_medium(medium)


def _material():
    mat = bpy.data.materials.new("Fire")
    nt = mat.node_tree
    nt.nodes.clear()
    return mat, nt, nt.nodes.new('ShaderNodeOutputMaterial')


def _attribute_math(nt, grid, operation, *constants):
    attribute = nt.nodes.new('ShaderNodeAttribute')
    attribute.attribute_name = grid
    node = nt.nodes.new('ShaderNodeMath')
    node.operation = operation
    nt.links.new(attribute.outputs["Fac"], node.inputs[0])
    for i, c in enumerate(constants, start=1):
        node.inputs[i].default_value = c
    return node


def test_attribute_math_chain_drives_emission_strength(blank):
    materials = _mod("materials")
    mat, nt, out = _material()
    pv = nt.nodes.new('ShaderNodeVolumePrincipled')
    pv.inputs["Emission Color"].default_value = (1.0, 0.4, 0.1, 1.0)
    scale = _attribute_math(nt, "flame", 'MULTIPLY', 5.0)
    add = nt.nodes.new('ShaderNodeMath')
    add.operation = 'ADD'
    nt.links.new(scale.outputs[0], add.inputs[0])
    add.inputs[1].default_value = 0.25
    nt.links.new(add.outputs[0], pv.inputs["Emission Strength"])
    pv.inputs["Blackbody Intensity"].default_value = 0.7
    pv.inputs["Temperature"].default_value = 1200.0
    pv.inputs["Temperature Attribute"].default_value = "temperature"
    pv.inputs["Color Attribute"].default_value = "color"
    nt.links.new(pv.outputs[0], out.inputs["Volume"])
    sigma, reason = materials.read_volume_material(mat, {"density", "flame", "temperature", "color"})
    assert sigma is not None, reason
    assert sigma.emission_color == pytest.approx((1.0, 0.4, 0.1))
    assert (sigma.emission_strength.grid, sigma.emission_strength.scale,
            sigma.emission_strength.offset) == ("flame", pytest.approx(5.0), pytest.approx(0.25))
    assert sigma.blackbody_intensity.offset == pytest.approx(0.7)
    assert (sigma.temperature.grid, sigma.temperature.scale) == ("temperature", pytest.approx(1200.0))
    assert sigma.color_grid == "color" and sigma.grid == "density"
    # A grid the volume lacks is ignored, as Cycles ignores it.
    sigma, _ = materials.read_volume_material(mat, {"density"})
    assert sigma.temperature.grid is None and sigma.temperature.offset == pytest.approx(1200.0)
    assert sigma.color_grid is None and sigma.emission_strength.grid is None


def test_emission_shader_into_volume_output_with_scatter(blank):
    materials = _mod("materials")
    mat, nt, out = _material()
    emission = nt.nodes.new('ShaderNodeEmission')
    emission.inputs["Color"].default_value = (0.2, 0.5, 1.0, 1.0)
    strength = _attribute_math(nt, "heat", 'MULTIPLY_ADD', 2.0, 0.5)
    nt.links.new(strength.outputs[0], emission.inputs["Strength"])
    scatter = nt.nodes.new('ShaderNodeVolumeScatter')
    add = nt.nodes.new('ShaderNodeAddShader')
    nt.links.new(emission.outputs[0], add.inputs[0])
    nt.links.new(scatter.outputs[0], add.inputs[1])
    nt.links.new(add.outputs[0], out.inputs["Volume"])
    sigma, reason = materials.read_volume_material(mat)
    assert sigma is not None, reason
    assert sigma.emission_color == pytest.approx((0.2, 0.5, 1.0))
    assert (sigma.emission_strength.grid, sigma.emission_strength.scale,
            sigma.emission_strength.offset) == ("heat", pytest.approx(2.0), pytest.approx(0.5))
    assert sigma.sigma_s == pytest.approx((0.8, 0.8, 0.8))   # Volume Scatter's defaults


def test_color_ramp_into_emission_is_evaluated_per_voxel(blank, tmp_path):
    """A Color Ramp the affine reader cannot fold is evaluated over the lattice (no fallback)."""
    scene = scenes.fire_scene(32, 18, 16, kind="EMISSION")
    made = scene_builder.build(scene, str(tmp_path))
    nt = made["medium"].data.materials[0].node_tree
    pv = next(n for n in nt.nodes if n.bl_idname == 'ShaderNodeVolumePrincipled')
    ramp = nt.nodes.new('ShaderNodeValToRGB')
    ramp.name = "Flame Ramp"
    nt.links.new(ramp.outputs["Alpha"], pv.inputs["Emission Strength"])
    ex = _mod("extract").extract(bpy.context.evaluated_depsgraph_get())
    assert not [w for w in ex.all_warnings if "Flame Ramp" in w], ex.all_warnings
    m = _resolved(ex.media[0])         # what the render thread evaluates
    assert m.has_emission and m.emission_grid is not None
    # the ramp's alpha at its unlinked factor (0.5) is 1: Emission Color x 1 wherever the volume is
    e = m.grids[m.emission_grid]
    color = tuple(pv.inputs["Emission Color"].default_value)[:3]
    assert e.reshape(-1, 3).max(axis=0) == pytest.approx(color, rel=1e-5)


def test_unknown_node_is_named_once_and_the_rest_renders(blank, tmp_path):
    scene = scenes.fire_scene(32, 18, 16, kind="EMISSION")
    made = scene_builder.build(scene, str(tmp_path))
    nt = made["medium"].data.materials[0].node_tree
    pv = next(n for n in nt.nodes if n.bl_idname == 'ShaderNodeVolumePrincipled')
    magic = nt.nodes.new('ShaderNodeTexMagic')
    magic.name = "Swirl"
    nt.links.new(magic.outputs["Fac"], pv.inputs["Anisotropy"])
    ramp = nt.nodes.new('ShaderNodeValToRGB')
    nt.links.new(ramp.outputs["Alpha"], pv.inputs["Emission Strength"])
    ex = _mod("extract").extract(bpy.context.evaluated_depsgraph_get())
    notes = [w for w in ex.all_warnings if "Swirl" in w]
    assert len(notes) == 1 and "Magic Texture" in notes[0], ex.all_warnings
    m = _resolved(ex.media[0])
    assert m.has_emission and float(m.density.max()) > 0.0


def test_panel_emission_fallback_scales_the_emission_grid(blank, tmp_path):
    scene = scenes.fire_scene(32, 18, 16, kind="EMISSION")
    made = scene_builder.build(scene, str(tmp_path), use_node_material=False)
    tfm = made["medium"].data.tfm
    tfm.emission_strength, tfm.emission_color, tfm.emission_grid = 3.0, (0.1, 0.2, 0.3), "flame"
    m = _mod("extract").extract(bpy.context.evaluated_depsgraph_get()).media[0]
    assert m.emission_strength.grid == "flame" and m.emission_strength.scale == pytest.approx(3.0)
    assert m.emission_color == pytest.approx((0.1, 0.2, 0.3))
    assert float(m.grids["flame"].max()) == pytest.approx(float(scene.media[0].grids["flame"].max()))


def _cube(name, material, location):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], [],
                     [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)])
    mesh.materials.append(material)
    ob = bpy.data.objects.new(name, mesh)
    ob.location = location
    bpy.context.scene.collection.objects.link(ob)
    return ob


def test_texture_driven_surface_is_a_texture_and_an_unread_one_is_named_once(blank):
    mat, nt, out = _material()
    bsdf = nt.nodes.new('ShaderNodeBsdfPrincipled')
    noise = nt.nodes.new('ShaderNodeTexNoise')
    nt.links.new(noise.outputs["Color"], bsdf.inputs["Base Color"])
    brick = nt.nodes.new('ShaderNodeTexBrick')
    nt.links.new(brick.outputs["Fac"], bsdf.inputs["Roughness"])
    nt.links.new(bsdf.outputs[0], out.inputs["Surface"])
    for i in range(3):
        _cube(f"Textured {i}", mat, (3.0 * i, 0, 0))
    ex = _mod("extract").extract(bpy.context.evaluated_depsgraph_get())
    kinds = [[n.kind for n in m.surface.base_texture.nodes] for m in ex.meshes]
    assert kinds == [["TEX_NOISE"]] * 3
    assert not [w for w in ex.all_warnings if "Noise Texture" in w], ex.all_warnings
    notes = [w for w in ex.all_warnings if "Brick Texture" in w]
    assert len(notes) == 1 and "Roughness" in notes[0], ex.all_warnings


def test_surface_and_volume_material_is_named_once(blank):
    mat, nt, out = _material()
    diffuse = nt.nodes.new('ShaderNodeBsdfDiffuse')
    nt.links.new(diffuse.outputs[0], out.inputs["Surface"])
    nt.links.new(nt.nodes.new('ShaderNodeVolumePrincipled').outputs[0], out.inputs["Volume"])
    _cube("A", mat, (0, 0, 0))
    _cube("B", mat, (3, 0, 0))
    ex = _mod("extract").extract(bpy.context.evaluated_depsgraph_get())
    assert len(ex.meshes) == 2 and not ex.media
    notes = [w for w in ex.all_warnings if "surface and a volume shader" in w]
    assert len(notes) == 1 and "'Fire'" in notes[0]


def test_material_edit_neither_rereads_nor_rehashes_the_grid(blank, tmp_path):
    """A 64 x 64 x 96 fire: after the first extraction, a material edit re-extracts the medium from the
    cached grids and builds its keys from the file's stamp (no array is hashed)."""
    volumes = _mod("volumes")
    extract = _mod("extract")
    changes = _mod("changes")
    scene_module = importlib.import_module(f"{MODULE}.tfm_addon.engine.scene")
    fire = scenes.fire_scene(32, 18, 64, kind="FIRE")
    made = scene_builder.build(fire, str(tmp_path))
    first = extract.extract(bpy.context.evaluated_depsgraph_get())
    reads = volumes.grid_cache.reads
    assert first.media[0].source_key is not None and set(first.media[0].grids) == {"flame", "temperature"}
    _ = first.media[0].density_key
    pv = next(n for n in made["medium"].data.materials[0].node_tree.nodes
              if n.bl_idname == 'ShaderNodeVolumePrincipled')
    pv.inputs["Emission Color"].default_value = (0.3, 0.6, 1.0, 1.0)
    scene_module.HASHED.clear()
    again = extract.extract(bpy.context.evaluated_depsgraph_get(), parts=changes.Change.MEDIUM,
                            previous=first)
    keys = (again.media[0].density_key, again.media[0].grids_key, again.media[0].key)
    assert volumes.grid_cache.reads == reads
    assert scene_module.HASHED["bytes"] < 4096, dict(scene_module.HASHED)
    assert keys[0] == first.media[0].density_key and keys[2] != first.media[0].key
    assert again.media[0].emission_color == pytest.approx((0.3, 0.6, 1.0))
    assert again.media[0].density is first.media[0].density      # the cached array, not a copy
    np.testing.assert_array_equal(again.media[0].grids["flame"], first.media[0].grids["flame"])
