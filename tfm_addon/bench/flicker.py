"""Flicker over a frame sequence: how much the parts of the image that the scene does not change
move from one frame to the next, TFM at its defaults against Cycles with OpenImageDenoise.

``python -m tfm_addon.bench --only flicker`` renders a sequence of an evolving smoke made by code
(``sequence``: one puff turning into another while it thickens, the optical depth along the
light rising from about 6 to 15, as a simulation's frames do), each frame by:

- TFM Auto at 16 samples (the add-on's defaults), recording Auto's choices (view and light steps,
  coefficients) frame by frame: a choice that changes between frames is a pop;
- TFM Custom 400/400/16 at 16 samples: the scene's own change from frame to frame (no noise, the
  most accurate settings), which defines the still pixels: the lit ones (``LIT`` of the white or
  more) it changes by less than ``STILL`` of the white;
- Cycles + OpenImageDenoise at 16 samples (Blender's default seed, the same every frame), whose
  frame-to-frame change in the still pixels is its noise.

The flicker figure of an engine is the mean absolute change between consecutive frames over the
still pixels, in units of the white (the 99.9th percentile of the Custom frame's brightest channel).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from .. import scenes
from ..engine import quality
from ..engine.renderer import Renderer
from ..engine.sampling import render_samples
from ..engine.scene import RenderSettings, Scene

FRAMES = 10
SIZE = (160, 90)
VOXELS = 96
STILL = 0.002          # a pixel the scene changes by less than this (of the white) is still ...
LIT = 0.02             # ... and counts where it is this bright (an empty pixel flickers in no engine)
SAMPLES = 16
CUSTOM = RenderSettings(view_steps=400, light_steps=400, coefficients=16, map_resolution=1024,
                        tfm_resolution="FOOTPRINT")


def sequence(frames: int = FRAMES, size: tuple[int, int] = SIZE, n: int = VOXELS) -> list[Scene]:
    """The paper's smoke set-up (a spot through a puff, a ground) whose puff turns into another
    one while it thickens, ``frames`` frames."""
    first, last = scenes.smoke_density(n, seed=1), scenes.smoke_density(n, seed=2)
    base = scenes.paper_smoke_scene(*size, n)
    out = []
    for f in range(frames):
        a = f / max(frames - 1, 1)
        density = (((1.0 - a) * first + a * last) * (4.0 + 6.0 * a)).astype(np.float32)
        out.append(dataclasses.replace(base, media=(dataclasses.replace(base.media[0], density=density),)))
    return out


def white(image: np.ndarray) -> float:
    return float(np.percentile(np.asarray(image)[..., :3].max(axis=-1), 99.9))


def still_pixels(truth: list[np.ndarray], still: float = STILL) -> list[np.ndarray]:
    """Per pair of consecutive frames, the lit pixels (at least LIT of the white) the scene changes
    by less than ``still`` of the white (every channel)."""
    return [(np.abs(b[..., :3] - a[..., :3]).max(axis=-1) < still * white(b))
            & (b[..., :3].max(axis=-1) >= LIT * white(b)) for a, b in zip(truth, truth[1:], strict=False)]


def flicker(images: list[np.ndarray], truth: list[np.ndarray], still: float = STILL) -> float:
    """The mean absolute change between consecutive ``images`` over the pixels ``truth`` keeps
    still, in units of the truth's white."""
    pairs = zip(images, images[1:], truth[1:], still_pixels(truth, still), strict=False)
    changes = [np.abs(b[..., :3] - a[..., :3]).mean(axis=-1)[mask] / white(t) for a, b, t, mask in pairs]
    values = np.concatenate([c for c in changes if c.size]) if changes else np.zeros(0)
    return float(values.mean()) if values.size else float("nan")


def run(out: Path, quick: bool = False) -> dict:
    """Render the sequence with TFM (Auto, Custom) and Cycles + OIDN; the figures and the choices."""
    from .peers import PeerConfig, _blender_runs, _load

    frames = sequence(frames=4 if quick else FRAMES)
    folder = out / "flicker"
    folder.mkdir(parents=True, exist_ok=True)
    renderer = Renderer()
    auto = RenderSettings(quality="AUTO", film_transparent=True)
    custom = dataclasses.replace(CUSTOM, film_transparent=True)
    tfm, truth, cycles, choices = [], [], [], []
    config = PeerConfig(sizes=(), cycles_gt_samples=0, eevee_samples=())
    for k, scene in enumerate(frames):
        chosen = quality.auto_settings(scene, auto)
        choices.append((chosen.view_steps, chosen.light_steps, chosen.coefficients))
        tfm.append(render_samples(renderer, scene, auto, SAMPLES).combined[..., :3].copy())
        truth.append(render_samples(renderer, scene, custom, SAMPLES).combined[..., :3].copy())
        runs = _blender_runs(scene, folder / f"frame_{k:02d}", config, [SAMPLES], gt=False)
        entry = next(r for r in runs["renders"] if "OIDN" in r["name"])
        cycles.append(_load(folder / f"frame_{k:02d}", entry["file"])[..., :3])
    still = still_pixels(truth)
    results = {"frames": len(frames), "size": list(SIZE), "samples": SAMPLES,
               "still_share": float(np.mean([m.mean() for m in still])),
               "tfm_auto": flicker(tfm, truth), "cycles_oidn": flicker(cycles, truth),
               "choices": choices, "pops": sum(a != b for a, b in zip(choices, choices[1:], strict=False))}
    (folder / "results.json").write_text(json.dumps(results, indent=1))
    return results


def summarise(results: dict) -> str:
    ratio = results["tfm_auto"] / results["cycles_oidn"] if results["cycles_oidn"] > 0 else float("nan")
    choices = ", ".join(f"{v}/{li}/{c}" for v, li, c in results["choices"])
    return (f"Flicker over {results['frames']} frames of an evolving smoke at {results['size'][0]}x"
            f"{results['size'][1]}, {results['samples']} samples, in the {results['still_share']:.0%} of "
            f"pixels the scene keeps still: TFM Auto {results['tfm_auto']:.5f} of the white from frame to "
            f"frame, Cycles + OpenImageDenoise {results['cycles_oidn']:.5f} ({ratio:.2f}x). Auto's "
            f"choices (view steps / light steps / coefficients) by frame: {choices}; "
            f"{results['pops']} change{'s' if results['pops'] != 1 else ''}.")


def publish(results: dict, quick: bool) -> None:
    """Print the figure; a full run writes it into the README (its ``flicker`` marks)."""
    from . import readme

    text = summarise(results)
    print(text)
    if not quick:
        readme.write_block("flicker", text)
