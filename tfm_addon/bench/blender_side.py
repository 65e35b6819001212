"""Cycles and EEVEE renders of an engine Scene, in a process of their own (``bpy`` and the
renderer's EGL context stay apart): ``python -m tfm_addon.bench.blender_side JOB.json``.

The job names a pickled Scene, the Cycles sample counts (each with its own seed), the ground
truth's sample count and the EEVEE runs (preset, TAA samples). Each render is timed around
``bpy.ops.render.render()`` alone, after an untimed warm-up render that loads Cycles' kernels or
compiles EEVEE's shaders. Writes <folder>/<name>.exr per render and results.json; prints
``STEP <label>`` after each render for the progress bar.
"""

from __future__ import annotations

import json
import pickle
import sys
import time
from pathlib import Path


def _render(path: Path) -> float:
    import bpy

    t0 = time.perf_counter()
    bpy.ops.render.render()
    seconds = time.perf_counter() - t0
    s = bpy.context.scene.render.image_settings
    s.file_format = "OPEN_EXR"
    s.color_depth = "32"
    s.color_mode = "RGBA"
    bpy.data.images["Render Result"].save_render(str(path))
    return seconds


def main(job_path: str) -> int:
    import bpy

    from . import blender_scene

    job = json.loads(Path(job_path).read_text())
    folder = Path(job["folder"])
    folder.mkdir(parents=True, exist_ok=True)
    with open(job["scene"], "rb") as f:
        scene = pickle.load(f)
    blender_scene.reset()
    blender_scene.build(scene, str(folder))
    results = {"blender": bpy.app.version_string, "threads": bpy.context.scene.render.threads,
               "renders": []}

    def step(label):
        print(f"STEP {label}", flush=True)

    runs = [(f"Cycles {n} spp", n, k + 1) for k, n in enumerate(job["cycles_samples"])]
    if job.get("cycles_gt_samples"):
        runs.append((f"Cycles {job['cycles_gt_samples']} spp (ground truth)", job["cycles_gt_samples"], 1000))
    if runs:
        blender_scene.cycles(1, seed=999)
        _render(folder / "warmup_cycles.exr")
    for name, samples, seed in runs:
        blender_scene.cycles(samples, seed=seed)
        seconds = _render(folder / f"{_file(name)}.exr")
        results["renders"].append(dict(name=name, engine="CYCLES", samples=samples, seconds=seconds,
                                       file=f"{_file(name)}.exr"))
        step(f"{name}: {seconds:.1f} s")

    for samples in job.get("cycles_denoised_samples", []):   # what a user renders: OIDN at its defaults
        name = f"Cycles {samples} spp + OIDN"
        blender_scene.cycles(samples, seed=1)
        if not any(r["engine"] == "CYCLES" for r in results["renders"]):
            _render(folder / "warmup_cycles.exr")
        c = bpy.context.scene.cycles
        c.use_denoising = True
        c.denoiser = "OPENIMAGEDENOISE"
        seconds = _render(folder / f"{_file(name)}.exr")
        results["renders"].append(dict(name=name, engine="CYCLES", samples=samples, seconds=seconds,
                                       file=f"{_file(name)}.exr", denoiser=c.denoiser,
                                       denoising_input_passes=c.denoising_input_passes,
                                       denoising_prefilter=c.denoising_prefilter))
        step(f"{name}: {seconds:.1f} s")

    for samples in job.get("cycles_adaptive_samples", []):    # Cycles' own adaptive sampling, its defaults
        name = f"Cycles {samples} spp adaptive"
        blender_scene.cycles(samples, seed=1)
        bpy.context.scene.cycles.use_adaptive_sampling = True
        seconds = _render(folder / f"{_file(name)}.exr")
        c = bpy.context.scene.cycles
        results["renders"].append(dict(name=name, engine="CYCLES", samples=samples, seconds=seconds,
                                       file=f"{_file(name)}.exr", adaptive_threshold=c.adaptive_threshold,
                                       adaptive_min_samples=c.adaptive_min_samples))
        step(f"{name}: {seconds:.1f} s")

    for preset, taa in job["eevee_runs"]:
        blender_scene.eevee(preset, scene)
        e = bpy.context.scene.eevee
        e.taa_render_samples = 1
        warm = _render(folder / "warmup_eevee.exr")       # shader compilation (not timed)
        e.taa_render_samples = int(taa)
        name = f"EEVEE {preset}, {taa} sample{'s' if taa > 1 else ''}"
        seconds = _render(folder / f"{_file(name)}.exr")
        results["renders"].append(dict(name=name, engine="EEVEE", preset=preset, samples=taa,
                                       seconds=seconds, warmup_seconds=warm, file=f"{_file(name)}.exr",
                                       settings={k: str(getattr(e, k)) for k in (
                                           "use_volumetric_shadows", "volumetric_tile_size",
                                           "volumetric_samples", "volumetric_shadow_samples",
                                           "use_volume_custom_range", "volumetric_start",
                                           "volumetric_end", "taa_render_samples")}))
        step(f"{name}: {seconds:.1f} s")
    (folder / "results.json").write_text(json.dumps(results, indent=1))
    return 0


def _file(name: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in name).strip("_")


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
