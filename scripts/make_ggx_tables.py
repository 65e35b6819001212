"""Compute the microfacet tables the surface shader reads (tfm_addon/engine/surface.py) into
tfm_addon/engine/data/ggx_tables.npz.

    .venv/bin/python scripts/make_ggx_tables.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def main() -> int:
    from tfm_addon.engine import surface

    t0 = time.perf_counter()
    tables = surface.compute_ggx_tables()
    surface.TABLES.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(surface.TABLES, **tables)
    print(f"{surface.TABLES}: {', '.join(f'{k} {v.shape}' for k, v in tables.items())} "
          f"in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
