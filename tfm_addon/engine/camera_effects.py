"""Depth of field and motion blur as Cycles renders them, sampled across the antialiasing samples.

A sample of a frame is a whole image drawn through one camera, so the lens point and the shutter
time of sample k are shared by all of its pixels (engine/sampling.py draws them from sequences of
their own, independent of the subpixel offsets):

- **Thin lens** (``lens_camera``): a pinhole at a point of the aperture (Cycles'
  ``camera_sample_aperture``: a concentric disk, or a regular polygon of ``blades`` corners turned
  by the rotation, x squeezed by 1 / ratio, times the aperture size) whose image window is moved
  so that the plane in focus stays where it was (Cycles' ray from the lens point through the
  pixel's point on that plane: exactly an off-axis pinhole per lens point).
- **Motion** (``Motion``, ``moved_scene``): each moving object's matrices at equally spaced times
  across the shutter, interpolated at the sample's time as Cycles interpolates its motion steps
  (translation and scale linearly, rotation by quaternion slerp), applied to the object's
  placement (a medium's grid, a mesh, the camera).

This module imports nothing of the engine (scene.py imports it): it edits the dataclasses through
``dataclasses.replace``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

# ---------------------------------------------------------------------------------------------
# Thin lens

def aperture_point(blades: int, rotation: float, ratio: float, u: float, v: float) -> tuple[float, float]:
    """A point of the unit aperture for (u, v) in [0, 1)^2, as Cycles' camera_sample_aperture:
    the concentric disk (blades < 3) or the regular polygon (corners at radius 1), x / ratio."""
    if blades < 3:
        a, b = 2.0 * u - 1.0, 2.0 * v - 1.0
        if a == 0.0 and b == 0.0:
            x = y = 0.0
        elif a * a > b * b:
            r, theta = a, math.pi / 4 * (b / a)
            x, y = r * math.cos(theta), r * math.sin(theta)
        else:
            r, theta = b, math.pi / 2 - math.pi / 4 * (a / b)
            x, y = r * math.cos(theta), r * math.sin(theta)
    else:
        corner = math.floor(u * blades)
        uu = math.sqrt(u * blades - corner)
        vv = v * uu
        uu = 1.0 - uu
        angle = math.pi / blades
        px, py = (uu + vv) * math.cos(angle), (uu - vv) * math.sin(angle)
        rot = rotation + corner * 2.0 * math.pi / blades
        c, s = math.cos(rot), math.sin(rot)
        x, y = c * px - s * py, s * px + c * py
    return x / max(ratio, 1e-6), y


def _fitted_side(camera) -> float:
    """The image side the sensor spans, at unit depth (the lens shift's unit)."""
    sensor = camera.sensor_height_mm if camera.sensor_fit == "VERTICAL" else camera.sensor_width_mm
    return sensor / camera.lens_mm


def lens_camera(camera, u: float, v: float):
    """``camera`` as the pinhole at aperture point (u, v) of its thin lens, looking through the
    same window on the plane in focus (aperture None: the camera itself, without it)."""
    ap = camera.aperture
    if ap is None or ap.radius_m <= 0.0 or camera.projection != "PERSP":
        return dataclasses.replace(camera, aperture=None) if ap is not None else camera
    x, y = aperture_point(ap.blades, ap.rotation_rad, ap.ratio, u, v)
    dx, dy = x * ap.radius_m, y * ap.radius_m
    m = np.array(camera.matrix_world, dtype=np.float64)
    axes = m[:3, :3] / np.sqrt((m[:3, :3] ** 2).sum(axis=0))
    m[:3, 3] += axes[:, 0] * dx + axes[:, 1] * dy
    # The window at unit depth moves by -lens / focus: the focus plane's points keep their pixels.
    side = _fitted_side(camera) * max(ap.focus_m, 1e-6)
    return dataclasses.replace(camera, matrix_world=m, aperture=None,
                               shift_x=camera.shift_x - dx / side, shift_y=camera.shift_y - dy / side)


# ---------------------------------------------------------------------------------------------
# Motion

def _quaternion(r: np.ndarray) -> np.ndarray:
    """(w, x, y, z) of a rotation matrix."""
    w = math.sqrt(max(0.0, 1.0 + r[0, 0] + r[1, 1] + r[2, 2])) / 2.0
    x = math.copysign(math.sqrt(max(0.0, 1.0 + r[0, 0] - r[1, 1] - r[2, 2])) / 2.0, r[2, 1] - r[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - r[0, 0] + r[1, 1] - r[2, 2])) / 2.0, r[0, 2] - r[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - r[0, 0] - r[1, 1] + r[2, 2])) / 2.0, r[1, 0] - r[0, 1])
    q = np.array([w, x, y, z])
    return q / np.linalg.norm(q)


