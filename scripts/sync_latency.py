"""Blender's thread time of the viewport's ``view_update`` for edits that touch little: a
selection click, a move of a small object next to a big mesh, a move of the big mesh, and a
Mesh to Volume object moved with its mesh; beside what reading the whole scene again costs (the
former behaviour: a click re-read everything, a move re-triangulated every mesh).

    PYTHONPATH=. .venv/bin/python scripts/sync_latency.py [segments rings] [--volume]

The big mesh is a UV sphere of 2 x segments x (rings - 1) triangles (default 1024 x 640: 1.31 M).
``--volume`` adds a 127³ Mesh to Volume object, parented with its mesh to an empty that moves.
"""

import sys
import time

import bpy

import tfm_addon


def main(segments: int, rings: int, volume: bool) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    tfm_addon.register()
    from tfm_addon.blender import changes, viewport
    from tfm_addon.blender import extract as ex

    scene = bpy.context.scene
    scene.render.engine = 'TFM'
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=rings)
    big = bpy.context.object
    bpy.ops.mesh.primitive_cube_add(location=(4.0, 0.0, 0.0))
    cube = bpy.context.object
    bpy.ops.object.light_add(type='SPOT', location=(0.0, 0.0, 5.0))
    bpy.ops.object.camera_add(location=(0.0, -10.0, 0.0), rotation=(1.5708, 0.0, 0.0))
    scene.camera = bpy.context.object
    parent = None
    if volume:
        bpy.ops.object.empty_add(location=(0.0, 4.0, 0.0))
        parent = bpy.context.object
        bpy.ops.mesh.primitive_cube_add(size=2.0)
        source = bpy.context.object
        source.hide_set(True)
        bpy.ops.object.volume_add()
        vol = bpy.context.object
        source.parent = vol.parent = parent
        mod = vol.modifiers.new("ToVolume", 'MESH_TO_VOLUME')
        mod.object, mod.resolution_mode, mod.voxel_size = source, 'VOXEL_SIZE', 2.0 / 126
    bpy.context.view_layer.update()

    session = viewport.ViewportSession()
    t0 = time.perf_counter()
    session.update(bpy.context.evaluated_depsgraph_get())
    first = time.perf_counter() - t0
    triangles = sum(len(m.triangles) for m in session.extraction.meshes)
    print(f"{triangles} triangles in the scene; first extraction {1000 * first:.0f} ms")
    if session.extraction.media:
        print(f"medium grid {session.extraction.media[0].density.shape}")

    timed = []

    def handler(_scene, depsgraph):
        session.update(depsgraph)
        timed.append((session.update_s, session.last_changes))

    bpy.app.handlers.depsgraph_update_post.append(handler)

    def measure(label, edit, former_parts, repeats=5):
        times = []
        for i in range(repeats):
            timed.clear()
            edit(i)
            bpy.context.view_layer.update()
            times.append(max((t for t, _ in timed), default=0.0))
        flags = timed[-1][1] if timed else None
        t0 = time.perf_counter()   # the same edit as it was read before: these parts, every mesh read
        ex.extract(bpy.context.evaluated_depsgraph_get(), parts=former_parts, previous=session.extraction)
        former = time.perf_counter() - t0
        print(f"{label}: {1000 * min(times):.1f}-{1000 * max(times):.1f} ms on Blender's thread "
              f"(flags {flags}); reading {former_parts} afresh: {1000 * former:.0f} ms")

    def click(i):
        ob = (cube, big, None)[i % 3]
        for o in bpy.context.view_layer.objects:
            o.select_set(o is ob)
        bpy.context.view_layer.objects.active = ob

    measure("selection click", click, changes.Change.ALL)
    measure("move the small cube", lambda i: setattr(cube.location, "z", 0.1 * (i + 1)),
            changes.Change.SOLIDS)
    measure("move the big mesh", lambda i: setattr(big.location, "z", 0.1 * (i + 1)),
            changes.Change.SOLIDS)
    if parent is not None:
        measure("move the Mesh to Volume object with its mesh",
                lambda i: setattr(parent.location, "x", 0.1 * (i + 1)), changes.Change.MEDIUM)
    print("counters", dict(session.kept.counters))
    bpy.app.handlers.depsgraph_update_post.remove(handler)


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    main(int(args[0]) if args else 1024, int(args[1]) if len(args) > 1 else 640, "--volume" in sys.argv)
