"""The renderer against brute force and the numpy ground truth on the smoke scene: full frames and
camera-only re-renders."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from ..engine import Renderer, RenderSettings, Scene
from ..engine.metrics import psnr, ssim
from ..engine.reference import render_reference
from ..scenes import look_at, paper_smoke_scene
from .timing import time_side_by_side


@dataclass(frozen=True)
class Size:
    width: int
    height: int
    grid: int
    map_resolution: int
    repeats: int
    numpy_reference: bool = True


FULL = Size(320, 180, 128, 256, 3)
QUICK = Size(64, 36, 32, 64, 1)
PAPER = Size(1280, 720, 128, 1024, 5, numpy_reference=False)
"""The paper's set-up (1280x720, 1024^2 maps): for a GPU; brute force is the reference there."""


def run(size: Size, log=print) -> list[dict]:
    """Rows of method, seconds per frame, SSIM and PSNR against the numpy reference, and the
    camera-only against full re-render times."""
    scene = paper_smoke_scene(width=size.width, height=size.height, n=size.grid)
    renderer = Renderer()
    log(f"{renderer.gl.ctx.info['GL_RENDERER']}: {size.width}x{size.height}, {size.grid}^3 smoke, "
        f"{size.map_resolution}^2 maps")
    steps = dict(view_steps=100, light_steps=100, map_resolution=size.map_resolution)
    methods = {f"TFM-{n}": RenderSettings(coefficients=n, **steps) for n in (4, 8, 16)}
    methods["brute force 100x100"] = RenderSettings(method="BRUTE_FORCE", **steps)

    def full(settings):
        def go():
            renderer.clear_maps()
            return renderer.render(scene, settings, passes=False)
        return go

    images = {name: full(s)() for name, s in methods.items()}           # compiles the shaders
    times = time_side_by_side({name: full(s) for name, s in methods.items()}, size.repeats)
    if size.numpy_reference:
        log("numpy reference, 100x100 steps ...")
        t0 = time.perf_counter()
        ref = render_reference(scene, view_steps=100, light_steps=100).rgb
        ref_name = "numpy reference (CPU)"
        ref_s = time.perf_counter() - t0
    else:
        ref_name = "brute force 100x100"
        ref, ref_s = images[ref_name].rgb, times[ref_name]
    rows = [dict(method=name, seconds=times[name], ssim=ssim(img.rgb, ref), psnr=psnr(img.rgb, ref))
            for name, img in images.items() if name != ref_name]
    rows.append(dict(method=ref_name, seconds=ref_s, ssim=1.0, psnr=float("inf")))

    # Camera-only re-render: the maps stay; a full render rebuilds them.
    tfm8 = methods["TFM-8"]
    cams = [_moved(scene, k) for k in range(2)]
    state = {"k": 0}

    def camera_only():
        state["k"] ^= 1
        return renderer.render(cams[state["k"]], tfm8, passes=False)

    renderer.render(cams[0], tfm8)
    t = time_side_by_side({"full": full(tfm8), "camera-only": camera_only}, max(size.repeats, 3))
    rows.append(dict(method="TFM-8 camera-only re-render", seconds=t["camera-only"], ssim=float("nan"),
                     psnr=float("nan"), full_seconds=t["full"]))
    renderer.release()
    return rows


def _moved(scene: Scene, k: int) -> Scene:
    eye = np.array([0.0, -2.6, 1.3]) + np.array([0.2, 0.0, 0.1]) * (k + 1)
    cam = dataclasses.replace(scene.camera, matrix_world=look_at(eye, (0, 0, 1.2)))
    return dataclasses.replace(scene, camera=cam)


def report(rows: list[dict]) -> str:
    """A Markdown table with the ratios the targets ask for."""
    by = {r["method"]: r for r in rows}
    bf = by["brute force 100x100"]["seconds"]
    ref = next(r["method"] for r in rows if r["ssim"] == 1.0)
    lines = [f"SSIM and PSNR against: {ref}.", "",
             "| method | s/frame | fps | speed-up vs brute force | SSIM | PSNR dB |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        if "full_seconds" in r:
            continue
        lines.append(f"| {r['method']} | {r['seconds']:.4f} | {1 / r['seconds']:.1f} | "
                     f"{bf / r['seconds']:.1f}x | {r['ssim']:.4f} | {r['psnr']:.1f} |")
    cam = by["TFM-8 camera-only re-render"]
    tfm8 = by["TFM-8"]
    lines += ["", f"TFM-8: {bf / tfm8['seconds']:.1f}x faster than brute force (target >= 15x) at SSIM "
              f"{tfm8['ssim']:.4f} (target >= 0.99).",
              f"Camera-only re-render: {cam['seconds']:.3f} s against {cam['full_seconds']:.3f} s for a full "
              f"one = {cam['seconds'] / cam['full_seconds']:.2f}x (target <= 0.6x)."]
    return "\n".join(lines)
