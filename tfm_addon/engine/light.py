"""Light geometry: the projection faces a light's maps are built on, and whether a face reaches a
box.

A light is one concept (scene.Light) with a list of map faces: a spot has one perspective face
(its cone's frustum), a point light six cube faces (90 degrees each), an area light the five cube
faces in front of it, a sun one orthographic face fitted to the media. Every face gets its own
shadow map and TFM; culling, caching and counters work per face."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .scene import Light

MAX_HALF_ANGLE_RAD = math.radians(85.0)
"""A spot's maps cover at most this half angle (a perspective map cannot reach 90 degrees)."""


PROFILE_SPOT, PROFILE_UNIFORM, PROFILE_COSINE = 0, 1, 2
"""How a face's light falls off with direction: the spot cone, none, cos(theta) about an axis."""


def _cone_scale(light: Light) -> tuple[float, float]:
    sx, sy = (float(s) if math.isfinite(s) and s > 0 else 1.0 for s in light.cone_scale)
    return sx, sy


def lit_half_angle(light: Light) -> float:
    """The half angle (radians, in the cone's scaled space) that the renderer lights: the spot's
    own, or less where its widest half-width would pass the maps' MAX_HALF_ANGLE_RAD."""
    half = 0.5 * max(float(light.spot_size_rad), 0.0)
    widest = max(_cone_scale(light))
    return min(half, math.atan(math.tan(MAX_HALF_ANGLE_RAD) / widest))


def cone_warning(light: Light) -> str | None:
    """The render report's line for a cone wider than the maps cover, or None."""
    if light.kind != "SPOT":
        return None
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
    """One projection face of a light: what the shaders need to build and read its maps.

    Perspective faces: ``world_to_light`` is rigid with the light at the origin looking along
    -Z; ``tan_xy`` the half-widths of the frustum at unit distance. Orthographic faces (a sun):
    the origin is the centre of the map's near plane, light travelling along -Z, ``tan_xy`` the
    half extents in metres; ``shadow_rect`` (cx, cy, hx, hy) the face-space rectangle the shadow
    map covers; ``far`` the depth of the box, metres. ``profile`` and ``emit_axis`` (face
    space) give the emission's dependence on direction. ``world_spread``: for a sun standing in
    for part of the world's light, the tangent of the half angle of its cone of directions (its
    shadows on surfaces are that soft), else 0; ``occluder_depth`` the depth of what shadows
    (the media's centre, or the casters') below the near plane, metres.
    """

    world_to_light: np.ndarray
    position: np.ndarray
    cos_half: float
    spot_smooth: float            # (1 - cos_half) * blend
    tan_xy: tuple[float, float]
    ortho: bool = False
    profile: int = PROFILE_SPOT
    emit_axis: tuple[float, float, float] = (0.0, 0.0, -1.0)
    shadow_rect: tuple[float, float, float, float] | None = None
    far: float = 0.0
    index: int = 0
    cone_scale: tuple[float, float] = (1.0, 1.0)
    world_spread: float = 0.0
    occluder_depth: float = 0.0

    @property
    def tan_half(self) -> float:
        """The larger half-width of the map frustum (its bounding square)."""
        return max(self.tan_xy)

    @property
    def key(self) -> tuple:
        """What the face's maps depend on, beyond the light."""
        return (self.index, self.ortho, tuple(np.round(self.world_to_light, 12).ravel()),
                tuple(round(float(t), 12) for t in self.tan_xy), self.shadow_rect, round(self.far, 9))

    @staticmethod
    def of(light: Light) -> LightFrame:
        m = np.array(light.matrix_world, dtype=np.float64)
        half = lit_half_angle(light)
        cos_half = math.cos(half)
        scale = _cone_scale(light)
        t = math.tan(max(half, 1e-4))
        return LightFrame(
            world_to_light=np.linalg.inv(_rigid(m)),
            position=m[:3, 3].copy(),
            cos_half=cos_half,
            spot_smooth=(1.0 - cos_half) * max(float(light.spot_blend), 0.0),
            tan_xy=(t * scale[0], t * scale[1]),
            cone_scale=scale,
        )

    def clip_matrix(self, near: float, far: float) -> np.ndarray:
        """World to the clip space of the face's map (perspective frustum; for an orthographic
        face the shadow rectangle, depth 0 to ``far``, ``near`` unused)."""
        p = np.zeros((4, 4))
        if self.ortho:
            cx, cy, hx, hy = self.shadow_rect
            p[0, 0], p[0, 3] = 1.0 / hx, -cx / hx
            p[1, 1], p[1, 3] = 1.0 / hy, -cy / hy
            p[2, 2], p[2, 3] = -2.0 / far, -1.0
            p[3, 3] = 1.0
            return p @ self.world_to_light
        p[0, 0], p[1, 1] = 1.0 / self.tan_xy[0], 1.0 / self.tan_xy[1]
        p[2, 2], p[2, 3] = -(far + near) / (far - near), -2 * far * near / (far - near)
        p[3, 2] = -1.0
        return p @ self.world_to_light


