"""Render the README's pictures, TFM beside Cycles, each with its render time:

- ``--scene shaft`` (the first picture): a spot's beam through fog with a bar's shadow shaft over
  a ground (docs/readme_shaft.png);
- ``--scene sky``: a smoke under Blender's default Sky Texture with a Sun lamp along the sky's
  sun, seen against the sky (the conformance row ``world_sky_sun_seen`` at this size;
  docs/readme_sky.png).

    .venv/bin/python scripts/readme_picture.py [--scene shaft|sky] [--size 480x270] [--cycles-samples 256]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def _shaft(w: int, h: int, tmp: str) -> None:
    """The spot's beam through the World's fog, a bar and a crate over a ground."""
    import bpy

    from tfm_addon import scenes
    from tfm_addon.blender import scene_builder as sb
    from tfm_addon.engine import Camera, Light, Scene

    light = Light(matrix_world=scenes.look_at((-2.2, -0.8, 5.0), (0.4, 0.3, 0.0)), power_w=4000.0,
                  spot_size_rad=math.radians(38), spot_blend=0.2)
    meshes = (scenes.box_mesh((-1.15, -0.45, 3.4), (0.16, 1.4, 0.16), name="Bar"),
              scenes.box_mesh((1.2, 1.0, 0.5), (1.0, 1.0, 1.0), color=(0.7, 0.5, 0.3), name="Crate"),
              scenes.plane_mesh((0, 0, 0), 14.0, color=(0.6, 0.6, 0.6)))
    camera = Camera(matrix_world=scenes.look_at((6.0, -7.0, 2.4), (0.0, 0.0, 1.6)), width_px=w, height_px=h,
                    lens_mm=32.0)
    sb.build(Scene(camera=camera, lights=(light,), meshes=meshes), tmp)
    nt = bpy.context.scene.world.node_tree
    out = next(n for n in nt.nodes if n.bl_idname == 'ShaderNodeOutputWorld')
    fog = nt.nodes.new('ShaderNodeVolumeScatter')
    fog.inputs["Density"].default_value = 0.08
    nt.links.new(fog.outputs[0], out.inputs["Volume"])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", choices=("shaft", "sky"), default="shaft")
    parser.add_argument("--size", default="480x270")
    parser.add_argument("--cycles-samples", type=int, default=256)
    parser.add_argument("--out", default=None, help="default: docs/readme_<scene>.png")
    args = parser.parse_args(argv)
    args.out = args.out or os.path.join(ROOT, "docs", f"readme_{args.scene}.png")
    w, h = (int(v) for v in args.size.split("x"))

    import bpy
    import numpy as np

    import tfm_addon
    from tfm_addon.blender import scene_builder as sb

    tfm_addon.register()
    bpy.ops.wm.read_homefile(use_empty=True)
    tmp = tempfile.mkdtemp(prefix="tfm_readme_")
    if args.scene == "sky":
        from tfm_addon.bench import conformance

        conformance.build(conformance.ROW_BY_ID["world_sky_sun_seen"], tmp)
        scene = bpy.context.scene
        scene.render.resolution_x, scene.render.resolution_y = w, h
    else:
        _shaft(w, h, tmp)
        scene = bpy.context.scene

    def render(name):
        t0 = time.perf_counter()
        bpy.ops.render.render()
        seconds = time.perf_counter() - t0
        path = os.path.join(tmp, f"{name}.exr")
        settings = scene.render.image_settings
        settings.media_type = 'MULTI_LAYER_IMAGE'
        settings.file_format = 'OPEN_EXR_MULTILAYER'
        settings.color_depth = '32'
        bpy.data.images["Render Result"].save_render(path)
        import OpenEXR
        with OpenEXR.File(path, separate_channels=True) as f:
            ch = f.parts[0].channels
            names = [k for k in sorted(ch, key=lambda k: "RGBA".find(k[-1])) if k[-1] in "RGB"]
            rgb = np.stack([np.asarray(ch[k].pixels, np.float32) for k in names[:3]], -1)
        return rgb, seconds

    scene.render.engine = 'TFM'
    scene.render.film_transparent = False
    scene.tfm.samples = 16
    tfm, t_tfm = render("tfm")
    tfm, t_tfm = render("tfm")          # the second render: maps and shaders warm, as when working
    sb.cycles_single_scattering(scene, samples=args.cycles_samples)
    scene.cycles.use_denoising = True
    scene.render.film_transparent = False
    cycles, t_cycles = render("cycles")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    white = float(np.percentile(cycles, 99.5))
    fig, ax = plt.subplots(1, 2, figsize=(2 * w / 100, h / 100 + 0.45), dpi=100)
    titles = (f"TFM, {t_tfm:.2f} s", f"Cycles {args.cycles_samples} spp, {t_cycles:.1f} s")
    for a, img, title in zip(ax, (tfm, cycles), titles, strict=True):
        a.imshow(np.clip(img / white, 0, 1) ** (1 / 2.2))
        a.set_title(title, fontsize=10)
        a.axis("off")
    plt.tight_layout()
    plt.savefig(args.out)
    print(f"wrote {args.out}: TFM {t_tfm:.2f} s, Cycles {t_cycles:.1f} s ({args.cycles_samples} spp), "
          f"{w}x{h}")
    sys.stdout.flush()
    os._exit(0)


if __name__ == "__main__":
    raise SystemExit(main())
