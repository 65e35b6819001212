"""Frame time against the number of lights (spot, point, sun) and of volumes.

Every frame is rendered from scratch (maps dropped first) so that its time holds the maps it
builds; the counters say how many maps (shadow maps and TFMs, per light face) that was. Times are
medians of interleaved repetitions in one run; the report divides them by the one-light (one
volume) frame and by the maps built, so that "cost grows at most linearly in the maps" reads off
the last column.
"""

from __future__ import annotations

import dataclasses
import math

from ..engine import Light, Medium, Renderer, RenderSettings, Scene
from ..scenes import grid_to_world, look_at, plane_mesh, smoke_density, smoke_scene, translate_scale
from .renderer_bench import Size  # width, height, grid, map_resolution, repeats
from .timing import time_side_by_side

FULL = Size(320, 180, 64, 256, 3)
QUICK = Size(48, 27, 16, 32, 1)
PAPER = Size(1280, 720, 128, 1024, 3)
LIGHT_COUNTS = (1, 2, 4, 8)
VOLUME_COUNTS = (1, 2, 4)


def _lights(kind: str, n: int) -> tuple[Light, ...]:
    """``n`` lights of one kind around the smoke, their power shared so the image stays alike."""
    out = []
    for i in range(n):
        a = 2 * math.pi * i / n
        eye = (3.5 * math.cos(a), 3.5 * math.sin(a) - 1.0, 4.0)
        if kind == "POINT":
            m = translate_scale((0.5 * math.cos(a), 0.5 * math.sin(a), 1.4), 1.0)   # inside the smoke
            out.append(Light(matrix_world=m, power_w=600.0 / n, kind="POINT", name=f"Point{i}"))
        elif kind == "SUN":
            out.append(Light(matrix_world=look_at(eye, (0, 0, 1.0)), power_w=3.0 / n, kind="SUN",
                             name=f"Sun{i}"))
        else:
            out.append(Light(matrix_world=look_at(eye, (0, 0, 1.0)), power_w=2000.0 / n,
                             spot_size_rad=math.radians(40), spot_blend=0.2, name=f"Spot{i}"))
    return tuple(out)


def _volumes(size: Size, n: int) -> tuple[Medium, ...]:
    """``n`` distinct smoke grids side by side."""
    out = []
    for i in range(n):
        x = (i - (n - 1) / 2) * 1.4
        d = smoke_density(size.grid, seed=1 + i)
        out.append(Medium(sigma_a=(0.2,) * 3, sigma_s=(2.0,) * 3, density=d,
                          index_to_world=grid_to_world(d.shape, 1.4, (x, 0.0, 1.1)), name=f"Smoke{i}"))
    return tuple(out)


def run(size: Size, log=print) -> list[dict]:
    """Rows: case ('lights' or 'volumes'), kind, count, seconds per frame, maps built per frame."""
    base = smoke_scene(width=size.width, height=size.height, n=size.grid, with_bar=False)
    settings = RenderSettings(view_steps=100, light_steps=100, coefficients=8,
                              map_resolution=size.map_resolution)
    renderer = Renderer()
    cases = {}
    for kind in ("SPOT", "POINT", "SUN"):
        for n in LIGHT_COUNTS:
            cases[("lights", kind, n)] = dataclasses.replace(base, lights=_lights(kind, n))
    for n in VOLUME_COUNTS:
        cases[("volumes", "SPOT", n)] = Scene(camera=base.camera, lights=_lights("SPOT", 1),
                                             media=_volumes(size, n), meshes=(plane_mesh((0, 0, 0), 8.0),))
    maps = {}

    def frame(key):
        def go():
            renderer.clear_maps()
            before = renderer.counters["tfms"] + renderer.counters["shadow_maps"]
            renderer.render(cases[key], settings, passes=False)
            maps[key] = renderer.counters["tfms"] + renderer.counters["shadow_maps"] - before
        return go

    for key in cases:            # compiles every program variant first
        frame(key)()
    log(f"lights bench: {len(cases)} frames x {size.repeats} at {size.width}x{size.height}")
    times = time_side_by_side({key: frame(key) for key in cases}, size.repeats)
    renderer.release()
    return [dict(case=c, kind=k, count=n, seconds=times[(c, k, n)], maps=maps[(c, k, n)])
            for (c, k, n) in cases]


def report(rows: list[dict]) -> str:
    """A markdown table: time and maps against the first row of each group."""
    lines = ["## Frame time against lights and volumes", "",
             "Each frame rebuilt from scratch (its maps included); ratios against the first row of "
             "its group, measured in one run.", "",
             "| case | kind | count | s/frame | time ratio | maps built | maps ratio | time / maps ratio |",
             "|---|---|---|---|---|---|---|---|"]
    first = {}
    for r in rows:
        g = (r["case"], r["kind"])
        first.setdefault(g, r)
        f = first[g]
        t_ratio = r["seconds"] / max(f["seconds"], 1e-12)
        m_ratio = r["maps"] / max(f["maps"], 1)
        lines.append(f"| {r['case']} | {r['kind'].lower()} | {r['count']} | {r['seconds']:.3f} | "
                     f"{t_ratio:.2f} | {r['maps']} | {m_ratio:.2f} | {t_ratio / max(m_ratio, 1e-12):.2f} |")
    return "\n".join(lines)


def linear_in_maps(rows: list[dict]) -> bool:
    """Whether every group's time ratio stays within its maps ratio (at most linear growth)."""
    first = {}
    ok = True
    for r in rows:
        f = first.setdefault((r["case"], r["kind"]), r)
        ok &= bool(r["seconds"] / max(f["seconds"], 1e-12) <= max(r["maps"] / max(f["maps"], 1), 1.0) * 1.1)
    return ok

