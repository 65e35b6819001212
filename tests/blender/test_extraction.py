"""Scene extraction: Blender data in, the renderer's dataclasses out, compared to known numbers."""

import dataclasses
import importlib
import math
import os

import bpy
import numpy as np
import pytest
from blender_helpers import MODULE
from mathutils import Euler, Matrix

from tfm_addon.blender import scene_builder
from tfm_addon.engine.camera import clip_matrix


def _mod(name):
    return importlib.import_module(f"{MODULE}.tfm_addon.blender.{name}")


def _extract(**kwargs):
    return _mod("extract").extract(bpy.context.evaluated_depsgraph_get(), **kwargs)


def _link(ob):
    bpy.context.scene.collection.objects.link(ob)
    return ob


def _blob(shape=(24, 20, 16)):
    """A smooth blob, zero on the faces, maximum 1 at voxel (10, 8, 6)."""
    i, j, k = np.meshgrid(*[np.arange(n, dtype=np.float64) for n in shape], indexing="ij")
    d = np.exp(-((i - 10) ** 2 + (j - 8) ** 2 + (k - 6) ** 2) / 8.0)
    d[d < 0.01] = 0.0
    return d.astype(np.float32)


def _volume(path, name="Smoke", location=(0.0, 0.0, 0.0)):
    data = bpy.data.volumes.new(name)
    data.filepath = path
    ob = _link(bpy.data.objects.new(name, data))
    ob.location = location
    return ob


# Camera --------------------------------------------------------------------------------------

@pytest.mark.parametrize("projection, fit, width, height", [
    ('PERSP', 'AUTO', 64, 48), ('PERSP', 'AUTO', 40, 64), ('PERSP', 'VERTICAL', 64, 48),
    ('ORTHO', 'HORIZONTAL', 48, 64),
])
def test_camera_matches_blenders_projection(blank, projection, fit, width, height):
    data = bpy.data.cameras.new("Cam")
    data.type, data.sensor_fit = projection, fit
    data.lens, data.sensor_width, data.sensor_height = 35.0, 32.0, 20.0
    data.shift_x, data.shift_y = 0.1, -0.05
    data.clip_start, data.clip_end, data.ortho_scale = 0.2, 50.0, 5.0
    ob = _link(bpy.data.objects.new("Cam", data))
    ob.location, ob.rotation_euler, ob.scale = (1.0, -5.0, 2.0), Euler((1.2, 0.1, 0.3)), (2, 2, 2)
    blank.camera = ob
    blank.render.resolution_x, blank.render.resolution_y = 2 * width, 2 * height
    blank.render.resolution_percentage = 50
    dg = bpy.context.evaluated_depsgraph_get()
    camera = _mod("extract").extract(dg).camera
    assert (camera.width_px, camera.height_px) == (width, height)
    world_to_camera = np.linalg.inv(_mod("camera").without_scale(ob.matrix_world))
    projection_matrix = np.array(ob.evaluated_get(dg).calc_matrix_camera(dg, x=width, y=height))
    blender = projection_matrix @ world_to_camera
    np.testing.assert_allclose(clip_matrix(camera), blender, rtol=1e-5, atol=1e-5)
    # The viewport's camera, rebuilt from a view and a projection matrix, projects the same.
    from_view = _mod("camera").camera_from_view(world_to_camera, projection_matrix, width, height)
    np.testing.assert_allclose(clip_matrix(from_view), blender, rtol=1e-5, atol=1e-5)


# Lights --------------------------------------------------------------------------------------

