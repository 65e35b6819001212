"""Blender's camera model: the view plane, the pixel window of a render border, projections."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import caches
from .scene import Camera


@dataclass(frozen=True)
class ViewPlane:
    """The image window in camera space: x, y of its lower-left corner at unit depth
    (perspective) or in metres (orthographic), the pixel size likewise, and its size in pixels."""

    x0: float
    y0: float
    pixel_size: float
    width_px: int
    height_px: int
    ortho: bool


def pixel_window(camera: Camera) -> tuple[int, int, int, int]:
    """(x0, y0, width, height) in pixels, y0 from the bottom: the render border or the frame."""
    w, h = camera.width_px, camera.height_px
    if camera.border is None:
        return 0, 0, w, h
    xmin, ymin, xmax, ymax = camera.border
    x0, x1 = int(math.floor(xmin * w)), int(math.ceil(xmax * w))
    y0, y1 = int(math.floor(ymin * h)), int(math.ceil(ymax * h))
    x0, y0 = max(0, min(x0, w - 1)), max(0, min(y0, h - 1))
    return x0, y0, max(1, min(x1, w) - x0), max(1, min(y1, h) - y0)


def view_plane(camera: Camera) -> ViewPlane:
    """Blender's viewplane (BKE_camera_params_compute_viewplane) for the pixel window."""
    w, h = camera.width_px, camera.height_px
    fit = camera.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if w >= h else "VERTICAL"
    viewfac = w if fit == "HORIZONTAL" else h
    ortho = camera.projection == "ORTHO"
    if ortho:
        size = camera.ortho_scale
    else:
        sensor = camera.sensor_height_mm if camera.sensor_fit == "VERTICAL" else camera.sensor_width_mm
        size = sensor / camera.lens_mm
    pix = size / viewfac
    bx, by, bw, bh = pixel_window(camera)
    x0 = (-0.5 * w + camera.shift_x * viewfac + bx) * pix
    y0 = (-0.5 * h + camera.shift_y * viewfac + by) * pix
    return ViewPlane(x0, y0, pix, bw, bh, ortho)


def camera_to_world(camera: Camera) -> np.ndarray:
    """The camera's matrix with its rotation made orthonormal (Blender ignores camera scale)."""
    m = np.array(camera.matrix_world, dtype=np.float64)
    # A sample's passes, and the jittered cameras of a frame's samples (the same matrix, another
    # lens shift), ask for the same matrix again: one SVD per placement.
    last = _LAST.get(m.tobytes())
    if last is not None:
        return last.copy()
    u, _, vt = np.linalg.svd(m[:3, :3])
    r = u @ vt
    out = np.eye(4)
    out[:3, :3] = r
    out[:3, 3] = m[:3, 3]
    _LAST.put(m.tobytes(), out.copy())
    return out


_LAST = caches.memo("camera.placement", 1)   # the last camera matrix camera_to_world was asked for


def rigid_inverse(m: np.ndarray) -> np.ndarray:
    """The inverse of a rigid 4x4 matrix (orthonormal rotation and a translation): the transposed
    rotation, without LAPACK (whose threads, woken for a 4x4 inverse while llvmpipe's run, took
    ~0.25 ms a call on the shared 2 cores, once per sample)."""
    out = np.eye(4)
    rt = m[:3, :3].T
    out[:3, :3] = rt
    out[:3, 3] = -(rt @ m[:3, 3])
    return out


def clip_matrix(camera: Camera) -> np.ndarray:
    """World to OpenGL clip space for the pixel window (off-axis frustum or orthographic box)."""
    vp = view_plane(camera)
    n, f = camera.clip_start, camera.clip_end
    l, b = vp.x0, vp.y0
    r, t = l + vp.width_px * vp.pixel_size, b + vp.height_px * vp.pixel_size
    p = np.zeros((4, 4))
    if vp.ortho:
        p[0, 0], p[0, 3] = 2 / (r - l), -(r + l) / (r - l)
        p[1, 1], p[1, 3] = 2 / (t - b), -(t + b) / (t - b)
        p[2, 2], p[2, 3] = -2 / (f - n), -(f + n) / (f - n)
        p[3, 3] = 1
    else:
        l, r, b, t = l * n, r * n, b * n, t * n
        p[0, 0], p[0, 2] = 2 * n / (r - l), (r + l) / (r - l)
        p[1, 1], p[1, 2] = 2 * n / (t - b), (t + b) / (t - b)
        p[2, 2], p[2, 3] = -(f + n) / (f - n), -2 * f * n / (f - n)
        p[3, 2] = -1
    return p @ rigid_inverse(camera_to_world(camera))
