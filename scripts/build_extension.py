"""Build the Blender extension zip: python scripts/build_extension.py [--platforms ...]

1. Downloads the moderngl, glcontext and OpenEXR wheels the add-on needs (binary only, no
   dependencies: numpy ships with Blender) for each target platform and Python version into
   ``wheels/`` (kept between builds, git-ignored).
2. Copies the extension's files into ``build/extension/`` and writes the manifest's ``platforms``
   and ``wheels`` lists there.
3. Runs Blender's own extension tool (``blender_ext.py build``, shipped in the bpy wheel) and
   ``blender_ext.py validate`` on the result, which lands in ``dist/``.

``--platforms current`` builds for this machine only; ``--platforms none`` bundles no wheels (the
add-on then needs moderngl, glcontext and OpenEXR importable in Blender's Python already).
"""

from __future__ import annotations

import argparse
import glob
import os
import platform
import re
import shutil
import subprocess
import sys
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

PACKAGES = ("moderngl", "glcontext", "openexr")

# Blender platform -> pip --platform tags, newest first.
PLATFORM_TAGS = {
    "linux-x64": ["manylinux_2_28_x86_64", "manylinux_2_17_x86_64", "manylinux2014_x86_64",
                  "manylinux1_x86_64", "manylinux_2_5_x86_64"],
    "windows-x64": ["win_amd64"],
    "macos-arm64": ["macosx_11_0_arm64", "macosx_12_0_arm64", "macosx_14_0_arm64"],
    "macos-x64": ["macosx_10_9_x86_64", "macosx_10_13_x86_64", "macosx_10_15_x86_64",
                  "macosx_11_0_x86_64"],
}
# Blender 4.2-5.0 embed Python 3.11; 5.1 and later 3.13.
PYTHON_VERSIONS = ("3.11", "3.13")
# Files and folders of the repository that make up the extension.
EXTENSION_FILES = ("blender_manifest.toml", "__init__.py", "tfm_addon", "LICENSE")


def this_platform() -> str:
    system = {"darwin": "macos"}.get(platform.system().lower(), platform.system().lower())
    machine = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64"}.get(
        platform.machine().lower(), platform.machine().lower())
    return f"{system}-{machine}"


def blender_ext_path() -> str:
    """Blender's extension command-line tool inside the installed bpy wheel."""
    import importlib.util

    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise SystemExit("bpy is not installed: pip install bpy==5.0.1 (it carries blender_ext.py), "
                         "or pass --blender-ext PATH")
    base = spec.submodule_search_locations[0]
    found = sorted(glob.glob(os.path.join(base, "*", "scripts", "addons_core", "bl_pkg", "cli",
                                          "blender_ext.py")))
    if not found:
        raise SystemExit(f"blender_ext.py not found under {base}")
    return found[-1]


def _normalise(name: str) -> str:
    return re.sub(r"[-_.]+", "_", name).lower()


def wheels_for(platform_name: str, python: str, wheel_dir: str, offline: bool) -> list[str] | None:
    """Paths of one wheel per package for a platform and Python version (downloaded once and kept
    in ``wheel_dir``), or None if a package has no wheel there."""
    folder = os.path.join(wheel_dir, platform_name, "cp" + python.replace(".", ""))
    os.makedirs(folder, exist_ok=True)
    found = []
    for package in PACKAGES:
        have = [p for p in glob.glob(os.path.join(folder, "*.whl"))
                if _normalise(os.path.basename(p).split("-")[0]) == _normalise(package)]
        if not have and not offline:
            cmd = [sys.executable, "-m", "pip", "download", "--quiet", "--only-binary=:all:",
                   "--no-deps", "--python-version", python, "--implementation", "cp",
                   "--dest", folder, package]
            for tag in PLATFORM_TAGS[platform_name]:
                cmd += ["--platform", tag]
            done = subprocess.run(cmd, capture_output=True, text=True)
            if done.returncode != 0:
                last = (done.stderr.strip().splitlines() or ["?"])[-1]
                print(f"  no {package} wheel for {platform_name} cp{python}: {last}")
                return None
            have = [p for p in glob.glob(os.path.join(folder, "*.whl"))
                    if _normalise(os.path.basename(p).split("-")[0]) == _normalise(package)]
        if not have:
            return None
        found.append(sorted(have)[-1])
    return found