def test_light_numbers_of_every_kind(blank):
    spot = bpy.data.lights.new("Spot", 'SPOT')
    spot.energy, spot.exposure, spot.color = 500.0, 1.0, (1.0, 0.5, 0.25)
    spot.spot_size, spot.spot_blend = 0.7, 0.3
    ob = _link(bpy.data.objects.new("Spot", spot))
    ob.location, ob.rotation_euler, ob.scale = (1, 2, 3), Euler((0.3, -0.4, 0.5)), (1, 2, 3)
    point = bpy.data.lights.new("Point", 'POINT')
    point.energy, point.shadow_soft_size = 300.0, 0.25
    _link(bpy.data.objects.new("Point", point)).location = (0, 0, 2)
    sun = bpy.data.lights.new("Sun", 'SUN')
    sun.energy, sun.angle = 4.0, math.radians(2.0)
    sun_ob = _link(bpy.data.objects.new("Sun", sun))
    sun_ob.rotation_euler = Euler((0.4, 0.2, 0.0))
    area = bpy.data.lights.new("Area", 'AREA')
    area.energy, area.shape, area.size, area.size_y = 100.0, 'RECTANGLE', 0.5, 0.25
    _link(bpy.data.objects.new("Area", area)).scale = (2.0, 1.0, 1.0)
    ex = _extract()
    by_kind = {light.kind: light for light in ex.lights}
    assert set(by_kind) == {"SPOT", "POINT", "SUN", "AREA"}
    light = by_kind["SPOT"]
    assert light.power_w == pytest.approx(1000.0)  # energy * 2^exposure
    assert light.color == pytest.approx((1.0, 0.5, 0.25))
    assert light.spot_size_rad == pytest.approx(0.7) and light.spot_blend == pytest.approx(0.3)
    np.testing.assert_allclose(light.position, (1, 2, 3), atol=1e-6)
    rotation = np.array(Euler((0.3, -0.4, 0.5)).to_matrix())
    np.testing.assert_allclose(light.direction, -rotation[:, 2], atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(light.matrix_world[:3, :3], axis=0), 1.0, atol=1e-6)
    assert by_kind["POINT"].power_w == pytest.approx(300.0)
    assert by_kind["POINT"].intensity_w_per_sr == pytest.approx([300.0 / (4 * math.pi)] * 3)
    assert by_kind["SUN"].intensity_w_per_sr == pytest.approx([4.0] * 3)       # W/m^2
    rotation = np.array(Euler((0.4, 0.2, 0.0)).to_matrix())
    np.testing.assert_allclose(by_kind["SUN"].direction, -rotation[:, 2], atol=1e-6)
    assert by_kind["AREA"].size_m == pytest.approx((1.0, 0.25))
    assert by_kind["AREA"].intensity_w_per_sr == pytest.approx([100.0 / math.pi] * 3)   # P / pi on axis
    # Sizes: soft shadows, nothing to report.
    assert by_kind["POINT"].radius_m == pytest.approx(0.25)
    assert by_kind["SUN"].angle_rad == pytest.approx(math.radians(2.0))
    assert not by_kind["AREA"].round_shape
    notes = ex.all_warnings
    assert not any("'Point'" in w or "'Sun'" in w for w in notes), notes
    assert not any("not rendered" in w for w in notes if "Light" in w), notes


def test_spot_light_gobo_is_read_top_row_first(blank):
    image = bpy.data.images.new("Gobo", 4, 2, float_buffer=True)
    pixels = np.zeros((2, 4, 4), np.float32)
    pixels[0, :, 0] = 1.0  # Blender's first row is the bottom row: red at the bottom
    pixels[1, :, 2] = 1.0
    image.pixels.foreach_set(pixels.ravel())
    spot = bpy.data.lights.new("Spot", 'SPOT')
    spot.tfm.gobo = image
    _link(bpy.data.objects.new("Spot", spot))
    (light,) = _extract().lights
    assert light.gobo.shape == (2, 4, 3)
    np.testing.assert_allclose(light.gobo[0, :, 2], 1.0)  # top row: blue
    np.testing.assert_allclose(light.gobo[1, :, 0], 1.0)


# Meshes --------------------------------------------------------------------------------------

