"""The README's two charts, small PNGs under docs/:

    python -m tfm_addon.bench.readme_figures side-by-side FOLDER [--out docs/tfm_cycles_eevee.png]
    python -m tfm_addon.bench.readme_figures chart ROWS.json [--out docs/speed_accuracy.png]

``side-by-side``: FOLDER is a finished ``blender_side`` job (its scene.pkl, results.json and EXR
renders, e.g. Cycles at 256 spp and EEVEE); the TFM renders the same pickled scene with
``quality='AUTO'`` here (median of 5 frames with the light moving, wall clock) and the three
images are shown side by side with their times, in the metrics' display convention (white: the
Cycles image's 99.9th percentile, gamma 1/2.2). SSIM of the TFM and of EEVEE against that Cycles
image is printed in the captions.

``chart``: ROWS.json from ``python -m tfm_addon.bench.speed --reference --json ROWS.json``; one
panel per scene, frame time against SSIM to the numpy reference.
"""

from __future__ import annotations

import argparse
import json
import pickle
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from ..engine import Renderer, RenderSettings
from ..engine.exr import read_exr
from ..engine.metrics import ssim
from .common import display, white_of
from .speed import _moved_light


def _rgb(path: Path) -> np.ndarray:
    ch = read_exr(path)
    return np.stack([ch[c] for c in "RGB"], axis=-1)


def side_by_side(folder: Path, out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with open(folder / "scene.pkl", "rb") as f:
        scene = pickle.load(f)
    results = json.loads((folder / "results.json").read_text())
    renderer = Renderer()
    settings = RenderSettings(quality="AUTO")
    states = [_moved_light(scene, 0), _moved_light(scene, 1)]
    renderer.render(states[1], settings, passes=False)
    times = []
    for k in range(6):
        t0 = time.perf_counter()
        image = renderer.render(states[k % 2], settings, passes=False).rgb
        times.append(time.perf_counter() - t0)
    tfm_s = statistics.median(times[1:])
    renderer.release()
    cycles = next(r for r in results["renders"] if r["engine"] == "CYCLES")
    eevee = next(r for r in results["renders"] if r["engine"] == "EEVEE")
    ref = _rgb(folder / cycles["file"])
    ev = _rgb(folder / eevee["file"])
    white = white_of(ref)
    panels = [(image, f"TFM (AUTO): {tfm_s * 1000:.0f} ms\nSSIM {ssim(image, ref):.3f} vs Cycles"),
              (ref, f"Cycles {cycles['samples']} spp: {cycles['seconds']:.0f} s\n(single scattering)"),
              (ev, f"EEVEE {eevee.get('preset', '')}, {eevee['samples']} samples: {eevee['seconds']:.0f} s\n"
                   f"SSIM {ssim(ev, ref):.3f} vs Cycles")]
    h, w = ref.shape[:2]
    fig, axes = plt.subplots(1, 3, figsize=(3 * w / 100, h / 100 + 0.45), dpi=100)
    for ax, (img, title) in zip(axes, panels, strict=True):
        ax.imshow(display(img, white))
        ax.set_title(title, fontsize=7)
        ax.axis("off")
    fig.subplots_adjust(left=0.005, right=0.995, bottom=0.005, top=h / (h + 45), wspace=0.02)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    print(f"{out}: TFM {tfm_s * 1000:.0f} ms, Cycles {cycles['seconds']:.1f} s, "
          f"EEVEE {eevee['seconds']:.1f} s")
    return out


LABELS = ("AUTO", "floor (AUTO steps)", "TFM-8 EXACT", "TFM-8 LINEAR", "floor (100 steps)",
          "brute force 100x100")
STYLE = {"AUTO": ("tab:green", "*"), "floor (AUTO steps)": ("black", "x"), "TFM-8 EXACT": ("tab:blue", "o"),
         "TFM-8 LINEAR": ("tab:cyan", "v"), "floor (100 steps)": ("gray", "x"),
         "brute force 100x100": ("tab:red", "^")}


def chart(rows_path: Path, out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    from .charts import _logit

    rows = [r for r in json.loads(rows_path.read_text()) if "ssim" in r]
    cols = min(3, len(rows))
    nrows = -(-len(rows) // cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(3.3 * cols, 2.6 * nrows + 0.5), squeeze=False, dpi=90)
    for ax, r in zip(axes.ravel(), rows, strict=False):
        for label in LABELS:
            if label in r["ms"] and label in r["ssim"]:
                color, marker = STYLE[label]
                ax.plot(r["ms"][label], min(r["ssim"][label], 1 - 1e-6), marker=marker, color=color,
                        linestyle="none", label=label, markersize=9 if label == "AUTO" else 6)
        ax.set_xscale("log")
        ax.xaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.xaxis.set_minor_formatter(NullFormatter())
        _logit(ax)
        ax.axhline(0.99, color="gray", linewidth=0.6, linestyle=":")
        ax.set_title(f"{r['scene']} {r['size']}", fontsize=8)
        ax.set_xlabel(f"ms per frame, light moving ({r.get('clock', 'wall')} clock)", fontsize=7)
        ax.set_ylabel("SSIM vs numpy reference", fontsize=7)
        ax.tick_params(labelsize=6)
        ax.grid(True, which="both", alpha=0.25)
    for ax in axes.ravel()[len(rows):]:
        ax.axis("off")
    handles = {}
    for ax in axes.ravel():
        for h, label in zip(*ax.get_legend_handles_labels(), strict=False):
            handles.setdefault(label, h)
    fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=6, fontsize=6)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    plt.close(fig)
    print(out)
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m tfm_addon.bench.readme_figures", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("what", choices=("side-by-side", "chart"))
    p.add_argument("source", type=Path)
    p.add_argument("--out", type=Path)
    args = p.parse_args(argv)
    if args.what == "side-by-side":
        side_by_side(args.source, args.out or Path("docs/tfm_cycles_eevee.png"))
    else:
        chart(args.source, args.out or Path("docs/speed_accuracy.png"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
