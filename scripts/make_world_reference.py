"""Render the Cycles references of the world-lit box (tfm_addon.scenes.world_lit_box_scene) into
tests/data/world_reference_<variant>.npz: a white world and an equirectangular sky.

    .venv/bin/python scripts/make_world_reference.py [--samples 1024]

Cycles single scattering (scene_builder.cycles_single_scattering: no bounces, the world's light
direct only), transparent film; the file keeps the RGB image (top row first), the samples, the
seconds and the Blender version.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
OUT = ROOT / "tests" / "data"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--samples", type=int, default=1024)
    args = parser.parse_args(argv)

    import bpy

    import tfm_addon
    from tfm_addon import scenes
    from tfm_addon.bench.conformance import _read_render
    from tfm_addon.blender import scene_builder

    tfm_addon.register()        # scene_builder sets the TFM engine's settings too
    for variant, env in (("white", None), ("sky", scenes.sky_environment())):
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = scenes.world_lit_box_scene(environment=env)
        with tempfile.TemporaryDirectory() as tmp:
            scene_builder.build(scene, tmp)
            if env is not None:
                nt = bpy.context.scene.world.node_tree
                bg = next(n for n in nt.nodes if n.bl_idname == 'ShaderNodeBackground')
                tex = nt.nodes.new('ShaderNodeTexEnvironment')
                h, w = env.shape[:2]
                image = bpy.data.images.new("Sky", w, h, float_buffer=True)
                # Blender's rows bottom first
                rgba = np.concatenate([env[::-1], np.ones((h, w, 1), np.float32)], axis=-1)
                image.pixels.foreach_set(rgba.ravel())
                tex.image = image
                nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
            scene_builder.cycles_single_scattering(bpy.context.scene, samples=args.samples)
            t0 = time.perf_counter()
            bpy.ops.render.render()
            seconds = time.perf_counter() - t0
            rgb = _read_render(tmp, variant)[..., :3]
        path = OUT / f"world_reference_{variant}.npz"
        np.savez_compressed(path, rgb=rgb.astype(np.float32), samples=args.samples, seconds=seconds,
                            blender=bpy.app.version_string)
        print(f"{variant}: {args.samples} spp in {seconds:.1f} s, mean {rgb.mean():.4f} -> {path}",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