def test_meshes_are_triangulated_coloured_and_instanced(blank):
    builder = scene_builder
    cube_mesh = bpy.data.meshes.new("Cube")
    corners = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    cube_mesh.from_pydata(corners, [], [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6),
                                        (0, 2, 6, 4), (1, 5, 7, 3)])
    material = bpy.data.materials.new("Paint")
    principled = material.node_tree.nodes.get("Principled BSDF")
    principled.inputs["Base Color"].default_value = (0.2, 0.4, 0.6, 1.0)
    cube_mesh.materials.append(material)
    collection = bpy.data.collections.new("Props")  # not in the scene: only its instances are
    cube = bpy.data.objects.new("Cube", cube_mesh)
    collection.objects.link(cube)
    for i in range(2):
        empty = _link(bpy.data.objects.new(f"Instancer{i}", None))
        empty.instance_type, empty.instance_collection = 'COLLECTION', collection
        empty.location = (3.0 * (i + 1), 0, 0)
    plane = bpy.data.meshes.new("Plane")
    plane.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    plane_ob = _link(bpy.data.objects.new("Plane", plane))
    plane_ob.color = (0.1, 0.9, 0.3, 1.0)
    del builder
    meshes = _extract().meshes
    cubes = [m for m in meshes if m.name.startswith("Cube")]
    (ground,) = [m for m in meshes if m.name == "Plane"]
    assert len(cubes) == 2
    assert cubes[0].triangles.shape == (12, 3) and ground.triangles.shape == (2, 3)
    assert np.shares_memory(cubes[0].vertices, cubes[1].vertices)  # instances share geometry
    assert sorted(m.matrix_world[0, 3] for m in cubes) == pytest.approx([3.0, 6.0])
    assert cubes[0].color == pytest.approx((0.2, 0.4, 0.6))
    assert ground.color == pytest.approx((0.1, 0.9, 0.3))


# Volumes -------------------------------------------------------------------------------------

def test_volume_grid_placement_and_cache(blank, tmp_path):
    builder, volumes = scene_builder, _mod("volumes")
    density = _blob()
    path = builder.write_vdb(str(tmp_path / "blob.vdb"), density, voxel_size_m=0.1)
    ob = _volume(path, location=(1.0, 2.0, 3.0))
    ob.rotation_euler = Euler((0.0, 0.0, math.pi / 2))
    volumes.grid_cache.clear()
    reads = volumes.grid_cache.reads
    medium = _extract().media[0]
    assert volumes.grid_cache.reads == reads + 1
    # The densest voxel, (10, 8, 6) in the file, lands where Blender puts it.
    peak = np.unravel_index(np.argmax(medium.density), medium.density.shape)
    assert medium.density[peak] == pytest.approx(1.0)
    world = medium.index_to_world @ np.array([*peak, 1.0])
    expected = np.array(ob.matrix_world) @ np.array([1.0, 0.8, 0.6, 1.0])
    np.testing.assert_allclose(world, expected, atol=1e-6)
    grid = ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.grids["density"]
    np.testing.assert_allclose(np.array(grid.matrix_object)[:3, :3] @ np.ones(3), 0.1, atol=1e-7)
    # no material: Cycles' default volume shader (a Principled Volume at its defaults)
    assert medium.sigma_s == pytest.approx((0.5, 0.5, 0.5))
    assert medium.sigma_a == pytest.approx((0.5, 0.5, 0.5))
    # Moving the object reads nothing again; a new file does.
    ob.location = (0.0, 0.0, 0.0)
    moved = _extract().media[0]
    assert volumes.grid_cache.reads == reads + 1
    assert moved.density is medium.density
    os.utime(path, ns=(os.stat(path).st_atime_ns, os.stat(path).st_mtime_ns + 10**9))
    _extract()
    assert volumes.grid_cache.reads == reads + 2


