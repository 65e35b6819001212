"""What emission costs a frame: the burning plume lit by a spot, rendered with and
without its emission, per kind of emission (Blender's Quick Fire material, a flame strength grid,
both), with and without a colour grid, side by side, maps built once beforehand.

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


CASES = (
    # (case, fire_scene kind, emission, colour grid, baseline: None for a baseline)
    ("no emission", "FIRE", False, False, None),
    ("flame strength", "EMISSION", True, False, "no emission"),
    ("emission + blackbody", "FIRE", True, False, "no emission"),
    ("constant emission", "CONSTANT", True, False, "no emission"),
    ("colour grid, no emission", "FIRE", False, True, None),
    ("emission + blackbody + colour grid", "FIRE", True, True, "colour grid, no emission"),
    ("Quick Fire, no emission", "QUICK_FIRE", False, False, None),
    ("Quick Fire (blackbody grid)", "QUICK_FIRE", True, False, "Quick Fire, no emission"),
    ("Quick Fire + colour grid, no emission", "QUICK_FIRE", False, True, None),
    ("Quick Fire + colour grid", "QUICK_FIRE", True, True, "Quick Fire + colour grid, no emission"),
)
"""The rows: each emitting frame's ratio is to its ``baseline``, the same frame without emission.
'FIRE' is the plume with a strength and a blackbody grid (combined per voxel beside the density:
one fetch a sample), 'EMISSION' its strength grid alone, 'QUICK_FIRE' Blender's Quick Smoke fire
material (blackbody grid alone), 'CONSTANT' a strength offset without grid."""


def _scene(size: Size, kind: str, emits: bool, colored: bool):
    base = "FIRE" if kind == "CONSTANT" else kind
    scene = fire_scene(size.width, size.height, size.grid, kind=base, with_light=True,
                       with_occluder=True, with_ground=True)
    m = scene.media[0]
    if not emits or kind == "CONSTANT":
        m = dataclasses.replace(m, emission_strength=GridValue(offset=0.3 if emits else 0.0),
                                blackbody_intensity=GridValue(offset=0.0))
    if colored:
        m = dataclasses.replace(m, grids={**m.grids, "color": _color(m)}, color_grid="color")
    return dataclasses.replace(scene, media=(m,))


def run(size: Size, log=print) -> list[dict]:
    """Median seconds per frame of the burning plume lit by a spot (``CASES``: emission kinds,
    with and without a colour grid) and
    each emitting frame's ratio to the same frame without emission (``_ratio``). Every map is built before
    the timing (a steady viewport frame: the emission needs no map, so it changes none)."""
    scenes = {name: _scene(size, kind, emits, colored) for name, kind, emits, colored, _ in CASES}
    settings = RenderSettings(map_resolution=size.map_resolution)
    first = Renderer()
    # One renderer (its own caches) per case on one GL context: a renderer keeps only what its
    # last frame used, so interleaving the cases on one would re-upload their grids every frame.
    renderers = {name: first if i == 0 else Renderer(gl=first.gl) for i, name in enumerate(scenes)}
    packed = {}
    try:
        for name in scenes:     # build maps and textures, compile shaders
            renderers[name].render(scenes[name], settings, passes=False)
            packed[name] = sorted({v for a in renderers[name]._attributes.items.values()
                                   for v, n in a.packed_passes.items() if n})
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
    rows = []
    for name, _, _, _, baseline in CASES:
        base = baseline or name
        rows.append(dict(case=name, seconds=statistics.median(seconds[name]), baseline=base,
                         ratio=_ratio(seconds, name, base),
                         cpu_ratio=_ratio(cpu, name, base) if cpu_gl else None,
                         rebuilt=rebuilt[name], packed=packed[name]))
    log(f"emission: {size.width}x{size.height}, {size.grid} grid: " +
        ", ".join(f"{r['case']} {r['seconds'] * 1e3:.1f} ms ({r['ratio']:.3f}x"
                  + (f", CPU {r['cpu_ratio']:.3f}x)" if r["cpu_ratio"] is not None else ")") for r in rows))
    return rows


EDITS = (("emission colour", lambda m, k: dict(emission_color=(1.0, 0.45 + 0.01 * k, 0.12))),
         ("emission strength", lambda m, k: dict(emission_strength=GridValue("flame", 4.0 + 0.1 * k, 0.0))),
         ("blackbody tint", lambda m, k: dict(blackbody_tint=(1.0, 0.9 - 0.005 * k, 0.8))))
"""The edits an artist makes to a burning plume's material, each the k-th of a drag."""


