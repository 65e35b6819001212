"""Priority 1: every method on every scene, frame time against SSIM/PSNR to the ground truth."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from ..engine import Light, Renderer, RenderSettings
from ..scenes import look_at
from .common import (
    BRUTE,
    FrameTimer,
    Method,
    compare,
    floor_ratio,
    fmt,
    ground_truth,
    markdown_table,
    methods_for,
    render_counted,
    save_images,
    write_csv,
)
from .config import Config
from .progress import Progress
from .scene_set import BenchScene
from .timing import time_side_by_side

COLUMNS = ["scene", "method", "family", "seconds", "fps", "speedup_vs_bf100", "vs_floor", "ssim", "psnr",
           "brightness", "reference", "tfms_built", "shadow_maps_built", "coefficients",
           "density_weight", "view_steps", "light_steps", "sampling", "tfm_filter", "width", "height",
           "grid"]


def count(config: Config, scenes: list[BenchScene]) -> int:
    """Progress steps: per scene the ground truth, each method's render, the timing."""
    return sum(2 + len(methods_for(s.scene, config)) for s in scenes)


def run(config: Config, scenes: list[BenchScene], renderer: Renderer, out: Path, progress: Progress,
        cache: Path | None) -> tuple[list[dict], dict]:
    """Rows of the method table and the ground truths by scene key."""
    rows: list[dict] = []
    truths = {}
    for bs in scenes:
        scene = bs.scene
        progress.note(f"{bs.key}: ground truth")
        gt = ground_truth(scene, config, renderer, cache)
        truths[bs.key] = gt
        progress.step(f"{bs.key}: ground truth ({gt.name})")
        folder = out / "images" / bs.key
        save_images(folder, "ground_truth", gt.image, None)
        methods = methods_for(scene, config)
        built = {}
        for m in methods:
            image, counters = render_counted(renderer, scene, m.settings)
            built[m.name] = counters
            metrics = compare(image.rgb, gt.image)
            save_images(folder, m.name, image.combined, gt.image)
            rows.append(_row(bs, m, metrics, counters, gt.name))
            progress.step(f"{bs.key}: {m.name} SSIM {metrics['ssim']:.4f}")
        progress.note(f"{bs.key}: timing {len(methods)} methods x {config.repeats}")
        timer = FrameTimer(renderer, scene)
        times = time_side_by_side({m.name: timer.contender(m.settings) for m in methods}, config.repeats)
        progress.step(f"{bs.key}: timed")
        scene_rows = [r for r in rows if r["scene"] == bs.key]
        bf100 = times.get("brute force 100x100")
        for r in scene_rows:
            r["seconds"] = times[r["method"]]
            r["fps"] = 1.0 / r["seconds"]
            r["speedup_vs_bf100"] = bf100 / r["seconds"] if bf100 else float("nan")
            r["vs_floor"] = floor_ratio(r, times)
    return rows, truths


def _row(bs: BenchScene, m: Method, metrics: dict, counters, reference: str) -> dict:
    s = m.settings
    return dict(scene=bs.key, scene_title=bs.title, method=m.name, family=m.family,
                ssim=metrics["ssim"], psnr=metrics["psnr"], brightness=metrics["brightness"],
                reference=reference, tfms_built=int(counters["tfms"]),
                shadow_maps_built=int(counters["shadow_maps"]),
                coefficients=s.coefficients if s.method == "TFM" else None,
                density_weight=("auto" if s.density_weight is None else s.density_weight)
                if s.method == "TFM" else None,
                view_steps=s.view_steps, light_steps=s.light_steps, sampling=s.sampling,
                tfm_filter=s.tfm_filter, method_kind=s.method, width=bs.scene.camera.width_px,
                height=bs.scene.camera.height_px, grid=bs.grid_text())


def counter_checks(config: Config, scenes: list[BenchScene], renderer: Renderer) -> list[dict]:
    """What the renderer built for one frame: a light that misses the medium and a homogeneous
    medium build no TFM (the renderer's counters, not timings)."""
    out = []
    settings = RenderSettings(map_resolution=config.map_resolution, coefficients=8)
    for bs in scenes:
        scene = bs.scene
        cases = [(bs.title, scene)]
        if not bs.homogeneous:
            away = Light(matrix_world=look_at((30.0, 30.0, 6.0), (40.0, 40.0, 0.0)), power_w=500.0,
                             spot_size_rad=math.radians(30), name="Away")
            cases.append((bs.title + " + a spot aimed away from it",
                          dataclasses.replace(scene, lights=scene.lights + (away,))))
        for title, sc in cases:
            _, counters = render_counted(renderer, sc, settings)
            out.append(dict(scene=title, lights=len(sc.lights), tfms=int(counters["tfms"]),
                            shadow_maps=int(counters["shadow_maps"]),
                            light_passes=int(counters["light_passes"]),
                            grid_uploads=int(counters["grid_uploads"])))
    return out


def write(rows: list[dict], checks: list[dict], scenes: list[BenchScene], out: Path, config: Config,
          machine: str) -> str:
    write_csv(out / "results.csv", rows, COLUMNS)
    write_csv(out / "counters.csv", checks, ["scene", "lights", "tfms", "shadow_maps", "light_passes",
                                             "grid_uploads"])
    lines = [f"# Method table ({config.name} run)", "", f"Machine: {machine}.", "",
             "Frame time: median of interleaved repetitions of one frame as if the light moved "
             "(shadow maps and TFMs rebuilt, the density texture kept on the GPU). SSIM/PSNR: "
             "`tfm_addon.engine.metrics` against the ground truth named per scene. "
             "Speed-up: against the 100x100 brute force of the same run. / floor: the frame time over "
             "the floor's (method UNSHADOWED, light transmittance 1, the same view steps: auto's for "
             "auto, 100 for the rest), the light-side overhead.", ""]
    for note in config.caps:
        lines.append(f"- Capped: {note}")
    lines.append("")
    for bs in scenes:
        srows = [r for r in rows if r["scene"] == bs.key]
        if not srows:
            continue
        lines += [f"## {bs.title}", "", f"{bs.description}. {srows[0]['width']}x{srows[0]['height']} "
                  f"pixels, {config.map_resolution}^2 maps. Ground truth: {srows[0]['reference']}.", ""]
        table = [[r["method"], fmt(r["seconds"] * 1000, ".0f"), fmt(r["fps"], ".2f"),
                  fmt(r.get("speedup_vs_bf100"), ".2f") + ("x" if r.get("speedup_vs_bf100") else ""),
                  fmt(r.get("vs_floor"), ".2f"),
                  fmt(r["ssim"], ".4f"), fmt(r["psnr"], ".1f"), fmt(r["brightness"], ".3f"),
                  str(r["tfms_built"])] for r in srows]
        lines += [markdown_table(["method", "ms/frame", "fps", "vs BF 100²", "/ floor", "SSIM", "PSNR dB",
                                  "brightness", "TFMs built"], table), ""]
    lines += ["## What each frame built (renderer counters)", "",
              markdown_table(["scene", "lights", "TFMs", "shadow maps", "light passes", "grid uploads"],
                             [[c["scene"], str(c["lights"]), str(c["tfms"]), str(c["shadow_maps"]),
                               str(c["light_passes"]), str(c["grid_uploads"])] for c in checks]), ""]
    text = "\n".join(lines)
    (out / "results.md").write_text(text + "\n")
    return text


def best_of(rows: list[dict], scene: str, family: str = BRUTE) -> list[dict]:
    return [r for r in rows if r["scene"] == scene and r["family"] == family]
