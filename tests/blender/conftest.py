"""Tests inside Blender (bpy 5.0.1 as a module): one Blender per pytest process.

The add-on is used the way a user's Blender uses it: the extension zip is built with
scripts/build_extension.py (this platform's wheels; none when they cannot be downloaded), installed
into an extension repository in a temporary user folder and enabled as ``bl_ext.<repo>.<id>``.
"""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
import tempfile

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
# pytest runs with --import-mode=importlib: make the repository and blender_helpers importable.
for path in (ROOT, HERE):
    if path not in sys.path:
        sys.path.insert(0, path)

# Blender reads its user folders once, when bpy is first imported: keep them out of the user's.
if "bpy" not in sys.modules:
    os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="tfm_blender_user_")

try:
    import bpy
except ImportError:  # no Blender module here: these tests are not collected ...
    if os.environ.get("TFM_REQUIRE_BLENDER"):  # ... unless the test command installed it
        raise
    bpy = None
    collect_ignore_glob = ["test_*.py"]

from blender_helpers import EXTENSION_ID, MODULE, REPO  # noqa: E402


@pytest.fixture(scope="session")
def extension_zip(tmp_path_factory) -> str:
    """The extension built by scripts/build_extension.py for this platform (wheels cached in
    wheels/; built without them when offline)."""
    out = tmp_path_factory.mktemp("dist")
    done = subprocess.run(
        [sys.executable, os.path.join(ROOT, "scripts", "build_extension.py"),
         "--platforms", "current", "--python", f"{sys.version_info.major}.{sys.version_info.minor}",
         "--allow-missing-wheels", "--output-dir", str(out),
         "--stage-dir", str(tmp_path_factory.mktemp("stage") / "extension")],
        capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    return str(out / f"{EXTENSION_ID}-0.1.0.zip")


@pytest.fixture(scope="session")
def addon(extension_zip, tmp_path_factory):
    """The installed, enabled extension's ``tfm_addon`` package."""
    import addon_utils

    repo_dir = str(tmp_path_factory.mktemp("extension_repo"))
    bpy.context.preferences.extensions.repos.new(
        name="TFM Test", module=REPO, custom_directory=repo_dir, source='USER')
    result = bpy.ops.extensions.package_install_files(
        filepath=extension_zip, repo=REPO, enable_on_install=True)
    assert result == {'FINISHED'}
    assert MODULE in {a.module for a in bpy.context.preferences.addons}
    yield importlib.import_module(MODULE + ".tfm_addon")
    addon_utils.disable(MODULE, default_set=True)


@pytest.fixture
def flags_of_next_update():
    """The change flags the add-on derives from the real depsgraph updates of the next view-layer
    update (collect() updates the view layer and ORs them)."""
    changes = importlib.import_module(MODULE + ".tfm_addon.blender.changes")
    seen = []

    def handler(scene, depsgraph):
        seen.append(changes.changes_from_depsgraph(depsgraph))

    bpy.app.handlers.depsgraph_update_post.append(handler)

    def collect():
        seen.clear()
        bpy.context.view_layer.update()
        flags = changes.Change.NONE
        for f in seen:
            flags |= f
        return flags

    yield collect
    bpy.app.handlers.depsgraph_update_post.remove(handler)


@pytest.fixture
def blank(addon):
    """An empty scene with the add-on enabled."""
    bpy.ops.wm.read_homefile(use_empty=True)
    yield bpy.context.scene


@pytest.fixture(scope="session")
def direct_worker():
    """A RenderWorker of the repository's renderer, independent of the add-on's."""
    from tfm_addon.engine.worker import RenderWorker

    worker = RenderWorker()
    yield worker
    worker.close()
