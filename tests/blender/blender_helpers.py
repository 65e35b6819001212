"""Helpers shared by the tests that run inside Blender."""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from tfm_addon import scenes
from tfm_addon.engine import RenderSettings, Scene

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# Where the tests install the extension: the add-on is the module bl_ext.<repo>.<id>.
REPO = "tfm_test"
EXTENSION_ID = "tfm_volumes"
MODULE = f"bl_ext.{REPO}.{EXTENSION_ID}"

# Small and quick on llvmpipe.
SETTINGS = RenderSettings(view_steps=64, light_steps=64, map_resolution=128, coefficients=8)


def read_passes(path: str) -> dict[str, np.ndarray]:
    """A multilayer EXR written by Blender (one part per pass) as {pass: (h, w, c) float32},
    top row first."""
    import OpenEXR

    out = {}
    with OpenEXR.File(path, separate_channels=True) as f:
        for part in f.parts:
            channels = part.channels
            names = sorted(channels, key=lambda k: "RGBA".index(k[-1]))
            out[part.name().split(".")[-1]] = np.stack(
                [np.asarray(channels[k].pixels, dtype=np.float32) for k in names], axis=-1)
    return out


def render_passes(directory, name: str = "render") -> dict[str, np.ndarray]:
    """bpy.ops.render.render() on the context scene; its Combined and passes as arrays."""
    import bpy

    scene = bpy.context.scene
    bpy.ops.render.render()
    settings = scene.render.image_settings
    settings.media_type = 'MULTI_LAYER_IMAGE'
    settings.file_format = 'OPEN_EXR_MULTILAYER'
    settings.color_depth = '32'
    path = os.path.join(str(directory), f"{name}.exr")
    bpy.data.images["Render Result"].save_render(path)
    return read_passes(path)


def crop_to_active(scene: Scene) -> Scene:
    """The scene with its density grid cropped to the non-zero voxels, as a .vdb file keeps it
    (zero voxels are inactive) and the add-on reads it back."""
    m = scene.media[0]
    nonzero = np.argwhere(m.density != 0)
    lo, hi = nonzero.min(axis=0), nonzero.max(axis=0) + 1
    shift = np.eye(4)
    shift[:3, 3] = lo
    medium = dataclasses.replace(m, density=m.density[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]],
                                 index_to_world=m.index_to_world @ shift)
    return dataclasses.replace(scene, media=(medium,))


def smoke(width=64, height=48, n=32, **kwargs) -> Scene:
    """The renderer's smoke test scene, cropped like a .vdb file crops it."""
    return crop_to_active(scenes.smoke_scene(width=width, height=height, n=n, **kwargs))


def against_cycles(directory, samples: int = 512) -> tuple[float, float, np.ndarray]:
    """The context scene rendered by TFM, then by Cycles with single scattering (``samples``):
    (SSIM, brightness ratio) of TFM against Cycles, and Cycles' Combined."""
    import bpy

    from tfm_addon.blender import scene_builder
    from tfm_addon.engine import metrics

    tfm = render_passes(directory, "tfm")["Combined"]
    scene_builder.cycles_single_scattering(bpy.context.scene, samples=samples)
    cycles = render_passes(directory, "cycles")["Combined"]
    return metrics.ssim(tfm, cycles), metrics.brightness_ratio(tfm, cycles), cycles
