"""``python -m tfm_addon.bench [--quick | --gpu] [--out DIR] [--only SECTION ...] [--no-blender]``

Runs the benchmark and writes everything under one folder (default out/bench):
summary.md, the method table (results.md/.csv) with its speed-accuracy charts, the paper's
Table 1, the stability sweeps, Cycles and EEVEE, the renderer table, and EXR/PNG images of every
render and of its error. A progress bar runs on stderr; the summary is printed at the end.

--quick: small sizes, for the tests (about a minute on 2 cores with llvmpipe; half that with
--cache tests/data/bench_cache, the ground truths the tests keep).
--only conformance (run only when named): the conformance suite against Cycles, every row of
tfm_addon/bench/conformance.py rendered by TFM and compared with its stored Cycles reference, written
to docs/conformance.md and docs/conformance/ (a Blender subprocess; about 10 s).
--only peers (run only when named): time to quality against Cycles with OpenImageDenoise and EEVEE
(tfm_addon/bench/peers.py), SSIM against seconds per scene at 320x180 and 1920x1080, written to
<out>/peers/ and, with the README's chart, docs/peers/; --quick: 320x180 only, fewer samples.
--only flicker (run only when named): frame-to-frame change of the still pixels of an evolving
smoke's frame sequence, TFM Auto against Cycles with OpenImageDenoise (tfm_addon/bench/flicker.py),
with Auto's choices by frame, written to <out>/flicker/ and the README; --quick: 4 frames.
--gpu (alias --paper): the renderer part only, at the paper's 1280x720 with 1024^2 maps, no
Blender and no numpy reference (the ground truth is the GPU brute force at one step per voxel).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

SECTIONS = ("methods", "table1", "sweeps", "blender", "renderer", "emission", "viewport", "lights")
# Run only when named with --only: the conformance suite against Cycles writes docs/conformance.md
# and docs/conformance/ (tfm_addon/bench/conformance.py, in a Blender subprocess).
OPT_IN = ("conformance", "peers", "flicker")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tfm_addon.bench", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    size = parser.add_mutually_exclusive_group()
    size.add_argument("--quick", action="store_true", help="tiny sizes, for the tests")
    size.add_argument("--gpu", "--paper", dest="gpu", action="store_true",
                      help="the paper's 1280x720 with 1024^2 maps, renderer only (for a GPU machine)")
    parser.add_argument("--out", type=Path, default=Path("out/bench"), help="output folder")
    parser.add_argument("--only", nargs="+", choices=SECTIONS + OPT_IN,
                        help="run these sections only (conformance: only when named here)")
    parser.add_argument("--scenes", nargs="+", choices=("smoke", "suzanne", "cloud", "gobo", "dense"),
                        help="method-table scenes (default: all five)")
    parser.add_argument("--size", metavar="WxH",
                        help="override the image size of the method table and Table 1 (e.g. to try a "
                             "--gpu run on a slow machine)")
    parser.add_argument("--no-blender", action="store_true", help="skip Cycles and EEVEE")
    parser.add_argument("--no-cache", action="store_true",
                        help="recompute ground truths even if the cache folder holds them")
    parser.add_argument("--cache", type=Path, default=None,
                        help="the folder of ground truths kept between runs, named by scene content "
                             "(default <out>/cache)")
    args = parser.parse_args(argv)

    from ..engine import Renderer
    from . import (
        blender_bench,
        methods_table,
        paper_table,
        readme,
        renderer_bench,
        scene_set,
        summary,
        sweeps,
    )
    from . import config as configs
    from .charts import have_matplotlib, speed_accuracy
    from .common import machine_line
    from .progress import Progress

    config = configs.QUICK if args.quick else configs.GPU if args.gpu else configs.FULL
    if args.size:
        w, h = (int(v) for v in args.size.lower().split("x"))
        config = dataclasses.replace(config, width=w, height=h, cloud_width=w, cloud_height=h,
                                     caps=config.caps + (f"images {w}x{h} (--size)",))
    sections = set(args.only or SECTIONS)
    if args.no_blender or not config.blender:
        sections.discard("blender")
    if "blender" in sections and not blender_bench.blender_available():
        print("bpy is not installed: Cycles and EEVEE are skipped", file=sys.stderr)
        sections.discard("blender")
    if "conformance" in sections:
        sections.discard("conformance")
        rc = run_conformance()
        if not sections:
            return rc
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    cache = None if args.no_cache else args.cache or out / "cache"
    if "peers" in sections:
        sections.discard("peers")
        from . import peers

        peers.publish(peers.run(out, args.quick, cache), quick=args.quick)
        if not sections:
            return 0
    if "flicker" in sections:
        sections.discard("flicker")
        from . import flicker

        flicker.publish(flicker.run(out, args.quick), quick=args.quick)
        if not sections:
            return 0
    t_start = time.perf_counter()

    renderer = Renderer()
    machine = machine_line(renderer)
    print(f"{config.name} run on {machine}; sections: {', '.join(s for s in SECTIONS if s in sections)}; "
          f"output: {out}", file=sys.stderr)
    bench_scenes = []
    if sections & {"methods", "table1"}:
        only = set(args.scenes) if args.scenes else None
        if "methods" not in sections:
            only = {"smoke", "suzanne", "dense"}
        bench_scenes = scene_set.build(config, only)
    total = 0
    if "methods" in sections:
        total += methods_table.count(config, bench_scenes) + len(bench_scenes)
    if "table1" in sections:
        total += paper_table.count(bench_scenes)
    if "sweeps" in sections:
        total += sweeps.count(config)
    if "blender" in sections:
        total += blender_bench.count(config)
    if "renderer" in sections:
        total += 1
    if "viewport" in sections:
        total += 1
    progress = Progress(total)

    rows, checks, table1_rows, blender_res, blender_targets, renderer_text = [], [], [], None, [], ""
    viewport_text = ""
    if "methods" in sections:
        rows, _ = methods_table.run(config, bench_scenes, renderer, out, progress, cache)
        checks = methods_table.counter_checks(config, bench_scenes, renderer)
        progress.step("counters", n=len(bench_scenes))
        methods_table.write(rows, checks, bench_scenes, out, config, machine)
        title = f"{config.name} run, {machine.split(' (')[0]}"
        if have_matplotlib():
            speed_accuracy(rows, out / "speed_accuracy_ssim.png", "ssim", title=title)
            speed_accuracy(rows, out / "speed_accuracy_psnr.png", "psnr", title=title)
        else:
            progress.log("matplotlib is not installed: no charts, no PNG images")
    if "table1" in sections:
        table1_rows = paper_table.run(config, bench_scenes, renderer, out, progress)
        paper_table.write(table1_rows, out, config, machine)
    if "sweeps" in sections and config.sweep and have_matplotlib():
        sweep_rows = sweeps.run(config, renderer, out, progress, cache)
        sweeps.write(sweep_rows, out, config)
    if "blender" in sections:
        try:
            blender_res = blender_bench.run(config, renderer, out, progress, cache)
            blender_bench.write(blender_res, out, config, machine)
            blender_targets = blender_bench.targets(blender_res)
        except Exception as ex:  # the renderer's figures stay useful without Blender's
            progress.log(f"Blender part failed: {ex}")
    renderer.release()
    if "renderer" in sections:
        size = (renderer_bench.QUICK if args.quick else renderer_bench.PAPER if args.gpu
                else renderer_bench.FULL)
        renderer_rows = renderer_bench.run(size, log=progress.log)
        renderer_text = renderer_bench.report(renderer_rows)
        (out / "renderer.md").write_text(renderer_text + "\n")
        progress.step("renderer table")
    if "emission" in sections:
        from . import emission_bench

        size = (emission_bench.QUICK if args.quick else emission_bench.PAPER if args.gpu
                else emission_bench.FULL)
        emission_rows = emission_bench.run(size, log=progress.log)
        edits = emission_bench.edit_rows(size, log=progress.log)
        (out / "emission.md").write_text(emission_bench.report(emission_rows) + "\n\n"
                                         + emission_bench.edit_report(edits) + "\n")
    if "viewport" in sections:
        from . import viewport_bench

        viewport_text = viewport_bench.run(args.quick, out, log=progress.log,
                                           blender=not args.no_blender and blender_bench.blender_available())
        progress.step("viewport")
    if "lights" in sections:
        from . import lights_bench

        size = lights_bench.QUICK if args.quick else lights_bench.PAPER if args.gpu else lights_bench.FULL
        lights_rows = lights_bench.run(size, log=progress.log)
        (out / "lights.md").write_text(lights_bench.report(lights_rows) + "\n")
    progress.close()
    text = summary.write(out / "summary.md", config=config, machine=machine,
                         seconds=time.perf_counter() - t_start, rows=rows, checks=checks, table1=table1_rows,
                         blender_res=blender_res, blender_targets=blender_targets,
                         sweeps_done="sweeps" in sections, renderer_text=renderer_text)
    if viewport_text:
        text += "\n" + viewport_text + "\n"
        (out / "summary.md").write_text(text)
    if config is configs.FULL and rows and "methods" in sections:   # the README's figure, from this run
        readme.write_block("speed", summary.headline(rows))
    print(text)
    return 0


def run_conformance() -> int:
    """``python -m tfm_addon.bench.conformance`` in a Blender process of its own (as blender_side
    runs Cycles): every conformance row rendered by TFM against its stored Cycles reference, written
    to docs/conformance.md and docs/conformance/<row>.png."""
    import os
    import subprocess

    from . import blender_bench

    if not blender_bench.blender_available():
        print("bpy is not installed: the conformance suite is skipped", file=sys.stderr)
        return 1
    root = str(Path(__file__).resolve().parents[2])
    env = dict(os.environ)
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    done = subprocess.run([sys.executable, "-m", "tfm_addon.bench.conformance"], env=env, cwd=root,
                          timeout=3600)
    return done.returncode


if __name__ == "__main__":
    sys.exit(main())
