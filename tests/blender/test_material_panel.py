"""Sigma from a Principled Volume material renders like the same sigma typed into the panel."""


import numpy as np
import pytest
from blender_helpers import SETTINGS, render_passes, smoke

from tfm_addon.blender import scene_builder


def test_principled_volume_equals_panel_sigma(blank, tmp_path):
    sigma_a, sigma_s = (0.3, 0.2, 0.1), (1.2, 1.6, 2.0)
    scene = smoke(width=64, height=48, n=32, sigma_a=sigma_a, sigma_s=sigma_s)
    made = scene_builder.build(scene, str(tmp_path), settings=SETTINGS)
    volume = made["medium"].data
    # The material says: Principled Volume with density, colour and absorption colour.
    node = volume.materials[0].node_tree.nodes["Principled Volume"]
    assert node.inputs["Density"].default_value == pytest.approx(2.1)  # max of sigma_a + sigma_s
    volume.tfm.use_node_material = True
    from_material = render_passes(tmp_path, "material")
    # The panel says the same sigma, and the material is ignored.
    volume.tfm.use_node_material = False
    volume.tfm.sigma_a, volume.tfm.sigma_s, volume.tfm.density_scale = sigma_a, sigma_s, 1.0
    from_panel = render_passes(tmp_path, "panel")
    # And a different sigma in the panel does change the image (the switch is live).
    volume.tfm.sigma_s = (0.5, 0.5, 0.5)
    other = render_passes(tmp_path, "other")
    for name in ("Combined", "Scattering", "Transmittance"):
        diff = float(np.abs(from_material[name] - from_panel[name]).max())
        assert diff <= 1e-5 * max(1.0, float(from_panel[name].max())), f"{name}: {diff:.2e}"
    assert float(np.abs(other["Combined"] - from_panel["Combined"]).max()) > 0.05
