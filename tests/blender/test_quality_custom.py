"""Quality Auto → Custom: Custom starts from what Auto chose for the last render, so the first
Custom render is Auto's picture at Auto's cost (not Custom's own 100 steps, 100 shadow steps and 8
coefficients)."""

import bpy
import numpy as np

from tfm_addon.bench import conformance
from tfm_addon.engine import metrics


def test_custom_starts_from_auto_s_choice(blank, tmp_path):
    row = conformance.ROW_BY_ID["density_5"]
    auto = conformance.render_tfm(row, str(tmp_path / "auto"))
    chosen = conformance.final_render_module().auto_choices[bpy.context.scene.name]
    tfm = bpy.context.scene.tfm
    assert (tfm.view_steps, tfm.light_steps, tfm.coefficients) == (100, 100, 8)      # Custom's own
    assert (chosen["view_steps"], chosen["light_steps"]) != (100, 100)
    tfm.quality = 'CUSTOM'
    assert (tfm.view_steps, tfm.light_steps, tfm.coefficients) == (
        chosen["view_steps"], chosen["light_steps"], chosen["coefficients"])
    bpy.ops.render.render()
    custom = conformance._read_render(str(tmp_path), "custom")
    print(f"Auto {chosen}; Custom from it: SSIM {metrics.ssim(custom, auto.image):.5f}")
    assert metrics.ssim(custom[..., :3], auto.image[..., :3]) >= 0.995
    assert abs(metrics.brightness_ratio(custom[..., :3], auto.image[..., :3]) - 1.0) <= 0.01
    assert np.isfinite(custom).all()


def test_custom_keeps_its_values_without_an_auto_render(blank, tmp_path):
    # a render's choice belongs to its file: File ▸ New (the fixture) forgets it
    conformance.render_tfm(conformance.ROW_BY_ID["density_5"], str(tmp_path))
    assert conformance.final_render_module().auto_choices
    bpy.ops.wm.read_homefile(use_empty=True)
    assert not conformance.final_render_module().auto_choices
    tfm = bpy.context.scene.tfm
    tfm.view_steps = 77
    tfm.quality = 'CUSTOM'
    assert tfm.view_steps == 77
