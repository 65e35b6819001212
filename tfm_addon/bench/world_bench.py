"""The cost of the world: its light shadowed by the media and the solids, and its fog beside a
smoke, each against the same frame without it, measured side by side in one run.

    python -m tfm_addon.bench.world_bench [--quick]

The smoke of ``scenes.smoke_scene`` with its spot and ground; the world colour (0.3, 0.4, 0.6).
Each frame is timed twice: with its maps kept (a camera move: the maps are built before timing)
and rebuilt (a light or medium edit: the maps dropped first). Medians of interleaved repetitions.
"""

from __future__ import annotations

import argparse
import dataclasses
import platform

from ..engine import Medium, Renderer, RenderSettings
from ..scenes import smoke_scene
from .timing import time_side_by_side

WORLD = (0.3, 0.4, 0.6)
FOG = Medium(sigma_a=(0.0, 0.0, 0.0), sigma_s=(0.05, 0.05, 0.05), name="World fog")


def cases(width: int, height: int, grid: int) -> dict[str, tuple]:
    """name -> (scene, settings)."""
    base = smoke_scene(width=width, height=height, n=grid)
    plain = RenderSettings(view_steps=64, light_steps=64, coefficients=8, map_resolution=256)
    lit = dataclasses.replace(base, ambient=WORLD)
    out = {"no world": (base, plain),
           "world unshadowed": (lit, plain)}
    for n in (8, 16, 32):
        out[f"world shadowed, {n} directions"] = (
            lit, dataclasses.replace(plain, world_light="SHADOWED", world_directions=n))
    out["world fog beside the smoke"] = (dataclasses.replace(base, media=(*base.media, FOG)), plain)
    return out


def run(width: int = 320, height: int = 180, grid: int = 64, repeats: int = 5, log=print) -> list[dict]:
    """Rows: name, seconds per frame with maps kept and with maps rebuilt."""
    renderer = Renderer()
    frames = cases(width, height, grid)

    def frame(name, rebuild):
        scene, settings = frames[name]

        def go():
            if rebuild:
                renderer.clear_maps()
            renderer.render(scene, settings, passes=False, client=name)    # each frame keeps its maps
        return go

    for name in frames:                  # compile every program variant, build the maps
        frame(name, False)()
    log(f"world bench: {len(frames)} frames x {repeats} at {width}x{height}, {grid}^3")
    kept = time_side_by_side({name: frame(name, False) for name in frames}, repeats)
    rebuilt = time_side_by_side({name: frame(name, True) for name in frames}, repeats)
    renderer.release()
    return [dict(name=name, kept=kept[name], rebuilt=rebuilt[name]) for name in frames]


def report(rows: list[dict], width: int, height: int) -> str:
    base = rows[0]
    lines = [f"{width}x{height}, {platform.machine()} ({platform.processor() or 'cpu'}), Mesa llvmpipe; "
             "ratios to the frame without the world (first row), one run.", "",
             "| frame | s/frame, maps kept | ratio | s/frame, maps rebuilt | ratio |",
             "|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['name']} | {r['kept']:.3f} | {r['kept'] / base['kept']:.2f} | "
                     f"{r['rebuilt']:.3f} | {r['rebuilt'] / base['rebuilt']:.2f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="64x36, 16^3, one repetition")
    args = parser.parse_args(argv)
    size = (64, 36, 16, 1) if args.quick else (320, 180, 64, 5)
    rows = run(*size)
    print(report(rows, size[0], size[1]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