def edit_rows(size: Size, log=print) -> list[dict]:
    """What an emission edit costs beside a camera move (the target: at most 1.05x), on the fire
    with both grids (its emission combined per voxel, so an edit recomputes that combination):
    frames after a small camera move and frames after each edit of ``EDITS``, interleaved on one
    renderer. The medium carries a ``source_key``, as the Blender side gives it, so an edit
    hashes no grid (a medium made by code without one is hashed whole when it changes)."""
    from .speed import _moved_camera

    scene = _scene(size, "FIRE", True, False)
    scene = dataclasses.replace(scene, media=(dataclasses.replace(scene.media[0], source_key="bench plume"),))
    settings = RenderSettings(map_resolution=size.map_resolution)
    renderer = Renderer()
    state = {"scene": scene, "k": 0}

    def camera():
        state["k"] += 1
        renderer.render(_moved_camera(state["scene"], state["k"]), settings, passes=False)

    def edit(change):
        def go():
            state["k"] += 1
            m = state["scene"].media[0]
            m = dataclasses.replace(m, **change(m, state["k"]))
            state["scene"] = dataclasses.replace(state["scene"], media=(m,))
            renderer.render(state["scene"], settings, passes=False)
        return go

    try:
        renderer.render(scene, settings, passes=False)
        before = dict(renderer.counters)
        frames = {"camera move": camera, **{name: edit(change) for name, change in EDITS}}
        seconds, cpu = _side_by_side(frames, size.repeats)
        rebuilt = sum(renderer.counters[k] - before.get(k, 0)
                      for k in ("shadow_maps", "tfms", "grid_uploads", "attribute_uploads"))
        (attributes,) = renderer._attributes.items.values()
        cpu_gl = "llvmpipe" in str(renderer.gl.ctx.info.get("GL_RENDERER", "")).lower()
        rows = [dict(case=name, seconds=statistics.median(seconds[name]),
                     ratio=_ratio(seconds, name, "camera move"),
                     cpu_ratio=_ratio(cpu, name, "camera move") if cpu_gl else None,
                     rebuilt=rebuilt, combines=attributes.combines) for name in frames]
    finally:
        renderer.release()
    log("emission edits: " + ", ".join(f"{r['case']} {r['seconds'] * 1e3:.1f} ms ({r['ratio']:.3f}x)"
                                       for r in rows))
    return rows


def edit_report(rows: list[dict]) -> str:
    cpu = all(r.get("cpu_ratio") is not None for r in rows)
    lines = ["## An emission edit beside a camera move", "",
             "The fire with a strength and a blackbody grid (combined per voxel: an edit recomputes "
             "the combination over the emission's box), frames after a camera move and after each "
             "edit interleaved on one renderer; ratio to the camera move, the median of the rounds' "
             "ratios. Target: at most 1.05.", "",
             "| frame after | ms | ratio to a camera move |" + (" CPU ratio |" if cpu else ""),
             "|---|---:|---:|" + ("---:|" if cpu else "")]
    for r in rows:
        lines.append(f"| {r['case']} | {r['seconds'] * 1e3:.1f} | {r['ratio']:.3f} |"
                     + (f" {r['cpu_ratio']:.3f} |" if cpu else ""))
    lines += ["", f"Maps or grids rebuilt while timing: {rows[0]['rebuilt']}; combinations computed "
              f"(one at the first frame, one per edit): {rows[0]['combines']}."]
    return "\n".join(lines)


def _side_by_side(frames: dict, repeats: int) -> tuple[dict[str, list[float]], dict[str, list[float]]]:
    """Wall-clock and process CPU seconds of each frame per round, the frames interleaved (in
    reverse order every other round, so that no frame always follows the same one). On a GL that
    renders on this process's CPU threads (llvmpipe) the CPU seconds are the frame's work, which
    other jobs on a shared machine do not inflate as they do the wall clock."""
    wall: dict[str, list[float]] = {name: [] for name in frames}
    cpu: dict[str, list[float]] = {name: [] for name in frames}
    for k in range(repeats):
        for name, frame in (list(frames.items()) if k % 2 == 0 else list(frames.items())[::-1]):
            t0, c0 = time.perf_counter(), time.process_time()
            frame()
            wall[name].append(time.perf_counter() - t0)
            cpu[name].append(time.process_time() - c0)
    return wall, cpu


def _ratio(times: dict[str, list[float]], name: str, base: str) -> float:
    """Median over the rounds of the frame's time over its baseline's in the same round: a load
    that changes between rounds cancels."""
    return statistics.median(a / b for a, b in zip(times[name], times[base], strict=True))


def _color(medium):
    from ..scenes import color_grid_for

    return color_grid_for(medium.density)


READ = {0: "own texture", 1: "attributes' R", 3: "colour grid's A"}
TARGET_ROWS = ("Quick Fire (blackbody grid)", "flame strength", "emission + blackbody")


def report(rows: list[dict]) -> str:
    cpu = all(r.get("cpu_ratio") is not None for r in rows)
    lines = ["# What emission costs a frame", "",
             "Burning plume lit by one spot, maps cached; medians of interleaved repetitions; each "
             "ratio to the row named (the same frame without emission), the median of the ratios "
             "of the two frames in each round"
             + ("; CPU ratio: process CPU seconds (this GL renders on the CPU)." if cpu else "."), "",
             "| case | density read from | ms per frame | ratio | to |" + (" CPU ratio |" if cpu else "")
             + " maps or grids rebuilt while timing |",
             "|---|---|---:|---:|---|" + ("---:|" if cpu else "") + "---:|"]
    for r in rows:
        read = ", ".join(READ[v] for v in r.get("packed") or [0])
        lines.append(f"| {r['case']} | {read} | {r['seconds'] * 1e3:.1f} | {r['ratio']:.3f} |"
                     f" {r['baseline'] if r['baseline'] != r['case'] else '-'} |"
                     + (f" {r['cpu_ratio']:.3f} |" if cpu else "") + f" {r['rebuilt']} |")
    verdicts = []
    for r in rows:
        if r["case"] in TARGET_ROWS:
            ratios = [r["ratio"]] + ([r["cpu_ratio"]] if cpu else [])
            verdicts.append(f"{r['case']} {'met' if max(ratios) <= 1.10 else 'missed'} ("
                            + ", ".join(f"{100 * (x - 1):+.1f} %" for x in ratios) + ")")
    lines += ["", "Target: emission adds at most 10 % to a frame"
              + (" (wall clock, CPU)" if cpu else "") + ": "
              + "; ".join(verdicts) + ". The colour grid, two-fetch and constant emission rows are "
              "further rows, not part of the target ('grids apart': the fire before its two grids were "
              "combined per voxel)."]
    return "\n".join(lines)
