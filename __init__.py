"""Blender extension entry point: hands over to the ``tfm_addon`` package next to this file."""

from .tfm_addon import register, unregister

__all__ = ["register", "unregister"]
