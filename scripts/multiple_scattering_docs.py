"""The figures of docs/multiple_scattering.md: the error table against bounce count and the
picture of one cloud (TFM single scattering | TFM multiple scattering | Cycles with bounces), with
times and the cost of multiple scattering measured in this run.

    .venv/bin/python scripts/multiple_scattering_docs.py [--samples 256] [--table-only]

The README's sentence on the held-out media (between its ``multiple scattering`` marks) is written
from the table, its cost of multiple scattering (``multiple scattering cost``) from the picture's
frames.

Table: every medium of ``tfm_addon.bench.bounces`` at every stored bounce count: TFM at 0 bounces
(single scattering) and at N bounces (the octaves of ``engine/multiple_scattering.octaves``)
against the stored Cycles reference at N (tests/data/bounces, scripts/make_bounce_refs.py).
Picture: ``PICTURE_MEDIUM`` at 320x180 and ``PICTURE_BOUNCES`` bounces; the TFM times are the
fastest of ``REPEATS`` frames after the first (maps built), single and multiple scattering taking
turns, and the first frame of each; Cycles renders ``--samples`` samples.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

PICTURE_MEDIUM = "cumulus"
PICTURE_BOUNCES = 128
SIZE = (320, 180)
REPEATS = 4


def table(tmp: str, records: list | None = None) -> list[str]:
    """The error table's lines; ``records`` gets (medium, bounces, single (SSIM, brightness),
    multiple (SSIM, brightness)) per row."""
    from tfm_addon.bench import bounces as bn
    from tfm_addon.engine import metrics

    lines = ["| medium | fitted on | bounces | single scattering: SSIM | brightness | "
             "multiple scattering: SSIM | brightness |", "|---|---|---|---|---|---|---|"]
    for medium in (*bn.FIT, *bn.HELD_OUT):
        single = bn.render_tfm(medium, 0, os.path.join(tmp, medium)).image[..., :3]
        for n in bn.stored_counts(medium):
            cycles = bn.load_reference(medium, n)[0]
            multi = bn.render_tfm(medium, n, os.path.join(tmp, medium)).image[..., :3]
            s = (metrics.ssim(single, cycles), metrics.brightness_ratio(single, cycles))
            m = (metrics.ssim(multi, cycles), metrics.brightness_ratio(multi, cycles))
            line = (f"| {medium} | {'yes' if medium in bn.FIT else 'no'} | {n} | {s[0]:.4f} | {s[1]:.3f} | "
                    f"{m[0]:.4f} | {m[1]:.3f} |")
            print(line, flush=True)
            lines.append(line)
            if records is not None:
                records.append((medium, n, s, m))
    return lines


def readme_sentence(records: list, counts=(16, 128), cloud: str = "cumulus") -> str:
    """The README's figures of multiple scattering on the held-out media at ``counts`` bounces:
    the lowest SSIM and the largest brightness error against Cycles, and ``cloud``'s."""
    from tfm_addon.bench import bounces as bn

    held = [r for r in records if r[0] in bn.HELD_OUT and r[1] in counts]
    ssim = min(m[0] for _, _, _, m in held)
    error = max(abs(m[1] - 1.0) for _, _, _, m in held)
    text = (f"within SSIM {math.floor(ssim * 100) / 100:.2f} and {math.ceil(error * 100):.0f} % of "
            f"Cycles' brightness at {' and '.join(map(str, counts))} bounces")
    mine = sorted((r for r in held if r[0] == cloud), key=lambda r: r[1])
    if mine:
        text += (f" (the 40 m cloud: SSIM {' and '.join(f'{r[3][0]:.3f}' for r in mine)}, brightness "
                 f"{' and '.join(f'{r[3][1]:.2f}' for r in mine)}, where single scattering has "
                 f"{' and '.join(f'{r[2][1]:.2f}' for r in mine)} of it)")
    return text


def fields_time(size) -> tuple[float, float]:
    """The current scene's first frame at ``PICTURE_BOUNCES`` through a new engine renderer, and
    the part of it that built the diffused light and the surfaces' light (seconds)."""
    import bpy

    from tfm_addon.blender import extract as ex
    from tfm_addon.engine import Renderer

    e = ex.extract(bpy.context.evaluated_depsgraph_get(), size=size)
    settings = dataclasses.replace(ex.render_settings(bpy.context.scene), volume_bounces=PICTURE_BOUNCES)
    renderer = Renderer()
    try:
        out = renderer.render(e.scene(), settings)
    finally:
        renderer.release()
    return out.timings_s["total"], out.timings_s.get("fluence", 0.0)


