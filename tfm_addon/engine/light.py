"""Spot-light geometry: its frame, the frustum of its maps, and whether its cone meets a box."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .scene import SpotLight

MAX_HALF_ANGLE_RAD = math.radians(85.0)
"""A spot's maps cover at most this half angle (a perspective map cannot reach 90 degrees)."""


def _cone_scale(light: SpotLight) -> tuple[float, float]:
    sx, sy = (float(s) if math.isfinite(s) and s > 0 else 1.0 for s in light.cone_scale)
    return sx, sy


def lit_half_angle(light: SpotLight) -> float:
    """The half angle (radians, in the cone's scaled space) that the renderer lights: the spot's
    own, or less where its widest half-width would pass the maps' MAX_HALF_ANGLE_RAD."""
    half = 0.5 * max(float(light.spot_size_rad), 0.0)
    widest = max(_cone_scale(light))
    return min(half, math.atan(math.tan(MAX_HALF_ANGLE_RAD) / widest))


def cone_warning(light: SpotLight) -> str | None:
    """The render report's line for a cone wider than the maps cover, or None."""
    half = 0.5 * max(float(light.spot_size_rad), 0.0)
    lit = lit_half_angle(light)
    if lit >= half - 1e-9:
        return None
    widest = math.degrees(2.0 * math.atan(math.tan(lit) * max(_cone_scale(light))))
    return (f"Spot '{light.name}': its cone ({math.degrees(2 * half):.0f} degrees) is wider than the "
            f"{2 * math.degrees(MAX_HALF_ANGLE_RAD):.0f} degrees its maps cover; it is rendered "
            f"as a {widest:.0f} degree cone.")


@dataclass(frozen=True)
class LightFrame:
    """What the shaders need to know of a spot light."""

    world_to_light: np.ndarray   # rigid; the light at the origin shining along -Z
    position: np.ndarray
    cos_half: float              # of the lit cone, in its scaled space (see lit_half_angle)
    spot_smooth: float           # (1 - cos_half) * blend
    tan_xy: tuple[float, float]  # half-widths of the map frustum at unit distance, x and y
    cone_scale: tuple[float, float] = (1.0, 1.0)

    @property
    def tan_half(self) -> float:
        """The larger half-width of the map frustum (its bounding square)."""
        return max(self.tan_xy)

    @staticmethod
    def of(light: SpotLight) -> LightFrame:
        m = np.array(light.matrix_world, dtype=np.float64)
        u, _, vt = np.linalg.svd(m[:3, :3])
        to_world = np.eye(4)
        to_world[:3, :3] = u @ vt
        to_world[:3, 3] = m[:3, 3]
        half = lit_half_angle(light)
        cos_half = math.cos(half)
        scale = _cone_scale(light)
        t = math.tan(max(half, 1e-4))
        return LightFrame(
            world_to_light=np.linalg.inv(to_world),
            position=m[:3, 3].copy(),
            cos_half=cos_half,
            spot_smooth=(1.0 - cos_half) * max(float(light.spot_blend), 0.0),
            tan_xy=(t * scale[0], t * scale[1]),
            cone_scale=scale,
        )

    def clip_matrix(self, near: float, far: float) -> np.ndarray:
        """World to the clip space of the light's map frustum."""
        p = np.zeros((4, 4))
        p[0, 0], p[1, 1] = 1.0 / self.tan_xy[0], 1.0 / self.tan_xy[1]
        p[2, 2], p[2, 3] = -(far + near) / (far - near), -2 * far * near / (far - near)
        p[3, 2] = -1.0
        return p @ self.world_to_light


def is_dark(light: SpotLight) -> bool:
    """A light that adds nothing: no power, no colour or no cone."""
    return light.power_w <= 0.0 or max(light.color) <= 0.0 or light.spot_size_rad <= 0.0


def cone_meets_box(frame: LightFrame, box_to_world: np.ndarray, lo, hi) -> bool:
    """Whether the light's cone (within its map frustum) meets the box [lo, hi]^3 placed by
    ``box_to_world``. Exact for a convex box and a round cone of half angle below 90 degrees;
    an elliptical cone is tested by the round cone around it (may say yes where it misses)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    corners_box = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])
    to_light = frame.world_to_light @ np.asarray(box_to_world, float)
    c = corners_box @ to_light[:3, :3].T + to_light[:3, 3]

    # The light inside the box.
    inv = np.linalg.inv(to_light)
    apex = inv[:3, 3]
    if np.all(apex >= lo - 1e-9) and np.all(apex <= hi + 1e-9):
        return True
    cos_h = math.cos(math.atan(frame.tan_half))     # the round cone around the map frustum

    def inside(q):
        n = np.linalg.norm(q, axis=-1)
        return (-q[..., 2]) >= cos_h * n

    if np.any(inside(c)):
        return True
    # An edge crossing the cone: f(s) = (axis.v)^2 - cos^2 |v|^2 >= 0 with axis.v >= 0.
    edges = [(i, j) for i in range(8) for j in range(i + 1, 8) if bin(i ^ j).count("1") == 1]
    for i, j in edges:
        a, d = c[i], c[j] - c[i]
        qa = d[2] ** 2 - cos_h**2 * d @ d
        qb = 2 * (a[2] * d[2] - cos_h**2 * a @ d)
        qc = a[2] ** 2 - cos_h**2 * a @ a
        cand = [0.0, 1.0]
        if abs(qa) > 1e-15:
            disc = qb * qb - 4 * qa * qc
            if disc >= 0:
                r = math.sqrt(disc)
                cand += [(-qb - r) / (2 * qa), (-qb + r) / (2 * qa)]
        elif abs(qb) > 1e-15:
            cand.append(-qc / qb)
        cand = sorted(s for s in cand if 0.0 <= s <= 1.0)
        probes = cand + [(x + y) / 2 for x, y in zip(cand, cand[1:], strict=False)]
        if np.any(inside(np.array([a + s * d for s in probes]))):
            return True
    # The axis through a face (the cone's section lies within that face).
    axis_dir = np.array([0.0, 0.0, -1.0])
    o_box = inv[:3, 3]
    d_box = inv[:3, :3] @ axis_dir
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = (lo - o_box) / d_box
        t1 = (hi - o_box) / d_box
    t0 = np.where(np.isnan(t0), -np.inf, t0)
    t1 = np.where(np.isnan(t1), np.inf, t1)
    t_in = np.max(np.minimum(t0, t1))
    t_out = np.min(np.maximum(t0, t1))
    return bool(t_out >= max(t_in, 0.0))
