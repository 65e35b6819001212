"""Blender's own ``openvdb`` Python module.

A Blender installation has it on ``sys.path``; the ``bpy`` wheel keeps it in its bundled Python's
site-packages, which is added here on first use.
"""

import os
import sys

_module = None


def import_openvdb():
    """Return Blender's ``openvdb`` module; raise ImportError with the places searched."""
    global _module
    if _module is not None:
        return _module
    try:
        import openvdb
    except ImportError:
        import bpy

        version = f"python{sys.version_info.major}.{sys.version_info.minor}"
        local = bpy.utils.resource_path('LOCAL')
        candidates = [
            os.path.join(local, "python", "lib", version, "site-packages"),
            os.path.join(local, "python", "lib", "site-packages"),
        ]
        for path in candidates:
            if os.path.isdir(path) and path not in sys.path:
                sys.path.append(path)
        try:
            import openvdb
        except ImportError as ex:
            raise ImportError(
                "Blender's openvdb module was not found (looked in " + ", ".join(candidates) + ")"
            ) from ex
    _module = openvdb
    return openvdb
