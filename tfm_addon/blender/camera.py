"""Cameras: a Blender camera object, or a 3D viewport's view, as the renderer's Camera."""

from __future__ import annotations

import numpy as np

from ..engine.scene import Aperture, Camera


def without_scale(matrix) -> np.ndarray:
    """A 4x4 object matrix with unit-length axes (object scale does not change a view or a cone)."""
    m = np.array(matrix, dtype=np.float64).reshape(4, 4)
    norms = np.linalg.norm(m[:3, :3], axis=0)
    m[:3, :3] /= np.where(norms > 0.0, norms, 1.0)
    return m


def border_window(render, width_px: int, height_px: int) -> tuple[int, int, int, int] | None:
    """Blender's render border as a pixel window (x0, y0, x1, y1), y up, ends exclusive.

    Blender truncates border * size in single precision; None when the border is off or empty.
    """
    if not render.use_border:
        return None
    f = np.float32
    x0 = int(f(render.border_min_x) * f(width_px))
    x1 = int(f(render.border_max_x) * f(width_px))
    y0 = int(f(render.border_min_y) * f(height_px))
    y1 = int(f(render.border_max_y) * f(height_px))
    if (x0, y0, x1, y1) == (0, 0, width_px, height_px) or x1 <= x0 or y1 <= y0:
        return None
    return x0, y0, x1, y1


def border_fractions(window, width_px: int, height_px: int) -> tuple[float, float, float, float]:
    """A pixel window as Camera.border fractions that floor/ceil (or round) back to exactly that
    window, whatever the rounding error of the multiplication."""
    x0, y0, x1, y1 = window
    pad = 1e-3
    return ((x0 + pad) / width_px, (y0 + pad) / height_px,
            (x1 - pad) / width_px, (y1 - pad) / height_px)


def camera_from_object(camera_object, width_px: int, height_px: int, *, window=None,
                       warnings: list[str] | None = None) -> Camera:
    """The renderer's Camera for an evaluated camera object rendering width_px x height_px."""
    data = camera_object.data
    projection = data.type
    notes = [] if warnings is None else warnings
    if projection not in ('PERSP', 'ORTHO'):
        kind = "panoramic" if projection == 'PANO' else projection.lower()
        notes.append(f"Camera '{camera_object.name}': {kind} cameras are not supported, "
                     f"rendering it as a perspective camera")
        projection = 'PERSP'
    return Camera(
        matrix_world=without_scale(camera_object.matrix_world),
        width_px=width_px,
        height_px=height_px,
        projection=projection,
        lens_mm=data.lens,
        sensor_width_mm=data.sensor_width,
        sensor_height_mm=data.sensor_height,
        sensor_fit=data.sensor_fit,
        shift_x=data.shift_x,
        shift_y=data.shift_y,
        ortho_scale=data.ortho_scale,
        clip_start=data.clip_start,
        clip_end=data.clip_end,
        border=None if window is None else border_fractions(window, width_px, height_px),
        aperture=aperture(camera_object, projection, notes),
    )


def aperture(camera_object, projection: str, warnings: list[str]) -> Aperture | None:
    """The camera's depth of field as Cycles reads it (blender/camera.cpp): aperture size =
    focal length / (2 f-stop), the focus distance along the view axis to the focus object when
    one is set; None when Depth of Field is off."""
    dof = camera_object.data.dof
    if not dof.use_dof:
        return None
    if projection != 'PERSP':
        warnings.append(f"Camera '{camera_object.name}': depth of field of an orthographic camera is "
                        f"not rendered")
        return None
    focus = float(dof.focus_distance)
    target = dof.focus_object
    if target is not None:
        if dof.focus_subtarget:
            warnings.append(f"Camera '{camera_object.name}': depth of field focuses on the object "
                            f"'{target.name}', not on its bone '{dof.focus_subtarget}'")
        m = without_scale(camera_object.matrix_world)
        t = np.array(target.matrix_world, dtype=np.float64).reshape(4, 4)
        focus = abs(float(np.dot(m[:3, 2], m[:3, 3] - t[:3, 3])))
    fstop = max(float(dof.aperture_fstop), 1e-5)
    return Aperture(radius_m=camera_object.data.lens * 1e-3 / (2.0 * fstop), focus_m=focus,
                    blades=int(dof.aperture_blades) if dof.aperture_blades >= 3 else 0,
                    rotation_rad=float(dof.aperture_rotation), ratio=float(dof.aperture_ratio))


def camera_view_aperture(rv3d, scene, depsgraph) -> Aperture | None:
    """The depth of field a viewport shows: the scene camera's when the view looks through it
    (Cycles' viewport does the same), else none."""
    ob = scene.camera
    if rv3d.view_perspective != 'CAMERA' or ob is None or ob.type != 'CAMERA':
        return None
    ob = ob.evaluated_get(depsgraph)
    return aperture(ob, 'PERSP' if ob.data.type != 'ORTHO' else 'ORTHO', [])


def camera_from_view(view_matrix, window_matrix, width_px: int, height_px: int) -> Camera:
    """The Camera of a 3D viewport: ``view_matrix`` (world to view) and ``window_matrix``
    (OpenGL projection) of ``RegionView3D``, for an image of width_px x height_px.

    Written as a camera with a horizontal sensor fit of 36 mm: lens and shift follow from the
    projection's scale and offset, the clip distances from its depth terms.
    """
    view = np.array(view_matrix, dtype=np.float64).reshape(4, 4)
    p = np.array(window_matrix, dtype=np.float64).reshape(4, 4)
    aspect = width_px / height_px
    sensor = 36.0
    if p[3, 3] == 0.0:  # perspective
        near = p[2, 3] / (p[2, 2] - 1.0)
        far = p[2, 3] / (p[2, 2] + 1.0)
        return Camera(
            matrix_world=np.linalg.inv(view), width_px=width_px, height_px=height_px,
            projection='PERSP', lens_mm=p[0, 0] * sensor / 2.0, sensor_width_mm=sensor,
            sensor_height_mm=sensor / aspect, sensor_fit='HORIZONTAL',
            shift_x=p[0, 2] / 2.0, shift_y=p[1, 2] / (2.0 * aspect),
            clip_start=near, clip_end=far,
        )
    near = (p[2, 3] + 1.0) / p[2, 2]
    far = (p[2, 3] - 1.0) / p[2, 2]
    return Camera(
        matrix_world=np.linalg.inv(view), width_px=width_px, height_px=height_px,
        projection='ORTHO', ortho_scale=2.0 / p[0, 0], sensor_width_mm=sensor,
        sensor_height_mm=sensor / aspect, sensor_fit='HORIZONTAL',
        shift_x=-p[0, 3] / 2.0, shift_y=-p[1, 3] / (2.0 * aspect),
        clip_start=near, clip_end=far,
    )
