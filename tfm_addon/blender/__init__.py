"""The Blender host of the renderer: reads the evaluated depsgraph into ``engine.scene`` objects
and hands them to one GL thread; the RenderEngine class forwards Blender's callbacks here.

Imports ``bpy`` (through ``render_engine``); only ``tfm_addon.register`` imports this package.
"""

import bpy

from ..engine import caches
from . import final_render, preflight, render_engine, viewport
from .render_worker import close_worker

_register_classes, _unregister_classes = bpy.utils.register_classes_factory(
    render_engine.classes + preflight.classes)


@bpy.app.handlers.persistent
def _file_loaded(*_args) -> None:
    """A file opened (or File ▸ New): what Auto chose belonged to the other file's renders."""
    final_render.auto_choices.clear()


def register():
    _register_classes()
    bpy.app.handlers.load_post.append(_file_loaded)


def shutdown():
    """Stop the viewport's timer and the GL thread (bounded wait); safe to call twice."""
    viewport.stop_polling()
    close_worker()


def unregister():
    # The GL thread and the viewport's timer end before the engine class goes: nothing of ours
    # runs against an unregistered class.
    shutdown()
    if _file_loaded in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_file_loaded)
    _unregister_classes()
    # Every memo, and the background work (bakes, grid reads) that ends with them: an add-on
    # registered again starts from nothing.
    caches.REGISTRY.clear()
