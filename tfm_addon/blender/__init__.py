"""The Blender host of the renderer: reads the evaluated depsgraph into ``engine.scene`` objects
and hands them to one GL thread; the RenderEngine class forwards Blender's callbacks here.

Imports ``bpy`` (through ``render_engine``); only ``tfm_addon.register`` imports this package.
"""

import bpy

from . import extract, preflight, render_engine, viewport
from .render_worker import close_worker
from .volumes import grid_cache

_register_classes, _unregister_classes = bpy.utils.register_classes_factory(
    render_engine.classes + preflight.classes)


def register():
    _register_classes()


def shutdown():
    """Stop the viewport's timer and the GL thread (bounded wait); safe to call twice."""
    viewport.stop_polling()
    close_worker()


def unregister():
    # The GL thread and the viewport's timer end before the engine class goes: nothing of ours
    # runs against an unregistered class.
    shutdown()
    _unregister_classes()
    grid_cache.clear()
    extract.clear_simplified()
