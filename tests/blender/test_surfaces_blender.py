"""A material's surface shader as the engine reads it (blender/surfaces.py): the Principled BSDF's
inputs (constants and constant graphs), Mix Shader of a Diffuse BSDF and an Emission, and one
report line per material for what is not rendered. Extraction only (the images are compared with
Cycles in the conformance rows surface_*)."""

import importlib
import math

import bpy
import pytest
from blender_helpers import MODULE


def _surface(mat):
    mesh = bpy.data.meshes.new("Plane")
    mesh.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    mesh.materials.append(mat)
    ob = bpy.data.objects.new("Plane", mesh)
    bpy.context.scene.collection.objects.link(ob)
    extract = importlib.import_module(f"{MODULE}.tfm_addon.blender.extract")
    ex = extract.extract(bpy.context.evaluated_depsgraph_get())
    return ex.meshes[0].surface, [w for w in ex.all_warnings if mat.name in w]


def test_principled_inputs(blank):
    mat = bpy.data.materials.new("Metal")
    nt = mat.node_tree
    p = nt.nodes["Principled BSDF"]
    p.distribution = 'GGX'
    value = nt.nodes.new('ShaderNodeValue')
    value.outputs[0].default_value = 0.1
    half = nt.nodes.new('ShaderNodeMath')
    half.operation = 'MULTIPLY'
    half.inputs[1].default_value = 2.0
    nt.links.new(value.outputs[0], half.inputs[0])
    nt.links.new(half.outputs[0], p.inputs["Roughness"])          # a constant graph: 0.2
    p.inputs["Metallic"].default_value = 0.7
    p.inputs["IOR"].default_value = 1.45
    p.inputs["Specular IOR Level"].default_value = 0.25
    p.inputs["Specular Tint"].default_value = (1.0, 0.5, 0.25, 1.0)
    p.inputs["Coat Weight"].default_value = 0.5
    s, notes = _surface(mat)
    assert (s.metallic, s.roughness, s.multiscatter) == (pytest.approx(0.7), pytest.approx(0.2), False)
    f0 = ((1.45 - 1) / 2.45) ** 2 * 0.5                               # Specular IOR Level 0.25 halves F0
    assert s.ior == pytest.approx((1 + math.sqrt(f0)) / (1 - math.sqrt(f0)), rel=1e-5)
    assert s.specular_tint == pytest.approx((1.0, 0.5, 0.25))
    assert len(notes) == 1 and "'Coat Weight'" in notes[0], notes


def test_principled_alpha(blank):
    """A constant Alpha is read and rendered (no line); one from a texture is named."""
    mat = bpy.data.materials.new("Veil")
    p = mat.node_tree.nodes["Principled BSDF"]
    p.inputs["Alpha"].default_value = 0.4
    s, notes = _surface(mat)
    assert s.alpha == pytest.approx(0.4) and notes == []
    checker = mat.node_tree.nodes.new('ShaderNodeTexChecker')
    mat.node_tree.links.new(checker.outputs["Fac"], p.inputs["Alpha"])
    s, notes = _surface(mat)
    assert len(notes) == 1 and "'Alpha'" in notes[0] and "varies over the surface" in notes[0], notes


def test_mix_of_diffuse_and_emission(blank):
    mat = bpy.data.materials.new("Sign")
    nt = mat.node_tree
    nt.nodes.remove(nt.nodes["Principled BSDF"])
    mix = nt.nodes.new('ShaderNodeMixShader')
    mix.inputs["Fac"].default_value = 0.25
    diffuse = nt.nodes.new('ShaderNodeBsdfDiffuse')
    diffuse.inputs["Color"].default_value = (0.2, 0.4, 0.6, 1.0)
    emission = nt.nodes.new('ShaderNodeEmission')
    emission.inputs["Color"].default_value = (1.0, 0.5, 0.0, 1.0)
    emission.inputs["Strength"].default_value = 4.0
    nt.links.new(diffuse.outputs[0], mix.inputs[1])
    nt.links.new(emission.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
    s, notes = _surface(mat)
    assert s.weight == pytest.approx(0.75) and s.ior == 1.0
    assert s.base_color == pytest.approx((0.2, 0.4, 0.6))
    assert s.emission == pytest.approx((1.0, 0.5, 0.0))
    assert len(notes) == 1 and "lights nothing" in notes[0], notes


@pytest.mark.parametrize("node_type", ['ShaderNodeRGB', 'ShaderNodeVolumeScatter', 'ShaderNodeBsdfToon'])
def test_what_is_no_surface_shader_renders_grey_with_a_line(blank, node_type):
    """A colour, a volume shader or a shader the engine does not read, plugged into the Surface
    (and into one side of a Mix Shader): the grey diffuse stands in, one line names it."""
    mat = bpy.data.materials.new("Odd")
    nt = mat.node_tree
    nt.nodes.remove(nt.nodes["Principled BSDF"])
    odd = nt.nodes.new(node_type)
    nt.links.new(odd.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
    s, notes = _surface(mat)
    assert s.base_color == pytest.approx((0.5, 0.5, 0.5)) and len(notes) == 1, notes
    assert f"'{odd.name}'" in notes[0] and "rendered as a diffuse grey" in notes[0], notes
    mix = nt.nodes.new('ShaderNodeMixShader')
    diffuse = nt.nodes.new('ShaderNodeBsdfDiffuse')
    nt.links.new(odd.outputs[0], mix.inputs[1])
    nt.links.new(diffuse.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
    s, notes = _surface(mat)
    assert any("rendered as a diffuse grey" in n for n in notes), notes
