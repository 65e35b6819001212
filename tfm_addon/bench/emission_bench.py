"""What emission costs a frame (issue 10): the burning plume lit by a spot, rendered with and
without its emission (and its colour grid), side by side, maps built once beforehand.

``python -m tfm_addon.bench --only emission`` writes emission.md; the target is at most 10 %.
"""

from __future__ import annotations

import dataclasses
import statistics
import time

from ..engine import Renderer, RenderSettings
from ..engine.scene import GridValue
from ..scenes import fire_scene
from .renderer_bench import Size  # width, height, grid, map_resolution, repeats

FULL = Size(320, 180, 64, 256, 15)
QUICK = Size(64, 36, 16, 64, 3)
PAPER = Size(1280, 720, 128, 1024, 9)


def run(size: Size, log=print) -> list[dict]:
    """Median seconds per frame of the fire scene without emission, with emission (strength from
    the flame grid and blackbody from the temperature grid), with a colour grid as well, and with
    a constant emission (no grid read), and each one's ratio to the first. Every map is built
    before the timing (a steady viewport frame: the emission needs no map, so it changes none)."""
    fire = fire_scene(size.width, size.height, size.grid, kind="FIRE", with_light=True,
                      with_occluder=True, with_ground=True)
    m = fire.medium
    dark = dataclasses.replace(m, emission_strength=GridValue(offset=0.0),
                               blackbody_intensity=GridValue(offset=0.0))
    colored = dataclasses.replace(m, grids={**m.grids, "color": _color(m)}, color_grid="color")
    constant = dataclasses.replace(dark, emission_strength=GridValue(offset=0.3))
    scenes = {"no emission": dataclasses.replace(fire, medium=dark),
              "emission + blackbody": fire,
              "emission + blackbody + colour grid": dataclasses.replace(fire, medium=colored),
              "constant emission": dataclasses.replace(fire, medium=constant)}
    settings = RenderSettings(map_resolution=size.map_resolution)
    first = Renderer()
    # One renderer (its own caches) per case on one GL context: a renderer keeps only what its
    # last frame used, so interleaving the cases on one would re-upload their grids every frame.
    renderers = {name: first if i == 0 else Renderer(gl=first.gl) for i, name in enumerate(scenes)}
    try:
        for name, scene in scenes.items():
            renderers[name].render(scene, settings, passes=False)   # build maps, compile shaders
        before = {name: dict(r.counters) for name, r in renderers.items()}
        frames = {name: (lambda s=scene, r=renderers[name]: r.render(s, settings, passes=False))
                  for name, scene in scenes.items()}
        seconds, cpu = _side_by_side(frames, size.repeats)
        cpu_gl = "llvmpipe" in str(first.gl.ctx.info.get("GL_RENDERER", "")).lower()
        rebuilt = {name: sum(r.counters[k] - before[name].get(k, 0)
                             for k in ("shadow_maps", "tfms", "grid_uploads", "attribute_uploads"))
                   for name, r in renderers.items()}
    finally:
        for r in list(renderers.values())[1:]:
            r.clear_maps()
        first.release()
    base, cpu_base = seconds["no emission"], cpu["no emission"]
    rows = [dict(case=name, seconds=s, ratio=s / base, rebuilt=rebuilt[name],
                 cpu_ratio=cpu[name] / cpu_base if cpu_gl else None) for name, s in seconds.items()]
    log(f"emission: {size.width}x{size.height}, {size.grid} grid: " +
        ", ".join(f"{r['case']} {r['seconds'] * 1e3:.1f} ms ({r['ratio']:.3f}x"
                  + (f", CPU {r['cpu_ratio']:.3f}x)" if r["cpu_ratio"] is not None else ")") for r in rows))
    return rows


def _side_by_side(frames: dict, repeats: int) -> tuple[dict[str, float], dict[str, float]]:
    """Median wall-clock and process CPU seconds of each frame, repetitions interleaved. On a GL
    that renders on this process's CPU threads (llvmpipe) the CPU seconds are the frame's work,
    which other jobs on a shared machine do not inflate as they do the wall clock."""
    wall: dict[str, list[float]] = {name: [] for name in frames}
    cpu: dict[str, list[float]] = {name: [] for name in frames}
    for _ in range(repeats):
        for name, frame in frames.items():
            t0, c0 = time.perf_counter(), time.process_time()
            frame()
            wall[name].append(time.perf_counter() - t0)
            cpu[name].append(time.process_time() - c0)
    return ({n: statistics.median(v) for n, v in wall.items()},
            {n: statistics.median(v) for n, v in cpu.items()})


def _color(medium):
    from ..scenes import color_grid_for

    return color_grid_for(medium.density)


def report(rows: list[dict]) -> str:
    cpu = all(r.get("cpu_ratio") is not None for r in rows)
    lines = ["# What emission costs a frame", "",
             "Fire scene lit by one spot, maps cached; median of interleaved repetitions"
             + (" (CPU ratio: process CPU seconds, this GL renders on the CPU)." if cpu else "."), "",
             "| case | ms per frame | ratio to no emission |" + (" CPU ratio |" if cpu else "")
             + " maps or grids rebuilt while timing |",
             "|---|---:|---:|" + ("---:|" if cpu else "") + "---:|"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['seconds'] * 1e3:.1f} | {r['ratio']:.3f} |"
                     + (f" {r['cpu_ratio']:.3f} |" if cpu else "") + f" {r['rebuilt']} |")
    emission = next(r["ratio"] for r in rows if r["case"] == "emission + blackbody")
    lines += ["", f"Target: emission adds at most 10 % to a frame: {'met' if emission <= 1.10 else 'missed'} "
              f"({100 * (emission - 1):+.1f} %; the colour grid and the constant emission are further rows, "
              "not part of the target)."]
    return "\n".join(lines)