def test_mesh_to_volume_modifier_is_read_and_follows_edits(blank):
    volumes = _mod("volumes")
    cube_mesh = bpy.data.meshes.new("Src")
    corners = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    cube_mesh.from_pydata(corners, [], [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6),
                                        (0, 2, 6, 4), (1, 5, 7, 3)])
    source = bpy.data.objects.new("Src", cube_mesh)  # not linked: only the volume shows
    ob = _link(bpy.data.objects.new("Fog", bpy.data.volumes.new("Fog")))
    mod = ob.modifiers.new("ToVolume", 'MESH_TO_VOLUME')
    mod.object, mod.resolution_mode, mod.voxel_size, mod.density = source, 'VOXEL_SIZE', 0.2, 2.0
    medium = _extract().media[0]
    assert medium is not None and medium.density.max() == pytest.approx(2.0)
    extent = medium.index_to_world[:3, :3] @ (np.array(medium.density.shape) - 1)
    assert np.all(np.abs(extent) >= 1.5)  # covers the 2 m cube
    reads = volumes.grid_cache.reads
    mod.density = 3.0
    assert _extract().media[0].density.max() == pytest.approx(3.0)
    assert volumes.grid_cache.reads == reads + 1


def test_instanced_volume_takes_the_instance_transform(blank, tmp_path):
    path = scene_builder.write_vdb(str(tmp_path / "blob.vdb"), _blob(), voxel_size_m=0.1)
    collection = bpy.data.collections.new("SmokeAsset")
    data = bpy.data.volumes.new("Smoke")
    data.filepath = path
    collection.objects.link(bpy.data.objects.new("Smoke", data))
    empty = _link(bpy.data.objects.new("Instancer", None))
    empty.instance_type, empty.instance_collection = 'COLLECTION', collection
    empty.location = (5.0, 0.0, 0.0)
    medium = _extract().media[0]
    peak = np.unravel_index(np.argmax(medium.density), medium.density.shape)
    np.testing.assert_allclose((medium.index_to_world @ np.array([*peak, 1.0]))[:3],
                               (6.0, 0.8, 0.6), atol=1e-6)


# Materials -----------------------------------------------------------------------------------

def _material_with(*nodes_and_links):
    mat = bpy.data.materials.new("Medium")
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new('ShaderNodeOutputMaterial')
    return mat, nt, out


def test_principled_volume_follows_cycles(blank):
    materials = _mod("materials")
    mat, nt, out = _material_with()
    node = nt.nodes.new('ShaderNodeVolumePrincipled')
    node.inputs["Density"].default_value = 2.0
    node.inputs["Color"].default_value = (0.8, 0.5, 0.2, 1.0)
    node.inputs["Absorption Color"].default_value = (0.25, 0.0, 1.0, 1.0)
    node.inputs["Anisotropy"].default_value = 0.4
    nt.links.new(node.outputs[0], out.inputs["Volume"])
    sigma, _ = materials.read_volume_material(mat)
    assert sigma.sigma_s == pytest.approx((1.6, 1.0, 0.4))
    # sigma_a = d * (1 - c) * (1 - sqrt(absorption colour))
    assert sigma.sigma_a == pytest.approx((2 * 0.2 * 0.5, 2 * 0.5 * 1.0, 0.0))
    assert sigma.anisotropy == pytest.approx(0.4) and sigma.grid == "density"


def test_scatter_plus_absorption_reading_a_grid(blank):
    materials = _mod("materials")
    mat, nt, out = _material_with()
    attribute = nt.nodes.new('ShaderNodeAttribute')
    attribute.attribute_name = "smoke"
    multiply = nt.nodes.new('ShaderNodeMath')
    multiply.operation = 'MULTIPLY'
    multiply.inputs[1].default_value = 3.0
    nt.links.new(attribute.outputs["Fac"], multiply.inputs[0])
    scatter = nt.nodes.new('ShaderNodeVolumeScatter')
    scatter.inputs["Color"].default_value = (0.5, 0.5, 1.0, 1.0)
    scatter.inputs["Anisotropy"].default_value = -0.3
    absorb = nt.nodes.new('ShaderNodeVolumeAbsorption')
    absorb.inputs["Color"].default_value = (0.9, 0.8, 0.7, 1.0)
    for shader in (scatter, absorb):
        nt.links.new(multiply.outputs[0], shader.inputs["Density"])
    add = nt.nodes.new('ShaderNodeAddShader')
    nt.links.new(scatter.outputs[0], add.inputs[0])
    nt.links.new(absorb.outputs[0], add.inputs[1])
    nt.links.new(add.outputs[0], out.inputs["Volume"])
    sigma, _ = materials.read_volume_material(mat)
    assert sigma.sigma_s == pytest.approx((1.5, 1.5, 3.0))
    assert sigma.sigma_a == pytest.approx((0.3, 0.6, 0.9))
    assert sigma.anisotropy == pytest.approx(-0.3) and sigma.grid == "smoke"


