"""What the benchmark's sections share: methods, ground truths, frame timing, images, CSV/Markdown."""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import json
import math
import subprocess
import sys
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..engine import Renderer, RenderSettings, Scene
from ..engine.exr import read_exr, write_exr
from ..engine.metrics import brightness_ratio, psnr, ssim
from ..engine.quality import auto_settings, medium_stats
from .config import Config

# Method families (one curve each on the speed-accuracy chart).
TFM_ALPHA = "TFM, density weighting (auto alpha)"
TFM_NO_ALPHA = "TFM, no density weighting"
TFM_EXACT = "TFM, auto alpha, EXACT filter"      # the other rows use the default, LINEAR
TFM_ALPHA10 = "TFM, alpha = 10 (the paper's)"
TFM_SSAA = "TFM, supersampled (k x k samples per pixel)"
AUTO = "auto quality"
BRUTE = "GPU brute force (double march)"
WORLD = "homogeneous, world-space samples"
PROJECTIVE = "homogeneous, projective samples"
CYCLES = "Cycles single scattering"
EEVEE = "EEVEE, volume shadows"
FLOOR = "floor: light transmittance 1 (UNSHADOWED)"

PAPER_STEPS = dict(view_steps=100, light_steps=100)


@dataclass(frozen=True)
class Method:
    name: str
    family: str
    settings: RenderSettings


def tfm_name(n: int, alpha: float | None) -> str:
    if alpha is None:
        return f"TFM-{n} α"
    if alpha == 1.0:
        return f"TFM-{n} no α"
    return f"TFM-{n} α={alpha:g}"


def auto_method(scene: Scene, base: RenderSettings) -> Method:
    s = auto_settings(scene, dataclasses.replace(base, quality="AUTO"))
    if scene.media and scene.media[0].density is None:
        label = f"auto ({s.sampling.lower()} {s.view_steps})"
    else:
        label = f"auto (TFM-{s.coefficients} α, {s.view_steps}x{s.light_steps})"
    return Method(label, AUTO, s)


def methods_for(scene: Scene, config: Config) -> list[Method]:
    """The method table's rows for one scene."""
    base = RenderSettings(map_resolution=config.map_resolution, **PAPER_STEPS)
    out = []
    if scene.media and scene.media[0].density is None:
        for sampling, family in (("WORLD", WORLD), ("PROJECTIVE", PROJECTIVE)):
            for n in config.homogeneous_steps:
                out.append(Method(f"{sampling.lower()} {n}", family,
                                  dataclasses.replace(base, sampling=sampling, view_steps=n)))
        out.append(Method("TFM-8 α (builds none)", TFM_ALPHA, base))
    else:
        for n in (2, 4, 8, 16):
            out.append(Method(tfm_name(n, None), TFM_ALPHA, dataclasses.replace(base, coefficients=n)))
        for n in (2, 4, 8, 16):
            out.append(Method(tfm_name(n, 1.0), TFM_NO_ALPHA,
                              dataclasses.replace(base, coefficients=n, density_weight=1.0)))
        out.append(Method("TFM-8 α EXACT", TFM_EXACT,
                          dataclasses.replace(base, coefficients=8, tfm_filter="EXACT")))
        for n in config.brute_force_steps:
            out.append(Method(f"brute force {n}x{n}", BRUTE,
                              dataclasses.replace(base, method="BRUTE_FORCE", view_steps=n, light_steps=n)))
        out.append(Method(FLOOR_100, FLOOR, dataclasses.replace(base, method="UNSHADOWED")))
    auto = auto_method(scene, base)
    out.append(auto)
    out.append(Method(FLOOR_AUTO, FLOOR, dataclasses.replace(auto.settings, method="UNSHADOWED",
                                                             quality="CUSTOM")))
    return out


FLOOR_100 = "floor, 100 steps"
FLOOR_AUTO = "floor, auto's steps"


def floor_ratio(row: dict, times: dict) -> float:
    """A row's frame time over the floor's (the same frame with light transmittance 1) at the
    same view steps: auto's floor for auto, the 100-step floor for the rest."""
    floor = times.get(FLOOR_AUTO if row["family"] == AUTO or row["method"] == FLOOR_AUTO else FLOOR_100)
    return row["seconds"] / floor if floor else float("nan")


