"""The guard against another Python's wheels: Blender 4.2.0 installs an extension's wheels without
matching them to its Python, so a zip holding 3.11 and 3.13 wheels can put the 3.13 moderngl in a
3.11 Blender. The import then fails, and the message must say that, not blame the driver."""

import builtins
import sys

import pytest

from tfm_addon.engine import gl_context
from tfm_addon.engine.errors import GLUnavailableError

OTHER = 13 if sys.version_info.minor != 13 else 11


def _site(tmp_path, names):
    for package, name in names:
        (tmp_path / package).mkdir(exist_ok=True)
        (tmp_path / package / name).write_bytes(b"")
    return str(tmp_path)


def test_foreign_wheels_are_found_and_own_ones_are_not(tmp_path):
    mine = f"{sys.version_info.major}{sys.version_info.minor}"
    site = _site(tmp_path, [("moderngl", f"mgl.cpython-3{OTHER}-x86_64-linux-gnu.so"),
                            ("glcontext", f"egl.cpython-{mine}-x86_64-linux-gnu.so"),
                            ("glcontext", f"wgl.cp3{OTHER}-win_amd64.pyd"),
                            ("moderngl", "__init__.py")])
    found = gl_context.foreign_wheels([site])
    assert [p.rsplit("/", 1)[-1] for p in found] == [f"mgl.cpython-3{OTHER}-x86_64-linux-gnu.so",
                                                     f"wgl.cp3{OTHER}-win_amd64.pyd"]


def test_a_failed_import_beside_another_pythons_wheel_names_it(tmp_path, monkeypatch):
    site = _site(tmp_path, [("moderngl", f"mgl.cpython-3{OTHER}-x86_64-linux-gnu.so")])
    monkeypatch.setattr(sys, "path", [site, *sys.path])
    real_import = builtins.__import__

    def no_moderngl(name, *args, **kwargs):
        if name == "moderngl":
            raise ImportError("No module named 'moderngl.mgl'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_moderngl)
    with pytest.raises(GLUnavailableError) as err:
        gl_context.create_context()
    message = str(err.value)
    assert f"mgl.cpython-3{OTHER}" in message and "another Python" in message
    assert f"--python {sys.version_info.major}.{sys.version_info.minor}" in message
