"""A production-sized sparse .vdb's first final frame (``python -m tfm_addon.bench.sparse_vdb``).

Writes (once, by code) a float grid whose active box is ``--side``³ voxels with about
``--active`` million active voxels (blobs of smoke scattered in the box, the rest inactive), then
renders it in fresh Blender processes (bpy as a module, the add-on from this checkout) at 640x360
through ``bpy.ops.render.render``: the seconds from the render call to the written frame and the
peak resident memory above the process before the call (sampled every 5 ms), with the frame's
report lines. Two paths take turns (``--repeats`` each): the sparse one (the grid read as bricks
at full resolution, docs/blender.md "Volumes") and the dense one (the same file read dense at
reduced resolution, as for a grid that is not sparse enough: the sparse rule switched off).
``--viewport`` measures a Rendered viewport instead: its first images and the longest waits of a
loop standing for Blender's thread, with the slow GL calls releasing Python's GIL or moderngl
calling the GL itself (``--calls released,moderngl`` takes turns).
"""

from __future__ import annotations

import os

import numpy as np

from .common import run_child

SETUP = r"""
import json, os, sys, threading, time
root, vdb, side, path = sys.argv[-4], sys.argv[-3], int(sys.argv[-2]), sys.argv[-1]
sys.path.insert(0, root); sys.path.insert(0, os.path.join(root, "tests", "blender"))
import bpy, numpy as np, tfm_addon
tfm_addon.register()
from tfm_addon.blender import volumes
if path == "dense":
    volumes.SPARSE_MAX_FILL = -1.0          # never sparse: read dense at reduced resolution
from blender_helpers import smoke, SETTINGS
from tfm_addon.blender import scene_builder, final_render
import tempfile
bpy.ops.wm.read_factory_settings(use_empty=True)
made = scene_builder.build(smoke(width=640, height=360, n=32), tempfile.mkdtemp(prefix="tfm_sparse_"),
                           settings=SETTINGS, samples=1)
scene = bpy.context.scene
scene.tfm.quality = 'AUTO'
ob = made["medium"]
ob.data.filepath = vdb
voxel = 2.0 / side                        # the smoke's 2 m box, centred at (0, 0, 1.2)
ob.matrix_world = ((1, 0, 0, -1.0), (0, 1, 0, -1.0), (0, 0, 1, 0.2), (0, 0, 0, 1))
"""

CHILD = SETUP + r"""
def rss():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

peak = [0]; stop = [False]
def watch():
    while not stop[0]:
        peak[0] = max(peak[0], rss())
        time.sleep(0.005)
import gc; gc.collect()
before = rss()
t = threading.Thread(target=watch, daemon=True); t.start()
start = time.perf_counter()
bpy.ops.render.render()
seconds = time.perf_counter() - start
stop[0] = True; t.join()
print("RESULT " + json.dumps({"seconds": seconds, "rss_peak_above": peak[0] - before,
      "before": before, "messages": final_render.last_messages,
      "timings": final_render.last_timings, "load": os.getloadavg()[0]}), flush=True)
os._exit(0)
"""