def stage(stage_dir: str, wheels: list[str], platforms: list[str]) -> None:
    """Copy the extension's files to ``stage_dir`` with the wheels and a manifest that lists them."""
    shutil.rmtree(stage_dir, ignore_errors=True)
    os.makedirs(stage_dir)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for name in EXTENSION_FILES:
        src = os.path.join(ROOT, name)
        if os.path.isdir(src):
            shutil.copytree(src, os.path.join(stage_dir, name), ignore=ignore)
        elif os.path.isfile(src):
            shutil.copy2(src, stage_dir)
    rel = []
    if wheels:
        os.makedirs(os.path.join(stage_dir, "wheels"))
        for path in wheels:
            shutil.copy2(path, os.path.join(stage_dir, "wheels"))
            rel.append("./wheels/" + os.path.basename(path))
    manifest_path = os.path.join(stage_dir, "blender_manifest.toml")
    with open(manifest_path, encoding="utf-8") as f:
        text = f.read()
    generated = ""
    if platforms:
        generated += "platforms = [" + ", ".join(f'"{p}"' for p in platforms) + "]\n"
    if rel:
        generated += "wheels = [\n" + "".join(f'  "{w}",\n' for w in sorted(set(rel))) + "]\n"
    text = text.replace("\n[permissions]", "\n" + generated + "\n[permissions]", 1)
    text = text.replace('  "/wheels/",\n', "")
    with open(manifest_path, "w", encoding="utf-8") as f:
        f.write(text)
    tomllib.loads(text)  # fail here, not in Blender, if the edit broke the TOML


def main(argv=None) -> str:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--platforms", default="all",
                        help="'all', 'current', 'none' or a comma list of "
                             + ", ".join(PLATFORM_TAGS))
    parser.add_argument("--python", default=",".join(PYTHON_VERSIONS),
                        help="Python versions to bundle wheels for (first one required)")
    parser.add_argument("--wheel-dir", default=os.path.join(ROOT, "wheels"))
    parser.add_argument("--output-dir", default=os.path.join(ROOT, "dist"))
    parser.add_argument("--stage-dir", default=os.path.join(ROOT, "build", "extension"))
    parser.add_argument("--blender-ext", default=None, help="path to blender_ext.py")
    parser.add_argument("--offline", action="store_true",
                        help="use only wheels already in --wheel-dir, download nothing")
    parser.add_argument("--allow-missing-wheels", action="store_true",
                        help="build without wheels when they cannot be had (instead of failing)")
    args = parser.parse_args(argv)

    if args.platforms == "all":
        targets = list(PLATFORM_TAGS)
    elif args.platforms == "current":
        targets = [this_platform()]
    elif args.platforms == "none":
        targets = []
    else:
        targets = [p.strip() for p in args.platforms.split(",") if p.strip()]
    unknown = [p for p in targets if p not in PLATFORM_TAGS]
    if unknown:
        raise SystemExit(f"no wheel platform tags known for {unknown}; known: {list(PLATFORM_TAGS)}")
    pythons = [v.strip() for v in args.python.split(",") if v.strip()]

    wheels: list[str] = []
    platforms: list[str] = []
    for target in targets:
        print(f"wheels for {target}:")
        required = wheels_for(target, pythons[0], args.wheel_dir, args.offline)
        if required is None:
            print(f"  skipping {target}: not every package has a cp{pythons[0]} wheel")
            continue
        platforms.append(target)
        wheels += required
        for python in pythons[1:]:
            extra = wheels_for(target, python, args.wheel_dir, args.offline)
            if extra is not None:
                wheels += extra
    if targets and not platforms:
        if not args.allow_missing_wheels:
            raise SystemExit("no wheels could be had for any platform (offline?); "
                             "use --allow-missing-wheels to build without them")
        print("building WITHOUT wheels: moderngl, glcontext and OpenEXR must already be importable")
    for w in wheels:
        print("  " + os.path.relpath(w, ROOT) if w.startswith(ROOT) else "  " + w)

    stage(args.stage_dir, wheels, platforms)
    tool = args.blender_ext or blender_ext_path()
    os.makedirs(args.output_dir, exist_ok=True)
    with open(os.path.join(args.stage_dir, "blender_manifest.toml"), "rb") as f:
        manifest = tomllib.load(f)
    zip_path = os.path.join(args.output_dir, f"{manifest['id']}-{manifest['version']}.zip")
    subprocess.run([sys.executable, tool, "build", "--source-dir", args.stage_dir,
                    "--output-filepath", zip_path], check=True)
    subprocess.run([sys.executable, tool, "validate", zip_path], check=True)
    print(f"built {zip_path} ({os.path.getsize(zip_path) / 1e6:.1f} MB, "
          f"platforms: {', '.join(platforms) or 'any (no wheels)'})")
    return zip_path


if __name__ == "__main__":
    main()
