"""The light-side overhead: every setting against the floor, measured side by side.

    python -m tfm_addon.bench.speed [--scenes demo smoke ...] [--repeats 3] [--reference]
    python tfm_addon/bench/speed.py --demo-only      # also runs on an older checkout (PYTHONPATH)
    python -m tfm_addon.bench.speed --pixels --clock cpu   # cost against pixels, 160x90 .. 1280x720

Per scene, frames are timed as if the light moved (maps rebuilt each frame, the density texture
kept), the contenders interleaved, medians of ``--repeats``: 'AUTO', the floor with AUTO's steps
(``method='UNSHADOWED'``: light transmittance 1 through the medium, the solids' shadow maps
kept, no TFM), TFM-8 EXACT and LINEAR at 100x100 steps, the floor at 100 steps, the brute force
100x100. It prints TFM / floor and brute force / floor. Then AUTO's camera move, light move and
sigma edit. With ``--reference`` each render is compared (SSIM, metrics.ssim) with the numpy
reference at one step per voxel crossed (``bench.common.ground_truth_steps``), rendered at the
accuracy size (default 320x180 for the demo, the scene's own otherwise), cached in out/bench/cache.

Absolute imports only, so that this file can time a checkout that predates it
(``PYTHONPATH=<old checkout> python <this file> --demo-only``); there 'UNSHADOWED' is emulated
by ``use_tfm=False`` on every light (the same frame for one light).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import statistics
import sys
import time

import numpy as np

from tfm_addon import scenes
from tfm_addon.engine import Renderer, RenderSettings

FLOOR = "UNSHADOWED"


def _has_floor() -> bool:
    return "UNSHADOWED" in str(RenderSettings.__annotations__.get("method", ""))


def floor_of(scene, settings):
    """(scene, settings) of the floor: the same frame with light transmittance 1."""
    if _has_floor():
        return scene, dataclasses.replace(settings, method=FLOOR, quality="CUSTOM")
    lights = tuple(dataclasses.replace(lt, use_tfm=False) for lt in scene.lights)
    return dataclasses.replace(scene, lights=lights), dataclasses.replace(settings, quality="CUSTOM")


def _moved_light(scene, k):
    lights = []
    for lt in scene.lights:
        m = np.array(lt.matrix_world)
        m[0, 3] += 1e-3 * k
        lights.append(dataclasses.replace(lt, matrix_world=m))
    return dataclasses.replace(scene, lights=tuple(lights))


def _moved_camera(scene, k):
    m = np.array(scene.camera.matrix_world)
    m[0, 3] += 1e-3 * k
    return dataclasses.replace(scene, camera=dataclasses.replace(scene.camera, matrix_world=m))


def _sigma_edit(scene, k):
    med = scene.media[0]
    s = tuple(x * (1.0 + 1e-3 * k) for x in med.sigma_s)
    return dataclasses.replace(scene, media=(dataclasses.replace(med, sigma_s=s),))


def contender(renderer, scene, settings, change=_moved_light):
    """A callable that renders one frame of ``scene`` after ``change`` (alternating two states)."""
    states = [change(scene, 0), change(scene, 1)]
    k = [0]

    def go():
        k[0] ^= 1
        return renderer.render(states[k[0]], settings, passes=False)
    return go


def time_side_by_side(contenders, repeats, clock=time.perf_counter):
    """Median seconds of each contender by ``clock``, interleaved; each timed frame follows an
    untimed one of the contender's other state, so that what its change keeps is cached (another
    contender's frame in between would have swept it). ``time.process_time`` counts the CPU
    seconds of every thread of this process (llvmpipe's included): on a machine shared with
    other jobs it measures the work, where the wall clock also measures the neighbours."""
    samples = {name: [] for name in contenders}
    for fn in contenders.values():      # warm-up: compile programs, upload the grid
        fn()
        fn()
    for _ in range(repeats):
        for name, fn in contenders.items():
            fn()                        # the other state: what this one's change starts from
            t0 = clock()
            fn()
            samples[name].append(clock() - t0)
    return {name: statistics.median(s) for name, s in samples.items()}


def bench_scenes(names, demo_size=(960, 540)):
    out = {}
    for name in names:
        if name == "demo":
            out[name] = scenes.demo_scene(*demo_size)
        elif name == "smoke":
            out[name] = scenes.paper_smoke_scene(320, 180, 128)
        elif name == "dense":
            out[name] = scenes.dense_smoke_scene(320, 180, 128, thickness=30.0)
        elif name == "suzanne":
            from tfm_addon.bench.scene_set import suzanne_mesh
            v, t = suzanne_mesh()
            out[name] = scenes.suzanne_scene(v, t, 320, 180, 256)
        elif name == "cloud":
            out[name] = scenes.cloud_scene(320, 180, (600, 400, 200))
        elif name == "gobo":
            out[name] = scenes.gobo_box_scene(320, 180, with_bar=True)
    return out


def settings_for(scene, map_resolution=512):
    from tfm_addon.engine.renderer import effective_settings

    base = RenderSettings(map_resolution=map_resolution, view_steps=100, light_steps=100)
    auto = effective_settings(scene, dataclasses.replace(base, quality="AUTO"))
    out = {"AUTO": dataclasses.replace(base, quality="AUTO")}
    out["floor (AUTO steps)"] = floor_of(scene, auto)
    if scene.media and scene.media[0].density is not None:
        out["TFM-8 EXACT"] = dataclasses.replace(base, coefficients=8, tfm_filter="EXACT")
        out["TFM-8 LINEAR"] = dataclasses.replace(base, coefficients=8, tfm_filter="LINEAR")
        out["floor (100 steps)"] = floor_of(scene, base)
        out["brute force 100x100"] = dataclasses.replace(base, method="BRUTE_FORCE")
    return out


CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}

def run_scene(renderer, name, scene, repeats, reference=None, clock="wall"):
    cases = settings_for(scene)
    contenders = {}
    for label, s in cases.items():
        sc, st = s if isinstance(s, tuple) else (scene, s)
        contenders[label] = contender(renderer, sc, st)
    auto = cases["AUTO"]
    if scene.media:
        contenders["AUTO camera move"] = contender(renderer, scene, auto, _moved_camera)
        contenders["AUTO sigma edit"] = contender(renderer, scene, auto, _sigma_edit)
    times = time_side_by_side(contenders, repeats, CLOCKS[clock])
    row = {"scene": name, "size": f"{scene.camera.width_px}x{scene.camera.height_px}", "clock": clock,
           "ms": {k: 1000 * v for k, v in times.items()}}
    if reference is not None:
        ref_scene, ref_image = reference
        row["ssim"] = {}
        from tfm_addon.engine.metrics import ssim
        for label, s in cases.items():
            sc, st = s if isinstance(s, tuple) else (ref_scene, s)
            if isinstance(s, tuple):
                sc = dataclasses.replace(sc, camera=ref_scene.camera)
            renderer.clear_maps()
            img = renderer.render(sc, st, passes=False).rgb
            row["ssim"][label] = ssim(img, ref_image)
    return row


PIXEL_SIZES = ((160, 90), (320, 180), (640, 360), (1280, 720))


def run_pixels(renderer, sizes=PIXEL_SIZES, repeats=3, clock="cpu", grid=128) -> list[dict]:
    """How a frame's cost grows with its pixels (the target: linearly): AUTO on the paper smoke at
    each of ``sizes``, after a camera move (the maps kept) and after a light move (the maps
    rebuilt: their cost does not depend on the image), all interleaved; per size the ms and the
    ms per pixel relative to the first size's."""
    contenders = {}
    for w, h in sizes:
        scene = scenes.paper_smoke_scene(w, h, grid)
        auto = RenderSettings(map_resolution=512, view_steps=100, light_steps=100, quality="AUTO")
        contenders[(w, h, "camera move")] = contender(renderer, scene, auto, _moved_camera)
        contenders[(w, h, "light move")] = contender(renderer, scene, auto)
    times = time_side_by_side(contenders, repeats, CLOCKS[clock])
    rows = []
    for kind in ("camera move", "light move"):
        base = None
        for w, h in sizes:
            per_pixel = times[(w, h, kind)] / (w * h)
            base = per_pixel if base is None else base
            rows.append({"frame": kind, "size": f"{w}x{h}", "clock": clock,
                         "ms": {kind: 1000 * times[(w, h, kind)]}, "per pixel / first": per_pixel / base})
    return rows


def reference_image(scene, cache_dir="out/bench/cache"):
    from pathlib import Path

    from tfm_addon.bench import config as configs
    from tfm_addon.bench.common import ground_truth

    return ground_truth(scene, configs.FULL, None, Path(cache_dir)).image


def ratios(row):
    ms = row["ms"]
    out = {}
    if "floor (AUTO steps)" in ms:
        out["AUTO / floor"] = ms["AUTO"] / ms["floor (AUTO steps)"]
    if "floor (100 steps)" in ms:
        f = ms["floor (100 steps)"]
        for k in ("TFM-8 EXACT", "TFM-8 LINEAR", "brute force 100x100"):
            out[f"{k} / floor"] = ms[k] / f
        out["BF 100x100 / AUTO"] = ms["brute force 100x100"] / ms["AUTO"]
    if "AUTO camera move" in ms:
        out["light move / camera move"] = ms["AUTO"] / ms["AUTO camera move"]
        out["sigma edit / camera move"] = ms["AUTO sigma edit"] / ms["AUTO camera move"]
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m tfm_addon.bench.speed", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenes", nargs="+", default=["demo", "smoke", "dense", "suzanne", "cloud", "gobo"])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--reference", action="store_true", help="SSIM against the numpy reference")
    p.add_argument("--demo-only", action="store_true",
                   help="only AUTO on the demo 960x540 with a light move (for an old checkout)")
    p.add_argument("--clock", choices=tuple(CLOCKS), default="wall",
                   help="wall: elapsed seconds; cpu: CPU seconds of this process, all threads")
    p.add_argument("--json", help="write the rows here")
    p.add_argument("--pixels", action="store_true",
                   help="AUTO on the paper smoke at 160x90 .. 1280x720: cost against pixels")
    args = p.parse_args(argv)
    renderer = Renderer()
    if args.pixels:
        rows = run_pixels(renderer, repeats=args.repeats, clock=args.clock)
        for row in rows:
            (ms,) = row["ms"].values()
            print(f"  {row['frame']:12s} {row['size']:>9s} {ms:8.1f} ms  per pixel / 160x90's "
                  f"{row['per pixel / first']:5.2f}", file=sys.stderr)
        return _finish(renderer, rows, args.json)
    if args.demo_only:
        scene = scenes.demo_scene(960, 540)
        fn = contender(renderer, scene, RenderSettings(map_resolution=512, quality="AUTO"))
        t = time_side_by_side({"AUTO": fn}, args.repeats, CLOCKS[args.clock])["AUTO"]
        print(json.dumps({f"demo AUTO ms ({args.clock})": 1000 * t}))
        return 0
    rows = []
    for name, scene in bench_scenes(args.scenes).items():
        ref = None
        if args.reference:
            ref_scene = scene
            if name == "demo":
                ref_scene = dataclasses.replace(scene, camera=dataclasses.replace(
                    scene.camera, width_px=320, height_px=180))
            ref = (ref_scene, reference_image(ref_scene))
        row = run_scene(renderer, name, scene, args.repeats, ref, args.clock)
        row["ratios"] = ratios(row)
        rows.append(row)
        print(f"## {name} {row['size']} ({args.clock} clock)", file=sys.stderr)
        for k, v in row["ms"].items():
            extra = f"  SSIM {row['ssim'][k]:.4f}" if "ssim" in row and k in row["ssim"] else ""
            print(f"  {k:24s} {v:8.1f} ms{extra}", file=sys.stderr)
        for k, v in row["ratios"].items():
            print(f"  {k:32s} {v:6.2f}", file=sys.stderr)
    return _finish(renderer, rows, args.json)


def _finish(renderer, rows: list[dict], json_path: str | None) -> int:
    """Write the rows to ``json_path`` (if given), release the renderer; 0 when every time is finite."""
    if json_path:
        with open(json_path, "w") as f:
            json.dump(rows, f, indent=1)
    renderer.release()
    return 0 if all(math.isfinite(v) for r in rows for v in r["ms"].values()) else 1


if __name__ == "__main__":
    sys.exit(main())