VIEWPORT_CHILD = SETUP + r"""
from tfm_addon.blender import viewport
from tfm_addon.blender.changes import Change
from tfm_addon.blender.camera import camera_from_view, without_scale
samples = int(os.environ.get("TFM_VIEW_SAMPLES", "4"))

def view_camera(dg, w, h):
    cam = scene.camera.evaluated_get(dg)
    view = np.linalg.inv(without_scale(cam.matrix_world))
    return camera_from_view(view, np.array(cam.calc_matrix_camera(dg, x=w, y=h)), w, h)

# Blender's thread as a loop of Python callbacks: each step's gap is how long it was held (by our
# calls, or by another thread holding Python's lock), less the time it waited for a CPU (Linux's
# run-queue delay of the thread: a loaded machine's share, not a hold).
if os.environ.get("TFM_BENCH_CALLS") == "moderngl":  # moderngl calls the GL itself, holding the GIL
    from tfm_addon.engine import gl_context
    gl_context.RELEASED_CALLS.clear()
sched = os.open(f"/proc/self/task/{threading.get_native_id()}/schedstat", os.O_RDONLY)

def cpu_wait():
    return int(os.pread(sched, 200, 0).split()[1]) * 1e-9

holds, events = [], {}
session = viewport.ViewportSession()
start = time.perf_counter()
last, last_wait = start, cpu_wait()
dg = bpy.context.evaluated_depsgraph_get()
session.update(dg)
events["first update (s)"] = session.update_s
camera = view_camera(dg, 640, 360)
session.request(camera, samples)
first, told, waiting, before = None, set(), None, None
stacks = os.environ.get("TFM_BENCH_STACKS")    # every thread's stack whenever the loop waits 35 ms
if stacks:
    import faulthandler
    stacks = open(stacks, "w")
while time.perf_counter() - start < 300:
    now = time.perf_counter()
    if stacks:
        stacks.write(f"--- {now - start:.3f}\n"); stacks.flush()
        faulthandler.dump_traceback_later(0.035, file=stacks)
    wait = cpu_wait()
    holds.append((now - last, last - start, wait - last_wait))
    frame = session.frame()
    if frame is not None and first is None:
        first = now - start
    news = ({"preview"} if volumes.grid_cache.previews else set()) | (
        {"read"} if not volumes.grid_cache.reading else set())
    if news - told:                            # what the add-on's timer does: tag, Blender updates
        name = "+".join(sorted(news - told))
        told |= news
        events[f"{name} done (s)"] = now - start
        ob.data.update_tag()
        dg = bpy.context.evaluated_depsgraph_get()
        session.update(dg, Change.MEDIUM)      # the flags view_update's depsgraph would give
        events[f"update after the {name} (s)"] = session.update_s
        session.request(camera, samples)
        waiting, before = name, frame
    if waiting and frame is not None and frame is not before:
        events[f"first image after the {waiting} (s)"] = now - start
        waiting, before = None, None
    if "read" in told and waiting is None and frame.samples == samples and session.view.state == "idle":
        events[f"{samples} samples (s)"] = now - start
        break
    last, last_wait = time.perf_counter(), cpu_wait()
    time.sleep(0.002)
events["first image (before the read) (s)"] = first
events["longest hold of the main loop (ms)"] = 1e3 * max(h for h, _, _ in holds[1:])
events["longest hold less its wait for a CPU (ms)"] = 1e3 * max(h - w for h, _, w in holds[1:])
events["holds over 50 ms (ms at s, of which waiting for a CPU)"] = " ".join(
    f"{1e3 * h:.0f}@{t:.1f}({1e3 * w:.0f})" for h, t, w in holds[1:] if h > 0.05)
events["warnings"] = session.warnings
print("RESULT " + json.dumps(events), flush=True)
os._exit(0)
"""


def viewport_once(root: str, vdb: str, side: int, calls: str = "released", stacks: str = "") -> dict:
    """A Rendered viewport's first images of the grid (ViewportSession, as the engine drives it).
    ``calls``: 'released' (the slow GL calls release the GIL, gl_context.ReleasingLoader) or
    'moderngl' (moderngl calls the GL itself); ``stacks``: a file for the stacks of the loop's
    waits over 35 ms."""
    env = dict(os.environ, TFM_BENCH_CALLS=calls, TFM_BENCH_STACKS=stacks)
    return run_child(VIEWPORT_CHILD, [root, vdb, str(side), "sparse"], env, timeout=900)