def _rigid(m: np.ndarray) -> np.ndarray:
    """The matrix without its scale (nearest rotation) and with its translation."""
    u, _, vt = np.linalg.svd(np.asarray(m, np.float64)[:3, :3])
    r = np.eye(4)
    r[:3, :3] = u @ vt
    r[:3, 3] = np.asarray(m, np.float64)[:3, 3]
    return r


# Cube faces: (local direction the face looks along, an up vector), in the light's frame.
_CUBE = (((0, 0, -1), (0, 1, 0)), ((1, 0, 0), (0, 1, 0)), ((-1, 0, 0), (0, 1, 0)),
         ((0, 1, 0), (0, 0, 1)), ((0, -1, 0), (0, 0, 1)), ((0, 0, 1), (0, 1, 0)))


def _look_rotation(forward, up) -> np.ndarray:
    """3x3 rotation whose -Z column is ``forward`` and +Y column ``up``."""
    f = np.asarray(forward, float)
    u = np.asarray(up, float)
    z = -f
    x = np.cross(u, z)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1)


def cube_faces(light: Light) -> list[LightFrame]:
    """Six 90-degree perspective faces (a point light) or the five in front of an area light,
    with the emission profile of the light."""
    m = _rigid(np.array(light.matrix_world, dtype=np.float64))
    area = light.kind == "AREA"
    faces = []
    for i, (forward, up) in enumerate(_CUBE[:5] if area else _CUBE):
        r = _look_rotation(forward, up)
        to_world = np.eye(4)
        to_world[:3, :3] = m[:3, :3] @ r
        to_world[:3, 3] = m[:3, 3]
        axis = tuple(float(a) for a in r.T @ np.array([0.0, 0.0, -1.0]))
        faces.append(LightFrame(world_to_light=np.linalg.inv(to_world), position=m[:3, 3].copy(),
                                cos_half=0.0, spot_smooth=0.0, tan_xy=(1.0, 1.0),
                                profile=PROFILE_COSINE if area else PROFILE_UNIFORM,
                                emit_axis=axis, index=i))
    return faces


def _corners(box_to_world, lo, hi) -> np.ndarray:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    c = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    return (c @ np.asarray(box_to_world, float).T)[:, :3]


def sun_face(light: Light, medium_boxes, caster_bounds) -> LightFrame:
    """The orthographic face of a sun: its map rectangle fitted to the media's boxes (tight:
    texels where the medium is), its shadow rectangle to the media and the shadow casters'
    bounds (a caster's shadow falls where it stands, seen along the light), its depth from the
    most sunward of them to the farthest. ``medium_boxes``: (box_to_world, lo, hi) each;
    ``caster_bounds``: (lo, hi) world bounds of the casters or None."""
    rot = _rigid(np.array(light.matrix_world, dtype=np.float64))[:3, :3]
    media = [_corners(*b) for b in medium_boxes]
    solids = [] if caster_bounds is None else [_corners(np.eye(4), *caster_bounds)]
    pts_media = np.concatenate(media) @ rot if media else np.zeros((0, 3))
    pts_all = np.concatenate(media + solids) @ rot if (media or solids) else np.zeros((1, 3))

    def rect(q):
        lo, hi = q[:, :2].min(axis=0), q[:, :2].max(axis=0)
        half = np.maximum((hi - lo) * 0.5 * 1.002, 1e-3 + 1e-6 * np.abs(hi + lo))
        return (lo + hi) * 0.5, half

    centre, half = rect(pts_media if len(pts_media) else pts_all)
    s_centre, s_half = rect(pts_all)
    z_top, z_bottom = float(pts_all[:, 2].max()), float(pts_all[:, 2].min())
    margin = 1e-3 * max(z_top - z_bottom, float(half.max()), 1e-3)
    z_top += margin
    origin = rot @ np.array([centre[0], centre[1], z_top])
    to_world = np.eye(4)
    to_world[:3, :3] = rot
    to_world[:3, 3] = origin
    spread = math.tan(0.5 * min(max(float(light.angle_rad), 0.0), math.radians(170.0))) if light.from_world \
        else 0.0
    occluders = pts_media if len(pts_media) else pts_all
    return LightFrame(world_spread=spread, occluder_depth=float(z_top - occluders[:, 2].mean()),
                      world_to_light=np.linalg.inv(to_world), position=origin, cos_half=0.0,
                      spot_smooth=0.0, tan_xy=(float(half[0]), float(half[1])), ortho=True,
                      profile=PROFILE_UNIFORM,
                      shadow_rect=(float(s_centre[0] - centre[0]), float(s_centre[1] - centre[1]),
                                   float(s_half[0]), float(s_half[1])),
                      far=float(z_top - z_bottom + margin))


