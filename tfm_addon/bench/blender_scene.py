"""An engine Scene written into Blender for Cycles and EEVEE, matching the renderer's physics.

Runs inside a process that imported ``bpy`` (see ``blender_side.py``). Unlike the add-on's own
``tfm_addon.blender.scene_builder`` it needs no registered add-on: the medium is a Volume Scatter
plus a Volume Absorption node (sigma_s = D * colour_s * k_s, sigma_a = D * (1 - colour_a) * k_a,
BLENDER.md), the density a .vdb file written with Blender's openvdb module, the world black, the
spot lights of zero radius, the solids Diffuse BSDF.
"""

from __future__ import annotations

import os

import numpy as np

from ..blender.scene_builder import add_camera, diffuse_material, to_blender_matrix, write_vdb
from ..engine.scene import Medium, Scene


def reset() -> None:
    """An empty scene: every object, mesh, material, light, camera and volume removed."""
    import bpy

    for collection in (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.lights,
                       bpy.data.cameras, bpy.data.volumes, bpy.data.images):
        for item in list(collection):
            collection.remove(item)


def _nodes(owner):
    if owner.node_tree is None:
        owner.use_nodes = True
    nt = owner.node_tree
    nt.nodes.clear()
    return nt


def _channel_split(sigma) -> tuple[float, tuple[float, float, float]]:
    """A per-channel coefficient as (scale, colour) with colour = sigma / scale in [0, 1]."""
    s = np.asarray(sigma, dtype=np.float64)
    k = float(max(s.max(), 1e-12))
    return k, tuple(float(x) for x in s / k)


def volume_material(name: str, medium: Medium, grid: str | None):
    """sigma_s = D * medium.sigma_s, sigma_a = D * medium.sigma_a, Henyey-Greenstein g; D is the
    grid attribute ``grid`` or 1 when None."""
    import bpy

    mat = bpy.data.materials.new(name)
    nt = _nodes(mat)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    scatter = nt.nodes.new("ShaderNodeVolumeScatter")
    absorb = nt.nodes.new("ShaderNodeVolumeAbsorption")
    add = nt.nodes.new("ShaderNodeAddShader")
    ks, cs = _channel_split(medium.sigma_s)
    ka, ca = _channel_split(medium.sigma_a)
    scatter.inputs["Color"].default_value = (*cs, 1.0)
    scatter.inputs["Anisotropy"].default_value = float(medium.anisotropy)
    absorb.inputs["Color"].default_value = (*(1.0 - c for c in ca), 1.0)
    for node, k in ((scatter, ks), (absorb, ka)):
        if grid is None:
            node.inputs["Density"].default_value = k
        else:
            attr = nt.nodes.new("ShaderNodeAttribute")
            attr.attribute_type = "GEOMETRY"
            attr.attribute_name = grid
            mul = nt.nodes.new("ShaderNodeMath")
            mul.operation = "MULTIPLY"
            mul.inputs[1].default_value = k
            nt.links.new(attr.outputs["Factor"], mul.inputs[0])
            nt.links.new(mul.outputs[0], node.inputs["Density"])
    nt.links.new(scatter.outputs[0], add.inputs[0])
    nt.links.new(absorb.outputs[0], add.inputs[1])
    nt.links.new(add.outputs[0], out.inputs["Volume"])
    return mat


