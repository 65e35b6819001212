"""TFM volumes: spot-light scattering in participating media for Blender.

``tfm_addon.engine`` is the renderer and runs without Blender. ``register``/``unregister`` are the
add-on's entry points; they import the Blender side (``ui``, ``blender``) only when called, so
importing this package needs no ``bpy``.
"""

_unregister_steps: list = []


def register():
    from . import blender, ui

    steps = (
        (ui.properties.register, ui.properties.unregister),
        (blender.register, blender.unregister),
        (ui.panels.register, ui.panels.unregister),
        (lambda: None, blender.shutdown),  # undone first: no render thread outlives a class
    )
    for do, undo in steps:
        try:
            do()
        except Exception:
            unregister()
            raise
        _unregister_steps.append(undo)


def unregister():
    while _unregister_steps:
        _unregister_steps.pop()()
