"""summary.md: the benchmark's targets, met or missed and by how much, with the figures behind them."""

from __future__ import annotations

import math

from .common import AUTO, BRUTE, TFM_ALPHA, fmt, markdown_table


def tfm8_target(rows: list[dict], table1: list[dict]) -> list[str]:
    """TFM-8 with alpha at least 15x faster than the 100x100 brute force, at SSIM >= 0.99 on the
    smoke and >= 0.98 on the sharp 256^3 volume."""
    out = []
    for scene, floor in (("smoke", 0.99), ("suzanne", 0.98), ("dense", 0.99), ("cloud", 0.99)):
        t8 = next((r for r in rows if r["scene"] == scene and r["method"] == "TFM-8 α"), None)
        bf = next((r for r in rows if r["scene"] == scene and r["method"] == "brute force 100x100"), None)
        if t8 is None or bf is None:
            continue
        speed = bf["seconds"] / t8["seconds"]
        t1 = next((r for r in table1
                   if r["scene"] == scene and r["coefficients"] == 8 and r["alpha"] == "auto"), None)
        ssim_ok = t8["ssim"] >= floor
        short = floor - t8["ssim"]
        line = (f"{t8['scene_title']}: TFM-8 α {t8['seconds'] * 1000:.0f} ms vs brute force 100x100 "
                f"{bf['seconds'] * 1000:.0f} ms = x{speed:.2f} (target x15: "
                f"{'met' if speed >= 15 else f'missed by x{15 / speed:.1f}'}); SSIM {t8['ssim']:.4f} against "
                f"the ground truth (target {floor}: {'met' if ssim_ok else f'missed by {short:.4f}'})")
        if t1 is not None:
            line += f", {t1['ssim_pct'] / 100:.4f} against the 100x100 brute force"
        if scene in ("dense", "cloud"):
            line += " (not a target scene; for comparison)"
        out.append(line + ".")
    return out


def auto_lines(rows: list[dict]) -> list[str]:
    out = []
    table = []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        srows = [r for r in rows if r["scene"] == scene]
        auto = next((r for r in srows if r["family"] == AUTO), None)
        if auto is None:
            continue
        # The cheapest row of any TFM/brute-force/homogeneous setting reaching 0.99.
        ok = [r for r in srows if r["ssim"] >= 0.99]
        cheapest = min(ok, key=lambda r: r["seconds"]) if ok else None
        bf = next((r for r in srows if r["method"] == "brute force 100x100"), None)
        table.append([auto["scene_title"], auto["method"], fmt(auto["seconds"] * 1000, ".0f"),
                      fmt(auto["ssim"], ".4f"), "yes" if auto["ssim"] >= 0.99 else "NO",
                      str(auto["tfms_built"]),
                      f"{cheapest['method']} ({cheapest['seconds'] * 1000:.0f} ms)" if cheapest else "none",
                      fmt(bf["seconds"] / auto["seconds"], ".2f") + "x" if bf else "–"])
    if table:
        out.append(markdown_table(["scene", "auto picked", "ms/frame", "SSIM", "≥ 0.99", "TFMs built",
                                   "cheapest row ≥ 0.99", "vs BF 100²"], table))
    return out


def headline(rows: list[dict]) -> str:
    """The README's sentence on speed: what Auto costs against the floor (the same frame with light
    transmittance 1) and against the 100x100 brute force, at the lowest SSIM Auto reached, over
    the scenes of the method table that build maps (a homogeneous medium builds none)."""
    floors, brute, ssims, titles = [], [], [], []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        srows = [r for r in rows if r["scene"] == scene]
        auto = next((r for r in srows if r["family"] == AUTO), None)
        bf = next((r for r in srows if r["method"] == "brute force 100x100"), None)
        if auto is None or not int(auto.get("tfms_built") or 0) or not auto.get("vs_floor"):
            continue
        floors.append(float(auto["vs_floor"]))
        ssims.append(float(auto["ssim"]))
        titles.append(auto.get("scene_title") or scene)
        if bf is not None:
            brute.append(float(bf["seconds"]) / float(auto["seconds"]))
    if not floors:
        return "no scene of the method table built maps"
    text = (f"Auto cost {min(floors):.1f}–{max(floors):.1f}× the floor on {len(titles)} scenes "
            f"({', '.join(titles)}), at SSIM ≥ {math.floor(min(ssims) * 1000) / 1000:.3f}")
    if brute:
        text += f", and was {min(brute):.0f}–{max(brute):.0f}× faster than the double-march brute force"
    return text


def write(path, *, config, machine, seconds, rows, checks, table1, blender_res, blender_targets,
          sweeps_done, renderer_text) -> str:
    lines = [f"# Benchmark summary ({config.name} run)", "",
             f"Machine: {machine}. Total time {seconds / 60:.1f} min. Every ratio below is measured "
             "in this one run (interleaved repetitions).", ""]
    for note in config.caps:
        lines.append(f"- Capped: {note}")
    lines += ["", "![speed against accuracy](speed_accuracy_ssim.png)", "", "## Targets", ""]
    lines += [f"- {t}" for t in tfm8_target(rows, table1)]
    if blender_targets:
        lines += [f"- {t}" for t in blender_targets]
    elif config.blender:
        lines.append("- Cycles/EEVEE targets: not measured (Blender part skipped or failed).")
    lines += ["", "## The auto quality setting, as its own row", ""]
    if rows:
        lines += [headline(rows) + ".", ""]
    lines += auto_lines(rows)
    lines += ["", "## Builds (renderer counters)", ""]
    lines += [f"- {c['scene']}: {c['lights']} light(s), {c['tfms']} TFM(s) built, {c['shadow_maps']} shadow "
              f"map(s)" for c in checks]
    fam = {}
    for r in rows:
        if r["family"] in (TFM_ALPHA, BRUTE):
            fam.setdefault(r["scene"], []).append(r)
    lines += ["", "Files: `results.md`/`results.csv` (method table), `table1.md` (the paper's Table 1), "
              "`sweeps/sweeps.md` (stability), `blender/blender.md` (Cycles, EEVEE), `renderer.md` "
              "(full frames and camera-only re-renders), `images/<scene>/` (EXR and PNG of every render and "
              "of its error).", ""]
    if renderer_text:
        lines += ["## The renderer table (renderer_bench)", "", renderer_text, ""]
    text = "\n".join(lines)
    path.write_text(text + "\n")
    return text


def finite(x) -> bool:
    return isinstance(x, float) and math.isfinite(x)
