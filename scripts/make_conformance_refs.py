"""Render the conformance rows' Cycles references into tests/data/conformance/<id>.npz, or check
the rows' negative controls against them.

    .venv/bin/python scripts/make_conformance_refs.py [ROW ...] [--samples 1024] [--out DIR]
    .venv/bin/python scripts/make_conformance_refs.py [ROW ...] --controls [--out DIR]

Each reference is the mean of two Cycles renders of ``--samples`` samples with seeds 1 and 2
(single scattering, BLENDER.md's film settings; ``tfm_addon.blender.scene_builder.
cycles_single_scattering``). The two halves are compared with each other (SSIM, brightness ratio)
as the convergence check; the file keeps, beside the float16 RGB image (top row first): the total
samples, the seconds, the Blender version, the row's title and the seed-against-seed figures.

Every reference made is then checked with its row's negative control, as ``--controls`` does.
``--controls`` renders no Cycles: it renders each row's control (``conformance.Row.control``: the
row's subject set back to Blender's default) by TFM, compares it with the stored reference and
writes ``<id>.control.json`` beside it. It exits non-zero when a control does not fail its row
(unless the row is in ``conformance.WEAK_CONTROL``), when a row in WEAK_CONTROL now fails, or when
a reference is missing.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def make_references(rows, out: Path, samples: int) -> int:
    import bpy

    from tfm_addon.bench import conformance
    from tfm_addon.engine import metrics

    with tempfile.TemporaryDirectory(prefix="tfm_conformance_") as tmp:
        for row in rows:
            folder = os.path.join(tmp, row.id)
            a, sa = conformance.render_cycles(row, folder, samples=samples, seed=1)
            b, sb = conformance.render_cycles(row, folder, samples=samples, seed=2)
            image = (a + b) / 2.0
            seed_ssim = metrics.ssim(a[..., :3], b[..., :3])
            seed_ratio = metrics.brightness_ratio(a[..., :3], b[..., :3])
            path = conformance.save_reference(
                row.id, image, out, samples=2 * samples, seeds="1,2", seconds=sa + sb,
                blender=bpy.app.version_string, title=row.title, seed_ssim=seed_ssim,
                seed_ratio=seed_ratio, width=image.shape[1], height=image.shape[0])
            print(f"{row.id}: {2 * samples} spp in {sa + sb:.1f} s; seed 1 vs 2: SSIM "
                  f"{seed_ssim:.4f}, brightness {seed_ratio:.4f}; {path.stat().st_size / 1024:.0f} KiB",
                  flush=True)
    return 0


def check_controls(rows, out: Path) -> int:
    """Render each row's control by TFM, store its figures (``<id>.control.json``) and return 1 when
    one does not behave as WEAK_CONTROL says (or a reference is missing)."""
    import tfm_addon
    from tfm_addon.bench import conformance

    bad = []
    tfm_addon.register()
    try:
        with tempfile.TemporaryDirectory(prefix="tfm_conformance_") as tmp:
            for row in rows:
                if not (out / f"{row.id}.npz").exists():
                    print(f"{row.id}: no reference", flush=True)
                    bad.append(f"{row.id} (no reference)")
                    continue
                cycles, _ = conformance.load_reference(row.id, out)
                result = conformance.render_control(row, os.path.join(tmp, row.id))
                comparison = conformance.compare(row, result.image, cycles)
                fails = not comparison.passes()
                conformance.save_control(row.id, comparison, out)
                weak = row.id in conformance.WEAK_CONTROL
                verdict = "fails" if fails else "PASSES" + (" (weak control)" if weak else "")
                print(f"{row.id}: control {verdict}: SSIM {comparison.ssim:.4f}, brightness "
                      f"{comparison.ratio_text()}, TFM {result.seconds:.2f} s; {row.control_text}",
                      flush=True)
                if not fails and not weak:
                    bad.append(f"{row.id} (its control does not fail the row)")
                if fails and weak:
                    bad.append(f"{row.id} (its control fails the row: delete it from WEAK_CONTROL)")
    finally:
        tfm_addon.unregister()
    if bad:
        print("controls to look at: " + ", ".join(bad), flush=True)
        return 1
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("rows", nargs="*", help="row ids (default: every row)")
    parser.add_argument("--samples", type=int, default=1024, help="Cycles samples per seed")
    parser.add_argument("--out", type=Path, default=None, help="folder (default tests/data/conformance)")
    parser.add_argument("--controls", action="store_true",
                        help="render the rows' controls by TFM against the stored references (no "
                             "Cycles) and write <id>.control.json")
    args = parser.parse_args(argv)

    import bpy  # noqa: F401  (Blender first: the add-on's modules import it)

    from tfm_addon.bench import conformance

    out = args.out or conformance.REF_DIR
    rows = conformance.rows(args.rows)
    t_all = time.perf_counter()
    rc = 0 if args.controls else make_references(rows, out, args.samples)
    # a reference made is checked at once: its row's control must fail against it
    rc = rc or check_controls(rows, out)
    print(f"all: {time.perf_counter() - t_all:.0f} s", flush=True)
    return rc


if __name__ == "__main__":
    sys.exit(main())
