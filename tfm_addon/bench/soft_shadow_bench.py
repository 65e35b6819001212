"""What soft shadows cost: the smoke with the bar and the ground, lit by a spot (radius 0.25 m), an
area light (0.6 x 0.3 m) and a sun (3 degrees), each frame against the same light with no size
(sharp shadows), in one run.

    python -m tfm_addon.bench.soft_shadow_bench [--repeats 3] [--sizes 960x540 320x180]

Frames reuse their maps (a size edit rebuilds none), so the times are the light passes'; minima of
interleaved repetitions of the process's CPU time (every GL thread's: on a shared machine the wall
clock follows the other jobs' load, CPU time much less, and its minimum least: a repetition that
shared its cores' caches with another job is slower, none is faster)."""

from __future__ import annotations

import argparse
import dataclasses
import math
import time

from ..engine import Light, Renderer, RenderSettings
from ..scenes import look_at, smoke_scene

SETTINGS = RenderSettings(view_steps=100, light_steps=100, coefficients=8, map_resolution=512)


def lights() -> dict[str, tuple[Light, Light]]:
    """Per kind: (the light with its size, the same light with none)."""
    place = look_at((-2.5, -1.0, 4.0), (0.0, 0.0, 1.0))      # the bar's shadow through the smoke
    soft = {
        "spot, radius 0.25 m": Light(matrix_world=place, power_w=2000.0, spot_size_rad=math.radians(50),
                                     spot_blend=0.2, radius_m=0.25, name="Spot"),
        "area, 0.6 x 0.3 m": Light(matrix_world=place, power_w=2000.0, kind="AREA", size_m=(0.6, 0.3),
                                   name="Area"),
        "sun, 3 degrees": Light(matrix_world=place, power_w=3.0, kind="SUN", angle_rad=math.radians(3.0),
                                name="Sun"),
    }
    return {k: (v, dataclasses.replace(v, radius_m=0.0, size_m=(0.0, 0.0), angle_rad=0.0))
            for k, v in soft.items()}


def _cpu_side_by_side(renderer, scenes: dict, repeats: int) -> dict[str, float]:
    """The least CPU seconds of a frame of each scene, the repetitions interleaved."""
    samples: dict[str, list[float]] = {k: [] for k in scenes}
    for _ in range(repeats):
        for k, scene in scenes.items():
            t0 = time.process_time()
            renderer.render(scene, SETTINGS)
            samples[k].append(time.process_time() - t0)
    return {k: min(v) for k, v in samples.items()}


def run(sizes: list[tuple[int, int]], repeats: int, log=print) -> list[dict]:
    rows = []
    renderer = Renderer()
    try:
        for width, height in sizes:
            base = smoke_scene(width=width, height=height, n=64)
            for name, (soft, sharp) in lights().items():
                scenes = {"soft": dataclasses.replace(base, lights=(soft,)),
                          "sharp": dataclasses.replace(base, lights=(sharp,))}
                for s in scenes.values():
                    renderer.render(s, SETTINGS)           # maps and programs, once
                t = _cpu_side_by_side(renderer, scenes, repeats)
                row = dict(size=f"{width}x{height}", light=name, sharp=t["sharp"], soft=t["soft"],
                           ratio=t["soft"] / t["sharp"])
                log(f"{row['size']} {name}: sharp {row['sharp']:.3f} CPU s, soft {row['soft']:.3f} CPU s, "
                    f"ratio {row['ratio']:.2f}")
                rows.append(row)
    finally:
        renderer.release()
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--sizes", nargs="+", default=["960x540", "320x180"])
    args = parser.parse_args(argv)
    sizes = [tuple(int(v) for v in s.split("x")) for s in args.sizes]
    rows = run(sizes, args.repeats)
    print("\n| size | light | sharp (CPU s/frame) | soft (CPU s/frame) | soft / sharp |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['size']} | {r['light']} | {r['sharp']:.3f} | {r['soft']:.3f} | {r['ratio']:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
