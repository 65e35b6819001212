"""Procedural scenes for the tests, the benchmark and the demo (numpy only, no Blender)."""

from __future__ import annotations

import math

import numpy as np

from .engine.scene import Camera, Medium, Mesh, Scene, SpotLight


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """A 4x4 placing an object at ``eye`` with its local -Z toward ``target`` and +Y up-ish."""
    eye, target, up = (np.asarray(v, dtype=np.float64) for v in (eye, target, up))
    back = eye - target
    back /= np.linalg.norm(back)
    if abs(back @ up) > 0.999:
        up = np.array([0.0, 1.0, 0.0]) if abs(back[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    right = np.cross(up, back)
    right /= np.linalg.norm(right)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, np.cross(back, right), back, eye
    return m


def translate_scale(offset, scale) -> np.ndarray:
    m = np.diag([*np.broadcast_to(np.asarray(scale, float), 3), 1.0])
    m[:3, 3] = offset
    return m


def box_mesh(center, size, color=(0.8, 0.8, 0.8), name="Box") -> Mesh:
    """An axis-aligned box of the given full size (metres)."""
    c = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = [t for a, b, c_, d in quads for t in ((a, b, c_), (a, c_, d))]
    return Mesh(vertices=c, triangles=tris, matrix_world=translate_scale(center, size), color=color,
                name=name)


def plane_mesh(center, size, color=(0.8, 0.8, 0.8), name="Ground") -> Mesh:
    """A horizontal square of side ``size`` (metres)."""
    v = np.array([[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]])
    return Mesh(vertices=v, triangles=[(0, 1, 2), (0, 2, 3)],
                matrix_world=translate_scale(center, (size, size, 1.0)), color=color, name=name)


def smooth_noise(n: int, scale: float, rng: np.random.Generator) -> np.ndarray:
    """White noise low-passed by a Gaussian of ``scale`` voxels (periodic), unit variance."""
    k = np.fft.fftfreq(n)
    kx, ky, kz = np.meshgrid(k, k, np.fft.rfftfreq(n), indexing="ij")
    spectrum = np.fft.rfftn(rng.standard_normal((n, n, n)))
    spectrum *= np.exp(-2 * (math.pi * scale) ** 2 * (kx**2 + ky**2 + kz**2))
    field = np.fft.irfftn(spectrum, s=(n, n, n))
    return field / (field.std() + 1e-12)


def smoke_density(n: int = 64, seed: int = 1, turbulence: float = 1.0) -> np.ndarray:
    """A turbulent puff in an n^3 grid, values in [0, 1], zero near the faces: a few Gaussian
    blobs carved by three octaves of smooth noise."""
    rng = np.random.default_rng(seed)
    x = (np.arange(n) + 0.5) / n * 2 - 1
    X, Y, Z = np.meshgrid(x, x, x, indexing="ij")
    d = np.zeros((n, n, n))
    for _ in range(12):
        c = rng.uniform(-0.45, 0.45, 3)
        r = rng.uniform(0.1, 0.22)
        d += np.exp(-((X - c[0]) ** 2 + (Y - c[1]) ** 2 + (Z - c[2]) ** 2) / (2 * r * r))
    fbm = sum(smooth_noise(n, n / 2 ** (octave + 2), rng) / 2**octave for octave in range(3))
    d *= np.exp(1.2 * turbulence * fbm)
    edge = np.clip((1.0 - np.sqrt(X**2 + Y**2 + Z**2)) / 0.3, 0.0, 1.0)
    d *= edge * edge * (3 - 2 * edge)
    d = np.clip(d / np.percentile(d, 99.5) - 0.05, 0.0, 1.0)
    return d.astype(np.float32)


def grid_to_world(n_voxels, size_m: float, center=(0.0, 0.0, 0.0)) -> np.ndarray:
    """index_to_world for a grid spanning a cube of side ``size_m`` centred at ``center``."""
    n = np.asarray(n_voxels, dtype=np.float64)
    h = size_m / n.max()
    return translate_scale(np.asarray(center) - 0.5 * h * (n - 1), h)


def smoke_scene(width: int = 96, height: int = 64, n: int = 64, sigma_s=(2.0, 2.0, 2.0),
                sigma_a=(0.2, 0.2, 0.2), with_bar: bool = True, with_ground: bool = True,
                ambient=(0.0, 0.0, 0.0)) -> Scene:
    """A 2 m puff of smoke lit from above-left by a spot, a bar casting a shadow through it."""
    medium = Medium(sigma_a=sigma_a, sigma_s=sigma_s, density=smoke_density(n),
                    index_to_world=grid_to_world((n, n, n), 2.0, (0, 0, 1.2)))
    light = SpotLight(matrix_world=look_at((-2.5, -1.0, 4.0), (0, 0, 1.0)), power_w=2000.0,
                      spot_size_rad=math.radians(40), spot_blend=0.2)
    meshes = []
    if with_bar:
        meshes.append(box_mesh((-1.5, -0.6, 3.0), (0.12, 1.2, 0.12), name="Bar"))
    if with_ground:
        meshes.append(plane_mesh((0, 0, 0), 8.0))
    camera = Camera(matrix_world=look_at((0.0, -6.5, 1.6), (0, 0, 1.1)), width_px=width,
                    height_px=height, lens_mm=40.0)
    return Scene(camera=camera, lights=(light,), medium=medium, meshes=tuple(meshes), ambient=ambient)


def paper_smoke_scene(width: int = 320, height: int = 180, n: int = 128) -> Scene:
    """The paper's smoke set-up: a 128^3 puff filling the frame, lit whole by a wide spot."""
    base = smoke_scene(width=width, height=height, n=n)
    light = SpotLight(matrix_world=look_at((-2.0, -1.5, 3.2), (0, 0, 1.2)), power_w=2000.0,
                      spot_size_rad=math.radians(70), spot_blend=0.2)
    camera = Camera(matrix_world=look_at((0.0, -2.6, 1.3), (0, 0, 1.2)), width_px=width, height_px=height,
                    lens_mm=30.0)
    return Scene(camera=camera, lights=(light,), medium=base.medium, meshes=base.meshes)


def stripes_gobo(size: int = 64, period_px: int = 4) -> np.ndarray:
    """A high-frequency projected texture: concentric rings, ``period_px`` texels apart."""
    y, x = np.mgrid[0:size, 0:size] + 0.5
    r = np.hypot(x - size / 2, y - size / 2)
    g = (np.floor(r / (period_px / 2)) % 2).astype(np.float32)
    return np.repeat(g[:, :, None], 3, axis=2)


def homogeneous_box_scene(width: int = 96, height: int = 64, sigma_s=(0.6, 0.5, 0.4),
                          sigma_a=(0.05, 0.05, 0.05), gobo: np.ndarray | None = None,
                          camera_eye=(3.5, -5.0, 2.5), with_bar: bool = True,
                          ambient=(0.0, 0.0, 0.0)) -> Scene:
    """Fog in a 3 m box on a ground plane, lit by a spot (optionally through a gobo)."""
    medium = Medium(sigma_a=sigma_a, sigma_s=sigma_s, box_to_world=translate_scale((0, 0, 1.5), 1.5))
    light = SpotLight(matrix_world=look_at((-1.0, -3.0, 4.0), (0.0, 0.5, 0.0)), power_w=3000.0,
                      spot_size_rad=math.radians(45), spot_blend=0.1, gobo=gobo)
    meshes = [plane_mesh((0, 0, 0), 10.0)]
    if with_bar:
        meshes.append(box_mesh((-0.7, -1.8, 3.0), (1.0, 0.1, 0.1), name="Bar"))
    camera = Camera(matrix_world=look_at(camera_eye, (0, 0, 1.2)), width_px=width, height_px=height,
                    lens_mm=35.0)
    return Scene(camera=camera, lights=(light,), medium=medium, meshes=tuple(meshes), ambient=ambient)


def plume_density(n: int = 64, seed: int = 7) -> np.ndarray:
    """A rising smoke plume in an (n, n, 3n/2) grid: a column widening with height, bending, and
    carved by smooth noise; values in [0, 1]."""
    rng = np.random.default_rng(seed)
    m = 3 * n // 2
    x = (np.arange(n) + 0.5) / n * 2 - 1
    z = (np.arange(m) + 0.5) / m
    X, Y, Z = np.meshgrid(x, x, z, indexing="ij")
    cx = 0.12 * np.sin(2.5 * Z + 0.5) * Z
    cy = 0.15 * np.cos(3.0 * Z) * Z
    radius = 0.2 + 0.55 * Z
    rr = np.sqrt((X - cx) ** 2 + (Y - cy) ** 2) / radius
    column = np.clip(1.0 - rr, 0.0, 1.0) ** 0.8
    noise = sum(smooth_noise(m, m / 2 ** (octave + 3), rng)[:n, :n, :] / 2**octave for octave in range(3))
    d = column * np.exp(1.1 * noise) * np.clip(Z / 0.08, 0, 1) * np.clip((1.0 - Z) / 0.3, 0, 1)
    d = np.clip(d / np.percentile(d[d > 0], 99) - 0.08, 0.0, 1.0)
    return d.astype(np.float32)


def demo_scene(width: int = 640, height: int = 360, n: int = 64) -> Scene:
    """The demo: a plume of smoke rising from the ground, a spot light raking through it, a bar
    casting a shaft of shadow through the smoke and onto the ground, a faint blue world."""
    density = plume_density(n)
    medium = Medium(sigma_a=(0.15, 0.15, 0.15), sigma_s=(3.0, 2.9, 2.7), anisotropy=0.3, density=density,
                    index_to_world=grid_to_world(density.shape, 3.0, (0, 0, 1.5)))
    light = SpotLight(matrix_world=look_at((-3.2, -1.2, 4.2), (0.2, 0.3, 1.2)), power_w=4000.0,
                      color=(1.0, 0.93, 0.82), spot_size_rad=math.radians(45), spot_blend=0.25)
    meshes = (box_mesh((-2.2, -0.75, 3.3), (0.1, 1.6, 0.1), color=(0.3, 0.3, 0.3), name="Bar"),
              plane_mesh((0, 0, 0), 12.0, color=(0.6, 0.6, 0.6)))
    camera = Camera(matrix_world=look_at((0.6, -7.0, 1.8), (0, 0, 1.5)), width_px=width, height_px=height,
                    lens_mm=35.0)
    return Scene(camera=camera, lights=(light,), medium=medium, meshes=meshes, ambient=(0.02, 0.025, 0.04))