def light_faces(light: Light, medium_boxes=(), caster_bounds=None) -> list[LightFrame]:
    """The map faces of a light (see the module docstring)."""
    if light.kind == "SUN":
        return [sun_face(light, medium_boxes, caster_bounds)]
    if light.kind in ("POINT", "AREA"):
        return cube_faces(light)
    return [LightFrame.of(light)]


def face_meets_box(frame: LightFrame, box_to_world, lo, hi) -> bool:
    """Whether the face's frustum (its box for an orthographic face) meets the box [lo, hi]^3
    placed by ``box_to_world``: exact, by separating axes between the two convex solids."""
    c = _corners(box_to_world, lo, hi)
    q = c @ frame.world_to_light[:3, :3].T + frame.world_to_light[:3, 3]
    tx, ty = frame.tan_xy
    if frame.ortho:
        return bool(np.any(q[:, 0] >= -tx) and np.any(q[:, 0] <= tx) and np.any(q[:, 1] >= -ty)
                    and np.any(q[:, 1] <= ty) and np.any(q[:, 2] <= 0.0))
    far = float(np.linalg.norm(q, axis=1).max()) * 2.0 + 1e-9
    f = np.array([[0.0, 0.0, 0.0], [-tx * far, -ty * far, -far], [tx * far, -ty * far, -far],
                  [tx * far, ty * far, -far], [-tx * far, ty * far, -far]])
    box_axes = [frame.world_to_light[:3, :3] @ (np.asarray(box_to_world, float)[:3, k]) for k in range(3)]
    side_normals = [np.cross(f[i + 1], f[(i + 1) % 4 + 1]) for i in range(4)]
    edges = [f[i + 1] for i in range(4)] + [np.array([1.0, 0, 0]), np.array([0, 1.0, 0])]
    axes = box_axes + side_normals + [np.array([0, 0, 1.0])]
    axes += [np.cross(a, e) for a in box_axes for e in edges]
    for axis in axes:
        n = np.linalg.norm(axis)
        if n < 1e-12:
            continue
        pa, pb = q @ axis, f @ axis
        eps = 1e-9 * (np.abs(pa).max() + np.abs(pb).max())
        if pa.max() < pb.min() - eps or pb.max() < pa.min() - eps:
            return False
    return True


SHADOW_TEST_TRIANGLES = 20_000
"""solids_may_shadow tests at most this many triangles one by one (those of the meshes whose bounds
it cannot separate from the media); beyond, it answers that they may shadow."""