def test_noise_texture_colour_is_evaluated_per_voxel(blank, tmp_path):
    """A Noise Texture into the Principled Volume's colour: the graph is evaluated over the grid's
    voxels (no fallback to the panel's values): the scattering colour varies as the noise does."""
    path = scene_builder.write_vdb(str(tmp_path / "blob.vdb"), _blob(), voxel_size_m=0.1)
    ob = _volume(path)
    mat, nt, out = _material_with()
    node = nt.nodes.new('ShaderNodeVolumePrincipled')
    noise = nt.nodes.new('ShaderNodeTexNoise')
    nt.links.new(noise.outputs["Color"], node.inputs["Color"])
    nt.links.new(node.outputs[0], out.inputs["Volume"])
    ob.data.materials.append(mat)
    ob.data.tfm.sigma_s, ob.data.tfm.sigma_a, ob.data.tfm.density_scale = (0.5, 0.6, 0.7), (0, 0, 0.1), 2
    ex = _extract()
    assert not [w for w in ex.all_warnings if "Noise Texture" in w], ex.all_warnings
    m = importlib.import_module(MODULE + ".tfm_addon.engine.shading").resolve_medium(ex.media[0])
    assert m.color_grid is not None
    albedo = m.grids[m.color_grid][m.density > 0.05]
    assert float(albedo.std()) > 0.02 and 0.0 <= float(albedo.min()) and float(albedo.max()) <= 1.0


def test_world_colour_is_ambient(blank):
    world = bpy.data.worlds.new("World")
    blank.world = world
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.2, 0.3, 0.4, 1.0)
    background.inputs["Strength"].default_value = 0.5
    assert _extract().ambient == pytest.approx((0.1, 0.15, 0.2))


def test_box_mesh_with_volume_material_is_a_homogeneous_box(blank):
    """A closed mesh that fills its bounding box holds the exact homogeneous box (no grid)."""
    builder = scene_builder
    mesh = bpy.data.meshes.new("Box")
    mesh.from_pydata([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (0, 2)], [],
                     [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)])
    mesh.materials.append(builder.volume_material("Fog", (0.1, 0.1, 0.1), (0.5, 0.5, 0.5), grid=""))
    ob = _link(bpy.data.objects.new("Box", mesh))
    ob.matrix_world = Matrix.Translation((0, 0, 1)) @ Matrix.Diagonal((2, 2, 2, 1))
    ex = _extract()
    assert ex.meshes == ()
    assert ex.media[0].is_homogeneous
    assert ex.media[0].sigma_s == pytest.approx((0.5, 0.5, 0.5), rel=1e-5)
    corners = ex.media[0].box_to_world @ np.array([[-1, -1, -1, 1], [1, 1, 1, 1]]).T
    np.testing.assert_allclose(corners[:3].T, [(-2, -2, 1), (2, 2, 5)], atol=1e-6)


