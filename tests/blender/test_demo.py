"""The README's main job: scripts/demo.py renders the demo scene through Blender."""

import os
import re
import subprocess
import sys

import numpy as np

from tfm_addon.engine.exr import read_exr

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_demo_writes_a_lit_plume_and_reports_the_frame_time(tmp_path):
    proc = subprocess.run(
        [sys.executable, os.path.join(ROOT, "scripts", "demo.py"), "--out", str(tmp_path), "--width", "96",
         "--height", "54", "--grid", "24", "--direct"],
        capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert re.search(r"frame time: \d+\.\d+ s", proc.stdout), proc.stdout
    # at the add-on's defaults: quality Auto (its choice printed) and the default samples
    assert re.search(r"^quality: Auto quality: Steps \d+", proc.stdout, re.M), proc.stdout
    assert re.search(r"^scene: 96x54, 16 samples", proc.stdout, re.M), proc.stdout
    assert os.path.getsize(tmp_path / "tfm_demo.png") > 0
    layers = read_exr(tmp_path / "tfm_demo.exr")
    scatter = np.stack([layers[f"ViewLayer.Scattering.{c}"] for c in "RGB"], axis=-1)
    combined = np.stack([layers[f"ViewLayer.Combined.{c}"] for c in "RGBA"], axis=-1)
    assert scatter.shape[:2] == (54, 96)
    # The plume scatters light toward the camera, and the lit ground is brighter than the smoke.
    assert (scatter.max(axis=-1) > 1e-3).mean() > 0.02
    assert np.isfinite(combined).all() and combined[..., :3].max() > scatter.max()