def _rotation(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _slerp(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    d = float(np.dot(a, b))
    if d < 0.0:
        b, d = -b, -d
    if d > 0.9995:
        q = a + (b - a) * t
        return q / np.linalg.norm(q)
    theta = math.acos(min(d, 1.0))
    return (math.sin((1 - t) * theta) * a + math.sin(t * theta) * b) / math.sin(theta)


# No LAPACK here (called for every sample): its threads, woken while llvmpipe's run, slowed a
# frame with a moving camera to three times a still one's on the shared cores.

def orthonormal(a: np.ndarray) -> np.ndarray:
    """The rotation of the 3x3 ``a``'s columns by Gram-Schmidt (a mirror turned into a rotation)."""
    x = a[:, 0] / np.sqrt(a[:, 0] @ a[:, 0])
    y = a[:, 1] - x * (x @ a[:, 1])
    y = y / np.sqrt(y @ y)
    return np.stack([x, y, np.cross(x, y)], axis=1)


def _decompose(m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(translation, rotation quaternion, 3x3 scale and shear) with m[:3, :3] = R @ S."""
    r = orthonormal(m[:3, :3])
    return m[:3, 3].copy(), _quaternion(r), r.T @ m[:3, :3]


def _affine_inverse(m: np.ndarray) -> np.ndarray:
    """The inverse of an affine 4x4 (the 3x3 part by its adjugate)."""
    a = m[:3, :3]
    adj = np.stack([np.cross(a[:, 1], a[:, 2]), np.cross(a[:, 2], a[:, 0]), np.cross(a[:, 0], a[:, 1])])
    inv = adj / (a[:, 0] @ adj[0])
    out = np.eye(4)
    out[:3, :3] = inv
    out[:3, 3] = -(inv @ m[:3, 3])
    return out


def interpolate(steps: tuple[np.ndarray, ...], t: float) -> np.ndarray:
    """The matrix at ``t`` in [0, 1] between equally spaced ``steps`` (Cycles' motion steps:
    translation and scale linear, rotation slerp)."""
    n = len(steps)
    if n == 1:
        return np.array(steps[0], dtype=np.float64)
    x = min(max(t, 0.0), 1.0) * (n - 1)
    i = min(int(x), n - 2)
    f = x - i
    t0, q0, s0 = _decompose(np.asarray(steps[i], dtype=np.float64))
    t1, q1, s1 = _decompose(np.asarray(steps[i + 1], dtype=np.float64))
    out = np.eye(4)
    out[:3, :3] = _rotation(_slerp(q0, q1, f)) @ (s0 + (s1 - s0) * f)
    out[:3, 3] = t0 + (t1 - t0) * f
    return out


@dataclass(frozen=True, eq=False)
class ObjectMotion:
    """An object's world matrices at equally spaced times from the shutter's opening to its
    closing (``steps``) and at the frame itself (``frame``, the placement the scene holds)."""

    steps: tuple[np.ndarray, ...]
    frame: np.ndarray

    def moved(self, t: float) -> np.ndarray:
        """The world-space move from the frame's placement to the one at shutter time ``t``."""
        return interpolate(self.steps, t) @ _affine_inverse(np.asarray(self.frame, dtype=np.float64))

    @property
    def moves(self) -> bool:
        return any(not np.allclose(s, self.frame, atol=1e-9) for s in self.steps)


@dataclass(frozen=True, eq=False)
class Motion:
    """What moves across the shutter: the camera and objects by name (media and meshes as the
    scene names them); the rest stands still."""

    camera: ObjectMotion | None = None
    objects: Mapping[str, ObjectMotion] = field(default_factory=dict)


def moved_scene(scene, t: float):
    """``scene`` at shutter time ``t`` in [0, 1] (its ``motion`` then dropped)."""
    motion = scene.motion
    if motion is None:
        return scene
    camera = scene.camera
    if motion.camera is not None:
        camera = dataclasses.replace(camera, matrix_world=motion.camera.moved(t) @ camera.matrix_world)
    media = []
    for medium in scene.media:
        om = motion.objects.get(medium.name)
        if om is not None:
            d = om.moved(t)
            # The moved copies name their grids by the frame's medium's keys (hashed once a frame),
            # so that a sample hashes its new placement only.
            source = medium.source_key
            if source is None and medium.density is not None:
                source = f"{medium.grid_key}:{medium.grids_key}"
            medium = dataclasses.replace(
                medium, source_key=source,
                index_to_world=None if medium.density is None else d @ medium.index_to_world,
                box_to_world=None if medium.box_to_world is None else d @ medium.box_to_world)
        media.append(medium)
    meshes = []
    for mesh in scene.meshes:
        om = motion.objects.get(mesh.name)
        if om is not None:
            mesh = dataclasses.replace(mesh, matrix_world=om.moved(t) @ mesh.matrix_world)
        meshes.append(mesh)
    return dataclasses.replace(scene, camera=camera, media=tuple(media), meshes=tuple(meshes), motion=None)
