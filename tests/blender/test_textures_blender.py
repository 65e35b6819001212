"""tfm_addon.engine.textures against Blender 5.0's own texture nodes.

Geometry Nodes evaluate the shader texture nodes with the multi-functions of
source/blender/nodes/shader/nodes/node_shader_tex_*.cc, which call the blenlib noise code that Cycles'
SVM kernel mirrors. A mesh of random points gets the texture of its Position stored as named
attributes, read back from the evaluated mesh and compared with the numpy port at the same
(float32) points.

Tolerance: Blender computes in float32, the port in float64 from float32 coordinates (as Blender
holds them). Max abs error < 1e-4 for every output (measured <= 1e-5, printed with -s), except the
Noise Texture's Color: its green and blue are the fractal at the coordinate + an offset in
[100, 200], where float32 values are 1.5e-5 apart; after distortion, Blender's float32 rounding of
that sum can fall one step apart from the port's, and each octave multiplies the step by the
lacunarity (2^6 = 64 at detail 6). There the bound is 5e-4 (measured 1.8e-4).
"""

import bpy
import numpy as np
import pytest

from tfm_addon.engine import textures

N = 2000
TOL = 1e-4
TOL_NOISE_COLOR = 5e-4


@pytest.fixture
def points():
    """A vertex-only mesh object of N random points in [-1.5, 1.5]^3; the points as float64."""
    bpy.ops.wm.read_homefile(use_empty=True)
    rng = np.random.default_rng(7)
    co = rng.uniform(-1.5, 1.5, (N, 3)).astype(np.float32)
    mesh = bpy.data.meshes.new("Points")
    mesh.vertices.add(N)
    mesh.vertices.foreach_set("co", co.ravel())
    mesh.update()
    ob = bpy.data.objects.new("Points", mesh)
    bpy.context.scene.collection.objects.link(ob)
    yield ob, co.astype(np.float64)
    bpy.data.objects.remove(ob)


def evaluate(ob, node_type, settings=None, inputs=None, outputs=("Fac", "Color")):
    """The node's outputs at the object's vertices: {output: (N,) or (N, 3) float64}."""
    group = bpy.data.node_groups.new("Texture", 'GeometryNodeTree')
    group.interface.new_socket("Geometry", in_out='INPUT', socket_type='NodeSocketGeometry')
    group.interface.new_socket("Geometry", in_out='OUTPUT', socket_type='NodeSocketGeometry')
    nodes, links = group.nodes, group.links
    geometry = nodes.new('NodeGroupInput').outputs[0]
    position = nodes.new('GeometryNodeInputPosition').outputs[0]
    tex = nodes.new(node_type)
    for key, value in (settings or {}).items():
        setattr(tex, key, value)
    for key, value in (inputs or {}).items():
        tex.inputs[key].default_value = value
    links.new(position, tex.inputs["Vector"])
    kinds = {}
    for name in outputs:
        socket = tex.outputs[name]
        kind = {'VALUE': 'FLOAT', 'RGBA': 'FLOAT_COLOR', 'VECTOR': 'FLOAT_VECTOR'}[socket.type]
        store = nodes.new('GeometryNodeStoreNamedAttribute')
        store.data_type, store.domain = kind, 'POINT'
        store.inputs["Name"].default_value = f"out_{name}"
        links.new(geometry, store.inputs["Geometry"])
        links.new(socket, store.inputs["Value"])
        geometry = store.outputs["Geometry"]
        kinds[name] = kind
    links.new(geometry, nodes.new('NodeGroupOutput').inputs[0])

    modifier = ob.modifiers.new("Texture", 'NODES')
    modifier.node_group = group
    try:
        data = ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        result = {}
        for name, kind in kinds.items():
            attribute = data.attributes[f"out_{name}"]
            width, prop = {'FLOAT': (1, "value"), 'FLOAT_COLOR': (4, "color"),
                           'FLOAT_VECTOR': (3, "vector")}[kind]
            values = np.empty(N * width, dtype=np.float32)
            attribute.data.foreach_get(prop, values)
            values = values.reshape(N, width).astype(np.float64)
            result[name] = values[:, 0] if width == 1 else values[:, :3]
        return result
    finally:
        ob.modifiers.remove(modifier)
        bpy.data.node_groups.remove(group)


def check(name, blender, ours, tol=TOL):
    error = float(np.max(np.abs(np.asarray(blender) - np.asarray(ours))))
    print(f"\n{name}: max abs error {error:.2e}")
    assert np.all(np.isfinite(ours))
    assert error < tol, name
    return error


def _case_id(params):
    return "-".join(f"{k}={v}" for k, v in params.items()) or "defaults"


NOISE_CASES = [
    dict(),
    dict(scale=2.5, detail=3.7, roughness=0.62, lacunarity=2.3),
    dict(scale=4.0, detail=1.5, distortion=0.8),
    dict(scale=3.0, detail=6.0, roughness=0.7, normalize=False, distortion=-0.3),
    dict(scale=3.0, detail=15.0, roughness=0.5),
    dict(noise_type='MULTIFRACTAL', detail=2.5, roughness=0.6),
    dict(noise_type='HETERO_TERRAIN', detail=3.3, offset=0.4, lacunarity=1.9),
    dict(noise_type='HYBRID_MULTIFRACTAL', detail=4.5, offset=0.7, gain=1.6),
    dict(noise_type='HYBRID_MULTIFRACTAL', detail=4.0, offset=0.1, gain=0.5),
    dict(noise_type='RIDGED_MULTIFRACTAL', detail=3.6, offset=1.0, gain=2.0, distortion=0.5),
]


