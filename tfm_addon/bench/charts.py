"""Charts (matplotlib, Agg): speed against accuracy with the Pareto front, and the sweeps."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .common import (
    AUTO,
    BRUTE,
    CYCLES,
    EEVEE,
    FLOOR,
    PROJECTIVE,
    TFM_ALPHA,
    TFM_ALPHA10,
    TFM_EXACT,
    TFM_NO_ALPHA,
    TFM_SSAA,
    WORLD,
)

STYLE = {
    TFM_ALPHA: dict(color="tab:blue", marker="o"),
    TFM_NO_ALPHA: dict(color="tab:orange", marker="s"),
    TFM_EXACT: dict(color="tab:cyan", marker="v"),
    TFM_ALPHA10: dict(color="tab:purple", marker="P"),
    AUTO: dict(color="tab:green", marker="*", markersize=14),
    BRUTE: dict(color="tab:red", marker="^"),
    WORLD: dict(color="tab:brown", marker="<"),
    PROJECTIVE: dict(color="tab:olive", marker=">"),
    CYCLES: dict(color="tab:gray", marker="D"),
    EEVEE: dict(color="tab:pink", marker="X"),
    TFM_SSAA: dict(color="navy", marker="h"),
    FLOOR: dict(color="black", marker="x"),
}
SSIM_CEILING = 1 - 1e-6


def have_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _logit(ax) -> None:
    """A logit SSIM axis labelled with plain decimals (0.9, 0.99, 0.999 ...)."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

    ax.set_yscale("logit")
    ticks = [0.5, 0.8, 0.9, 0.95, 0.98, 0.99, 0.995, 0.998, 0.999, 0.9995, 0.9999, 0.99999, 0.999999]
    ax.yaxis.set_major_locator(FixedLocator(ticks))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.6f}".rstrip("0")))
    ax.yaxis.set_minor_formatter(NullFormatter())