# ------------------------------------------------------------------------------------------
# Ground truth
# ------------------------------------------------------------------------------------------

def scene_digest(scene: Scene) -> str:
    h = hashlib.blake2b(digest_size=12)
    cam = scene.camera
    parts = [cam.key, repr(scene.ambient)]
    parts += [light.key + repr((light.power_w, light.color, light.spot_blend, light.gobo_key))
              for light in scene.lights]
    parts += [m.key for m in scene.meshes]
    if scene.media:
        parts.append(scene.media[0].key)
    for p in parts:
        h.update(p.encode())
    return h.hexdigest()


def ground_truth_steps(scene: Scene, config: Config) -> tuple[int, int]:
    """(view, light) steps of the ground truth: one per voxel crossed by the longest ray
    (``config.gt_steps_per_voxel``), clamped; homogeneous media need view steps only."""
    stats = medium_stats(scene)
    if stats is None:
        return config.gt_min_steps, 1
    if scene.media[0].density is None:
        return config.gt_homogeneous_steps, 8

    def clamp(voxels):
        return int(min(config.gt_max_steps, max(config.gt_min_steps,
                                                 math.ceil(config.gt_steps_per_voxel * voxels))))
    return clamp(stats.view_voxels), clamp(stats.light_voxels)


@dataclass
class GroundTruth:
    image: np.ndarray          # (h, w, 3) linear
    name: str                  # what it is, for the tables
    seconds: float


def ground_truth(scene: Scene, config: Config, renderer: Renderer, cache_dir: Path | None,
                 steps: tuple[int, int] | None = None) -> GroundTruth:
    """The numpy double march (or, in a GPU run, the GPU brute force) at ``steps``
    (default ``ground_truth_steps``). Cached on disk by the scene's content."""
    from ..engine.reference import render_reference

    v, l = steps or ground_truth_steps(scene, config)
    kind = config.ground_truth
    name = f"{'numpy reference' if kind == 'numpy' else 'GPU brute force'} {v}x{l} steps"
    path = None
    if cache_dir is not None:
        path = cache_dir / f"gt_{kind.replace(' ', '_')}_{scene_digest(scene)}_{v}x{l}.exr"
        if path.exists():
            ch = read_exr(path)
            return GroundTruth(np.stack([ch[c] for c in "RGB"], axis=-1), name + " (cached)",
                               float("nan"))
    t0 = time.perf_counter()
    if kind == "numpy":
        image = render_reference(scene, view_steps=v, light_steps=l).rgb
    else:
        renderer.clear_maps()
        settings = RenderSettings(method="BRUTE_FORCE", view_steps=v, light_steps=l,
                                  map_resolution=config.map_resolution)
        image = renderer.render(scene, settings, passes=False).rgb
    seconds = time.perf_counter() - t0
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_exr(path, {c: image[:, :, i] for i, c in enumerate("RGB")})
    return GroundTruth(np.ascontiguousarray(image), name, seconds)


# ------------------------------------------------------------------------------------------
# Rendering and timing
# ------------------------------------------------------------------------------------------

def nudged(scene: Scene, offset_m: float = 1e-3) -> Scene:
    """The scene with every light moved by ``offset_m`` along x: its maps must be rebuilt."""
    lights = []
    for light in scene.lights:
        m = np.array(light.matrix_world)
        m[0, 3] += offset_m
        lights.append(dataclasses.replace(light, matrix_world=m))
    return dataclasses.replace(scene, lights=tuple(lights))


class FrameTimer:
    """Contenders for ``time_side_by_side`` that render one frame each as if the light moved:
    every call alternates between the scene and a copy whose lights moved by 1 mm, so shadow
    maps and TFMs are rebuilt while the density texture stays on the GPU (it is uploaded once
    per grid, not per frame). This is the frame time of the tables."""

    def __init__(self, renderer: Renderer, scene: Scene):
        self.renderer = renderer
        self.scenes = (scene, nudged(scene))
        self.k = 0

    def contender(self, settings: RenderSettings) -> Callable[[], object]:
        def go():
            self.k ^= 1
            return self.renderer.render(self.scenes[self.k], settings, passes=False)
        return go


