"""Render the built-in demo scene through Blender with the TFM engine.

    python scripts/demo.py --out out/
    python scripts/demo.py --fire --out out/     # a burning plume: emission and blackbody

Runs Blender as a Python module (bpy). Writes a procedural smoke .vdb, builds a scene around it
(a spot light whose beam shows in a thin fog, a bar under it casting a shaft of shadow down
through the smoke plume, a crate, a ground plane, a camera), enables the add-on, renders one frame
with the TFM engine at the add-on's defaults (quality Auto, the default samples) and writes a PNG
and a multilayer EXR (Combined, Scattering, Surfaces, Transmittance), printing where they are, how
long the frame took and what Auto chose. Giving any of --view-steps, --light-steps, --coefficients
or --map-resolution renders with quality Custom instead.

The add-on is installed the way a user installs it when a built extension is found in dist/
(``scripts/build_extension.py``) or given with --zip; otherwise it is registered straight from
this repository.
"""

from __future__ import annotations

import argparse
import glob
import os
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default=os.path.join(ROOT, "out"), help="output folder")
    p.add_argument("--width", type=int, default=640)
    p.add_argument("--height", type=int, default=360)
    p.add_argument("--grid", type=int, default=64, help="smoke grid side, voxels")
    p.add_argument("--samples", type=int, default=0,
                   help="antialiasing samples (0: the add-on's default)")
    p.add_argument("--view-steps", type=int, default=None, help="quality Custom: view steps")
    p.add_argument("--light-steps", type=int, default=None, help="quality Custom: shadow steps")
    p.add_argument("--coefficients", type=int, default=None, help="quality Custom: coefficients")
    p.add_argument("--map-resolution", type=int, default=None, help="quality Custom: map size")
    p.add_argument("--zip", default=None,
                   help="extension zip to install (default: the newest in dist/ when it is newer "
                        "than the sources, else the repository's tfm_addon is registered)")
    p.add_argument("--direct", action="store_true",
                   help="register tfm_addon from this repository instead of installing the zip")
    p.add_argument("--blend", action="store_true", help="also save the scene as a .blend file")
    p.add_argument("--fog", type=float, default=0.04,
                   help="density of the fog on the World's Volume output, in which the spot's beam and "
                        "the bar's shadow shaft show (0: none)")
    p.add_argument("--fire", action="store_true",
                   help="render a burning plume instead: smoke with flame and temperature grids made "
                        "by code, read through a Principled Volume's emission and blackbody")
    return p.parse_args(argv)


def enable_addon(zip_path: str | None, direct: bool):
    """Install and enable the extension (or register the repository's tfm_addon); return the
    tfm_addon package in use and a description of how it was enabled."""
    import importlib

    import bpy


    if not direct:
        zip_path = zip_path or newest_build()
        if zip_path:
            import addon_utils

            repo_dir = tempfile.mkdtemp(prefix="tfm_demo_repo_")
            bpy.context.preferences.extensions.repos.new(
                name="TFM Demo", module="tfm_demo", custom_directory=repo_dir, source='USER')
            bpy.ops.extensions.package_install_files(filepath=zip_path, repo="tfm_demo",
                                                     enable_on_install=False)
            module = "bl_ext.tfm_demo.tfm_volumes"
            addon_utils.enable(module, default_set=True, handle_error=_raise)
            return importlib.import_module(module + ".tfm_addon"), f"extension {zip_path}"
    sys.path.insert(0, ROOT)
    import tfm_addon

    tfm_addon.register()
    return tfm_addon, "tfm_addon registered from " + ROOT


def newest_build() -> str | None:
    """The newest zip in dist/ if it is newer than every source file of the add-on, else None."""
    zips = sorted(glob.glob(os.path.join(ROOT, "dist", "*.zip")), key=os.path.getmtime)
    if not zips:
        return None
    sources = glob.glob(os.path.join(ROOT, "tfm_addon", "**", "*"), recursive=True)
    sources += [os.path.join(ROOT, "__init__.py"), os.path.join(ROOT, "blender_manifest.toml")]
    newest_source = max(os.path.getmtime(p) for p in sources if os.path.isfile(p))
    return zips[-1] if os.path.getmtime(zips[-1]) >= newest_source else None


