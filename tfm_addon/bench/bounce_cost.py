"""What multiple scattering costs: each held-out medium of bench/bounces.py at 320x180, a frame at
16 and at 128 volume bounces against the same frame in single scattering, in one run.

    LP_NUM_THREADS=1 python -m tfm_addon.bench.bounce_cost [--repeats 8] [--media cumulus ...]

Runs where ``bpy`` imports (the media are built as Blender scenes and read by the add-on's
extraction). The frames reuse their maps and the lattice's fields (a bounce count builds none:
the ``fluences`` counter is printed), so the times are the light passes'; the first frame with
bounces builds the fields, whose time the renderer reports and this prints. The process's CPU time
per frame: its minimum over the rounds of interleaved repetitions; a ratio is the median over the
rounds of the frame with bounces over the frame without rendered just before it (a frame of these
small scenes takes 20-200 ms, and its time drifts by 10-20 % within a run: the minima of the two
frames, taken from different rounds, would mix that drift into the ratio)."""

from __future__ import annotations

import argparse
import dataclasses
import os
import tempfile
import time

import numpy as np

SIZE = (320, 180)


def measure(medium: str, repeats: int, tmp: str) -> dict:
    import bpy

    from ..blender import extract as ex
    from ..engine import Renderer
    from . import bounces as bn

    bn.build(medium, os.path.join(tmp, medium), 0)
    e = ex.extract(bpy.context.evaluated_depsgraph_get(), size=SIZE)
    base = ex.render_settings(bpy.context.scene)
    scene = e.scene()
    renderer = Renderer()
    try:
        renderer.render(scene, base)
        first = renderer.render(scene, dataclasses.replace(base, volume_bounces=16))
        fields_s = first.timings_s.get("fluence", 0.0)
        times = {0: [], 16: [], 128: []}
        for _ in range(repeats):
            for n, ts in times.items():
                t0 = time.process_time()
                renderer.render(scene, dataclasses.replace(base, volume_bounces=n))
                ts.append(time.process_time() - t0)
        builds = renderer.counters["fluences"]
    finally:
        renderer.release()
    row = {"medium": medium, "fields_s": fields_s, "builds": builds}
    for n, ts in times.items():
        row[str(n)] = min(ts)
        if n:   # the ratio of frames rendered one after the other, the median over the rounds
            row[f"{n}/0"] = float(np.median(np.asarray(ts) / np.asarray(times[0])))
    return row


def main(argv: list[str] | None = None) -> int:
    from . import bounces as bn

    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=16)
    parser.add_argument("--media", nargs="+", default=list(bn.HELD_OUT))
    args = parser.parse_args(argv)
    import tfm_addon

    tfm_addon.register()
    try:
        with tempfile.TemporaryDirectory(prefix="tfm_bounce_cost_") as tmp:
            rows = [measure(m, args.repeats, tmp) for m in args.media]
    finally:
        tfm_addon.unregister()
    print(f"\n{SIZE[0]}x{SIZE[1]}, LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS', 'unset')}")
    print("| medium | single (CPU s/frame) | 16 bounces | 128 bounces | 16 / single | 128 / single | "
          "fields built (s, once) |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['medium']} | {r['0']:.3f} | {r['16']:.3f} | {r['128']:.3f} | "
              f"{r['16/0']:.2f} | {r['128/0']:.2f} | {r['fields_s']:.2f} "
              f"({r['builds']} build) |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