@pytest.mark.parametrize("params", NOISE_CASES, ids=_case_id)
def test_noise(points, params):
    ob, co = points
    settings = {"noise_dimensions": '3D', "noise_type": params.get("noise_type", 'FBM'),
                "normalize": params.get("normalize", True)}
    names = {"scale": "Scale", "detail": "Detail", "roughness": "Roughness", "lacunarity": "Lacunarity",
             "distortion": "Distortion", "offset": "Offset", "gain": "Gain"}
    inputs = {names[k]: v for k, v in params.items() if k in names}
    blender = evaluate(ob, 'ShaderNodeTexNoise', settings, inputs)
    fac, color = textures.noise(co, **params)
    assert np.std(fac) > 0.01
    check(f"noise {params} fac", blender["Fac"], fac)
    check(f"noise {params} color", blender["Color"], color, TOL_NOISE_COLOR)


def test_white_noise(points):
    ob, co = points
    blender = evaluate(ob, 'ShaderNodeTexWhiteNoise', {"noise_dimensions": '3D'}, outputs=("Value", "Color"))
    value, color = textures.white_noise(co)
    check("white noise value", blender["Value"], value)
    check("white noise color", blender["Color"], color)


@pytest.mark.parametrize("gradient_type", textures.GRADIENT_TYPES)
def test_gradient(points, gradient_type):
    ob, co = points
    blender = evaluate(ob, 'ShaderNodeTexGradient', {"gradient_type": gradient_type})
    fac = textures.gradient(co, gradient_type)
    check(f"gradient {gradient_type}", blender["Fac"], fac)
    check(f"gradient {gradient_type} color", blender["Color"], np.repeat(fac[:, None], 3, axis=1))


VORONOI_CASES = [
    dict(),
    dict(feature='F2'),
    dict(distance='MANHATTAN', scale=3.0, randomness=0.7),
    dict(distance='CHEBYCHEV', feature='F2', scale=2.0),
    dict(distance='MINKOWSKI', exponent=0.8, scale=4.0),
    dict(distance='MINKOWSKI', exponent=3.0, feature='F2', normalize=True),
    dict(normalize=True, randomness=0.4),
    dict(detail=2.5, roughness=0.6, lacunarity=2.2, scale=2.0),
    dict(detail=3.0, feature='F2', normalize=True, distance='MANHATTAN', scale=2.0),
]


@pytest.mark.parametrize("params", VORONOI_CASES, ids=_case_id)
def test_voronoi(points, params):
    ob, co = points
    settings = {"voronoi_dimensions": '3D', "feature": params.get("feature", 'F1'),
                "distance": params.get("distance", 'EUCLIDEAN'), "normalize": params.get("normalize", False)}
    names = {"scale": "Scale", "detail": "Detail", "roughness": "Roughness", "lacunarity": "Lacunarity",
             "exponent": "Exponent", "randomness": "Randomness"}
    inputs = {names[k]: v for k, v in params.items() if k in names}
    blender = evaluate(ob, 'ShaderNodeTexVoronoi', settings, inputs,
                       outputs=("Distance", "Color", "Position"))
    distance, color, position = textures.voronoi(co, **params)
    check(f"voronoi {params} distance", blender["Distance"], distance)
    check(f"voronoi {params} color", blender["Color"], color)
    check(f"voronoi {params} position", blender["Position"], position)


WAVE_CASES = [
    dict(),
    dict(bands_direction='DIAGONAL', wave_profile='SAW', scale=2.0, phase_offset=0.7),
    dict(bands_direction='Z', wave_profile='TRI', distortion=3.0, detail=2.5),
    dict(wave_type='RINGS', rings_direction='SPHERICAL', distortion=5.0, detail=4.0, detail_scale=2.0,
         detail_roughness=0.6),
    dict(wave_type='RINGS', rings_direction='Y', wave_profile='SAW', scale=1.5),
]


@pytest.mark.parametrize("params", WAVE_CASES, ids=_case_id)
def test_wave(points, params):
    ob, co = points
    settings = {k: params[k] for k in ("wave_type", "bands_direction", "rings_direction", "wave_profile")
                if k in params}
    names = {"scale": "Scale", "distortion": "Distortion", "detail": "Detail", "detail_scale": "Detail Scale",
             "detail_roughness": "Detail Roughness", "phase_offset": "Phase Offset"}
    inputs = {names[k]: v for k, v in params.items() if k in names}
    blender = evaluate(ob, 'ShaderNodeTexWave', settings, inputs)
    fac, color = textures.wave(co, **params)
    check(f"wave {params}", blender["Fac"], fac)
    check(f"wave {params} color", blender["Color"], color)


@pytest.mark.parametrize("scale", [5.0, 1.3])
def test_checker(points, scale):
    ob, co = points
    c1, c2 = (0.9, 0.1, 0.3, 1.0), (0.05, 0.6, 0.2, 1.0)
    blender = evaluate(ob, 'ShaderNodeTexChecker', {},
                       {"Scale": scale, "Color1": c1, "Color2": c2})
    fac, color = textures.checker(co, scale=scale, color1=c1, color2=c2)
    assert 0.3 < fac.mean() < 0.7
    check(f"checker scale={scale}", blender["Fac"], fac)
    check(f"checker scale={scale} color", blender["Color"], color)
