"""Blender's thread time for a mesh edit next to an n^3 grid: the change flags, then the
extraction they ask for, with the medium-aware flags (now) and the former ones side by side.

    PYTHONPATH=. .venv/bin/python scripts/edit_latency.py 512 [generated]

``generated`` puts a modifier on the volume, so its grid is saved and hashed on every read (the
costly case); without it the grid is cached by its file's path, size and time.
"""

import os
import sys
import tempfile
import time

import bpy
import numpy as np

import tfm_addon


def main(n: int, generated: bool) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    tfm_addon.register()
    from tfm_addon.blender import changes, scene_builder, volumes
    from tfm_addon.blender import extract as ex

    axis = np.linspace(-1, 1, n, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij", copy=False)
    density = np.clip(1.0 - (x * x + y * y + z * z) * 1.5, 0, None).astype(np.float32)
    del x, y, z
    path = scene_builder.write_vdb(os.path.join(tempfile.mkdtemp(), "big.vdb"), density, 2.0 / n)
    del density
    scene = bpy.context.scene
    data = bpy.data.volumes.new("Big")
    data.filepath = path
    vol = bpy.data.objects.new("Big", data)
    scene.collection.objects.link(vol)
    if generated:
        vol.modifiers.new("Displace", 'VOLUME_DISPLACE').strength = 0.0
    bpy.ops.mesh.primitive_cube_add(location=(3, 0, 0))
    cube = bpy.context.object
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.engine = 'TFM'

    t0 = time.perf_counter()
    first = ex.extract(bpy.context.evaluated_depsgraph_get())
    t_first = time.perf_counter() - t0
    seen = []

    def handler(_scene, depsgraph):
        t = time.perf_counter()
        now = changes.changes_from_depsgraph(depsgraph, first.medium_source)
        seen.append((now, changes.changes_from_depsgraph(depsgraph), time.perf_counter() - t))

    bpy.app.handlers.depsgraph_update_post.append(handler)
    cube.location.x += 0.1
    bpy.context.view_layer.update()
    now, former, t_flags = seen[-1]
    dg = bpy.context.evaluated_depsgraph_get()
    for name, flags in (("now", now), ("former", former)):
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            ex.extract(dg, parts=flags & ~changes.Change.CAMERA, previous=first)
            times.append(time.perf_counter() - t0)
        print(f"{n}^3: mesh move, {name} flags {flags}: extract {min(times) * 1e3:.2f} ms "
              f"(change flags {t_flags * 1e3:.2f} ms)")
    print(f"{n}^3: first extraction {t_first:.2f} s; grid reads {volumes.grid_cache.reads}, "
          f"hits {volumes.grid_cache.hits}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 256, "generated" in sys.argv[2:])
