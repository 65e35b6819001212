"""Fit the octave constants of multiple scattering (tfm_addon/engine/multiple_scattering.py)
against the Cycles references with bounces (scripts/make_bounce_refs.py).

    .venv/bin/python scripts/fit_octaves.py [--bounces 1 2 4 16 128] [--json out.json]
        [--a-grid 0.4 0.5 0.6] [--max-octaves 5] [--cache octaves.npz]

An octave sum is linear in its octaves: the image with octaves (N, a, b) is the single-scattering
image plus b^n times the image octave n adds with b = 1, n = 1..N-1; the diffusion term adds k
times its image with k = 1. So each medium is rendered by TFM (the add-on's defaults, through
Blender) once in single scattering, once per octave count and factor a and once per diffusion
boundary z and albedo power m on the grids below, and every candidate (N, a, b, k, z, m) is
composed from those images and compared with Cycles, without rendering it. The fit minimises,
over the ``bounces.FIT`` media, the mean of |brightness ratio - 1| + (1 - SSIM) (the brightness
part, linear in the images, screens the candidates; the full loss picks among the ``SCREEN``
best); it prints the error of the chosen constants on the ``bounces.HELD_OUT`` media too. The
diffusion term is fitted from ``DIFFUSION_FROM`` bounces on; above that only k may grow, so more
bounces never give less light. The anisotropy factor c is not fitted: every medium here is
isotropic (Principled Volume's default), where c does nothing.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

A_GRID = (0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)
B_GRID = tuple(np.round(np.arange(0.2, 1.01, 0.05), 2))
MAX_OCTAVES = 10
DIFFUSION_FROM = 16                                          # bounce counts with the diffusion term
K_GRID = tuple(np.round(np.arange(0.0, 1.001, 0.05), 2))     # the diffusion term's weight
SCREEN = 300                                                 # candidates whose SSIM the fit computes
Z_GRID = (0.3, 0.5, 0.67)                                    # its extrapolated boundary
M_GRID = (0.0, 1.0, 2.0, 4.0)                                # its albedo power
DIFFUSION_GRID = tuple(itertools.product(Z_GRID, M_GRID))


def octave_images(medium: str, tmp: str) -> tuple[np.ndarray, dict[tuple, np.ndarray]]:
    """The medium's single-scattering TFM image and, per octave n and factor a, the image octave n
    adds with contribution factor b = 1 (the difference of the sums of n + 1 and n octaves); per
    boundary z and albedo power m (key ("d", z, m)), the image the diffusion term adds with k = 1."""
    import bpy

    from tfm_addon.bench import bounces as bn
    from tfm_addon.bench import conformance as cf
    from tfm_addon.engine import multiple_scattering as ms

    def render(o) -> np.ndarray:
        ms.FITTED[1] = o
        bpy.ops.render.render()
        return cf._read_render(tmp, "fit")[..., :3].astype(np.float64)

    bn.build(medium, tmp, 1)
    scene = bpy.context.scene
    scene.render.engine = 'TFM'
    scene.render.film_transparent = True
    scene.tfm.samples = cf.TFM_SAMPLES
    saved = dict(ms.FITTED)
    try:
        ms.FITTED.clear()
        single = render(ms.SINGLE)
        octave = {}
        for a in A_GRID:
            below = single
            for n in range(1, MAX_OCTAVES):
                total = render(ms.Octaves(n + 1, a, 1.0, 0.5))
                octave[(n, a)] = total - below
                below = total
        for z, m in DIFFUSION_GRID:
            octave[("d", z, m)] = render(ms.Octaves(2, 0.5, 0.0, 0.5, 1.0, z, m)) - single
    finally:
        ms.FITTED.clear()
        ms.FITTED.update(saved)
    return single, octave


def compose(single, octave, count: int, a: float, b: float, k: float = 0.0, d=DIFFUSION_GRID[0]):
    """The image (or, given sums, the sum) of the candidate (count, a, b, k, (z, m))."""
    image = single.copy() if isinstance(single, np.ndarray) else single
    for n in range(1, count):
        image += b ** n * octave[(n, a)]
    return image + k * octave[("d", *d)]


def _key(parts: list[str]) -> tuple:
    """An octave image's key from its name in the cache: (n, a) or ("d", z, m)."""
    if parts[0] == "d":
        return ("d", float(parts[1]), float(parts[2]))
    return (int(parts[0]), float(parts[1]))


def brightness_loss(candidate, sums) -> float:
    """The mean |brightness ratio - 1| of ``candidate`` over media given as (single's sum, the
    octave images' sums, the reference's sum)."""
    return float(np.mean([abs(compose(s0, so, *candidate) / sr - 1.0) for s0, so, sr in sums.values()]))