def build(scene: Scene, directory: str, name: str = "bench") -> dict:
    """Add ``scene`` to the context scene (call ``reset()`` first). Returns the objects made."""
    import bpy

    bl = bpy.context.scene
    col = bl.collection
    made: dict = {"lights": [], "meshes": []}
    made["camera"] = add_camera(bl, col, scene.camera, f"{name} camera")
    bl.render.use_border = False

    for i, light in enumerate(scene.lights):
        if light.gobo is not None:
            raise ValueError("projected textures are not built for Cycles/EEVEE by the benchmark")
        if light.kind not in ("SPOT", "SUN"):
            raise ValueError("the benchmark builds spots and suns only")
        ld = bpy.data.lights.new(f"{name} {light.kind.lower()} {i}", light.kind)
        ld.energy = light.power_w
        ld.color = light.color
        if light.kind == "SUN":
            ld.angle = light.angle_rad
        else:
            ld.spot_size = light.spot_size_rad
            ld.spot_blend = light.spot_blend
            ld.shadow_soft_size = 0.0
        lo = bpy.data.objects.new(ld.name, ld)
        col.objects.link(lo)
        lo.matrix_world = to_blender_matrix(light.matrix_world)
        made["lights"].append(lo)

    for i, mesh in enumerate(scene.meshes):
        md = bpy.data.meshes.new(f"{name} {mesh.name} {i}")
        md.from_pydata(mesh.vertices.tolist(), [], mesh.triangles.tolist())
        md.update()
        md.materials.append(diffuse_material(md.name, mesh.color))
        mo = bpy.data.objects.new(md.name, md)
        col.objects.link(mo)
        mo.matrix_world = to_blender_matrix(mesh.matrix_world)
        made["meshes"].append(mo)

    medium = scene.media[0]
    if medium is not None and medium.density is None:
        if medium.box_to_world is None:
            raise ValueError("fog filling the whole scene is not built for Cycles/EEVEE")
        bd = bpy.data.meshes.new(f"{name} fog")
        corners = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
        faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
        bd.from_pydata(corners, [], faces)
        bd.materials.append(volume_material(bd.name, medium, None))
        bo = bpy.data.objects.new(bd.name, bd)
        col.objects.link(bo)
        bo.matrix_world = to_blender_matrix(medium.box_to_world)
        made["medium"] = bo
    elif medium is not None:
        m = np.asarray(medium.index_to_world, dtype=np.float64)
        voxel = float(abs(np.linalg.det(m[:3, :3])) ** (1.0 / 3.0))
        path = write_vdb(os.path.join(directory, f"{name}_density.vdb"), medium.density, voxel)
        vd = bpy.data.volumes.new(f"{name} medium")
        vd.filepath = path
        vd.render.precision = "FULL"
        vd.render.clipping = 0.0
        vd.materials.append(volume_material(vd.name, medium, "density"))
        vo = bpy.data.objects.new(vd.name, vd)
        col.objects.link(vo)
        vo.matrix_world = to_blender_matrix(m @ np.diag([1.0 / voxel] * 3 + [1.0]))
        made["medium"] = vo

    world = bl.world or bpy.data.worlds.new(f"{name} world")
    bl.world = world
    world.color = scene.ambient
    nt = _nodes(world)
    out = nt.nodes.new("ShaderNodeOutputWorld")
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Color"].default_value = (*scene.ambient, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    nt.links.new(bg.outputs[0], out.inputs["Surface"])
    bl.render.film_transparent = True
    bl.view_settings.view_transform = "Standard"
    bl.view_settings.look = "None"
    bl.view_settings.exposure = 0.0
    bl.view_settings.gamma = 1.0
    return made


def cycles(samples: int, seed: int = 0) -> None:
    """Cycles single scattering as BLENDER.md checked it (settings of the add-on's builder)."""
    import bpy

    from ..blender.scene_builder import cycles_single_scattering

    bl = bpy.context.scene
    cycles_single_scattering(bl, samples=samples)
    bl.cycles.seed = seed
    bl.cycles.device = "CPU"
    bl.cycles.film_exposure = 1.0


EEVEE_PRESETS = {
    # Blender's defaults with volume shadows turned on (off by default: the medium casts none).
    "default": dict(use_volumetric_shadows=True),
    # What BLENDER.md measured closest to Cycles: 2 px froxels, 128 slices, 128 shadow steps.
    "high": dict(use_volumetric_shadows=True, volumetric_tile_size="2", volumetric_samples=128,
                 volumetric_shadow_samples=128, taa_render_samples=64),
}


def eevee(preset: str, scene: Scene) -> None:
    """EEVEE with volume shadows; 'high' also fits the froxel range to the medium's depth."""
    import bpy

    bl = bpy.context.scene
    bl.render.engine = "BLENDER_EEVEE"
    e = bl.eevee
    for key, value in EEVEE_PRESETS[preset].items():
        setattr(e, key, value)
    if preset == "high" and scene.media:
        near, far = medium_depth_range(scene)
        e.use_volume_custom_range = True
        e.volumetric_start = max(near, scene.camera.clip_start)
        e.volumetric_end = far
    bl.render.film_transparent = True


def medium_depth_range(scene: Scene) -> tuple[float, float]:
    """Nearest and farthest camera depth (m along the view axis) of the medium's bounds."""
    m = scene.media[0]
    if m.density is not None:
        n = np.asarray(m.density.shape, dtype=np.float64)
        corners = np.array([[x, y, z, 1.0] for x in (-1, n[0]) for y in (-1, n[1]) for z in (-1, n[2])])
        world = corners @ np.asarray(m.index_to_world).T
    else:
        corners = np.array([[x, y, z, 1.0] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
        world = corners @ np.asarray(m.box_to_world).T
    cam = np.linalg.inv(np.asarray(scene.camera.matrix_world))
    depth = -(world @ cam.T)[:, 2]
    return float(max(depth.min(), 0.0)), float(depth.max())