def disable_addon(addon) -> None:
    if addon.__name__.startswith("bl_ext."):
        import addon_utils

        addon_utils.disable(addon.__name__.rsplit(".", 1)[0], default_set=True)
    else:
        addon.unregister()


def _raise(ex):
    raise ex


def main(argv=None) -> int:
    args = parse_args(argv)
    out_dir = os.path.abspath(args.out)
    os.makedirs(out_dir, exist_ok=True)

    # Keep Blender's user folders (extension repositories, wheels) out of the user's own.
    os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="tfm_demo_user_"))
    import bpy

    sys.path.insert(0, ROOT)
    from tfm_addon import scenes  # numpy only: the demo scene's numbers

    addon, how = enable_addon(args.zip, args.direct)
    import importlib

    # Not in the extension zip (development code): the repository's copy, writing the properties
    # the enabled add-on registered.
    from tfm_addon.blender import scene_builder

    final_render = importlib.import_module(addon.__name__ + ".blender.final_render")
    engine_api = importlib.import_module(addon.__name__ + ".engine")

    bpy.ops.wm.read_homefile(use_empty=True)
    make = scenes.fire_demo_scene if args.fire else scenes.shaft_demo_scene
    demo = make(width=args.width, height=args.height, n=args.grid)
    stem = "tfm_fire" if args.fire else "tfm_demo"
    custom = {k: v for k, v in (("view_steps", args.view_steps), ("light_steps", args.light_steps),
                                ("coefficients", args.coefficients), ("map_resolution", args.map_resolution))
              if v is not None}
    settings = engine_api.RenderSettings(quality="CUSTOM", **custom) if custom else None
    scene_builder.build(demo, out_dir, settings=settings, name="Demo", samples=args.samples)
    scene = bpy.context.scene
    scene.render.engine = 'TFM'
    scene.render.film_transparent = False
    if args.fog > 0.0 and not args.fire:     # fog in the air, as artists show a light's beam
        nt = scene.world.node_tree
        fog = nt.nodes.new('ShaderNodeVolumeScatter')
        fog.inputs["Density"].default_value = args.fog
        nt.links.new(fog.outputs["Volume"], nt.nodes["World Output"].inputs["Volume"])

    png = os.path.join(out_dir, f"{stem}.png")
    exr = os.path.join(out_dir, f"{stem}.exr")
    settings_out = scene.render.image_settings
    scene.view_settings.view_transform = 'AgX'

    t0 = time.perf_counter()
    bpy.ops.render.render()
    frame_s = time.perf_counter() - t0

    result = bpy.data.images["Render Result"]
    settings_out.media_type = 'MULTI_LAYER_IMAGE'
    settings_out.file_format = 'OPEN_EXR_MULTILAYER'
    settings_out.color_depth = '32'
    result.save_render(exr)
    settings_out.media_type = 'IMAGE'
    settings_out.file_format = 'PNG'
    settings_out.color_mode = 'RGB'
    settings_out.color_depth = '8'
    result.save_render(png)
    if args.blend:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out_dir, f"{stem}.blend"))

    for level, message in final_render.last_messages:
        print(f"{level}: {message}")
    print(f"add-on: {how}")
    what = "burning plume (density, flame, temperature)" if args.fire else "smoke plume"
    print(f"scene: {args.width}x{args.height}, {final_render.last_samples[0]} samples, {what} "
          f"{args.grid}x{args.grid}x{3 * args.grid // 2} ({os.path.join(out_dir, 'Demo_density.vdb')})")
    chosen = [m for _, m in final_render.last_messages if m.startswith("Auto quality")]
    print(f"quality: {chosen[0] if chosen else 'Custom ' + str(custom)}")
    print(f"PNG: {png}")
    print(f"EXR: {exr}")
    engine_s = final_render.last_timings.get("total", float("nan"))
    print(f"frame time: {frame_s:.2f} s (bpy.ops.render.render; the renderer itself: {engine_s:.2f} s, "
          f"first frame, so GL start-up and shader compilation included)")
    disable_addon(addon)
    return 0 if os.path.isfile(png) and os.path.isfile(exr) else 1


if __name__ == "__main__":
    sys.exit(main())