def error(image, cycles) -> tuple[float, float]:
    from tfm_addon.engine import metrics

    return metrics.ssim(image, cycles), metrics.brightness_ratio(image, cycles)


def loss(figures) -> float:
    return float(np.mean([abs(q - 1.0) + (1.0 - s) for s, q in figures]))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bounces", type=int, nargs="+", default=[1, 2, 4, 16, 128])
    parser.add_argument("--json", type=Path, default=None, help="write the fit and its errors here")
    parser.add_argument("--a-grid", type=float, nargs="+", default=None, help="octave factors a tried")
    parser.add_argument("--max-octaves", type=int, default=None)
    parser.add_argument("--cache", type=Path, default=None,
                        help="an .npz that keeps the TFM octave images between runs (not the references)")
    args = parser.parse_args(argv)
    global A_GRID, MAX_OCTAVES
    A_GRID = tuple(args.a_grid or A_GRID)
    MAX_OCTAVES = args.max_octaves or MAX_OCTAVES

    import tfm_addon
    from tfm_addon.bench import bounces as bn

    media = [m for m in (*bn.FIT, *bn.HELD_OUT)
             if all(bn.reference_path(m, n).exists() for n in args.bounces)]
    images = {}
    if args.cache and args.cache.exists():
        with np.load(args.cache) as z:
            for m in media:
                if f"{m}/single" in z.files:
                    keys = [k for k in z.files if k.startswith(f"{m}/") and k != f"{m}/single"]
                    images[m] = (z[f"{m}/single"], {_key(k.split("/")[1:]): z[k] for k in keys})
    missing = [m for m in media if m not in images]
    if missing:
        tfm_addon.register()
        try:
            with tempfile.TemporaryDirectory(prefix="tfm_fit_") as tmp:
                images.update({m: octave_images(m, tmp) for m in missing})
        finally:
            tfm_addon.unregister()
        if args.cache:
            np.savez(args.cache, **{f"{m}/single": s for m, (s, _) in images.items()},
                     **{"/".join(map(str, (m, *key))): o for m, (_, octs) in images.items()
                        for key, o in octs.items()})
    result = {}
    for n in args.bounces:
        refs = {m: bn.load_reference(m, n)[0].astype(np.float64) for m in images}
        ks = K_GRID if n >= DIFFUSION_FROM else (0.0,)
        candidates = [(count, a, float(b), float(k), d) for count, a, b, k, d in
                      itertools.product(range(2, MAX_OCTAVES + 1), A_GRID, B_GRID, ks, DIFFUSION_GRID)
                      if k > 0.0 or d == DIFFUSION_GRID[0]]
        below = [result[m] for m in result if DIFFUSION_FROM <= m < n]
        if below:
            # More bounces never give less light: above DIFFUSION_FROM only the diffusion term
            # grows (the light that scatters more often than that), the octaves stay.
            r = below[-1]
            candidates = [c for c in candidates if c[:3] == (r["count"], r["a"], r["b"])
                          and c[4] == (r["z"], r["m"]) and c[3] >= r["k"]]
        # The brightness part of the loss is linear in the images: every candidate by it first
        # (sums composed like the images), then the full loss for the SCREEN best.
        sums = {m: (images[m][0].sum(), {key: o.sum() for key, o in images[m][1].items()}, refs[m].sum())
                for m in bn.FIT}
        screened = sorted(candidates, key=lambda c: brightness_loss(c, sums))[:SCREEN]
        best = min((loss([error(compose(*images[m], *c), refs[m]) for m in bn.FIT]), *c) for c in screened)
        _, count, a, b, k, d = best
        per_medium = {}
        for m in images:
            ss = error(images[m][0], refs[m])
            ms_ = error(compose(*images[m], count, a, b, k, d), refs[m])
            per_medium[m] = {"fitted_on": m in bn.FIT, "single": ss, "octaves": ms_}
            print(f"{n:4d} bounces {m:16s} {'fit ' if m in bn.FIT else 'held'}  single: SSIM {ss[0]:.4f} "
                  f"brightness {ss[1]:.3f}   octaves: SSIM {ms_[0]:.4f} brightness {ms_[1]:.3f}", flush=True)
        print(f"{n:4d} bounces: Octaves({count}, {a}, {b}, 0.5, {k}, {d[0]}, {d[1]}), loss {best[0]:.4f}",
              flush=True)
        result[n] = {"count": count, "a": a, "b": b, "k": k, "z": d[0], "m": d[1], "media": per_medium}
    if args.json:
        args.json.write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
