"""The Blender host of the renderer: reads the evaluated depsgraph into ``engine.scene`` objects
and hands them to one GL thread; the RenderEngine class forwards Blender's callbacks here.

Imports ``bpy`` (through ``render_engine``); only ``tfm_addon.register`` imports this package.
"""

import bpy

from . import extract, render_engine
from .render_worker import close_worker
from .volumes import grid_cache

_register_classes, _unregister_classes = bpy.utils.register_classes_factory(render_engine.classes)


def register():
    _register_classes()


def unregister():
    _unregister_classes()
    close_worker()
    grid_cache.clear()
    extract.clear_simplified()
