"""scripts/demo.py --fire renders a burning plume through Blender."""

import os
import subprocess
import sys

import numpy as np

from tfm_addon.engine.exr import read_exr

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_fire_demo_glows(tmp_path):
    proc = subprocess.run(
        [sys.executable, os.path.join(ROOT, "scripts", "demo.py"), "--fire", "--out", str(tmp_path),
         "--width", "96", "--height", "54", "--grid", "24", "--direct"],
        capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "burning plume" in proc.stdout and "frame time" in proc.stdout, proc.stdout
    assert "not rendered" not in proc.stdout, proc.stdout
    layers = read_exr(tmp_path / "tfm_fire.exr")
    scatter = np.stack([layers[f"ViewLayer.Scattering.{c}"] for c in "RGB"], axis=-1)
    # The flame's own light: warm (red well above blue) and bright where the fire burns.
    assert scatter[..., 0].sum() > 1.5 * scatter[..., 2].sum()
    assert scatter.max() > 0.1 and np.isfinite(scatter).all()
    assert os.path.getsize(tmp_path / "tfm_fire.png") > 0
