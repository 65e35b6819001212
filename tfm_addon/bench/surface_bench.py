"""What shading a surface costs: the smoke scene's 8 m ground as a Lambertian surface, Blender's
default Principled BSDF, a metallic Principled BSDF, a Checker Texture (Generated coordinates) and
an Image Texture (UV, 256² sRGB bytes) into the Principled BSDF's Base Color, in one process.

``python -m tfm_addon.bench.surface_bench [--size 320 180] [--samples 16]`` prints the seconds of
a frame of ``samples`` antialiasing samples per surface (CPU seconds of the process, the best of
five taken in turns, maps built before) and the ratio to the Lambertian ground.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from ..engine import shading as S
from ..engine.surface import Surface

L = S.Link


def checker_graph() -> S.ShaderGraph:
    """Checker Texture (scale 4, its Vector unlinked: Generated) feeding the base colour."""
    node = S.Node("TEX_CHECKER", (), (S.Input("Color1", "RGBA", (0.9, 0.7, 0.3)),
                                      S.Input("Color2", "RGBA", (0.2, 0.2, 0.2)),
                                      S.Input("Scale", "VALUE", 4.0)))
    return S.ShaderGraph((node,), L(0, "Color", "RGBA"), texspace=((0.0, 0.0, 0.0), (0.5, 0.5, 0.001)))


def image_graph(size: int = 256) -> S.ShaderGraph:
    """Image Texture (UV map, linear interpolation, repeat) of a size² sRGB image."""
    rng = np.random.default_rng(0)
    pixels = np.concatenate([rng.random((size, size, 3)), np.ones((size, size, 1))], -1).astype(np.float32)
    S.register_image("bench", pixels, True)
    node = S.Node("TEX_IMAGE", (("image", "bench"), ("interpolation", "Linear"), ("extension", "REPEAT")))
    return S.ShaderGraph((node,), L(0, "Color", "RGBA"))


def surfaces() -> dict[str, Surface | None]:
    return {"Lambert": None, "Principled (default)": Surface(),
            "Principled metallic": Surface(base_color=(0.95, 0.64, 0.54), metallic=1.0, roughness=0.3),
            "Checker → Principled": Surface(base_texture=checker_graph()),
            "Image (UV) → Principled": Surface(base_texture=image_graph())}


def frame_times(width: int = 320, height: int = 180, samples: int = 16, repeats: int = 5,
                clock=time.process_time) -> dict[str, float]:
    """The best of ``repeats`` of each surface's frame, taken in turns (so that a busy moment of a
    shared machine falls on every surface alike), by ``clock`` (CPU seconds of the process: the
    GL's threads included)."""
    from .. import scenes
    from ..engine import Renderer, RenderSettings
    from ..engine.sampling import render_samples

    base = scenes.smoke_scene(width=width, height=height, n=64, with_bar=False)
    ground = base.meshes[0]
    uv = ((ground.vertices[ground.triangles][..., :2] + 0.5) * 4.0).astype(np.float32)
    settings = RenderSettings(quality="CUSTOM", view_steps=64, light_steps=64, map_resolution=256,
                              coefficients=8)
    scenes_by_name = {name: replace(base, meshes=(replace(ground, surface=surface, uv=uv),))
                      for name, surface in surfaces().items()}
    renderer = Renderer()
    best = dict.fromkeys(scenes_by_name, float("inf"))
    try:
        for scene in scenes_by_name.values():
            render_samples(renderer, scene, settings, samples, adaptive_threshold=None)
        for _ in range(repeats):
            for name, scene in scenes_by_name.items():
                t0 = clock()
                render_samples(renderer, scene, settings, samples, adaptive_threshold=None)
                best[name] = min(best[name], clock() - t0)
    finally:
        renderer.release()
    return best


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tfm_addon.bench.surface_bench", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", nargs=2, type=int, default=[320, 180])
    parser.add_argument("--samples", type=int, default=16)
    args = parser.parse_args(argv)
    times = frame_times(*args.size, samples=args.samples)
    lambert = times["Lambert"]
    size = f"{args.size[0]}x{args.size[1]}"
    print(f"| ground ({size}, {args.samples} samples) | CPU seconds | ratio to Lambert |")
    print("|---|---|---|")
    for name, seconds in times.items():
        print(f"| {name} | {seconds:.3f} | {seconds / lambert:.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
