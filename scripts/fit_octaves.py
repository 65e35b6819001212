"""Fit the weights of multiple scattering (tfm_addon/engine/multiple_scattering.py) against the
Cycles references with bounces (scripts/make_bounce_refs.py).

    .venv/bin/python scripts/fit_octaves.py [--bounces 1 2 4 16 128] [--json out.json]
        [--cache parts.npz]

A frame with bounces is linear in its parts: the single-scattering image, the image the second
octave adds with b = 1 (each row of FITTED has two octaves, so b scales it), the surfaces' light,
the diffused light and the emission's diffused light (engine/diffusion.py), each with weight 1.
So each medium is rendered by TFM (the add-on's defaults, through Blender) once per part and
every candidate (b, grid weight, anisotropy factor c) is composed from them and compared with
Cycles without rendering it (an anisotropic medium's second octave is rendered once per c of
``C_GRID``: the others' does not depend on c). The surfaces' light keeps weight 1 (what Cycles
renders from one bounce on). The octave count and decay a of each row are kept (FITTED); so are
the slab term's constants (k, z, m), used only where no lattice is made.

The fit minimises, over the ``bounces.FIT`` media, the mean of |brightness ratio - 1| + (1 - SSIM)
(the brightness part, linear in the images, screens the candidates; the full loss picks among the
``SCREEN`` best); it prints the error of the chosen weights on the ``bounces.HELD_OUT`` media too.
Above 16 bounces only the diffused lights' weights may grow from the 16-bounce row (b and c are
kept), so more bounces never give less light; the emission's diffused light's weight never falls
as the bounce count grows. It is weighed after the lights' weights, on the fitting media that
emit (no other image has it).
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

B_GRID = tuple(np.round(np.arange(0.0, 1.21, 0.025), 3))       # the second octave's weight
GRID_GRID = tuple(np.round(np.arange(0.0, 2.51, 0.05), 2))     # the diffused light's weight
SCREEN = 200                                                   # candidates whose SSIM the fit computes
GROWS_FROM = 16                                                # above it only the grid weight grows
E_GRID = tuple(np.round(np.arange(0.0, 4.01, 0.05), 2))       # the emission's diffused light's weight
C_GRID = (0.5, 0.625, 0.75, 0.875, 1.0)                        # the octaves' anisotropy factor
PARTS = ("single", "octave", "surface", "grid", "emission")


def parts(medium: str, tmp: str, rows: dict) -> dict:
    """The medium's TFM parts: "single"; per FITTED row n, ("octave", n) the image its second octave
    adds with b = 1 (an anisotropic medium: ("octave", n, c) for each c of C_GRID); "surface",
    "grid" and "emission" what the fields add with weight 1."""
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
        out = {"single": single,
               "surface": render(ms.Octaves(1, surface=1.0)) - single,
               "grid": render(ms.Octaves(1, grid=1.0)) - single,
               "emission": render(ms.Octaves(1, emission=1.0)) - single}
        for n, row in rows.items():
            if medium in bn.ANISOTROPIC:
                for c in C_GRID:
                    out[("octave", n, c)] = render(ms.Octaves(row.count, row.a, 1.0, c)) - single
            else:       # the anisotropy is 0: c changes nothing
                out[("octave", n)] = render(ms.Octaves(row.count, row.a, 1.0, row.c)) - single
    finally:
        ms.FITTED.clear()
        ms.FITTED.update(saved)
    return out


def compose(p: dict, n: int, b: float, grid: float, emission: float = 0.0, c: float | None = None):
    """The image (or, given sums, the sum) of weights (b, grid, emission) and anisotropy factor c
    for row ``n``."""
    octave = p.get(("octave", n, c), p.get(("octave", n)))
    return p["single"] + b * octave + p["surface"] + grid * p["grid"] + emission * p["emission"]


def error(image, cycles) -> tuple[float, float]:
    from tfm_addon.engine import metrics

    return metrics.ssim(image, cycles), metrics.brightness_ratio(image, cycles)


def loss(figures) -> float:
    return float(np.mean([abs(q - 1.0) + (1.0 - s) for s, q in figures]))


def _cache_key(key) -> str:
    return key if isinstance(key, str) else "_".join(str(k) for k in key)


def _from_cache_key(name: str):
    if not name.startswith("octave_"):
        return name
    fields = name.split("_")[1:]
    return ("octave", int(fields[0])) + ((float(fields[1]),) if len(fields) > 1 else ())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bounces", type=int, nargs="+", default=[1, 2, 4, 16, 128])
    parser.add_argument("--json", type=Path, default=None, help="write the fit and its errors here")
    parser.add_argument("--cache", type=Path, default=None,
                        help="an .npz that keeps the TFM parts between runs (not the references)")
    args = parser.parse_args(argv)

    import tfm_addon
    from tfm_addon.bench import bounces as bn
    from tfm_addon.engine import multiple_scattering as ms

    rows = {n: ms.octaves(n) for n in args.bounces}
    media = [m for m in (*bn.FIT, *bn.HELD_OUT)
             if any(bn.reference_path(m, n).exists() for n in args.bounces)]
    images: dict[str, dict] = {}
    if args.cache and args.cache.exists():
        with np.load(args.cache) as z:
            for m in media:
                names = [k.split("/", 1)[1] for k in z.files if k.startswith(f"{m}/")]
                if names:
                    images[m] = {_from_cache_key(k): z[f"{m}/{k}"] for k in names}
    missing = [m for m in media if m not in images]
    if missing:
        tfm_addon.register()
        try:
            with tempfile.TemporaryDirectory(prefix="tfm_fit_") as tmp:
                images.update({m: parts(m, tmp, rows) for m in missing})
        finally:
            tfm_addon.unregister()
        if args.cache:
            np.savez(args.cache, **{f"{m}/{_cache_key(k)}": v
                                    for m, p in images.items() for k, v in p.items()})
    result = {}
    for n in args.bounces:
        refs = {m: bn.load_reference(m, n)[0][..., :3].astype(np.float64) for m in images
                if bn.reference_path(m, n).exists()}
        fit = [m for m in bn.FIT if m in refs]
        # the media that emit: only the emission's diffused light's weight changes them
        glowing = [m for m in fit if np.any(images[m]["emission"] > 0.0)]
        lit = [m for m in fit if m not in glowing]
        candidates = list(itertools.product(B_GRID, GRID_GRID, C_GRID))
        below = [result[k] for k in result if GROWS_FROM <= k < n]
        if below:
            candidates = [(b, g, c) for b, g, c in candidates
                          if b == below[-1]["b"] and c == below[-1]["c"] and g >= below[-1]["grid"]]
        sums = {m: ({k: v.sum() for k, v in images[m].items()}, refs[m].sum()) for m in lit}
        screened = sorted(candidates, key=lambda q: np.mean(
            [abs(compose(s, n, q[0], q[1], 0.0, q[2]) / r - 1.0) for s, r in sums.values()]))[:SCREEN]
        best = min((loss([error(compose(images[m], n, q[0], q[1], 0.0, q[2]), refs[m]) for m in lit]), *q)
                   for q in screened)
        _, b, grid, c = best
        # the emission's diffused light: only the media that emit have it
        emission, e_loss = 0.0, float("nan")
        if glowing:
            least = max((result[k]["emission"] for k in result if k < n), default=0.0)
            e_candidates = [e for e in E_GRID if e >= least]
            e_loss, emission = min(
                (loss([error(compose(images[m], n, b, grid, e, c), refs[m]) for m in glowing]), e)
                for e in e_candidates)
        per_medium = {}
        for m in refs:
            ss = error(images[m]["single"], refs[m])
            mm = error(compose(images[m], n, b, grid, emission, c), refs[m])
            per_medium[m] = {"fitted_on": m in bn.FIT, "single": ss, "multiple": mm}
            print(f"{n:4d} bounces {m:16s} {'fit ' if m in bn.FIT else 'held'}  single: SSIM {ss[0]:.4f} "
                  f"brightness {ss[1]:.3f}   multiple: SSIM {mm[0]:.4f} brightness {mm[1]:.3f}", flush=True)
        row = dataclasses.replace(rows[n], b=float(b), c=float(c), grid=float(grid), surface=1.0,
                                  emission=float(emission))
        print(f"{n:4d} bounces: {row}, loss {best[0]:.4f} (emission: {e_loss:.4f})", flush=True)
        result[n] = {"b": float(b), "c": float(c), "grid": float(grid), "emission": float(emission),
                     "loss": best[0],
                     "emission_loss": e_loss, "media": per_medium}
    if args.json:
        args.json.write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
