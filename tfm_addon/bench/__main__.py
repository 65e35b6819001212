"""``python -m tfm_addon.bench [--quick] [--out DIR]``: run the benchmarks, print and save tables."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from . import renderer_bench


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tfm_addon.bench", description=__doc__)
    parser.add_argument("--quick", action="store_true", help="tiny sizes, for the tests")
    parser.add_argument("--paper", action="store_true",
                        help="the paper's 1280x720 with 1024^2 maps, against brute force (for a GPU)")
    parser.add_argument("--out", type=Path, default=Path("out/bench"), help="output folder")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    size = renderer_bench.QUICK if args.quick else renderer_bench.PAPER if args.paper else renderer_bench.FULL
    rows = renderer_bench.run(size, log=lambda m: print(m, file=sys.stderr))
    text = renderer_bench.report(rows)
    (args.out / "renderer.md").write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
