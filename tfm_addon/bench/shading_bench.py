"""What evaluating a volume node graph per voxel costs, and what the evaluated grid costs a frame.

``python -m tfm_addon.bench.shading_bench [--sizes 64 128 256]`` evaluates two five-node graphs
(engine/shading.py) over n³ lattices and prints seconds and nanoseconds per voxel:
- grid: Attribute density → Map Range (smooth step) → Power → Multiply → Principled Volume;
- procedural: Texture Coordinate (Object) → Noise (detail 2) → Map Range → Multiply → Principled.
Then it renders the procedural cloud at 320x180 twice in one process, as a uniform box (what a
graph the engine could not read rendered as before) and as the evaluated 128³ grid, and prints the
frame times and their ratio.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from ..engine import shading as S

L = S.Link


def _principled(density) -> S.Node:
    ins = [("Color", "RGBA", (0.8, 0.8, 0.8)), ("Density", "VALUE", density), ("Anisotropy", "VALUE", 0.0),
           ("Absorption Color", "RGBA", (0.0, 0.0, 0.0)), ("Emission Strength", "VALUE", 0.0),
           ("Emission Color", "RGBA", (1.0, 1.0, 1.0)), ("Blackbody Intensity", "VALUE", 0.0),
           ("Blackbody Tint", "RGBA", (1.0, 1.0, 1.0)), ("Temperature", "VALUE", 1000.0)]
    return S.Node("PRINCIPLED_VOLUME", (("density_attribute", ""),), tuple(S.Input(*i) for i in ins))


def grid_graph() -> S.ShaderGraph:
    return S.ShaderGraph((
        S.Node("ATTRIBUTE", (("name", "density"),)),
        S.Node("MAP_RANGE", (("interpolation_type", "SMOOTHSTEP"), ("clamp", True)), (
            S.Input("Value", "VALUE", L(0, "Fac")), S.Input("From Min", "VALUE", 0.1),
            S.Input("From Max", "VALUE", 0.7), S.Input("To Min", "VALUE", 0.0),
            S.Input("To Max", "VALUE", 1.0))),
        S.Node("MATH", (("operation", "POWER"), ("use_clamp", False)), (
            S.Input("A", "VALUE", L(1, "Result")), S.Input("B", "VALUE", 1.5))),
        S.Node("MATH", (("operation", "MULTIPLY"), ("use_clamp", False)), (
            S.Input("A", "VALUE", L(2, "Value")), S.Input("B", "VALUE", 4.0))),
        _principled(L(3, "Value"))), L(4, "Volume", "SHADER"))


def procedural_graph() -> S.ShaderGraph:
    return S.ShaderGraph((
        S.Node("TEX_COORD"),
        S.Node("TEX_NOISE", (("noise_type", "FBM"), ("normalize", True)), (
            S.Input("Vector", "VECTOR", L(0, "Object", "VECTOR")), S.Input("Scale", "VALUE", 1.5),
            S.Input("Detail", "VALUE", 2.0), S.Input("Roughness", "VALUE", 0.5),
            S.Input("Lacunarity", "VALUE", 2.0), S.Input("Distortion", "VALUE", 0.0))),
        S.Node("MAP_RANGE", (("interpolation_type", "LINEAR"), ("clamp", True)), (
            S.Input("Value", "VALUE", L(1, "Fac")), S.Input("From Min", "VALUE", 0.45),
            S.Input("From Max", "VALUE", 0.7), S.Input("To Min", "VALUE", 0.0),
            S.Input("To Max", "VALUE", 1.0))),
        S.Node("MATH", (("operation", "MULTIPLY"), ("use_clamp", False)), (
            S.Input("A", "VALUE", L(2, "Result")), S.Input("B", "VALUE", 4.0))),
        _principled(L(3, "Value"))), L(4, "Volume", "SHADER"))


def evaluation_times(sizes=(64, 128, 256)) -> list[tuple[str, int, float]]:
    """(graph, n, seconds) for each graph and lattice size."""
    rows = []
    rng = np.random.default_rng(0)
    for name, graph in (("grid", grid_graph()), ("procedural", procedural_graph())):
        for n in sizes:
            d = rng.random((n, n, n), dtype=np.float32)
            t0 = time.perf_counter()
            S.resolve(graph, {"density": d}, d.shape, np.diag([2.0 / n] * 3 + [1.0]))
            rows.append((name, n, time.perf_counter() - t0))
    return rows


def frame_times(n: int = 128, repeats: int = 3) -> tuple[float, float]:
    """Seconds a 320x180 frame of the procedural cloud takes as a uniform box and as the evaluated
    n³ grid (the best of ``repeats``, maps and textures built before timing)."""
    from dataclasses import replace

    from .. import scenes
    from ..engine import Medium, Renderer, RenderSettings

    base = scenes.smoke_scene(width=320, height=180, n=n, with_bar=False)
    to_object = np.diag([2.0 / n] * 3 + [1.0])
    to_object[:3, 3] = -1.0 + 1.0 / n
    r = S.resolve(procedural_graph(), {}, (n, n, n), to_object)
    index_to_world = np.asarray(base.media[0].index_to_world)
    grid = Medium(density=r.density, index_to_world=index_to_world, sigma_a=r.sigma_a, sigma_s=r.sigma_s)
    cube = np.diag([n / 2.0] * 3 + [1.0])      # [-1, 1]^3 onto the lattice's box [-0.5, n - 0.5]^3
    cube[:3, 3] = (n - 1) / 2.0
    mean = float(r.density.mean())              # the box at the grid's mean density
    box = Medium(sigma_a=tuple(mean * c for c in r.sigma_a), sigma_s=tuple(mean * c for c in r.sigma_s),
                 box_to_world=index_to_world @ cube)
    settings = RenderSettings(quality="CUSTOM", view_steps=128, light_steps=64, map_resolution=256,
                              coefficients=8)
    renderer = Renderer()
    out = []
    try:
        for medium in (box, grid):
            scene = replace(base, media=(medium,))
            renderer.render(scene, settings)
            best = min(_timed(renderer, scene, settings) for _ in range(repeats))
            out.append(best)
    finally:
        renderer.release()
    return out[0], out[1]


def _timed(renderer, scene, settings) -> float:
    t0 = time.perf_counter()
    renderer.render(scene, settings)
    return time.perf_counter() - t0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tfm_addon.bench.shading_bench", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", nargs="+", type=int, default=[64, 128, 256])
    parser.add_argument("--frame-grid", type=int, default=128)
    args = parser.parse_args(argv)
    print("| graph | lattice | seconds | ns per voxel |\n|---|---|---|---|")
    for name, n, seconds in evaluation_times(tuple(args.sizes)):
        print(f"| {name} | {n}³ | {seconds:.2f} | {seconds / n ** 3 * 1e9:.0f} |", flush=True)
    box, grid = frame_times(args.frame_grid)
    print(f"\nframe 320x180: uniform box {box:.3f} s, evaluated {args.frame_grid}³ grid {grid:.3f} s "
          f"(ratio {grid / box:.2f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
