"""Memory of a final render against its pixel count (``python -m tfm_addon.bench.frame_memory``).

Each size renders in a fresh Blender process (bpy as a module, the add-on from this checkout):
a small smoke, the scene's default quality and samples, through ``bpy.ops.render.render``. A
thread samples the process's resident memory every 5 ms; tracemalloc follows Python's and
numpy's allocations. Printed per size: the peak resident memory above the process before the
render (the renderer's context and shaders are warm: a 64x64 frame rendered first), the
tracemalloc peak, and both per pixel; "beyond the result" subtracts Blender's own render result
(Combined RGBA + the enabled passes, float32).
"""

from __future__ import annotations

import os

from .common import run_child

CHILD = r"""
import json, os, sys, threading, time, tracemalloc
root, side, samples = sys.argv[-3], int(sys.argv[-2]), int(sys.argv[-1])
sys.path.insert(0, root); sys.path.insert(0, os.path.join(root, "tests", "blender"))
import bpy, tfm_addon
tfm_addon.register()
from blender_helpers import smoke, SETTINGS
from tfm_addon.blender import scene_builder
import tempfile
tmp = tempfile.mkdtemp(prefix="tfm_mem_")
bpy.ops.wm.read_factory_settings(use_empty=True)
scene_builder.build(smoke(width=64, height=64, n=32), tmp, settings=SETTINGS, samples=samples)
scene = bpy.context.scene
scene.render.resolution_percentage = 100
bpy.ops.render.render()                     # warm: context, shaders, grid
scene.render.resolution_x = scene.render.resolution_y = side

def rss():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

peak = [0, 0.0]; stop = [False]; marks = []
def watch():
    while not stop[0]:
        r = rss()
        if r > peak[0]:
            peak[0], peak[1] = r, time.perf_counter()
        time.sleep(0.005)
from tfm_addon.blender import final_render
_write = final_render.write_result
def write_result(*a, **k):
    marks.append(("write", time.perf_counter(), rss()))
    try:
        return _write(*a, **k)
    finally:
        marks.append(("written", time.perf_counter(), rss()))
final_render.write_result = write_result
import gc; gc.collect()
before = rss()
t = threading.Thread(target=watch, daemon=True); t.start()
tracemalloc.start()
start = time.perf_counter()
bpy.ops.render.render()
seconds = time.perf_counter() - start
traced = tracemalloc.get_traced_memory()[1]
tracemalloc.stop()
stop[0] = True; t.join()
passes = sum(1 for p in ("scattering", "surfaces", "transmittance")
             if getattr(bpy.context.view_layer.tfm, f"use_pass_{p}", True))
print("RESULT " + json.dumps({"side": side, "samples": samples, "seconds": seconds,
      "rss_peak_above": peak[0] - before, "traced_peak": traced,
      "peak_at": peak[1] - start, "marks": [(m, t - start, r - before) for m, t, r in marks],
      "result_bytes_per_px": 4 * (4 + 3 * passes)}), flush=True)
os._exit(0)
"""


def measure(side: int, samples: int, budget_gb: float | None = None) -> dict:
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    # glibc returns freed arrays of 64 KiB and more to the system at once (as it does by itself
    # for arrays above 32 MiB): the resident peak then follows the live memory at every size.
    env = dict(os.environ, MALLOC_MMAP_THRESHOLD_="65536")
    if budget_gb is not None:     # a frame above it renders in tiles (final_render.tiling)
        env["TFM_MEMORY_BUDGET_GB"] = str(budget_gb)
    return run_child(CHILD, [root, str(side), str(samples)], env)


def main(argv=None) -> None:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sides", type=int, nargs="+", default=[1024, 2048])
    parser.add_argument("--samples", type=int, default=16)
    parser.add_argument("--verbose", action="store_true", help="when the peak came, RSS around the copy")
    parser.add_argument("--budget-gb", type=float, nargs="+", default=[None],
                        help="memory budgets (GiB) to render each size under: a frame above one renders "
                             "in tiles")
    args = parser.parse_args(argv)
    print("side  budget GiB  samples  seconds  RSS peak above (MB)  B/px  beyond result B/px  "
          "traced peak B/px")
    for side, budget in [(s, b) for s in args.sides for b in args.budget_gb]:
        r = measure(side, args.samples, budget)
        px = side * side
        print(f"{side:5d} {budget or '-':>10} {r['samples']:7d} {r['seconds']:8.1f} "
              f"{r['rss_peak_above'] / 1e6:18.0f} "
              f"{r['rss_peak_above'] / px:6.0f} {r['rss_peak_above'] / px - r['result_bytes_per_px']:18.0f} "
              f"{r['traced_peak'] / px:16.0f}", flush=True)
        if args.verbose:
            print(f"      peak at {r['peak_at']:.2f} s; " + ", ".join(
                f"{m} {t:.2f} s {b / px:.0f} B/px" for m, t, b in r["marks"]), flush=True)


if __name__ == "__main__":
    main()