def picture(tmp: str, samples: int, out: Path) -> list[str]:
    import bpy
    from PIL import Image, ImageDraw

    from tfm_addon.bench import bounces as bn
    from tfm_addon.bench import conformance as cf
    from tfm_addon.bench.common import display, white_of
    from tfm_addon.engine import metrics

    bn.build(PICTURE_MEDIUM, tmp, PICTURE_BOUNCES)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = SIZE
    scene.render.engine = 'TFM'
    scene.render.film_transparent = True
    scene.tfm.samples = cf.TFM_SAMPLES

    def tfm(bounces: int) -> tuple[np.ndarray, float]:
        scene.tfm.volume_bounces = bounces
        t0 = time.perf_counter()
        bpy.ops.render.render()
        return cf._read_render(tmp, f"tfm_{bounces}")[..., :3], time.perf_counter() - t0

    first = {n: tfm(n) for n in (0, PICTURE_BOUNCES)}
    engine_first, fields_s = fields_time(SIZE)
    warm: dict[int, list[float]] = {0: [], PICTURE_BOUNCES: []}
    images = {}
    for _ in range(REPEATS):
        for n in warm:
            images[n], seconds = tfm(n)
            warm[n].append(seconds)
    bn.cycles_with_bounces(scene, PICTURE_BOUNCES, samples)
    t0 = time.perf_counter()
    bpy.ops.render.render()
    cycles_s = time.perf_counter() - t0
    cycles = cf._read_render(tmp, "cycles")[..., :3]

    white = white_of(cycles)
    panels = [(images[0], f"TFM single scattering, {min(warm[0]):.2f} s"),
              (images[PICTURE_BOUNCES], f"TFM, {PICTURE_BOUNCES} bounces, "
                                        f"{min(warm[PICTURE_BOUNCES]):.2f} s"),
              (cycles, f"Cycles, {PICTURE_BOUNCES} volume bounces, {samples} spp, {cycles_s:.0f} s")]
    tiles = []
    for image, label in panels:
        tile = Image.fromarray((display(image, white) * 255 + 0.5).astype(np.uint8))
        ImageDraw.Draw(tile).text((4, 4), label, fill=(255, 255, 255))
        tiles.append(tile)
    strip = Image.new("RGB", (3 * SIZE[0] + 8, SIZE[1]), (255, 255, 255))
    for i, tile in enumerate(tiles):
        strip.paste(tile, (i * (SIZE[0] + 4), 0))
    out.parent.mkdir(parents=True, exist_ok=True)
    strip.save(out, optimize=True)
    ss, ms = ((metrics.ssim(images[n], cycles), metrics.brightness_ratio(images[n], cycles))
              for n in (0, PICTURE_BOUNCES))
    lines = [
        f"- {PICTURE_MEDIUM} at {SIZE[0]}x{SIZE[1]} against Cycles at {PICTURE_BOUNCES} volume bounces "
        f"({samples} spp, {cycles_s:.1f} s): single scattering SSIM {ss[0]:.4f}, brightness {ss[1]:.3f}; "
        f"multiple scattering SSIM {ms[0]:.4f}, brightness {ms[1]:.3f}.",
        f"- TFM frame (Auto quality, 16 samples), fastest of {REPEATS} after the first: single scattering "
        f"{min(warm[0]):.3f} s, {PICTURE_BOUNCES} bounces {min(warm[PICTURE_BOUNCES]):.3f} s: "
        f"**{min(warm[PICTURE_BOUNCES]) / min(warm[0]):.2f}×**; first frames (maps built) "
        f"{first[0][1]:.2f} s and {first[PICTURE_BOUNCES][1]:.2f} s; a new renderer's first frame at "
        f"{PICTURE_BOUNCES} bounces {engine_first:.2f} s, of which the lattice's fields {fields_s:.2f} s.",
    ]
    print("\n".join(lines), flush=True)
    from tfm_addon.bench import readme

    readme.write_block("multiple scattering cost",
                       f"{min(warm[PICTURE_BOUNCES]) / min(warm[0]):.2f}× single scattering (the lattice's "
                       f"fields built once, in {fields_s:.2f} s)")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--samples", type=int, default=256, help="Cycles samples of the picture")
    parser.add_argument("--table-only", action="store_true")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "multiple_scattering.png")
    args = parser.parse_args(argv)

    import bpy  # noqa: F401

    import tfm_addon
    from tfm_addon.bench import readme

    tfm_addon.register()
    try:
        with tempfile.TemporaryDirectory(prefix="tfm_ms_docs_") as tmp:
            records: list = []
            lines = table(tmp, records)
            readme.write_block("multiple scattering", readme_sentence(records))
            if not args.table_only:
                lines += [""] + picture(tmp, args.samples, args.out)
    finally:
        tfm_addon.unregister()
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
