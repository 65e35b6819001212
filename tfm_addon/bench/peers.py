"""Time to quality against the renderers a user would pick instead (``python -m tfm_addon.bench
--only peers [--quick]``): per scene and image size, TFM's quality ladder (Auto at 1, 4 and 16
samples, the add-on's default being 16; Custom 400/400/16) and, in the same run on the same
machine, Cycles single scattering with OpenImageDenoise (Blender's denoiser defaults) at 1 to 256
samples and EEVEE, each image's SSIM against converged Cycles (no denoiser) at 320x180, drawn as
SSIM against seconds.

Timing: TFM's frame follows a change of the light (its maps and fields rebuilt, as after an
artist's edit or in an animation), in a process that has rendered the scene once (no GL start-up);
Cycles and EEVEE render in a Blender process of their own (``blender_side.py``), each timed around
``bpy.ops.render.render()`` after an untimed warm-up render. At 1920x1080, where a converged
reference is not affordable, both images are averaged down to 320x180 (6x6 pixel blocks) and
compared with the converged 320x180 reference.

The scenes, made by code: a production-scale cloud (126 x 86 x 154 voxels of 6.6 cm, as a studio's
cloud scaled 0.02 on import, sigma_s up to 30 /m) lit by a sun over a ground, under Blender's
default grey world (0.05) and under a black world; the paper's smoke with its spot and bar.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import pickle
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from .. import scenes
from ..engine import Camera, Light, Medium, Renderer, RenderSettings, Scene
from ..engine.exr import read_exr, write_exr
from ..engine.sampling import render_samples
from . import charts
from .common import compare, machine_line, markdown_table, nudged, safe_name, scene_digest

BASE_SIZE = (320, 180)
FULL_SIZE = (1920, 1080)


@dataclasses.dataclass(frozen=True)
class PeerConfig:
    """``sizes``: (image size, Cycles + OIDN sample counts there, TFM's timed repeats) each."""

    sizes: tuple[tuple[tuple[int, int], tuple[int, ...], int], ...]
    cycles_gt_samples: int
    eevee_samples: tuple[int, ...]
    tfm_samples: tuple[int, ...] = (1, 4, 16)


QUICK = PeerConfig(sizes=((BASE_SIZE, (1, 4, 16), 1),), cycles_gt_samples=512, eevee_samples=(1,))
# At 1920x1080 Cycles stops at 64 spp: 256 would take about half an hour a scene on 2 cores.
FULL = PeerConfig(sizes=((BASE_SIZE, (1, 4, 16, 64, 256), 2), (FULL_SIZE, (1, 4, 16, 64), 1)),
                  cycles_gt_samples=2048, eevee_samples=(1, 16))
CUSTOM = RenderSettings(view_steps=400, light_steps=400, coefficients=16, map_resolution=1024,
                        tfm_resolution="FOOTPRINT")


def production_cloud(width: int, height: int, world: float) -> Scene:
    """The production-scale cloud over a ground, lit by a sun; ``world`` the grey world's colour."""
    shape = (126, 86, 154)
    voxel = 3.3 * 0.02
    density = scenes.cloud_density(shape, seed=5)
    centre = np.array([0.0, 0.0, 1.5 + 0.5 * voxel * shape[2]])
    medium = Medium(sigma_a=(0.0,) * 3, sigma_s=(30.0,) * 3, density=density,
                    index_to_world=scenes.grid_to_world(shape, voxel * max(shape), centre), name="Cloud")
    sun = Light(matrix_world=scenes.look_at((-6.0, -4.0, 9.0), (0.0, 0.0, 0.0)), kind="SUN", power_w=3.0,
                angle_rad=math.radians(0.526), name="Sun")
    ground = scenes.plane_mesh((0.0, 0.0, 0.0), 60.0, color=(0.8, 0.8, 0.8))
    camera = Camera(matrix_world=scenes.look_at((3.0, -15.0, 4.0), tuple(centre - [0.0, 0.0, 2.2])),
                    width_px=width, height_px=height, lens_mm=50.0)
    return Scene(camera=camera, lights=(sun,), media=(medium,), meshes=(ground,), ambient=(world,) * 3)


SCENES = {
    "cloud, default grey world": lambda w, h: production_cloud(w, h, 0.05),
    "cloud, black world": lambda w, h: production_cloud(w, h, 0.0),
    "smoke and spot": lambda w, h: scenes.paper_smoke_scene(w, h, 128),
}


def _downsampled(image: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``image`` averaged down to ``size`` (w, h) in whole pixel blocks."""
    h, w = image.shape[:2]
    fy, fx = h // size[1], w // size[0]
    return image[: size[1] * fy, : size[0] * fx, :3].reshape(size[1], fy, size[0], fx, 3).mean(axis=(1, 3))


def _tfm_runs(renderer: Renderer, scene: Scene, config: PeerConfig, repeats: int) -> list[dict]:
    """TFM's ladder on ``scene``: (name, seconds, image) of each, the frame after a light change."""
    auto = RenderSettings(quality="AUTO", world_light="SHADOWED", film_transparent=True)
    ladder = [(f"TFM Auto, {n} sample{'s' if n > 1 else ''}" + (" (default)" if n == 16 else ""), auto, n)
              for n in config.tfm_samples]
    custom = dataclasses.replace(CUSTOM, world_light="SHADOWED")
    ladder.append(("TFM Custom 400/400/16, 4 samples", custom, 4))
    runs = []
    moved = (scene, nudged(scene))
    for name, settings, n in ladder:
        render_samples(renderer, moved[1], settings, n)            # warm: shaders, grid upload
        times = []
        for k in range(repeats):
            t0 = time.perf_counter()
            out = render_samples(renderer, moved[k % 2], settings, n)
            times.append(time.perf_counter() - t0)
        runs.append(dict(name=name, engine="TFM", samples=n, seconds=float(np.median(times)),
                         image=out.combined[..., :3].copy()))
    return runs


def _blender_runs(scene: Scene, folder: Path, config: PeerConfig, cycles_samples, gt: bool) -> dict:
    """Cycles + OIDN, EEVEE (and, with ``gt``, Cycles converged) in a Blender process."""
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / "scene.pkl", "wb") as f:
        pickle.dump(scene, f)
    job = dict(scene=str(folder / "scene.pkl"), folder=str(folder), cycles_samples=[],
               cycles_denoised_samples=list(cycles_samples),
               cycles_gt_samples=config.cycles_gt_samples if gt else 0,
               eevee_runs=[["default", n] for n in config.eevee_samples])
    (folder / "job.json").write_text(json.dumps(job, indent=1))
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    proc = subprocess.run([sys.executable, "-m", "tfm_addon.bench.blender_side", str(folder / "job.json")],
                          capture_output=True, text=True, env=env, cwd=root)
    (folder / "blender_log.txt").write_text(proc.stdout + proc.stderr)
    if proc.returncode != 0:
        raise RuntimeError(f"the Blender process failed ({proc.returncode}); "
                           f"see {folder / 'blender_log.txt'}")
    return json.loads((folder / "results.json").read_text())


def _load(folder: Path, file: str) -> np.ndarray:
    ch = read_exr(folder / file)
    return np.stack([ch[c] for c in "RGB"], axis=-1)


def equal_quality_seconds(points: list[tuple[float, float]], target: float) -> float | None:
    """The seconds at which a peer's (seconds, SSIM) curve first reaches ``target`` SSIM,
    interpolated in log time between its points; None where it never does."""
    pts = sorted(points)
    for k, (t, s) in enumerate(pts):
        if s >= target:
            if k == 0:
                return t
            t0, s0 = pts[k - 1]
            f = (target - s0) / max(s - s0, 1e-12)
            return float(math.exp(math.log(t0) + f * (math.log(t) - math.log(t0))))
    return None


def run(out: Path, quick: bool, cache: Path | None, only: list[str] | None = None) -> dict:
    """Every scene at every size; writes ``out/peers/`` (images, results.json, charts, peers.md) and
    returns the summary rows."""
    config = QUICK if quick else FULL
    folder = out / "peers"
    folder.mkdir(parents=True, exist_ok=True)
    renderer = Renderer()
    results = {"config": dataclasses.asdict(config), "scenes": {}}
    for key, make in SCENES.items():
        if only and key not in only:
            continue
        base_scene = make(*BASE_SIZE)
        digest = scene_digest(base_scene)
        gt_path = (cache or folder) / f"peers_gt_{digest}_{config.cycles_gt_samples}.exr"
        per_size = {}
        reference = None
        if gt_path.exists():
            ch = read_exr(gt_path)
            reference = np.stack([ch[c] for c in "RGB"], axis=-1)
        for size, cycles_samples, repeats in config.sizes:
            scene = make(*size)
            sub = folder / f"{safe_name(key)}_{size[0]}x{size[1]}"
            gt = reference is None and size == BASE_SIZE
            blender = _blender_runs(scene, sub, config, cycles_samples, gt=gt)
            if reference is None:
                entry = next(r for r in blender["renders"] if "ground truth" in r["name"])
                reference = _load(sub, entry["file"])
                gt_path.parent.mkdir(parents=True, exist_ok=True)
                write_exr(gt_path, {c: reference[..., i] for i, c in enumerate("RGB")})
            rows = []
            for r in blender["renders"]:
                if "ground truth" in r["name"]:
                    continue
                image = _load(sub, r["file"])
                rows.append(dict(name=r["name"], engine=r["engine"], samples=r["samples"],
                                 seconds=r["seconds"], **_judged(image, reference, size)))
            for r in _tfm_runs(renderer, scene, config, repeats):
                image = r.pop("image")
                rows.append(dict(r, **_judged(image, reference, size)))
            per_size[f"{size[0]}x{size[1]}"] = rows
        results["scenes"][key] = per_size
    results["machine"] = machine_line(renderer)
    (folder / "results.json").write_text(json.dumps(results, indent=1))
    summary = summarise(results)
    (folder / "peers.md").write_text(summary)
    if charts.have_matplotlib():
        chart(results, folder / "peers.png")
    return results


def _judged(image: np.ndarray, reference: np.ndarray, size) -> dict:
    small = image if tuple(size) == BASE_SIZE else _downsampled(image, BASE_SIZE)
    m = compare(small[..., :3], reference)
    return dict(ssim=m["ssim"], brightness=m["brightness"])


def _family(row: dict) -> str:
    if row["engine"] == "TFM":
        return "TFM"
    if row["engine"] == "EEVEE":
        return "EEVEE"
    return "Cycles + OIDN"


def summarise(results: dict) -> str:
    """The table: per scene and size, TFM's default frame, Cycles + OIDN's time to its SSIM, the
    ratio, and each family's best."""
    header = ["scene", "size", "TFM default (Auto, 16 samples)", "Cycles + OIDN at that SSIM",
              "TFM faster by", "Cycles + OIDN 16 spp", "EEVEE best"]
    table = []
    for key, sizes in results["scenes"].items():
        for size, rows in sizes.items():
            tfm = next((r for r in rows if r["engine"] == "TFM" and "(default)" in r["name"]), None)
            cycles = [(r["seconds"], r["ssim"]) for r in rows if _family(r) == "Cycles + OIDN"]
            c16 = next((r for r in rows if _family(r) == "Cycles + OIDN" and r["samples"] == 16), None)
            eevee = max((r for r in rows if r["engine"] == "EEVEE"), key=lambda r: r["ssim"], default=None)
            if tfm is None:
                continue
            t = equal_quality_seconds(cycles, tfm["ssim"])
            table.append([key, size, f"{tfm['seconds']:.2f} s, SSIM {tfm['ssim']:.3f}",
                          "never" if t is None else f"{t:.2f} s",
                          "—" if t is None else f"{t / tfm['seconds']:.1f}×",
                          "—" if c16 is None else f"{c16['seconds']:.2f} s, SSIM {c16['ssim']:.3f}",
                          "—" if eevee is None else f"{eevee['seconds']:.2f} s, SSIM {eevee['ssim']:.3f}"])
    slow = [f"{row[0]} at {row[1]} ({row[4] if row[4] != '—' else 'Cycles + OIDN never reaches it'})"
            for row in table if row[4] != "—" and float(row[4].rstrip("×")) < 5.0]
    text = markdown_table(header, table) + "\n"
    if slow:
        text += "\nWhere TFM's default frame is less than 5× faster than Cycles + OIDN at its SSIM: " + \
            "; ".join(slow) + ".\n"
    return text


def chart(results: dict, path: Path) -> Path:
    """SSIM against seconds: a row per scene, a column per size, a line per renderer (TFM's
    samples, Cycles + OIDN's samples, EEVEE's samples), TFM's Custom as a point."""
    plt = charts._plt()
    keys = list(results["scenes"])
    sizes = sorted({size for per in results["scenes"].values() for size in per},
                   key=lambda t: int(t.split("x")[0]))
    fig, axes = plt.subplots(len(keys), len(sizes), figsize=(5.2 * len(sizes), 3.4 * len(keys)),
                             squeeze=False)
    styles = {"TFM": ("tab:blue", "o"), "Cycles + OIDN": ("tab:orange", "s"), "EEVEE": ("tab:green", "^")}
    for row, key in enumerate(keys):
        for col, size in enumerate(sizes):
            ax = axes[row][col]
            rows = results["scenes"][key].get(size, [])
            xs = []
            for family, (colour, marker) in styles.items():
                pts = sorted((r["samples"], r["seconds"], r["ssim"]) for r in rows if _family(r) == family
                             and not r["name"].startswith("TFM Custom"))
                if not pts:
                    continue
                ax.plot([p[1] for p in pts], [min(p[2], charts.SSIM_CEILING) for p in pts], marker=marker,
                        color=colour, label=f"{family} ({', '.join(str(p[0]) for p in pts)} samples)")
                for n, t, v in pts:
                    ax.annotate(str(n), (t, min(v, charts.SSIM_CEILING)), fontsize=6, xytext=(3, -8),
                                textcoords="offset points", color=colour)
                xs += [p[1] for p in pts]
            for r in rows:
                if r["name"].startswith("TFM Custom"):
                    ax.plot([r["seconds"]], [min(r["ssim"], charts.SSIM_CEILING)], marker="D",
                            color="tab:red", linestyle="", label="TFM Custom 400/400/16, 4 samples")
                    xs.append(r["seconds"])
            if xs:
                charts._log_seconds(ax, xs)
            charts._logit(ax)
            ax.set_title(f"{key}, {size}", fontsize=9)
            ax.grid(True, which="both", alpha=0.25)
            ax.legend(fontsize=6)
            if row == len(keys) - 1:
                ax.set_xlabel("seconds per frame")
            if col == 0:
                ax.set_ylabel("SSIM against converged Cycles")
    fig.tight_layout()
    return charts._save(plt, fig, path)


def publish(results: dict, quick: bool) -> None:
    """Print the table; a full run also writes the README's time-to-quality block and chart
    (docs/peers.png) and docs/peers.md."""
    from . import readme

    text = summarise(results)
    print(text)
    if quick:
        return
    docs = Path(__file__).resolve().parents[2] / "docs"
    note = (f"\nEach scene's rows measured in one run (TFM and its peers side by side) on "
            f"{results['machine']}; SSIM against converged Cycles at 320x180 "
            f"({results['config']['cycles_gt_samples']} spp, no denoiser); 1920x1080 images averaged down "
            "to 320x180 first. `python -m tfm_addon.bench --only peers` writes it.\n")
    (docs / "peers.md").write_text("# Time to quality against Cycles + OpenImageDenoise and EEVEE\n\n"
                                   + text + note + "\n![SSIM against seconds](peers.png)\n")
    if charts.have_matplotlib():
        chart(results, docs / "peers.png")
    readme.write_block("time to quality", "\n" + text + note)