def solids_may_shadow(frame: LightFrame, parts, boxes, map_res: int, shadow_far: float,
                      extent: Softness | None = None) -> bool:
    """Whether a solid may shadow a point of the media's ``boxes`` ((box_to_world, lo, hi) each)
    from the face ``frame``, as the light passes' filtered shadow-map lookup sees it. ``parts``:
    (lo, hi, triangles) per caster mesh, world bounds and (k, 3, 3) world triangles (None: not kept,
    passes/solids.SolidsBuffer). False only when every caster triangle is separated from the convex
    hull of the face's origin (a sun: the boxes' corners carried back to its near plane) and the
    boxes' corners, by one of the hull's faces or by the triangle's own plane, with a margin of
    three shadow-map texels at the boxes' farthest corner plus twice the lookup's depth bias; then
    no light ray to a point of a box, nor its neighbours the 2x2 filter reads, meets a solid before
    the point, and the lookup there is exactly 1 (the light passes skip it). True when the
    triangles to test are too many (SHADOW_TEST_TRIANGLES). A light with a size (``extent``,
    soft_extent) adds the corners of its shape to the hull (a sun: its angle's reach over the
    depth to the margin). Numpy only (the render path in Blender has no scipy)."""
    corners = [_corners(*b) for b in boxes if all(h > lo for lo, h in zip(b[1], b[2], strict=True))]
    if not corners:
        return True
    corners = np.concatenate(corners)
    if len(corners) > 24:                    # many boxes: the corners of their bounds (a larger hull)
        corners = _corners(np.eye(4), corners.min(axis=0), corners.max(axis=0))
    if frame.ortho:
        q = corners @ frame.world_to_light[:3, :3].T + frame.world_to_light[:3, 3]
        q[:, 2] = 0.0
        inv = np.linalg.inv(frame.world_to_light)
        points = np.concatenate([corners, q @ inv[:3, :3].T + inv[:3, 3]])
        footprint = 2.0 * max(frame.shadow_rect[2:]) / max(int(map_res), 1)
    else:
        shape = [(0.0, 0.0)] if extent is None else [(x * extent.extent[0], y * extent.extent[1])
                                                     for x in (-1.0, 1.0) for y in (-1.0, 1.0)]
        to_world = np.linalg.inv(frame.world_to_light)
        points = np.concatenate([corners, np.array([to_world[:3, :3] @ (x, y, 0.0) + to_world[:3, 3]
                                                    for x, y in shape])])
        reach = float(np.linalg.norm(corners - frame.position, axis=1).max())
        footprint = 2.0 * frame.tan_half * reach / max(int(map_res), 1)
    margin = 3.0 * footprint + 4e-4 * float(shadow_far)
    if frame.ortho and extent is not None:      # a sun's rays tilt by up to its half angle
        margin += max(extent.extent) * float(shadow_far)
    facets = _hull_planes(points)                        # n . x + d <= 0 inside, |n| = 1
    tested = []
    for lo, hi, triangles in parts:
        box = _corners(np.eye(4), lo, hi)
        if np.any(np.all(box @ facets[:, :3].T + facets[:, 3] > margin, axis=0)):
            continue                                     # the whole mesh outside one hull face
        if triangles is None:
            return True
        tested.append(np.asarray(triangles, np.float64))
    if not tested:
        return False
    tri = np.concatenate(tested)
    if len(tri) > SHADOW_TEST_TRIANGLES:
        return True
    outside = np.any(np.all(tri @ facets[:, :3].T + facets[:, 3] > margin, axis=1), axis=1)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(n, axis=1)
    n = n / np.maximum(length, 1e-300)[:, None]
    side = points @ n.T - np.einsum("kj,kj->k", n, tri[:, 0])
    apart = (length > 0) & (np.all(side > margin, axis=0) | np.all(side < -margin, axis=0))
    return bool(np.any(~(outside | apart) & (length > 0)))


def _hull_planes(points: np.ndarray) -> np.ndarray:
    """(F, 4) planes (unit n, d) of the convex hull of a few points, n . x + d <= 0 inside: every
    plane through three of them with all the others on one side (coplanar points: both sides)."""
    p = np.asarray(points, np.float64)
    i, j, k = np.array(list(itertools.combinations(range(len(p)), 3))).T
    n = np.cross(p[j] - p[i], p[k] - p[i])
    length = np.linalg.norm(n, axis=1)
    scale = float(np.abs(p).max()) + float(np.ptp(p, axis=0).max())
    keep = length > 1e-12 * scale * scale
    n = n[keep] / length[keep, None]
    d = -np.einsum("fj,fj->f", n, p[i[keep]])
    side = p @ n.T + d                                   # (points, planes)
    eps = 1e-9 * scale
    below, above = np.all(side <= eps, axis=0), np.all(side >= -eps, axis=0)
    planes = np.concatenate([np.c_[n[below], d[below]], -np.c_[n[above], d[above]]])
    return planes if len(planes) else np.zeros((0, 4))


def is_dark(light: Light) -> bool:
    """A light that adds nothing: no power, no colour or (a spot) no cone."""
    return bool(why_dark(light))


