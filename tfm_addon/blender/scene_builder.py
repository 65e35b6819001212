"""The reverse of ``extract``: a renderer Scene written into Blender as ordinary objects.

Volume objects reading .vdb files written here (heterogeneous media; instances of one grid share
one Volume data) or cubes with a volume material (homogeneous boxes), lights of every kind, meshes
with Diffuse BSDF materials, a camera and a world.
Used by the demo scene, the benchmarks and the tests, which render the same Scene directly and
through Blender. Development code, left out of the extension zip (the add-on never imports it): it
is imported from the repository and needs only bpy and the properties of an enabled add-on.
"""

from __future__ import annotations

import os

import numpy as np

from ..engine.scene import Medium, RenderSettings, Scene


def write_vdb(path: str, density: np.ndarray, voxel_size_m: float = 1.0, name: str = "density",
              extra_grids: dict[str, np.ndarray] | None = None) -> str:
    """Write a float grid (x, y, z index order) as a .vdb file with a uniform voxel size.
    ``extra_grids``: more grids by name; (nx, ny, nz, 3) arrays become vector grids."""
    from .openvdb_module import import_openvdb

    vdb = import_openvdb()
    grids = []
    for grid_name, array in {name: density, **(extra_grids or {})}.items():
        array = np.array(array, dtype=np.float32, order="C")  # a writable copy for openvdb
        grid = vdb.Vec3SGrid() if array.ndim == 4 else vdb.FloatGrid()
        grid.copyFromArray(array)
        grid.name = grid_name
        grid.transform = vdb.createLinearTransform(voxelSize=voxel_size_m)
        grids.append(grid)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    vdb.write(path, grids=grids)
    return path


def to_blender_matrix(m):
    from mathutils import Matrix

    return Matrix([list(map(float, row)) for row in np.asarray(m).reshape(4, 4)])


def add_camera(bl_scene, collection, cam, name: str):
    """A camera object named ``name`` for the engine camera ``cam``, linked into ``collection``
    and made ``bl_scene``'s camera, with the render resolution at 100 % and square pixels."""
    import bpy

    data = bpy.data.cameras.new(name)
    data.type = cam.projection
    data.lens = cam.lens_mm
    data.sensor_width, data.sensor_height = cam.sensor_width_mm, cam.sensor_height_mm
    data.sensor_fit = cam.sensor_fit
    data.shift_x, data.shift_y = cam.shift_x, cam.shift_y
    data.ortho_scale = cam.ortho_scale
    data.clip_start, data.clip_end = cam.clip_start, cam.clip_end
    ob = _link(bpy.data.objects.new(name, data), collection)
    ob.matrix_world = to_blender_matrix(cam.matrix_world)
    bl_scene.camera = ob
    r = bl_scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = cam.width_px, cam.height_px, 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    return ob


def _link(obj, collection):
    collection.objects.link(obj)
    return obj


def principled_volume_inputs(sigma_a, sigma_s) -> tuple[float, tuple, tuple]:
    """Density, Color and Absorption Color of a Principled Volume with these sigmas (per channel):
    sigma_s = d c, sigma_a = d (1 - c)(1 - sqrt(absorption))."""
    sa, ss = np.asarray(sigma_a, float), np.asarray(sigma_s, float)
    d = float(max((sa + ss).max(), 1e-6))
    color = ss / d
    rest = d - ss
    absorption = np.where(rest > 1e-9, (1.0 - np.clip(sa / np.maximum(rest, 1e-9), 0, 1)) ** 2, 1.0)
    return d, tuple(color), tuple(absorption)


def volume_material(name: str, sigma_a, sigma_s, anisotropy: float = 0.0, grid: str = "density"):
    """A Principled Volume material giving these sigmas per unit of ``grid`` ('' for constant)."""
    import bpy

    mat = bpy.data.materials.new(name)
    nt = mat.node_tree if mat.node_tree is not None else _use_nodes(mat)
    nt.nodes.clear()
    out = nt.nodes.new('ShaderNodeOutputMaterial')
    node = nt.nodes.new('ShaderNodeVolumePrincipled')
    d, color, absorption = principled_volume_inputs(sigma_a, sigma_s)
    node.inputs["Density"].default_value = d
    node.inputs["Color"].default_value = (*color, 1.0)
    node.inputs["Absorption Color"].default_value = (*absorption, 1.0)
    node.inputs["Anisotropy"].default_value = anisotropy
    node.inputs["Density Attribute"].default_value = grid
    nt.links.new(node.outputs[0], out.inputs["Volume"])
    return mat


