"""How long a command-line render takes to stop on a farm's cancel (SIGTERM) or a Ctrl+C (SIGINT):
a saved smoke animation rendered by the farm job's worker (``farm/openjd/render_chunk.py``), the
signal sent ``--into`` seconds after the first frame is on disk (in the middle of the second frame),
the time measured from the signal to the process's end, whole frames and tiled ones (a memory
budget small enough to tile the frame).

    .venv/bin/python -m tfm_addon.bench.stop_time [--size 1280x720] [--repeats 3] [--into 0.5]

Runs where bpy imports (it builds and saves the scene); the renders run in processes of their own.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
WORKER = ROOT / "farm" / "openjd" / "render_chunk.py"
HANG_S = 300.0


def _shot(folder: str, width: int, height: int) -> str:
    """A 3-frame smoke animation (the light moves: every frame builds its maps) saved as a .blend."""
    import bpy

    from .. import scenes
    from ..blender import scene_builder

    bpy.ops.wm.read_homefile(use_empty=True)
    made = scene_builder.build(scenes.smoke_scene(width=width, height=height, n=48), folder, samples=16)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 3
    light = made["lights"][0]
    for frame in (1, 2, 3):
        light.location.x += 0.3
        light.keyframe_insert("location", frame=frame)
    scene.render.image_settings.file_format = 'OPEN_EXR'
    blend = os.path.join(folder, "shot.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    return blend


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def stop(blend: str, out: str, signum: int, into_s: float, budget_gb: float | None) -> tuple[float, int]:
    """(seconds from the signal to the worker's end, its exit status)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    if budget_gb is not None:
        env["TFM_MEMORY_BUDGET_GB"] = str(budget_gb)
    proc = subprocess.Popen([sys.executable, str(WORKER), "--blend", blend, "--output",
                             os.path.join(out, "frame_####"), "--frames", "1-3"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, preexec_fn=_default_sigint)
    first = os.path.join(out, "frame_0001.exr")
    deadline = time.monotonic() + HANG_S
    while not os.path.exists(first) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(into_s)
    proc.send_signal(signum)
    t0 = time.perf_counter()
    code = proc.wait(timeout=HANG_S)
    return time.perf_counter() - t0, code


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", default="1280x720")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--into", type=float, default=0.5, help="seconds into the second frame")
    args = parser.parse_args(argv)
    w, h = (int(v) for v in args.size.split("x"))

    import tfm_addon

    tfm_addon.register()
    rows = []
    with tempfile.TemporaryDirectory(prefix="tfm_stop_") as tmp:
        blend = _shot(tmp, w, h)
        # tiled: a budget of a quarter of the frame's estimate
        from ..blender.final_render import GIB, frame_estimate

        tiled_gb = frame_estimate(w, h, 3) / 4 / GIB
        for label, budget in (("whole", None), ("tiled", tiled_gb)):
            for signum in (signal.SIGINT, signal.SIGTERM):
                times, codes = [], set()
                for k in range(args.repeats):
                    out = os.path.join(tmp, f"{label}_{signum}_{k}")
                    os.makedirs(out)
                    seconds, code = stop(blend, out, signum, args.into, budget)
                    times.append(seconds)
                    codes.add(code)
                rows.append((label, signal.Signals(signum).name, min(times), max(times), sorted(codes)))
    tfm_addon.unregister()
    print(f"| frame ({w}x{h}, 16 samples) | signal | signal to exit, s (min–max of {args.repeats}) "
          f"| exit status |")
    print("|---|---|---|---|")
    for label, name, lo, hi, codes in rows:
        print(f"| {label} | {name} | {lo:.2f}–{hi:.2f} | {', '.join(map(str, codes))} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