def why_dark(light: Light) -> str:
    """Why ``light`` adds nothing, as the render report says it ('' where it lights): a negative
    or zero power (Blender renders a negative power as no light), no colour, or a spot's cone of
    angle 0."""
    if light.power_w < 0.0:
        return f"a negative power ({light.power_w:g} W), which renders as no light"
    if light.power_w == 0.0:
        return "zero power"
    if max(light.color) <= 0.0:
        return "a black colour"
    if light.kind == "SPOT" and light.spot_size_rad <= 0.0:
        return "a spot cone of angle 0"
    return ""


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


class Softness(NamedTuple):
    """A light's size as one of its faces sees it (soft_extent): ``extent`` the half-widths of its
    shape across the face (metres; a sun: the tangent of half its angle), ``round`` an ellipse
    rather than a rectangle; an area light's half sides as face-space vectors (``area_u``,
    ``area_v``; an ellipse's scaled to the rectangle of its area), its emission's shape, and its
    spread as (tan h, 1 / (tan h - h)) for the half spread h, Cycles' soft-box grid ((0, 0): 180
    degrees)."""

    extent: tuple[float, float]
    round: bool
    area_u: tuple[float, float, float] = (0.0, 0.0, 0.0)
    area_v: tuple[float, float, float] = (0.0, 0.0, 0.0)
    area_spread: tuple[float, float] = (0.0, 0.0)


# Beyond this many half diagonals of an area light, the fourth-order expansion of its emission is
# within 0.2 % of the solid angle (shaders/soft_shadow.glsl area_emission).
AREA_EXPANSION_REACH = 3.5


def area_emission_far(soft: Softness, position, boxes, solids_near: float | None, fog: bool) -> bool:
    """Whether everything an area light's face lights lies beyond AREA_EXPANSION_REACH half
    diagonals of the light: the media's ``boxes`` ((box_to_world, lo, hi) each, their corners'
    bounds), the solids (``solids_near``: their nearest bounds' distance, None unknown) and no fog
    that fills space (``fog``)."""
    if fog or solids_near is None:
        return False
    half_diagonal = math.sqrt(float(np.dot(soft.area_u, soft.area_u) + np.dot(soft.area_v, soft.area_v)))
    reach = AREA_EXPANSION_REACH * half_diagonal
    p = np.asarray(position, dtype=np.float64)
    for box in boxes:
        c = _corners(*box)
        if np.linalg.norm(np.maximum(np.maximum(c.min(axis=0) - p, p - c.max(axis=0)), 0.0)) < reach:
            return False
    return solids_near >= reach


def soft_extent(light: Light, frame: LightFrame) -> Softness | None:
    """The light's size as its face sees it (soft shadows and an area light's emission;
    shaders/soft_shadow.glsl), or None for a point (sharp shadows): a sphere's radius, a sun's
    disk, an area light's rectangle or ellipse projected on the face's plane (its side faces see it
    edge on). A sun standing in for part of the world softens its shadows on surfaces by its own
    cone (shaders/world_soft.glsl): None here."""
    if light.from_world:
        return None
    if light.kind in ("SPOT", "POINT"):
        r = max(float(light.radius_m), 0.0)
        return Softness((r, r), True) if r > 0.0 else None
    if light.kind == "SUN":
        t = math.tan(0.5 * min(max(float(light.angle_rad), 0.0), math.radians(179.0)))
        return Softness((t, t), True) if t > 0.0 else None
    sx, sy = (0.5 * max(float(s), 0.0) for s in light.size_m)
    if sx <= 0.0 or sy <= 0.0:
        return None
    axes = frame.world_to_light[:3, :3] @ _rigid(np.array(light.matrix_world, dtype=np.float64))[:3, :2]
    ex, ey = np.abs(axes[:2]) @ np.array([sx, sy])
    equal_area = math.sqrt(math.pi) / 2.0 if light.round_shape else 1.0
    half = 0.5 * min(max(float(light.spread_rad), 1e-3), math.pi)
    spread = (0.0, 0.0) if half >= 0.5 * math.pi - 1e-6 else (
        math.tan(half), 1.0 / (math.tan(half) - half) if half > 0.05 else 3.0 / half**3)
    return Softness((float(ex), float(ey)), bool(light.round_shape),
                    tuple(float(a) for a in axes[:, 0] * sx * equal_area),
                    tuple(float(a) for a in axes[:, 1] * sy * equal_area), spread)
