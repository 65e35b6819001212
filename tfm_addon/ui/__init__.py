"""The add-on's user interface: settings stored in .blend files (``properties``) and the panels
that show them (``panels``). Imports ``bpy``; only ``tfm_addon.register`` imports this package."""

from . import panels, properties

__all__ = ["panels", "properties"]