def _log_seconds(ax, xs=None) -> None:
    """A log axis labelled 0.01, 0.02, 0.05, 0.1 ... (powers of ten only over a wide range)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    ax.set_xscale("log")
    lo, hi = ax.get_xlim() if xs is None else (min(xs), max(xs))
    wide = lo > 0 and hi / lo > 1e3
    ax.xaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0,) if wide else (1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())


def pareto(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the points no other point beats in both time (lower) and accuracy (higher),
    by increasing time."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], -points[i][1]))
    front, best = [], -math.inf
    for i in order:
        if points[i][1] > best:
            front.append(i)
            best = points[i][1]
    return front


def _accuracy(r: dict, metric: str) -> float:
    v = r[metric]
    if metric == "ssim":
        return min(v, SSIM_CEILING)
    return min(v, 99.0) if math.isfinite(v) else 99.0


def speed_accuracy(rows: list[dict], path: Path, metric: str = "ssim", title: str = "") -> Path:
    """One panel per scene: frame time (log) against SSIM (logit axis) or PSNR; a line per method
    family through its points by time; the Pareto front dashed, its points ringed."""
    plt = _plt()
    scenes = list(dict.fromkeys(r["scene_title"] for r in rows))
    cols = min(3, len(scenes))
    nrows = math.ceil(len(scenes) / cols)
    single = cols == 1
    fig, axes = plt.subplots(nrows, cols, figsize=(6.2 * cols + 2.0 * single, 4.6 * nrows + 1.2 * single),
                             squeeze=False)
    for ax, scene in zip(axes.ravel(), scenes, strict=False):
        srows = [r for r in rows if r["scene_title"] == scene and math.isfinite(r.get("seconds", math.nan))]
        for family in dict.fromkeys(r["family"] for r in srows):
            fr = [r for r in srows if r["family"] == family]       # in the table's order (n, steps)
            style = dict(STYLE.get(family, dict(marker="o")))
            ax.plot([r["seconds"] for r in fr], [_accuracy(r, metric) for r in fr], label=family,
                    linestyle="-" if len(fr) > 1 else "none", alpha=0.9, **style)
            for r in fr:
                if (r["family"] in (AUTO, BRUTE, CYCLES, EEVEE) or r["method"].startswith("TFM-8")
                        or "maps" in r["method"]):
                    ax.annotate(r["method"].replace(" (builds none)", ""),
                                (r["seconds"], _accuracy(r, metric)),
                                fontsize=6, xytext=(3, 3), textcoords="offset points")
        pts = [(r["seconds"], _accuracy(r, metric)) for r in srows]
        front = pareto(pts)
        if front:
            fx = [pts[i][0] for i in front]
            fy = [pts[i][1] for i in front]
            ax.step(fx, fy, where="post", color="black", linestyle="--", linewidth=1, label="Pareto front")
            ax.scatter(fx, fy, s=140, facecolors="none", edgecolors="black", linewidths=1.2)
        _log_seconds(ax)
        if metric == "ssim":
            _logit(ax)
            ax.axhline(0.99, color="gray", linewidth=0.6, linestyle=":")
        ax.set_xlabel("seconds per frame (log)")
        ax.set_ylabel("SSIM (logit axis)" if metric == "ssim" else "PSNR dB")
        ax.set_title(scene, fontsize=10)
        ax.grid(True, which="both", alpha=0.25)
    for ax in axes.ravel()[len(scenes):]:
        ax.axis("off")
    handles = {}
    for ax in axes.ravel():
        for h, label in zip(*ax.get_legend_handles_labels(), strict=False):
            handles.setdefault(label, h)
    ncol = 4 if cols > 1 else 2
    fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=ncol, fontsize=8)
    if title:
        fig.suptitle(title, fontsize=11)
    legend_rows = math.ceil(len(handles) / ncol)
    bottom = (0.24 * legend_rows + 0.25) / fig.get_figheight()        # the legend's height, inches
    fig.tight_layout(rect=(0, min(0.45, bottom), 1, 0.97))
    return _save(plt, fig, path)


def _save(plt, fig, path: Path) -> Path:
    """Write ``fig`` to ``path`` (its folder made), close it, return ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def lines(series: dict[str, tuple[list[float], list[float]]], path: Path, xlabel: str, ylabel: str,
          title: str, xlog: bool = True, ylogit: bool = False, marks: dict[str, float] | None = None,
          hline: float | None = None, panels: dict[str, dict] | None = None) -> Path:
    """A line chart (or a row of them, ``panels``: title -> series): x against y per label."""
    plt = _plt()
    panels = panels or {title: series}
    fig, axes = plt.subplots(1, len(panels), figsize=(6.0 * len(panels), 4.4), squeeze=False)
    for ax, (ptitle, pseries) in zip(axes[0], panels.items(), strict=True):
        for label, (xs, ys) in pseries.items():
            y = [min(v, SSIM_CEILING) if ylogit else v for v in ys]
            ls = "--" if "no α" in label or "world" in label else "-"
            ax.plot(xs, y, marker="o", linestyle=ls, label=label)
        if xlog:
            _log_seconds(ax, [x for xs, _ in pseries.values() for x in xs if x > 0])
        if ylogit:
            _logit(ax)
        for name, x in (marks or {}).items():
            ax.axvline(x, color="gray", linestyle=":", linewidth=1)
            ax.annotate(name, (x, 0.02), xycoords=("data", "axes fraction"), fontsize=7, rotation=90)
        if hline is not None:
            ax.axhline(hline, color="gray", linestyle=":", linewidth=0.8)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.set_title(ptitle, fontsize=10)
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return _save(plt, fig, path)


def dots(groups: list[str], series: dict[str, list[float]], path: Path, ylabel: str, title: str,
         ylogit: bool = False) -> Path:
    """Grouped markers: one group per category, one marker per series (bars cannot start at 0 on
    a logit axis)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(max(7.0, 2.2 * len(groups)), 4.6))
    width = 0.8 / max(len(series), 1)
    x = np.arange(len(groups))
    markers = "osD^v<>Ph*"
    for k, (label, ys) in enumerate(series.items()):
        y = [min(v, SSIM_CEILING) if ylogit else v for v in ys]
        ax.plot(x + (k - (len(series) - 1) / 2) * width, y, linestyle="none",
                marker=markers[k % len(markers)], markersize=8, label=label)
    ax.set_xticks(x, groups, fontsize=8, rotation=10)
    if ylogit:
        _logit(ax)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(True, axis="y", which="both", alpha=0.25)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return _save(plt, fig, path)