def _drive(nt, socket, value, x: float) -> None:
    """Set ``socket`` to a GridValue: its constant, or Attribute -> Math (multiply add)."""
    if value.grid is None:
        socket.default_value = value.offset
        return
    attribute = nt.nodes.new('ShaderNodeAttribute')
    attribute.attribute_name = value.grid
    attribute.location = (x - 400, socket.node.location[1])
    math_node = nt.nodes.new('ShaderNodeMath')
    math_node.operation = 'MULTIPLY_ADD'
    math_node.location = (x - 200, socket.node.location[1])
    nt.links.new(attribute.outputs["Fac"], math_node.inputs[0])
    math_node.inputs[1].default_value = value.scale
    math_node.inputs[2].default_value = value.offset
    nt.links.new(math_node.outputs[0], socket)


def medium_material(name: str, medium: Medium):
    """A Principled Volume material for ``medium`` as Cycles would render it: density from grid
    'density', the colour grid as Color Attribute, Emission Strength and Blackbody Intensity driven
    by Attribute -> Math nodes, the temperature grid as Temperature Attribute."""
    mat = volume_material(name, medium.sigma_a, medium.sigma_s, medium.anisotropy)
    nt = mat.node_tree
    node = next(n for n in nt.nodes if n.bl_idname == 'ShaderNodeVolumePrincipled')
    node.inputs["Color Attribute"].default_value = medium.color_grid or ""
    node.inputs["Emission Color"].default_value = (*medium.emission_color, 1.0)
    _drive(nt, node.inputs["Emission Strength"], medium.emission_strength, node.location[0])
    _drive(nt, node.inputs["Blackbody Intensity"], medium.blackbody_intensity, node.location[0])
    node.inputs["Blackbody Tint"].default_value = (*medium.blackbody_tint, 1.0)
    t = medium.temperature
    if t.grid is not None and t.offset == 0.0:
        node.inputs["Temperature"].default_value = t.scale
        node.inputs["Temperature Attribute"].default_value = t.grid
    else:
        node.inputs["Temperature Attribute"].default_value = ""
        _drive(nt, node.inputs["Temperature"], t, node.location[0])
    return mat


def diffuse_material(name: str, color):
    """A Diffuse BSDF material (the engine's solids are Lambertian)."""
    import bpy

    mat = bpy.data.materials.new(name)
    nt = mat.node_tree if mat.node_tree is not None else _use_nodes(mat)
    nt.nodes.clear()
    out = nt.nodes.new('ShaderNodeOutputMaterial')
    node = nt.nodes.new('ShaderNodeBsdfDiffuse')
    node.inputs["Color"].default_value = (*color, 1.0)
    nt.links.new(node.outputs[0], out.inputs["Surface"])
    mat.diffuse_color = (*color, 1.0)
    return mat


def _use_nodes(owner):
    owner.use_nodes = True  # Blender < 5.0
    return owner.node_tree


def apply_settings(scene_settings, settings: RenderSettings) -> None:
    """Copy RenderSettings into ``scene.tfm``."""
    scene_settings.view_steps = settings.view_steps
    scene_settings.light_steps = settings.light_steps
    scene_settings.coefficients = settings.coefficients
    scene_settings.density_weight_auto = settings.density_weight is None
    if settings.density_weight is not None:
        scene_settings.density_weight = settings.density_weight
    scene_settings.map_resolution = settings.map_resolution
    scene_settings.sampling = settings.sampling
    scene_settings.method = settings.method
    scene_settings.ambient = settings.ambient
    scene_settings.tfm_filter = settings.tfm_filter
    scene_settings.quality = settings.quality


