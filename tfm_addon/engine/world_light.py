"""The world's light, shadowed by the media and the solids, as a set of directional lights.

Cycles lights a medium sample and a surface point with the environment's radiance from every
direction, attenuated by what lies that way (direct light from the environment, even with zero
bounces). For a constant world of radiance L this is an integral over directions of L times the
transmittance (and the phase function, or the cosine for a surface). The engine approximates it
with ``n`` suns (orthographic transmittance-map faces, every kind of shadow included) spread evenly
over the sphere by a Fibonacci lattice, each carrying the irradiance of its share of the solid
angle, L · 4π/n: the sum over the suns is a quadrature of that integral. Where nothing shadows,
the sum of a surface's cos θ · 4π/n over the suns above it is close to π, the exact cosine
integral, and a medium sample's sum of phase-weighted shares is close to L. An environment image
(an HDRI) gives each direction the irradiance of the part of the sphere nearest to it, coming from
that part's brightness-weighted mean direction.

Each sun also carries, as ``Light.angle_rad``, the cone of directions it stands for: a cap of its
share of the sphere (a constant world), or the cap whose mean cosine is that of its part's light
about its direction (an environment: a small bright patch gives a narrow cone, an even sky a wide
one). The light passes light surfaces over that cone (shaders/world_soft.glsl), so that the suns'
shadows blend into one soft shadow.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from . import environment
from .scene import Light, Scene

DEFAULT_DIRECTIONS = 16
MIN_DIRECTIONS = 6          # an octahedron's worth: each sun stands for at most 2/3 pi sr


def directions(n: int) -> np.ndarray:
    """(n, 3) unit vectors spread evenly over the sphere (a Fibonacci lattice, z up)."""
    i = np.arange(n, dtype=np.float64) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def _sun_matrix(towards_sky: np.ndarray) -> np.ndarray:
    """A sun whose light comes from ``towards_sky``: its local -Z is the light's travel, -w."""
    z = np.asarray(towards_sky, np.float64)      # local +Z points back towards the sky
    helper = np.array([0.0, 0.0, 1.0]) if abs(z[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = x, y, z
    return m


def world_suns(radiance, n: int = DEFAULT_DIRECTIONS) -> tuple[Light, ...]:
    """Suns standing in for a constant world of ``radiance`` (RGB, W/(sr m^2))."""
    rgb = np.asarray(radiance, np.float64)
    if n <= 0 or not np.any(rgb > 0.0):
        return ()
    share = 4.0 * math.pi / n
    angle = 2.0 * math.acos(1.0 - 2.0 / n) if n > 1 else math.pi    # a cap of the share's solid angle
    return tuple(Light(matrix_world=_sun_matrix(w), color=tuple(float(c) for c in rgb), power_w=share,
                       kind="SUN", name=f"World {k + 1}/{n}", from_world=True, angle_rad=angle)
                 for k, w in enumerate(directions(n)))


def environment_suns(env: np.ndarray, n: int = DEFAULT_DIRECTIONS) -> tuple[Light, ...]:
    """Suns standing in for an environment image: each direction of the lattice carries the
    irradiance of the pixels nearest to it, the sum of radiance times solid angle."""
    env = np.asarray(env, np.float64)
    dirs, omega = environment.directions(env.shape[:2])
    centres = directions(n)
    nearest = np.argmax(dirs @ centres.T, axis=1)
    weight = env.reshape(-1, 3) * omega[:, None]
    power = np.zeros((n, 3))
    np.add.at(power, nearest, weight)
    # each sun comes from its part's brightness-weighted mean direction (a small bright sun in the
    # image lights from where it is, not from the lattice point nearest to it)
    toward = np.zeros((n, 3))
    np.add.at(toward, nearest, dirs * weight.mean(axis=1)[:, None])
    total = np.zeros(n)
    np.add.at(total, nearest, weight.mean(axis=1))
    length = np.linalg.norm(toward, axis=1, keepdims=True)
    # The spread of its part about that direction: the weighted mean cosine m of a uniform cap of
    # half angle h is (1 + cos h) / 2 (a small bright patch gives a sharp sun, an even sky a wide one).
    mean_cos = length[:, 0] / np.maximum(total, 1e-300)
    angle = 2.0 * np.arccos(np.clip(2.0 * mean_cos - 1.0, -1.0, 1.0))
    toward = np.where(length > 1e-12, toward / np.maximum(length, 1e-300), centres)
    return tuple(Light(matrix_world=_sun_matrix(w), color=tuple(float(c) for c in power[k]), power_w=1.0,
                       kind="SUN", name=f"World {k + 1}/{n}", from_world=True, angle_rad=float(angle[k]))
                 for k, w in enumerate(toward) if np.any(power[k] > 0.0))


def world_share(scene: Scene) -> float:
    """The world's share of the light arriving at the middle of the scene's media (of its solids
    where it has none), unshadowed: the world's fluence there, 4 pi times its mean radiance,
    against the lights' (a sun's irradiance, another light's on-axis intensity over the squared
    distance). 1 where no light shines."""
    world = 4.0 * math.pi * max(scene.ambient)
    if world <= 0.0:
        return 0.0
    own = [light for light in scene.lights
           if not light.from_world and (light.lights_medium or light.lights_surfaces)]
    lights = sum(float(np.max(light.intensity_w_per_sr)) for light in own if light.kind == "SUN")
    near = [light for light in own if light.kind != "SUN"]
    if near:            # their light falls with the distance to the scene's middle
        boxes = [b for b in (_medium_bounds(m) for m in scene.media) if b is not None]
        boxes = boxes or [b for b in (m.world_bounds for m in scene.meshes) if b is not None]
        centre = (0.5 * (np.min([b[0] for b in boxes], axis=0) + np.max([b[1] for b in boxes], axis=0))
                  if boxes else np.zeros(3))
        for light in near:
            r2 = float(np.sum((np.asarray(light.matrix_world, np.float64)[:3, 3] - centre) ** 2))
            lights += float(np.max(light.intensity_w_per_sr)) / max(r2, 1e-6)
    return world / (world + lights)


def directions_for(scene: Scene, n: int = DEFAULT_DIRECTIONS) -> int:
    """How many directions the world's light comes from: ``n`` (the most, the user's setting)
    where the world is all the light, fewer as its share falls (``world_share``): the error of
    the directions' quadrature is about proportional to the world's share over the count's square
    root, held at ``n``'s; at least MIN_DIRECTIONS (or ``n`` where smaller)."""
    share = world_share(scene)
    return int(min(n, max(MIN_DIRECTIONS, math.ceil(n * share * share))))


def _medium_bounds(m) -> tuple[np.ndarray, np.ndarray] | None:
    """A bounded medium's world bounds (None: fog without bounds)."""
    if m.density is not None:
        lo, hi, mat = -0.5 * np.ones(3), np.asarray(m.density.shape, np.float64) - 0.5, m.index_to_world
    elif m.box_to_world is not None:
        lo, hi, mat = -np.ones(3), np.ones(3), m.box_to_world
    else:
        return None
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    mat = np.asarray(mat, np.float64)
    w = corners @ mat[:3, :3].T + mat[:3, 3]
    return w.min(axis=0), w.max(axis=0)


def with_world_light(scene: Scene, n: int = DEFAULT_DIRECTIONS) -> Scene:
    """``scene`` with its ambient light replaced by shadowed world suns (what a frame renders
    when RenderSettings.world_light is 'SHADOWED'), ``directions_for(scene, n)`` of them; the world
    seen behind everything is unchanged."""
    if not any(c > 0.0 for c in scene.ambient):
        return scene
    n = directions_for(scene, n)
    env = scene.environment
    suns = ()
    if scene.world_lights_medium or scene.world_lights_surfaces:
        suns = world_suns(scene.ambient, n) if env is None else environment_suns(env.image(), n)
        suns = tuple(replace(s, lights_medium=scene.world_lights_medium,
                             lights_surfaces=scene.world_lights_surfaces) for s in suns)
    seen = scene.background        # the world behind everything stays as it was
    return replace(scene, lights=(*scene.lights, *suns), ambient=(0.0, 0.0, 0.0),
                   world=seen if isinstance(seen, tuple) else None)