def test_geometry_nodes_volume_is_read(blank):
    tree = bpy.data.node_groups.new("MakeFog", 'GeometryNodeTree')
    tree.interface.new_socket(name="Geometry", in_out='OUTPUT', socket_type='NodeSocketGeometry')
    cube = tree.nodes.new('GeometryNodeVolumeCube')
    cube.inputs["Density"].default_value = 0.75
    cube.inputs["Min"].default_value = (-1.0, -1.0, 0.0)
    cube.inputs["Max"].default_value = (1.0, 1.0, 2.0)
    for axis in "XYZ":
        cube.inputs[f"Resolution {axis}"].default_value = 16
    out = tree.nodes.new('NodeGroupOutput')
    tree.links.new(cube.outputs[0], out.inputs[0])
    mesh = bpy.data.meshes.new("Emitter")
    ob = _link(bpy.data.objects.new("Emitter", mesh))
    ob.modifiers.new("Fog", 'NODES').node_group = tree
    ob.location = (0.0, 0.0, 1.0)
    ex = _extract()
    assert ex.meshes == ()
    medium = ex.media[0]
    assert medium is not None and medium.density.max() == pytest.approx(0.75)
    lo = medium.index_to_world @ np.array([0, 0, 0, 1.0])
    hi = medium.index_to_world @ np.array([*(np.array(medium.density.shape) - 1), 1.0])
    np.testing.assert_allclose(lo[:3], (-1.0, -1.0, 1.0), atol=0.15)
    np.testing.assert_allclose(hi[:3], (1.0, 1.0, 3.0), atol=0.15)


def test_render_settings_come_from_the_panel(blank):
    from tfm_addon.engine import RenderSettings

    tfm = blank.tfm
    tfm.view_steps, tfm.light_steps, tfm.coefficients, tfm.map_resolution = 33, 44, 12, 256
    tfm.density_weight_auto, tfm.density_weight = False, 7.5
    tfm.sampling, tfm.method, tfm.ambient = 'PROJECTIVE', 'BRUTE_FORCE', False
    assert tfm.quality == 'AUTO', "the add-on's default quality is automatic"
    tfm.quality, tfm.tfm_filter = 'CUSTOM', 'LINEAR'
    settings = _mod("extract").render_settings(blank)
    expected = RenderSettings(view_steps=33, light_steps=44, coefficients=12, density_weight=7.5,
                              map_resolution=256, sampling='PROJECTIVE', method='BRUTE_FORCE',
                              ambient=False, quality='CUSTOM', tfm_filter='LINEAR',
                              film_transparent=False,   # Blender's default film is opaque
                              world_light='SHADOWED')   # the add-on's default: as Cycles
    assert vars(settings) == vars(expected)
    blank.render.film_transparent = True
    assert _mod("extract").render_settings(blank).film_transparent
    tfm.density_weight_auto = True
    assert _mod("extract").render_settings(blank).density_weight is None


# Several media --------------------------------------------------------------------------------

def test_every_volume_is_a_medium_and_instances_share_their_grid(blank, tmp_path):
    from tfm_addon import scenes
    from tfm_addon.engine import Medium, Scene

    d = (0.5 + scenes.smoke_density(16, seed=2)).astype(np.float32)   # no zero voxel: no cropping
    base = Medium(sigma_a=(0.1,) * 3, sigma_s=(1.0,) * 3, density=d,
                  index_to_world=scenes.grid_to_world(d.shape, 1.0, (0, 0, 1)))
    copies = [dataclasses.replace(base, index_to_world=scenes.grid_to_world(d.shape, 1.0, (x, 0, 1)))
              for x in (-1.5, 0.0, 1.5)]
    fog = Medium(sigma_a=(0.0,) * 3, sigma_s=(0.3,) * 3, box_to_world=scenes.translate_scale((0, 2, 1), 1.0))
    scene = Scene(camera=scenes.smoke_scene(16, 12, 16).camera, media=(*copies, fog))
    made = scene_builder.build(scene, str(tmp_path))
    assert len({ob.data.name for ob in made["media"][:3]}) == 1
    ex = _extract()
    assert len(ex.media) == 4
    grids = [m for m in ex.media if m.density is not None]
    assert len(grids) == 3 and len({m.grid_key for m in grids}) == 1
    centres = sorted(float((m.index_to_world @ np.r_[(np.array(m.density.shape) - 1) / 2, 1])[0])
                     for m in grids)
    np.testing.assert_allclose(centres, [-1.5, 0.0, 1.5], atol=0.08)
    assert [m.is_homogeneous for m in ex.media].count(True) == 1
    assert not any("medium" in w.lower() and "skipping" in w for w in ex.all_warnings), ex.all_warnings
    assert len(ex.scene().media) == 4