def build(scene: Scene, directory: str, *, bl_scene=None, settings: RenderSettings | None = None,
          name: str = "TFM", use_node_material: bool = True, samples: int = 1) -> dict:
    """Add ``scene``'s objects to ``bl_scene`` (default: the context scene) and set its camera,
    resolution, world and TFM settings (``samples``: antialiasing samples; 1, the pixel centres,
    renders what Renderer.render renders for ``scene``). A heterogeneous medium's grid is written to
    ``directory``/<name>_density.vdb. Returns the created objects by role."""
    import bpy

    bl_scene = bl_scene or bpy.context.scene
    collection = bl_scene.collection
    made: dict = {"lights": [], "meshes": []}

    made["camera"] = add_camera(bl_scene, collection, scene.camera, f"{name} Camera")

    for i, light in enumerate(scene.lights):
        kind = getattr(light, "kind", "SPOT")
        data = bpy.data.lights.new(light.name or f"{name} {kind.title()} {i}", kind)
        data.energy = light.power_w
        data.color = light.color
        if kind == 'SPOT':
            data.spot_size = light.spot_size_rad
            data.spot_blend = light.spot_blend
        if kind in ('SPOT', 'POINT'):
            data.shadow_soft_size = light.radius_m
        elif kind == 'SUN':
            data.angle = light.angle_rad
        elif kind == 'AREA':
            sx, sy = (float(v) if v > 0 else 0.1 for v in light.size_m)
            data.shape = 'ELLIPSE' if light.round_shape else 'RECTANGLE'
            data.size, data.size_y = sx, sy
            data.spread = light.spread_rad
        if light.gobo is not None:
            img = bpy.data.images.new(f"{data.name} Gobo", light.gobo.shape[1], light.gobo.shape[0],
                                      float_buffer=True)
            rgba = np.ones((*light.gobo.shape[:2], 4), np.float32)
            rgba[:, :, :3] = light.gobo[::-1]
            img.pixels.foreach_set(rgba.ravel())
            data.tfm.gobo = img
        data.tfm.use_tfm = light.use_tfm
        ob = _link(bpy.data.objects.new(data.name, data), collection)
        ob.matrix_world = to_blender_matrix(light.matrix_world)
        made["lights"].append(ob)
    for i, mesh in enumerate(scene.meshes):
        data = bpy.data.meshes.new(mesh.name or f"{name} Mesh {i}")
        data.from_pydata(mesh.vertices.tolist(), [], mesh.triangles.tolist())
        data.update()
        data.materials.append(diffuse_material(f"{data.name} Diffuse", mesh.color))
        ob = _link(bpy.data.objects.new(data.name, data), collection)
        ob.matrix_world = to_blender_matrix(mesh.matrix_world)
        ob.color = (*mesh.color, 1.0)
        made["meshes"].append(ob)

    made["media"] = []
    shared: dict = {}      # a grid's key -> the Volume data written for it (instances share it)
    for i, medium in enumerate(scene.media):
        label = name if i == 0 else f"{name}{i}"
        made["media"].append(_build_medium(medium, directory, collection, label, use_node_material,
                                           shared))
    if made["media"]:
        made["medium"] = made["media"][0]

    world = bl_scene.world or bpy.data.worlds.new(f"{name} World")
    bl_scene.world = world
    world.color = scene.ambient
    nt = world.node_tree if world.node_tree is not None else _use_nodes(world)
    nt.nodes.clear()
    out = nt.nodes.new('ShaderNodeOutputWorld')
    bg = nt.nodes.new('ShaderNodeBackground')
    bg.inputs["Color"].default_value = (*scene.ambient, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    nt.links.new(bg.outputs[0], out.inputs["Surface"])

    bl_scene.render.engine = 'TFM'
    bl_scene.render.film_transparent = True if settings is None else settings.film_transparent
    bl_scene.tfm.samples = samples
    if settings is not None:
        apply_settings(bl_scene.tfm, settings)
    return made


def _build_medium(medium: Medium, directory: str, collection, name: str, use_node_material: bool,
                  shared: dict | None = None):
    """A medium as a Volume object (a grid; media with the same grid and material share one
    Volume data, as linked duplicates do) or a cube with a volume material (a box)."""
    import bpy

    if medium.density is None:
        box = bpy.data.meshes.new(f"{name} Fog")
        corners = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
        faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
        box.from_pydata(corners, [], faces)
        box.materials.append(volume_material(f"{name} Fog", medium.sigma_a, medium.sigma_s,
                                             medium.anisotropy, grid=""))
        ob = _link(bpy.data.objects.new(box.name, box), collection)
        ob.matrix_world = to_blender_matrix(medium.box_to_world if medium.box_to_world is not None
                                  else np.diag([50.0, 50.0, 50.0, 1.0]))
        return ob

    m = np.asarray(medium.index_to_world, dtype=np.float64)
    voxel = float(abs(np.linalg.det(m[:3, :3])) ** (1.0 / 3.0))
    share_key = (medium.grid_key, medium.grids_key, medium.emission_key, medium.color_grid,
                 medium.sigma_a, medium.sigma_s, medium.anisotropy, round(voxel, 9))
    if shared is not None and share_key in shared:
        ob = _link(bpy.data.objects.new(f"{name} Smoke", shared[share_key]), collection)
        ob.matrix_world = to_blender_matrix(m @ np.diag([1.0 / voxel] * 3 + [1.0]))
        return ob
    path = write_vdb(os.path.join(directory, f"{name}_density.vdb"), medium.density, voxel,
                     extra_grids=dict(medium.grids))
    data = bpy.data.volumes.new(f"{name} Smoke")
    if shared is not None:
        shared[share_key] = data
    data.filepath = path
    data.render.precision = 'FULL'
    data.render.clipping = 0.0
    data.tfm.use_node_material = use_node_material
    data.tfm.sigma_a, data.tfm.sigma_s = medium.sigma_a, medium.sigma_s
    data.tfm.density_scale, data.tfm.anisotropy = 1.0, medium.anisotropy
    data.materials.append(medium_material(f"{name} Smoke", medium))
    ob = _link(bpy.data.objects.new(data.name, data), collection)
    ob.matrix_world = to_blender_matrix(m @ np.diag([1.0 / voxel] * 3 + [1.0]))
    return ob


def cycles_single_scattering(bl_scene, samples: int = 256) -> None:
    """Cycles settings that render what TFM renders (BLENDER.md): single scattering, no filter,
    transparent film."""
    bl_scene.render.engine = 'CYCLES'
    c = bl_scene.cycles
    c.device = 'CPU'
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.max_bounces = 0
    c.volume_bounces = 0
    c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = c.transparent_max_bounces = 0
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.use_guiding = False
    c.volume_biased = True
    c.pixel_filter_type = 'BOX'
    c.filter_width = 1.0
    c.seed = 0
    bl_scene.render.film_transparent = True
    bl_scene.view_settings.view_transform = 'Standard'



def write_fluid_cache_frame(cache_directory: str, frame: int, grids: dict[str, np.ndarray],
                            cell_size: float) -> str:
    """Write one frame of a Mantaflow smoke cache as Blender lays it out
    (``<cache_directory>/data/fluid_data_####.vdb``, grids 'density', 'flame', 'temperature',
    'color_r'...). For tests and demos: baking itself does not run in the bpy module."""
    from .fluid import cache_file

    path = cache_file(cache_directory, frame)
    density = grids["density"]
    extra = {k: v for k, v in grids.items() if k != "density"}
    return write_vdb(path, density, voxel_size_m=cell_size, extra_grids=extra)


def fluid_domain(name: str, corner_min, corner_max, resolution_max: int, cache_directory: str,
                 material=None, collection=None, enabled: bool = True):
    """A box mesh with a Fluid modifier set up as a smoke / fire domain whose OpenVDB cache is
    ``cache_directory`` (not baked here). ``enabled`` False turns the modifier off in the viewport
    and render, so that Blender never evaluates it (Mantaflow is broken in the bpy module).
    Setting the cache up empties ``cache_directory`` (Blender frees the cache): write the cache
    files (``write_fluid_cache_frame``) after this."""
    import bpy

    lo, hi = np.asarray(corner_min, float), np.asarray(corner_max, float)
    mesh = bpy.data.meshes.new(name)
    corners = [(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    mesh.from_pydata(corners, [], faces)
    if material is not None:
        mesh.materials.append(material)
    ob = bpy.data.objects.new(name, mesh)
    (collection or bpy.context.scene.collection).objects.link(ob)
    modifier = ob.modifiers.new("Fluid", 'FLUID')
    modifier.show_viewport = modifier.show_render = enabled
    modifier.fluid_type = 'DOMAIN'
    settings = modifier.domain_settings
    settings.domain_type = 'GAS'
    settings.resolution_max = resolution_max
    settings.cache_directory = cache_directory
    settings.cache_data_format = 'OPENVDB'
    settings.cache_type = 'ALL'
    return ob