def write_sparse_vdb(path: str, side: int, active_millions: float, seed: int = 5) -> int:
    """A float grid 'density' with voxel size 2/side m, its active voxels in spherical blobs (a
    smooth falloff to 0 at their rim) filling a ``side``³ box; written slab by slab, never dense.
    Returns the active voxel count."""
    from tfm_addon.blender.openvdb_module import import_openvdb

    vdb = import_openvdb()
    rng = np.random.default_rng(seed)
    radius = side / 24.0
    per_blob = 4.0 / 3.0 * np.pi * radius ** 3
    count = max(1, int(active_millions * 1e6 / per_blob))
    centres = rng.uniform(radius, side - radius, size=(count, 3))
    grid = vdb.FloatGrid()
    grid.name = "density"
    grid.transform = vdb.createLinearTransform(voxelSize=2.0 / side)
    slab = 64
    r = int(np.ceil(radius))
    for z0 in range(0, side, slab):
        block = np.zeros((side, side, slab), np.float32)
        for c in centres[np.abs(centres[:, 2] - (z0 + slab / 2)) < slab / 2 + radius]:
            lo = np.maximum(np.floor(c - r).astype(int), [0, 0, z0])
            hi = np.minimum(np.ceil(c + r).astype(int) + 1, [side, side, z0 + slab])
            if np.any(hi <= lo):
                continue
            x, y, z = np.meshgrid(*(np.arange(lo[k], hi[k]) for k in range(3)), indexing="ij")
            d2 = ((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2) / radius ** 2
            value = np.clip(1.0 - d2, 0.0, None) * 8.0
            view = block[lo[0]:hi[0], lo[1]:hi[1], lo[2] - z0:hi[2] - z0]
            np.maximum(view, value.astype(np.float32), out=view)
        grid.copyFromArray(block, ijk=(0, 0, z0), tolerance=0.0)
    vdb.write(path, grids=[grid])
    return int(grid.activeVoxelCount())


def render_once(root: str, vdb: str, side: int, path: str) -> dict:
    """One first final frame in a fresh Blender process: 'sparse' or 'dense'."""
    env = dict(os.environ, MALLOC_MMAP_THRESHOLD_="65536")
    return run_child(CHILD, [root, vdb, str(side), path], env)


def main(argv=None) -> None:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--side", type=int, default=1024)
    parser.add_argument("--active", type=float, default=32.0, help="millions of active voxels")
    parser.add_argument("--vdb", default="/tmp/tfm_sparse_bench.vdb")
    parser.add_argument("--repeats", type=int, default=2, help="frames per path (viewport: runs per --calls)")
    parser.add_argument("--paths", default="dense,sparse")
    parser.add_argument("--viewport", action="store_true", help="a Rendered viewport's first images")
    parser.add_argument("--calls", default="released",
                        help="viewport: 'released' (slow GL calls release the GIL), 'moderngl', or both "
                             "(comma-separated, taking turns)")
    parser.add_argument("--stacks", default="", help="viewport: write the stacks of the loop's waits "
                        "over 35 ms to FILE.CALLS.REPEAT (faulthandler, which reads running threads' "
                        "stacks without Python's lock: a diagnosis that can crash the child)")
    args = parser.parse_args(argv)
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    if not os.path.exists(args.vdb):
        active = write_sparse_vdb(args.vdb, args.side, args.active)
        print(f"wrote {args.vdb}: {args.side}³ box, {active / 1e6:.1f} M active voxels", flush=True)
    if args.viewport:
        for repeat in range(args.repeats):
            for calls in args.calls.split(","):
                stacks = f"{args.stacks}.{calls}.{repeat}" if args.stacks else ""
                r = viewport_once(root, args.vdb, args.side, calls, stacks)
                print(f"viewport, GL calls {calls}, load average {os.getloadavg()[0]:.1f}:", flush=True)
                for k, v in r.items():
                    print(f"  {k}: {v:.2f}" if isinstance(v, float) else f"  {k}: {v}", flush=True)
        return
    results: dict[str, list] = {}
    for _ in range(args.repeats):
        for path in args.paths.split(","):
            r = render_once(root, args.vdb, args.side, path)
            results.setdefault(path, []).append(r)
            print(f"{path}: first final frame 640x360: {r['seconds']:.1f} s, "
                  f"peak {r['rss_peak_above'] / 2**30:.2f} GiB above the process "
                  f"({r['before'] / 2**30:.2f} GiB before), load average {r['load']:.1f}", flush=True)
            for level, message in r["messages"]:
                print(f"  {level}: {message}")
            print("  timings: " + ", ".join(f"{k} {v:.2f} s" for k, v in sorted(r["timings"].items())))
    for path, rs in results.items():
        print(f"{path}: fastest {min(r['seconds'] for r in rs):.1f} s, median "
              f"{sorted(r['seconds'] for r in rs)[len(rs) // 2]:.1f} s, largest peak "
              f"{max(r['rss_peak_above'] for r in rs) / 2**30:.2f} GiB")


if __name__ == "__main__":
    main()
