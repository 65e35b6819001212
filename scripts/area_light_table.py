"""The area-light error table of docs/architecture.md: the conformance suite's smoke and ground lit
by area lights of several shapes, sizes and distances, rendered by Cycles (single scattering) and
by TFM (the add-on's defaults), SSIM and brightness ratio of TFM against Cycles.

    .venv/bin/python scripts/area_light_table.py [--samples 512]
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

# (shape, size, size_y, location of the light; it is aimed at the smoke's centre)
CASES = (("SQUARE", 0.5, 0.5, (1.8, -1.8, 1.7)), ("SQUARE", 1.5, 1.5, (1.4, -1.4, 1.5)),
         ("RECTANGLE", 2.0, 1.0, (1.0, -1.0, 1.1)), ("DISK", 1.0, 1.0, (1.2, -1.2, 1.3)),
         ("ELLIPSE", 2.0, 0.5, (1.2, -1.2, 1.3)))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--samples", type=int, default=512)
    args = parser.parse_args(argv)
    import numpy as np

    import tfm_addon
    from tfm_addon.bench import conformance

    tfm_addon.register()
    print("| shape | size (m) | distance to the smoke's centre (m) | SSIM | brightness TFM / Cycles |")
    print("|---|---|---|---|---|")
    try:
        for shape, sx, sy, loc in CASES:
            def build(tmpdir, shape=shape, sx=sx, sy=sy, loc=loc):
                mat, nt, out = conformance.material()
                conformance.principled(nt, out)
                conformance.base(lights=None)
                area = conformance.light('AREA', loc, energy=300.0)
                area.data.shape, area.data.size, area.data.size_y = shape, sx, sy
                conformance.volume_object(tmpdir, mat=mat)

            row = conformance.Row(id=f"area_{shape.lower()}_{sx}x{sy}", title="", build=build)
            with tempfile.TemporaryDirectory() as tmp:
                cycles, _ = conformance.render_cycles(row, os.path.join(tmp, "c"), samples=args.samples,
                                                      seed=1)
                tfm = conformance.render_tfm(row, os.path.join(tmp, "t"))
            c = conformance.compare(row, tfm.image, cycles[..., :3])
            size = f"{sx} × {sy}" if shape in ('RECTANGLE', 'ELLIPSE') else f"{sx}"
            print(f"| {shape.lower()} | {size} | {float(np.linalg.norm(loc)):.1f} | {c.ssim:.4f} | "
                  f"{c.ratio_text()} |", flush=True)
    finally:
        tfm_addon.unregister()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
