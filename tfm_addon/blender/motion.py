"""Motion blur: where the camera and the objects are across the shutter, read at sub-frames.

Only matrices are read at the shutter's times (``RenderEngine.frame_set`` with a sub-frame, as
Cycles does, then the frame restored): the grids and meshes are the frame's, so no grid is read
again. The engine interpolates the matrices at each antialiasing sample's time
(engine/camera_effects.py).
"""

from __future__ import annotations

import math

import numpy as np

from ..engine.camera_effects import Motion, ObjectMotion
from ..engine.scene import Scene

MAX_STEPS = 9      # matrices read across the shutter at most (an object's Motion Steps 3)


def _blurred(ob) -> bool:
    """Whether Cycles blurs the object (Object ▸ Motion Blur, on by default)."""
    settings = getattr(ob, "cycles", None)
    return bool(getattr(settings, "use_motion_blur", True))


def _steps(ob) -> int:
    """Cycles' motion steps of an object: 2^Motion Steps + 1 matrices (3 by default)."""
    settings = getattr(ob, "cycles", None)
    return min(2 ** max(int(getattr(settings, "motion_steps", 1)), 1) + 1, MAX_STEPS)


def shutter_window(render, frame: float) -> tuple[float, float]:
    """The frames the shutter is open between (Render ▸ Motion Blur ▸ Position and Shutter)."""
    shutter = float(render.motion_blur_shutter)
    position = render.motion_blur_position
    if position == 'START':
        return frame, frame + shutter
    if position == 'END':
        return frame - shutter, frame
    return frame - shutter / 2.0, frame + shutter / 2.0


def _label(instance) -> str:
    from .extract import _label as label  # extract imports this module's callers, not this module

    return label(instance)


def _matrices(depsgraph, names: set[str], camera_object) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
    found: dict[str, np.ndarray] = {}
    for instance in depsgraph.object_instances:
        name = _label(instance)
        if name in names and name not in found and _blurred(instance.object):
            found[name] = np.array(instance.matrix_world, dtype=np.float64)
    camera = None
    if camera_object is not None and _blurred(camera_object):
        camera = np.array(camera_object.evaluated_get(depsgraph).matrix_world, dtype=np.float64)
    return found, camera


def velocity_notes(depsgraph) -> list[str]:
    """One line per Volume object whose velocity grid Cycles would blur it by."""
    notes = []
    for instance in depsgraph.object_instances:
        ob = instance.object
        if ob.type != 'VOLUME' or not instance.show_self:
            continue
        data = ob.data
        grids = {g.name for g in data.grids}
        names = [data.velocity_grid] if data.velocity_grid in grids else [
            n for n in (data.velocity_x_grid, data.velocity_y_grid, data.velocity_z_grid) if n in grids]
        if names:
            quoted = "', '".join(names)
            notes.append(f"Volume '{_label(instance)}': its velocity grid '{quoted}' is not rendered; "
                         f"motion blur moves the volume with its object only")
    return notes


def read_motion(engine, depsgraph, scene: Scene, camera_object) -> tuple[Motion | None, list[str]]:
    """The scene's motion across the shutter when Render ▸ Motion Blur is on: the camera's and
    each medium's and mesh's matrices (those Cycles blurs: Object ▸ Motion Blur on) at equally
    spaced times (``engine.frame_set``), as many as the largest of their Cycles motion steps asks
    for, and the report lines for what it leaves out. (None, []) when motion blur is off."""
    b_scene = depsgraph.scene
    render = b_scene.render
    if not render.use_motion_blur:
        return None, []
    frame, subframe = b_scene.frame_current, float(b_scene.frame_subframe)
    start, end = shutter_window(render, frame + subframe)
    names = {m.name for m in scene.media} | {m.name for m in scene.meshes}
    at_frame, camera_at_frame = _matrices(depsgraph, names, camera_object)
    owners = [i.object for i in depsgraph.object_instances if _label(i) in at_frame]
    count = max([_steps(ob) for ob in owners + ([camera_object] if camera_at_frame is not None else [])],
                default=3)
    steps = []
    try:
        for i in range(count):
            t = start + (end - start) * i / (count - 1)
            whole = math.floor(t)
            engine.frame_set(int(whole), t - whole)
            steps.append(_matrices(depsgraph, names, camera_object))
    finally:
        engine.frame_set(frame, subframe)
    objects = {}
    for name, matrix in at_frame.items():
        if all(name in s[0] for s in steps):
            om = ObjectMotion(tuple(s[0][name] for s in steps), matrix)
            if om.moves:
                objects[name] = om
    camera = None
    if camera_at_frame is not None:
        om = ObjectMotion(tuple(s[1] for s in steps), camera_at_frame)
        camera = om if om.moves else None
    motion = Motion(camera=camera, objects=objects) if camera is not None or objects else None
    notes = velocity_notes(depsgraph)
    cycles = getattr(b_scene, "cycles", None)
    if getattr(cycles, "rolling_shutter_type", 'NONE') != 'NONE':
        notes.append("Motion blur: the rolling shutter is not rendered (the whole frame is exposed at once)")
    return motion, notes
