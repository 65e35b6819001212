"""Priority 3: where the methods fail. Each sweep writes its rows to sweeps.csv and a chart.

(a) error against the largest optical depth tau along the light rays, TFM 4/8/16 with and
    without density weighting, smoke and Suzanne (reference: the GPU brute force with the same
    100 view x 100 light steps, so that only the transmittance approximation differs);
(b) error against a fixed alpha on the dense smoke (too small rings, too large loses float
    precision), the automatic alpha marked;
(c) error against the angle between the light's and the camera's axes, world against projective
    samples in a homogeneous box under a gobo (reference: the numpy march at many steps);
(d) light inside / camera inside the medium, heterogeneous and homogeneous (reference: numpy);
(e) error of the brute force against the ground truth for its view and light steps per voxel
    crossed (what the auto rule's step counts come from).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from .. import scenes
from ..engine import Medium, Renderer, RenderSettings, Scene
from ..engine.quality import medium_stats
from . import charts
from .common import (
    PAPER_STEPS,
    auto_method,
    compare,
    fmt,
    ground_truth,
    ground_truth_steps,
    markdown_table,
    render_counted,
    save_images,
    write_csv,
)
from .config import Config
from .progress import Progress
from .scene_set import DENSE_THICKNESS, suzanne_mesh

COLUMNS = ["sweep", "scene", "series", "x", "ssim", "psnr", "brightness", "reference", "note"]
COEFFS = (4, 8, 16)


def count(config: Config) -> int:
    if not config.sweep:
        return 0
    a = 2 * len(config.sweep_taus) * (1 + 2 * len(COEFFS))
    b = len(config.sweep_alphas) * len(COEFFS) + 1 + len(COEFFS)
    c = len(config.sweep_angles_deg) * (1 + 2 * len(config.sweep_angle_steps))
    d = 8 * 4
    e = 3 * (1 + 2 * len(config.sweep_steps))
    return a + b + c + d + e


def _scaled(scene: Scene, k: float) -> Scene:
    m = scene.media[0]
    medium = Medium(sigma_a=tuple(k * s for s in m.sigma_a), sigma_s=tuple(k * s for s in m.sigma_s),
                    anisotropy=m.anisotropy, density=m.density, index_to_world=m.index_to_world,
                    box_to_world=m.box_to_world)
    return dataclasses.replace(scene, media=(medium,))


def _sweep_scenes(config: Config) -> dict[str, Scene]:
    w, h = config.sweep_width, config.sweep_height
    v, t = suzanne_mesh()
    return {"smoke": scenes.paper_smoke_scene(w, h, config.sweep_smoke_n),
            "Suzanne": scenes.suzanne_scene(v, t, w, h, config.sweep_suzanne_n)}


def run(config: Config, renderer: Renderer, out: Path, progress: Progress, cache: Path | None) -> list[dict]:
    rows: list[dict] = []
    folder = out / "sweeps"
    base = RenderSettings(map_resolution=config.map_resolution, **PAPER_STEPS)
    bf = dataclasses.replace(base, method="BRUTE_FORCE")

    def add(sweep, scene, series, x, metrics, reference, note=""):
        rows.append(dict(sweep=sweep, scene=scene, series=series, x=x, reference=reference, note=note,
                         **metrics))

    # (a) optical thickness
    for name, scene in _sweep_scenes(config).items():
        tau0 = medium_stats(scene).optical_depth
        for tau in config.sweep_taus:
            sc = _scaled(scene, tau / tau0)
            ref, _ = render_counted(renderer, sc, bf)
            progress.step(f"(a) {name} tau {tau:g}: brute force")
            for n in COEFFS:
                for alpha in (None, 1.0):
                    s = dataclasses.replace(base, coefficients=n, density_weight=alpha)
                    img, _ = render_counted(renderer, sc, s)
                    label = f"TFM-{n} " + ("α" if alpha is None else "no α")
                    add("a_optical_depth", name, label, tau, compare(img.rgb, ref.rgb),
                        "GPU brute force 100x100")
                    if tau == max(config.sweep_taus) and n == 8:
                        save_images(folder / "a_optical_depth", f"{name}_tau{tau:g}_{label}", img.combined,
                                    ref.rgb)
                    progress.step(f"(a) {name} tau {tau:g}: {label}")

    # (b) alpha on a fixed thick medium
    dense = scenes.dense_smoke_scene(config.sweep_width, config.sweep_height, config.sweep_smoke_n,
                                     thickness=DENSE_THICKNESS)
    tau_dense = medium_stats(dense).optical_depth
    ref, _ = render_counted(renderer, dense, bf)
    progress.step("(b) brute force")
    for n in COEFFS:
        img, _ = render_counted(renderer, dense, dataclasses.replace(base, coefficients=n))
        add("b_alpha", "dense smoke", f"TFM-{n}", float("nan"), compare(img.rgb, ref.rgb),
            "GPU brute force 100x100", note="auto alpha")
        progress.step(f"(b) TFM-{n} auto alpha")
        for alpha in config.sweep_alphas:
            s = dataclasses.replace(base, coefficients=n, density_weight=alpha)
            img, _ = render_counted(renderer, dense, s)
            add("b_alpha", "dense smoke", f"TFM-{n}", alpha, compare(img.rgb, ref.rgb),
                "GPU brute force 100x100", note=f"tau_max {tau_dense:.1f}")
            if alpha in (1.0, max(config.sweep_alphas)) and n == 8:
                save_images(folder / "b_alpha", f"TFM-8_alpha{alpha:g}", img.combined, ref.rgb)
            progress.step(f"(b) TFM-{n} alpha {alpha:g}")

    # (c) light-view angle, world against projective
    for angle in config.sweep_angles_deg:
        sc = scenes.gobo_angle_scene(angle, config.sweep_width, config.sweep_height)
        gt = ground_truth(sc, config, renderer, cache)
        progress.step(f"(c) angle {angle:g}: ground truth")
        for steps in config.sweep_angle_steps:
            for sampling in ("WORLD", "PROJECTIVE"):
                s = dataclasses.replace(base, sampling=sampling, view_steps=steps)
                img, counters = render_counted(renderer, sc, s)
                add("c_angle", "gobo box", f"{sampling.lower()} {steps}", angle, compare(img.rgb, gt.image),
                    gt.name, note=f"TFMs built {counters['tfms']}")
                if steps == min(config.sweep_angle_steps):
                    save_images(folder / "c_angle", f"angle{angle:g}_{sampling.lower()}{steps}", img.combined,
                                gt.image)
                progress.step(f"(c) angle {angle:g}: {sampling.lower()} {steps}")

    # (d) light inside, camera inside
    for homogeneous in (False, True):
        for light_inside in (False, True):
            for camera_inside in (False, True):
                sc = scenes.inside_scene(homogeneous, light_inside, camera_inside, config.sweep_width,
                                         config.sweep_height, config.sweep_smoke_n)
                case = f"light {'inside' if light_inside else 'outside'}, camera " \
                       f"{'inside' if camera_inside else 'outside'}"
                medium = "fog box" if homogeneous else "smoke"
                gt = ground_truth(sc, config, renderer, cache)
                progress.step(f"(d) {medium}, {case}: ground truth")
                if homogeneous:
                    methods = [("world 64", dataclasses.replace(base, view_steps=64)),
                               ("projective 64",
                                dataclasses.replace(base, view_steps=64, sampling="PROJECTIVE"))]
                else:
                    methods = [("TFM-8 α", dataclasses.replace(base, coefficients=8)),
                               ("brute force 100x100", bf)]
                am = auto_method(sc, base)
                methods.append(("auto", am.settings))
                for label, s in methods:
                    img, _ = render_counted(renderer, sc, s)
                    add("d_inside", medium, label, case, compare(img.rgb, gt.image), gt.name,
                        note=am.name if label == "auto" else "")
                    save_images(folder / "d_inside", f"{medium}_{case}_{label}", img.combined, gt.image)
                    progress.step(f"(d) {medium}, {case}: {label}")

    # (e) brute-force steps per voxel against the ground truth
    w, h = config.sweep_width, config.sweep_height
    steps_scenes = dict(_sweep_scenes(config))
    steps_scenes["cloud"] = scenes.cloud_scene(w, h, config.cloud_shape)
    for name, sc in steps_scenes.items():
        gt = ground_truth(sc, config, renderer, cache)
        gv, gl = ground_truth_steps(sc, config)
        stats = medium_stats(sc)
        progress.step(f"(e) {name}: ground truth")
        for steps in config.sweep_steps:
            for which, (v, l), voxels in (("view", (steps, gl), stats.view_voxels),
                                          ("light", (gv, steps), stats.light_voxels)):
                s = dataclasses.replace(bf, view_steps=v, light_steps=l)
                img, _ = render_counted(renderer, sc, s)
                add("e_steps", name, f"{which} steps", steps / voxels, compare(img.rgb, gt.image), gt.name,
                    note=f"view {v} x light {l}; {voxels:.0f} voxels crossed")
                progress.step(f"(e) {name}: {which} {steps}")
    return rows


def write(rows: list[dict], out: Path, config: Config) -> str:
    folder = out / "sweeps"
    write_csv(folder / "sweeps.csv", rows, COLUMNS)
    lines = ["# Stability sweeps", "", "SSIM/PSNR by `tfm_addon.engine.metrics`; the reference is "
             "named per sweep. The rows are in `sweeps.csv`.", ""]

    def series(sweep, scene=None, metric="ssim", x_filter=None):
        out_s: dict[str, tuple[list, list]] = {}
        for r in rows:
            if r["sweep"] != sweep or (scene is not None and r["scene"] != scene):
                continue
            if x_filter is not None and not x_filter(r["x"]):
                continue
            xs, ys = out_s.setdefault(r["series"], ([], []))
            xs.append(r["x"])
            ys.append(r[metric])
        return out_s

    if any(r["sweep"] == "a_optical_depth" for r in rows):
        scenes_a = list(dict.fromkeys(r["scene"] for r in rows if r["sweep"] == "a_optical_depth"))
        for metric, ylabel in (("ssim", "SSIM (logit axis)"), ("psnr", "PSNR dB")):
            charts.lines({}, folder / f"a_optical_depth_{metric}.png",
                         "largest optical depth τ along the light rays",
                         ylabel, "", ylogit=metric == "ssim", hline=0.99 if metric == "ssim" else None,
                         panels={s: series("a_optical_depth", s, metric) for s in scenes_a})
        lines += ["## (a) Optical depth", "", "![](a_optical_depth_ssim.png)", ""]
        lines += _table(rows, "a_optical_depth", "τ")
    if any(r["sweep"] == "b_alpha" for r in rows):
        fixed = [r for r in rows if r["sweep"] == "b_alpha" and not math.isnan(r["x"])]
        tau = next((r["note"] for r in fixed), "")
        tau_v = float(tau.split()[-1]) if tau else None
        for metric, ylabel in (("ssim", "SSIM (logit axis)"), ("psnr", "PSNR dB")):
            charts.lines(series("b_alpha", metric=metric, x_filter=lambda x: not math.isnan(x)),
                         folder / f"b_alpha_{metric}.png", "α (fixed, relative to σt max)", ylabel,
                         f"dense smoke, {tau}", ylogit=metric == "ssim",
                         marks={"auto α ≈ τ_max": tau_v} if tau_v else None,
                         hline=0.99 if metric == "ssim" else None)
        auto = [r for r in rows if r["sweep"] == "b_alpha" and math.isnan(r["x"])]
        lines += ["## (b) Density weighting α on the dense smoke", "", "![](b_alpha_ssim.png)", "",
                  "Automatic α: " + ", ".join(f"{r['series']} SSIM {r['ssim']:.4f} / {r['psnr']:.1f} dB"
                                              for r in auto), ""]
        lines += _table(rows, "b_alpha", "α", x_filter=lambda x: not math.isnan(x))
    if any(r["sweep"] == "c_angle" for r in rows):
        for metric, ylabel in (("ssim", "SSIM (logit axis)"), ("psnr", "PSNR dB")):
            charts.lines(series("c_angle", metric=metric), folder / f"c_angle_{metric}.png",
                         "angle between the light's and the camera's axes (degrees)", ylabel,
                         "homogeneous box under a ring gobo", xlog=False, ylogit=metric == "ssim")
        lines += ["## (c) Light-view angle, world against projective samples", "",
                  "![](c_angle_ssim.png)", ""]
        lines += _table(rows, "c_angle", "angle °")
    if any(r["sweep"] == "d_inside" for r in rows):
        cases = list(dict.fromkeys(r["x"] for r in rows if r["sweep"] == "d_inside"))
        ser: dict[str, list[float]] = {}
        for r in rows:
            if r["sweep"] == "d_inside":
                values = ser.setdefault(f"{r['scene']}: {r['series']}", [math.nan] * len(cases))
                values[cases.index(r["x"])] = r["ssim"]
        charts.dots(cases, ser, folder / "d_inside_ssim.png", "SSIM (logit axis)",
                    "light / camera inside the medium (against the numpy reference)", ylogit=True)
        lines += ["## (d) Light inside, camera inside", "", "![](d_inside_ssim.png)", ""]
        lines += _table(rows, "d_inside", "case", by_scene=True)
    if any(r["sweep"] == "e_steps" for r in rows):
        panels = {}
        for s in dict.fromkeys(r["scene"] for r in rows if r["sweep"] == "e_steps"):
            panels[s] = series("e_steps", s)
        charts.lines({}, folder / "e_steps_ssim.png", "steps per voxel crossed by the longest ray",
                     "SSIM (logit axis)", "", ylogit=True, hline=0.99, panels=panels)
        lines += ["## (e) Brute-force steps per voxel against the ground truth", "",
                  "![](e_steps_ssim.png)", ""]
        lines += _table(rows, "e_steps", "steps/voxel", by_scene=True)
    text = "\n".join(lines)
    (folder / "sweeps.md").write_text(text + "\n")
    return text


def _table(rows, sweep, xname, x_filter=None, by_scene=False) -> list[str]:
    sel = [r for r in rows if r["sweep"] == sweep and (x_filter is None or x_filter(r["x"]))]
    out = []
    for scene in dict.fromkeys(r["scene"] for r in sel):
        srows = [r for r in sel if r["scene"] == scene]
        xs = list(dict.fromkeys(r["x"] for r in srows))
        names = list(dict.fromkeys(r["series"] for r in srows))
        table = []
        for x in xs:
            cells = [fmt(x, ".3g") if isinstance(x, float) else str(x)]
            for n in names:
                r = next((r for r in srows if r["x"] == x and r["series"] == n), None)
                cells.append("–" if r is None else f"{r['ssim']:.4f} / {r['psnr']:.1f}")
            table.append(cells)
        out += [f"{scene}: SSIM / PSNR dB", "", markdown_table([xname] + names, table), ""]
    return out
