"""Material previews and mesh media, measured side by side in one Blender process.

    python -m tfm_addon.bench.preview [--repeats 5] [--size 160x90]

Registers the repository's add-on in background Blender (bpy 5.0.1) and prints two tables:

1. ``Material.asset_generate_preview()`` with TFM at 128x128 (Blender's preview size) for a
   Principled Volume (density 5) and a Principled BSDF on the sphere and the cube: the first
   preview of the process (GL context, shader compilation, the shape's voxelisation) and the
   median of the repeats after it (a new material each time, so Blender re-renders).
2. One frame of a UV-sphere medium lit by a spot over a ground plane, rendered as a mesh with a
   volume material (voxelised by engine/mesh_volume.py) and as a Volume object holding the same
   grid in a .vdb file: first frame (mesh: voxelisation included) and the median of the repeats
   with the camera moving (no map of the medium rebuilt); the ratio mesh / volume.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
import time

import numpy as np


def _median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _material(bpy, kind: str, name: str):
    mat = bpy.data.materials.new(name)
    nt = mat.node_tree
    if kind == "volume":
        nt.nodes.clear()
        out = nt.nodes.new('ShaderNodeOutputMaterial')
        pv = nt.nodes.new('ShaderNodeVolumePrincipled')
        pv.inputs["Density"].default_value = 5.0
        nt.links.new(pv.outputs[0], out.inputs["Volume"])
    return mat


def previews(bpy, repeats: int) -> list[dict]:
    rows = []
    counter = [0]
    bpy.context.scene.render.engine = 'TFM'
    for kind in ("volume", "surface"):
        for shape in ("SPHERE", "CUBE"):
            def one(kind=kind, shape=shape):
                counter[0] += 1
                mat = _material(bpy, kind, f"bench {kind} {shape} {counter[0]}")
                mat.preview_render_type = shape
                mat.asset_generate_preview()
                assert len(mat.preview.image_pixels_float) == 128 * 128 * 4

            t0 = time.perf_counter()
            one()
            first = time.perf_counter() - t0
            name = "Principled Volume (density 5)" if kind == "volume" else "Principled BSDF"
            rows.append({"material": name, "shape": shape, "first_s": first,
                         "median_s": _median_time(one, repeats)})
    return rows


def mesh_against_volume(bpy, repeats: int, size: tuple[int, int], folder: str) -> list[dict]:
    from mathutils import Vector

    from .. import scenes
    from ..blender import scene_builder
    from ..engine import Camera, Light, RenderSettings, Scene, mesh_volume

    settings = RenderSettings(view_steps=128, light_steps=128, map_resolution=256, coefficients=8)
    light = Light(matrix_world=scenes.look_at((0, 0, 5.0), (0, 0, 0), up=(0, 1, 0)), power_w=3000.0,
                      spot_size_rad=math.radians(70), spot_blend=0.1)
    camera = Camera(matrix_world=scenes.look_at((0.0, -5.5, 3.2), (0, 0, 0.7)), width_px=size[0],
                    height_px=size[1], lens_mm=40.0)
    base = Scene(camera=camera, lights=(light,), meshes=(scenes.plane_mesh((0, 0, 0), 10.0),))
    rows = []
    for kind in ("mesh", "volume"):
        bpy.ops.wm.read_homefile(use_empty=True)
        mesh_volume.occupancy_cache.clear()
        scene = bpy.context.scene
        if kind == "mesh":
            scene_builder.build(base, folder, settings=settings)
            bpy.ops.mesh.primitive_uv_sphere_add(radius=0.8, location=(0.0, 0.0, 1.5))
            ob = bpy.context.active_object
            ob.data.materials.append(scene_builder.volume_material("fog", (0.3,) * 3, (3.0,) * 3, grid=""))
        else:
            # The grid the mesh becomes, at the resolution a frame of this size gives it.
            from ..blender.extract import mesh_volume_resolution

            resolution = mesh_volume_resolution(size)
            v, t = scenes.uv_sphere(0.8, 32, 16, center=(0.0, 0.0, 1.5))
            medium_scene = Scene(camera=camera, lights=base.lights, meshes=base.meshes,
                                 media=(mesh_volume.mesh_medium(v, t, np.eye(4), sigma_a=(0.3,) * 3,
                                                                sigma_s=(3.0,) * 3,
                                                                resolution=resolution)[0],))
            scene_builder.build(medium_scene, folder, settings=settings)
        built = mesh_volume.occupancy_cache.counters["voxelisations"]   # what the renders build
        cam = scene.camera
        cam.rotation_mode = 'QUATERNION'
        angle = [0.0]

        def orbit(cam=cam, angle=angle):
            angle[0] += 7.0
            a = math.radians(angle[0])
            cam.location = (5.5 * math.sin(a), -5.5 * math.cos(a), 3.2)
            cam.rotation_quaternion = (Vector((0, 0, 0.7)) - Vector(cam.location)).to_track_quat('-Z', 'Y')
            bpy.ops.render.render()

        t0 = time.perf_counter()
        bpy.ops.render.render()
        first = time.perf_counter() - t0
        rows.append({"medium": "mesh with a volume material" if kind == "mesh" else "Volume object (.vdb)",
                     "first_s": first, "orbit_median_s": _median_time(orbit, repeats),
                     "voxelisations": mesh_volume.occupancy_cache.counters["voxelisations"] - built})
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tfm_addon.bench.preview", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--size", default="160x90", help="frame size of the mesh/volume comparison")
    args = parser.parse_args(argv)
    size = tuple(int(v) for v in args.size.lower().split("x"))

    import bpy

    import tfm_addon

    tfm_addon.register()
    try:
        bpy.ops.wm.read_homefile(use_empty=True)
        rows = previews(bpy, args.repeats)
        print(f"Material previews, TFM, 128x128, Blender {bpy.app.version_string} (median of {args.repeats})")
        print("| material | shape | first preview (s) | next previews (s) |")
        print("|---|---|---|---|")
        for r in rows:
            print(f"| {r['material']} | {r['shape']} | {r['first_s']:.3f} | {r['median_s']:.3f} |")
        with tempfile.TemporaryDirectory() as folder:
            media = mesh_against_volume(bpy, args.repeats, size, folder)
        print(f"\nA sphere medium, {size[0]}x{size[1]}, one spot, ground plane (median of {args.repeats} "
              f"frames of a camera orbit)")
        print("| medium | first frame (s) | orbit frame (s) | voxelisations |")
        print("|---|---|---|---|")
        for r in media:
            print(f"| {r['medium']} | {r['first_s']:.3f} | {r['orbit_median_s']:.3f} "
                  f"| {r['voxelisations']} |")
        print(f"\nmesh / volume: first frame {media[0]['first_s'] / media[1]['first_s']:.2f}, orbit frame "
              f"{media[0]['orbit_median_s'] / media[1]['orbit_median_s']:.2f}")
    finally:
        tfm_addon.unregister()
    return 0


if __name__ == "__main__":
    sys.exit(main())
