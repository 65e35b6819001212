"""Render the conformance rows' Cycles references into tests/data/conformance/<id>.npz.

    .venv/bin/python scripts/make_conformance_refs.py [ROW ...] [--samples 1024] [--out DIR]

Each reference is the mean of two Cycles renders of ``--samples`` samples with seeds 1 and 2
(single scattering, BLENDER.md's film settings; ``tfm_addon.blender.scene_builder.
cycles_single_scattering``). The two halves are compared with each other (SSIM, brightness ratio)
as the convergence check; the file keeps, beside the float16 RGB image (top row first): the total
samples, the seconds, the Blender version, the row's title and the seed-against-seed figures.
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("rows", nargs="*", help="row ids (default: every row)")
    parser.add_argument("--samples", type=int, default=1024, help="Cycles samples per seed")
    parser.add_argument("--out", type=Path, default=None, help="folder (default tests/data/conformance)")
    args = parser.parse_args(argv)

    import bpy

    from tfm_addon.bench import conformance
    from tfm_addon.engine import metrics

    out = args.out or conformance.REF_DIR
    t_all = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="tfm_conformance_") as tmp:
        for row in conformance.rows(args.rows):
            folder = os.path.join(tmp, row.id)
            a, sa = conformance.render_cycles(row, folder, samples=args.samples, seed=1)
            b, sb = conformance.render_cycles(row, folder, samples=args.samples, seed=2)
            image = (a + b) / 2.0
            seed_ssim = metrics.ssim(a[..., :3], b[..., :3])
            seed_ratio = metrics.brightness_ratio(a[..., :3], b[..., :3])
            path = conformance.save_reference(
                row.id, image, out, samples=2 * args.samples, seeds="1,2", seconds=sa + sb,
                blender=bpy.app.version_string, title=row.title, seed_ssim=seed_ssim,
                seed_ratio=seed_ratio, width=image.shape[1], height=image.shape[0])
            print(f"{row.id}: {2 * args.samples} spp in {sa + sb:.1f} s; seed 1 vs 2: SSIM "
                  f"{seed_ssim:.4f}, brightness {seed_ratio:.4f}; {path.stat().st_size / 1024:.0f} KiB",
                  flush=True)
    print(f"all: {time.perf_counter() - t_all:.0f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
