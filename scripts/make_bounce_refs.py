"""Render Cycles references with volume bounces into tests/data/bounces/<medium>_<N>.npz.

    .venv/bin/python scripts/make_bounce_refs.py [MEDIUM ...] [--bounces 2 16 128] [--samples 256]

Each reference is the mean of two Cycles renders of ``--samples`` samples (seeds 1 and 2) of a
medium of ``tfm_addon.bench.bounces.MEDIA`` with ``volume_bounces`` = ``max_bounces`` = N (every
other bounce kind 0, BLENDER.md's film settings). The two halves are compared with each other
(SSIM, brightness ratio) as the convergence check and kept in the file with the samples, seconds
and Blender version.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("media", nargs="*", help="media (default: every medium)")
    parser.add_argument("--bounces", type=int, nargs="+", default=[2, 16, 128])
    parser.add_argument("--samples", type=int, default=256, help="Cycles samples per seed")
    parser.add_argument("--skip-existing", action="store_true")
    args = parser.parse_args(argv)

    import bpy

    from tfm_addon.bench import bounces as bn
    from tfm_addon.bench import conformance as cf
    from tfm_addon.engine import metrics

    with tempfile.TemporaryDirectory(prefix="tfm_bounces_") as tmp:
        for medium in args.media or list(bn.MEDIA):
            for n in args.bounces:
                if args.skip_existing and bn.reference_path(medium, n).exists():
                    continue
                folder = os.path.join(tmp, f"{medium}_{n}")
                a, sa = bn.render_cycles(medium, n, folder, args.samples, seed=1)
                b, sb = bn.render_cycles(medium, n, folder, args.samples, seed=2)
                image = (a + b) / 2.0
                seed_ssim = metrics.ssim(a[..., :3], b[..., :3])
                seed_ratio = metrics.brightness_ratio(a[..., :3], b[..., :3])
                path = cf.save_reference(
                    f"{medium}_{n}", image, bn.REF_DIR, samples=2 * args.samples, seeds="1,2",
                    seconds=sa + sb, blender=bpy.app.version_string, title=bn.MEDIA[medium][1],
                    bounces=n, seed_ssim=seed_ssim, seed_ratio=seed_ratio)
                print(f"{medium} at {n} bounces: {2 * args.samples} spp in {sa + sb:.1f} s; seed 1 vs 2: "
                      f"SSIM {seed_ssim:.4f}, brightness {seed_ratio:.4f}; {path.name}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
