"""The benchmark runs end to end at its quick size, and its outputs hold numbers that can
fail: one row per scene and method, density weighting beating a truncated series where it rings,
no TFM for homogeneous media or lights that miss the medium, Cycles converging.

One run of ``python -m tfm_addon.bench --quick`` in a subprocess (its own GL context and, for
Cycles/EEVEE, its own Blender process), with the numpy ground truths read from
tests/data/bench_cache (named by scene content; a missing one is rendered there)."""

from __future__ import annotations

import csv
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tfm_addon.bench import config as configs
from tfm_addon.bench.blender_bench import blender_available
from tfm_addon.bench.common import methods_for, safe_name
from tfm_addon.bench.scene_set import build

ROOT = Path(__file__).resolve().parents[1]
SCENES = ("smoke", "suzanne", "cloud", "gobo", "dense")


def _csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def bench(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("bench")
    proc = subprocess.run([sys.executable, "-m", "tfm_addon.bench", "--quick", "--out", str(out),
                           "--cache", str(ROOT / "tests" / "data" / "bench_cache")],
                          cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "[####" in proc.stderr, "the progress bar is missing"
    return out


@pytest.fixture(scope="module")
def results(bench) -> list[dict]:
    return _csv(bench / "results.csv")


def _row(rows, scene, method) -> dict:
    found = [r for r in rows if r["scene"] == scene and r["method"] == method]
    assert len(found) == 1, (scene, method)
    return found[0]


def test_outputs_exist(bench):
    for name in ("summary.md", "results.md", "results.csv", "counters.csv", "speed_accuracy_ssim.png",
                 "speed_accuracy_psnr.png", "table1.md", "table1.csv", "renderer.md",
                 "sweeps/sweeps.csv", "sweeps/sweeps.md", "sweeps/a_optical_depth_ssim.png",
                 "sweeps/b_alpha_ssim.png", "sweeps/c_angle_ssim.png", "sweeps/d_inside_ssim.png",
                 "sweeps/e_steps_ssim.png", "lights.md"):
        path = bench / name
        assert path.is_file() and path.stat().st_size > 0, name
    summary = (bench / "summary.md").read_text()
    assert "x15" in summary and "auto" in summary


def test_one_row_per_scene_and_method_with_its_images(bench, results):
    expected = {s.key: [m.name for m in methods_for(s.scene, configs.QUICK)] for s in build(configs.QUICK)}
    assert set(expected) == set(SCENES)
    for scene, names in expected.items():
        got = [r["method"] for r in results if r["scene"] == scene]
        assert got == names, scene
        for name in names:
            for suffix in (".exr", ".png", "_error.exr", "_error.png"):
                path = bench / "images" / scene / (safe_name(name) + suffix)
                assert path.is_file(), (scene, name, suffix)
    assert len(results) == sum(len(v) for v in expected.values())
    for r in results:
        seconds, ssim, psnr = float(r["seconds"]), float(r["ssim"]), float(r["psnr"])
        assert seconds > 0 and math.isfinite(seconds), r
        assert 0 < ssim <= 1, r
        assert psnr > 10 or math.isinf(psnr), r


def test_density_weighting_beats_a_short_series_where_it_rings(results):
    """The dense smoke (the paper's Fig. 7): 16 coefficients with alpha against 2 without."""
    weighted = float(_row(results, "dense", "TFM-16 α")["ssim"])
    ringing = float(_row(results, "dense", "TFM-2 no α")["ssim"])
    assert weighted >= ringing
    assert weighted >= 0.99
    # and on the sharp-edged volume, weighting helps at every coefficient count
    for n in (2, 4, 8):
        assert float(_row(results, "suzanne", f"TFM-{n} α")["ssim"]) > float(
            _row(results, "suzanne", f"TFM-{n} no α")["ssim"]), n


def test_what_was_built(bench, results):
    for r in results:
        if r["scene"] == "gobo":
            assert int(r["tfms_built"]) == 0, r          # homogeneous: analytic, no TFM
        elif r["method"].startswith(("brute force", "floor")):
            assert int(r["tfms_built"]) == 0, r       # floor: method UNSHADOWED builds no TFM
            if r["method"].startswith("floor"):
                assert float(r["vs_floor"]) == 1.0, r
        else:
            assert float(r["vs_floor"]) > 0, r
            assert int(r["tfms_built"]) == 1, r
    checks = _csv(bench / "counters.csv")
    away = [c for c in checks if "aimed away" in c["scene"]]
    assert len(away) == 4
    for c in away:                                       # two lights, one misses the medium
        assert (int(c["lights"]), int(c["tfms"])) == (2, 1), c
    gobo = [c for c in checks if c["scene"].startswith("gobo")]
    assert [int(c["tfms"]) for c in gobo] == [0]


def test_auto_row_reaches_its_target_on_the_smoke(results):
    auto = [r for r in results if r["family"] == "auto quality"]
    assert len(auto) == len(SCENES)
    smoke = next(r for r in auto if r["scene"] == "smoke")
    assert float(smoke["ssim"]) >= 0.99


def test_paper_table(bench):
    rows = _csv(bench / "table1.csv")
    for scene in ("smoke", "suzanne"):
        tfm = [r for r in rows if r["scene"] == scene and r["coefficients"]]
        assert sorted((int(r["coefficients"]), r["alpha"]) for r in tfm) == sorted(
            (n, a) for n in (4, 8, 16) for a in ("10", "auto", "1"))
    paper = next(r for r in rows if r["scene"] == "smoke" and r["coefficients"] == "8" and r["alpha"] == "10")
    assert float(paper["paper_ssim_pct"]) == pytest.approx(99.74)
    suz = {r["alpha"]: float(r["ssim_pct"]) for r in rows
           if r["scene"] == "suzanne" and r["coefficients"] == "4"}
    assert suz["auto"] > suz["1"]


def test_sweeps(bench):
    rows = _csv(bench / "sweeps" / "sweeps.csv")
    assert {r["sweep"] for r in rows} == {"a_optical_depth", "b_alpha", "c_angle", "d_inside", "e_steps"}
    # (a) at the thickest point the weighted series is at least as good as the plain one
    thick = max(float(r["x"]) for r in rows if r["sweep"] == "a_optical_depth")
    for n in (4, 8, 16):
        def at(label):
            return next(float(r["ssim"]) for r in rows if r["sweep"] == "a_optical_depth"
                        and r["scene"] == "Suzanne" and r["series"] == label and float(r["x"]) == thick)
        assert at(f"TFM-{n} α") >= at(f"TFM-{n} no α"), n
    # (c) homogeneous media build no TFM at any angle
    assert all(r["note"] == "TFMs built 0" for r in rows if r["sweep"] == "c_angle")
    # (d) every inside case renders close to the numpy reference with the brute force
    inside = [r for r in rows if r["sweep"] == "d_inside" and r["series"] == "brute force 100x100"]
    assert len(inside) == 4 and all(float(r["ssim"]) >= 0.99 for r in inside)


@pytest.mark.skipif(not blender_available(), reason="bpy is not installed")
def test_cycles_and_eevee(bench):
    rows = _csv(bench / "blender" / "blender.csv")
    cycles = {int(r["method"].split()[1]): float(r["ssim"]) for r in rows
              if r["family"] == "Cycles single scattering" and "ground truth" not in r["method"]}
    counts = sorted(cycles)
    assert counts == list(configs.QUICK.cycles_samples)
    assert cycles[counts[-1]] > cycles[counts[0]], "Cycles does not converge toward its ground truth"
    assert sum(r["family"] == "EEVEE, volume shadows" for r in rows) == len(configs.QUICK.eevee_runs)
    tfm8 = next(r for r in rows if r["method"] == "TFM-8 α")
    assert float(tfm8["ssim"]) >= 0.97            # against converged Cycles: the same physics
    assert abs(float(tfm8["brightness"]) - 1) <= 0.03
    assert (bench / "blender" / "images" / "TFM-8_alpha_error.png").is_file()


# The auto rule itself (tfm_addon.engine.quality): pure numpy, no GL.

def test_auto_rule_follows_optical_depth_sharpness_and_medium_kind():
    import dataclasses

    from tfm_addon import scenes
    from tfm_addon.engine import RenderSettings
    from tfm_addon.engine.quality import auto_coefficients, auto_settings, medium_stats

    thin = scenes.paper_smoke_scene(64, 36, 32)
    dense = scenes.dense_smoke_scene(64, 36, 32, thickness=30.0)
    assert medium_stats(dense).optical_depth == pytest.approx(30 * medium_stats(thin).optical_depth, rel=1e-6)
    base = RenderSettings(map_resolution=64, quality="AUTO")
    a_thin, a_dense = auto_settings(thin, base), auto_settings(dense, base)
    assert (a_thin.coefficients, a_dense.coefficients) == (2, 16)    # tau 1.4, 42; smooth (g 0.40): 0.6, 17
    assert a_thin.density_weight is None and a_dense.density_weight is None
    assert a_thin.map_resolution == 64 and a_thin == auto_settings(thin, base)      # pure, repeatable

    # A block of constant density: sharpness 1, half a step per voxel crossed.
    d = np.zeros((40, 40, 40), np.float32)
    d[4:36, 4:36, 4:36] = 1.0
    block = dataclasses.replace(thin, media=(dataclasses.replace(thin.media[0], density=d),))
    stats = medium_stats(block)
    assert stats.sharpness == pytest.approx(1.0)
    assert auto_settings(block, base).view_steps == max(32, math.ceil(0.5 * stats.view_voxels))
    assert auto_settings(block, base).light_steps == max(32, math.ceil(0.2 * stats.light_voxels))
    sharp = dataclasses.replace(block, media=(dataclasses.replace(block.media[0], sigma_s=(3.0, 3.0, 3.0)),))
    assert medium_stats(sharp).optical_depth > 2.0
    assert auto_settings(sharp, base).coefficients == auto_coefficients(medium_stats(sharp).optical_depth) > 2

    fog = scenes.gobo_box_scene(64, 36)
    a_fog = auto_settings(fog, base)
    assert (a_fog.sampling, a_fog.view_steps) == ("PROJECTIVE", 32)
    empty = dataclasses.replace(thin, media=())
    assert auto_settings(empty, base) == base


def test_viewport_section_times_every_edit_and_an_orbit_rebuilds_no_map(bench):
    import json

    data = json.loads((bench / "viewport.json").read_text())
    rows = data["rows"]
    edits = {r["edit"] for r in rows}
    assert {"camera orbit", "light move", "sigma change", "nothing changed"} <= edits
    for r in rows:
        if r["edit"] == "nothing changed":
            assert r["posted"] is False and r["tfms"] == 0
        else:
            assert 0 < r["first_ms"] <= r["full_ms"] <= r["converged_ms"], r
        if r["edit"] == "camera orbit":
            assert r["tfms"] == r["shadow_maps"] == r["grid_uploads"] == 0, r
        if r["edit"] == "light move":
            assert r["tfms"] >= 1 and r["grid_uploads"] == 0, r
    if blender_available():
        assert {e["edit"] for e in data["callbacks"]["edits"]} >= {"light move", "frame change (.vdb)"}


def test_the_readme_s_speed_sentence_is_written_from_the_method_table(results):
    from tfm_addon.bench import readme, summary

    rows = [dict(r, seconds=float(r["seconds"]), ssim=float(r["ssim"]),
                 vs_floor=float(r["vs_floor"]) if r["vs_floor"] else None) for r in results]
    text = summary.headline(rows)
    assert re.fullmatch(r"Auto cost \d+\.\d–\d+\.\d× the floor on \d scenes \(.+\), at SSIM ≥ 0\.\d{3}, "
                        r"and was \d+–\d+× faster than the double-march brute force", text), text
    assert "Auto cost" in readme.block("speed")         # the README holds the full run's sentence