def render_counted(renderer: Renderer, scene: Scene, settings: RenderSettings):
    """A full render from empty caches and what it built (renderer.counters difference)."""
    renderer.clear_maps()
    before = Counter(renderer.counters)
    out = renderer.render(scene, settings, passes=False)
    built = Counter(renderer.counters)
    built.subtract(before)
    return out, built


def compare(image: np.ndarray, reference: np.ndarray) -> dict:
    return dict(ssim=ssim(image, reference), psnr=psnr(image, reference),
                brightness=brightness_ratio(image, reference))


# ------------------------------------------------------------------------------------------
# Images
# ------------------------------------------------------------------------------------------

ERROR_SCALE = 0.1
"""Error images: |display(image) - display(reference)| (metrics' display convention), max over
RGB, black 0 to white ERROR_SCALE, through the 'inferno' colour map."""


def white_of(reference: np.ndarray) -> float:
    w = float(np.percentile(np.asarray(reference)[..., :3].max(axis=-1), 99.9))
    return w if w > 0 else 1.0


def display(image: np.ndarray, white: float) -> np.ndarray:
    """The metrics' display values: linear / white, clipped to [0, 1], gamma 1/2.2."""
    return np.clip(np.asarray(image, dtype=np.float64)[..., :3] / white, 0.0, 1.0) ** (1 / 2.2)


def safe_name(text: str) -> str:
    keep = "".join(c if c.isalnum() or c in "-_." else "_" for c in text.replace("α", "alpha"))
    return "_".join(filter(None, keep.split("_")))


def save_images(folder: Path, name: str, image: np.ndarray, reference: np.ndarray | None) -> None:
    """<name>.exr (linear RGB(A)) and .png (display); with a reference also <name>_error.exr
    (linear absolute difference) and _error.png (display difference, ERROR_SCALE = white).
    Without matplotlib (a bare GPU machine) only the EXR files are written."""
    try:
        import matplotlib.image
    except ImportError:
        matplotlib = None
    folder.mkdir(parents=True, exist_ok=True)
    base = safe_name(name)
    channels = {c: image[:, :, i] for i, c in enumerate("RGBA"[: image.shape[2]])}
    write_exr(folder / f"{base}.exr", channels)
    white = white_of(reference if reference is not None else image)
    if matplotlib is not None:
        matplotlib.image.imsave(folder / f"{base}.png", display(image, white))
    if reference is not None:
        diff = np.abs(image[..., :3] - reference[..., :3])
        write_exr(folder / f"{base}_error.exr", {c: diff[:, :, i] for i, c in enumerate("RGB")})
    if reference is not None and matplotlib is not None:
        err = np.abs(display(image, white) - display(reference, white)).max(axis=-1)
        matplotlib.image.imsave(folder / f"{base}_error.png", np.clip(err / ERROR_SCALE, 0, 1),
                                cmap="inferno", vmin=0.0, vmax=1.0)


# ------------------------------------------------------------------------------------------
# Tables
# ------------------------------------------------------------------------------------------

def write_csv(path: Path, rows: list[dict], columns: list[str]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: _csv_value(r.get(k)) for k in columns})


def _csv_value(v):
    if isinstance(v, float):
        return "" if math.isnan(v) else f"{v:.6g}"
    return "" if v is None else v


def fmt(v, spec: str) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "–"
    if isinstance(v, float) and math.isinf(v):
        return "∞"
    return format(v, spec)


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def machine_line(renderer: Renderer) -> str:
    import os
    import platform

    info = renderer.gl.ctx.info
    return (f"{info.get('GL_RENDERER', '?')} (OpenGL {info.get('GL_VERSION', '?')}), "
            f"{os.cpu_count()} CPU threads, {platform.processor() or platform.machine()}")


def run_child(code: str, args: list[str], env: dict, timeout: float = 3600) -> dict:
    """Run ``code`` in a fresh Python (``python -c code *args``) with ``env`` and return the JSON
    of its line ``RESULT {...}``; its output's tails in the error when it printed none."""
    done = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                          timeout=timeout, env=env)
    for line in done.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    raise RuntimeError(done.stdout[-3000:] + done.stderr[-3000:])
