"""Procedural scenes for the tests, the benchmark and the demo (numpy only, no Blender)."""

from __future__ import annotations

import math

import numpy as np

from .engine.scene import Camera, Light, Medium, Mesh, Scene


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
    light = Light(matrix_world=look_at((-2.5, -1.0, 4.0), (0, 0, 1.0)), power_w=2000.0,
                      spot_size_rad=math.radians(40), spot_blend=0.2)
    meshes = []
    if with_bar:
        meshes.append(box_mesh((-1.5, -0.6, 3.0), (0.12, 1.2, 0.12), name="Bar"))
    if with_ground:
        meshes.append(plane_mesh((0, 0, 0), 8.0))
    camera = Camera(matrix_world=look_at((0.0, -6.5, 1.6), (0, 0, 1.1)), width_px=width,
                    height_px=height, lens_mm=40.0)
    return Scene(camera=camera, lights=(light,), media=(medium,), meshes=tuple(meshes), ambient=ambient)


def paper_smoke_scene(width: int = 320, height: int = 180, n: int = 128) -> Scene:
    """The paper's smoke set-up: a 128^3 puff filling the frame, lit whole by a wide spot."""
    base = smoke_scene(width=width, height=height, n=n)
    light = Light(matrix_world=look_at((-2.0, -1.5, 3.2), (0, 0, 1.2)), power_w=2000.0,
                      spot_size_rad=math.radians(70), spot_blend=0.2)
    camera = Camera(matrix_world=look_at((0.0, -2.6, 1.3), (0, 0, 1.2)), width_px=width, height_px=height,
                    lens_mm=30.0)
    return Scene(camera=camera, lights=(light,), media=(base.media[0],), meshes=base.meshes)


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
    light = Light(matrix_world=look_at((-1.0, -3.0, 4.0), (0.0, 0.5, 0.0)), power_w=3000.0,
                      spot_size_rad=math.radians(45), spot_blend=0.1, gobo=gobo)
    meshes = [plane_mesh((0, 0, 0), 10.0)]
    if with_bar:
        meshes.append(box_mesh((-0.7, -1.8, 3.0), (1.0, 0.1, 0.1), name="Bar"))
    camera = Camera(matrix_world=look_at(camera_eye, (0, 0, 1.2)), width_px=width, height_px=height,
                    lens_mm=35.0)
    return Scene(camera=camera, lights=(light,), media=(medium,), meshes=tuple(meshes), ambient=ambient)


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
    light = Light(matrix_world=look_at((-3.2, -1.2, 4.2), (0.2, 0.3, 1.2)), power_w=4000.0,
                      color=(1.0, 0.93, 0.82), spot_size_rad=math.radians(45), spot_blend=0.25)
    meshes = (box_mesh((-2.2, -0.75, 3.3), (0.1, 1.6, 0.1), color=(0.3, 0.3, 0.3), name="Bar"),
              plane_mesh((0, 0, 0), 12.0, color=(0.6, 0.6, 0.6)))
    camera = Camera(matrix_world=look_at((0.6, -7.0, 1.8), (0, 0, 1.5)), width_px=width, height_px=height,
                    lens_mm=35.0)
    return Scene(camera=camera, lights=(light,), media=(medium,), meshes=meshes, ambient=(0.02, 0.025, 0.04))


def shaft_demo_scene(width: int = 640, height: int = 360, n: int = 64) -> Scene:
    """The first picture a user renders (scripts/demo.py): a spot light's beam falling through the
    air onto a ground, a bar under the spot casting a shaft of shadow down through a smoke plume
    that stands in the beam, a crate beside it, a faint blue world. The air's fog (a Volume Scatter
    on the World, in which the beam and the shaft show) is the demo script's."""
    density = plume_density(n)
    medium = Medium(sigma_a=(0.3, 0.3, 0.3), sigma_s=(8.0, 7.7, 7.2), anisotropy=0.3, density=density,
                    index_to_world=grid_to_world(density.shape, 3.0, (0.3, 0.1, 1.5)))
    light = Light(matrix_world=look_at((-2.2, -0.8, 5.0), (0.4, 0.3, 0.0)), power_w=2500.0,
                  color=(1.0, 0.93, 0.82), spot_size_rad=math.radians(38), spot_blend=0.2)
    meshes = (box_mesh((-1.15, -0.45, 3.4), (0.16, 1.4, 0.16), color=(0.3, 0.3, 0.3), name="Bar"),
              box_mesh((2.2, 1.7, 0.5), (1.0, 1.0, 1.0), color=(0.7, 0.5, 0.3), name="Crate"),
              plane_mesh((0, 0, 0), 14.0, color=(0.6, 0.6, 0.6)))
    camera = Camera(matrix_world=look_at((5.2, -6.0, 2.2), (0.2, 0.1, 1.6)), width_px=width,
                    height_px=height, lens_mm=32.0)
    return Scene(camera=camera, lights=(light,), media=(medium,), meshes=meshes, ambient=(0.02, 0.025, 0.04))


# --------------------------------------------------------------------------------------------
# Benchmark scenes: a sharp-edged voxelised mesh, a large cloud, a dense smoke.
# --------------------------------------------------------------------------------------------

def smooth_noise_grid(shape, scale: float, rng: np.random.Generator) -> np.ndarray:
    """Periodic white noise of any (nx, ny, nz) shape low-passed by a Gaussian of ``scale``
    voxels, unit variance, float32."""
    shape = tuple(int(s) for s in shape)
    kx, ky, kz = np.meshgrid(np.fft.fftfreq(shape[0]), np.fft.fftfreq(shape[1]),
                             np.fft.rfftfreq(shape[2]), indexing="ij", sparse=True)
    spectrum = np.fft.rfftn(rng.standard_normal(shape).astype(np.float32))
    spectrum *= np.exp(-2 * (math.pi * scale) ** 2 * (kx**2 + ky**2 + kz**2)).astype(np.float32)
    field = np.fft.irfftn(spectrum, s=shape).astype(np.float32)
    return field / (field.std() + 1e-12)


def mesh_inside(vertices, triangles, shape, index_to_world) -> np.ndarray:
    """Which voxel centres of a grid lie inside a triangle mesh: the parity of the surface
    crossings along rays in +x, +y and +z, majority of the three (robust to small holes such as
    Suzanne's open eye sockets). ``vertices`` (n, 3) and ``index_to_world`` in the same space."""
    shape = tuple(int(s) for s in shape)
    v = np.asarray(vertices, dtype=np.float64)
    to_index = np.linalg.inv(np.asarray(index_to_world, dtype=np.float64))
    vi = v @ to_index[:3, :3].T + to_index[:3, 3]
    # A tiny irrational offset keeps the rays off shared edges and vertices.
    vi += np.array([1.234567e-5, 2.345678e-5, 3.456789e-5])
    tri = vi[np.asarray(triangles, dtype=np.int64)]
    votes = np.zeros(shape, dtype=np.uint8)
    for axis in range(3):
        a, b = [k for k in range(3) if k != axis]
        toggles = np.zeros((shape[a], shape[b], shape[axis] + 1), dtype=np.int32)
        for t in tri:
            pa, pb, pz = t[:, a], t[:, b], t[:, axis]
            ia = np.arange(max(math.ceil(pa.min()), 0), min(math.floor(pa.max()), shape[a] - 1) + 1)
            ib = np.arange(max(math.ceil(pb.min()), 0), min(math.floor(pb.max()), shape[b] - 1) + 1)
            if len(ia) == 0 or len(ib) == 0:
                continue
            A, B = np.meshgrid(ia, ib, indexing="ij")
            det = (pb[1] - pb[2]) * (pa[0] - pa[2]) + (pa[2] - pa[1]) * (pb[0] - pb[2])
            if abs(det) < 1e-12:
                continue
            l0 = ((pb[1] - pb[2]) * (A - pa[2]) + (pa[2] - pa[1]) * (B - pb[2])) / det
            l1 = ((pb[2] - pb[0]) * (A - pa[2]) + (pa[0] - pa[2]) * (B - pb[2])) / det
            l2 = 1.0 - l0 - l1
            hit = (l0 >= 0) & (l1 >= 0) & (l2 >= 0)
            if not hit.any():
                continue
            z = l0[hit] * pz[0] + l1[hit] * pz[1] + l2[hit] * pz[2]
            k = np.clip(np.ceil(z), 0, shape[axis]).astype(np.int64)
            np.add.at(toggles, (A[hit], B[hit], k), 1)
        inside = (np.cumsum(toggles, axis=2)[:, :, :-1] % 2).astype(np.uint8)
        order = [0, 0, 0]
        order[a], order[b], order[axis] = 0, 1, 2
        votes += np.transpose(inside, order)
    return votes >= 2


def suzanne_scene(vertices, triangles, width: int = 320, height: int = 180, n: int = 256,
                  sigma_s=(3.6, 3.6, 3.6), sigma_a=(0.4, 0.4, 0.4), with_ground: bool = True) -> Scene:
    """The paper's "bunny" case: a mesh (Blender's Suzanne, as ``primitive_monkey_add(size=2)``
    makes it, facing -Y) voxelised into an n^3 grid of constant density 1 inside: sharp steps
    and flat regions. Lit from the front left; the camera looks at its face."""
    v = np.asarray(vertices, dtype=np.float64)
    center = np.array([0.0, 0.0, 1.3])
    lo, hi = v.min(axis=0), v.max(axis=0)
    size = float((hi - lo).max()) * 1.04
    index_to_world = grid_to_world((n, n, n), size, center)
    placed = v - 0.5 * (lo + hi) + center
    density = mesh_inside(placed, triangles, (n, n, n), index_to_world).astype(np.float32)
    medium = Medium(sigma_a=sigma_a, sigma_s=sigma_s, density=density, index_to_world=index_to_world)
    light = Light(matrix_world=look_at((-2.2, -3.2, 3.6), tuple(center)), power_w=2500.0,
                      spot_size_rad=math.radians(50), spot_blend=0.2, name="Key")
    meshes = (plane_mesh((0, 0, 0), 10.0),) if with_ground else ()
    camera = Camera(matrix_world=look_at((1.2, -4.6, 1.7), (0.0, 0.0, 1.25)), width_px=width,
                    height_px=height, lens_mm=45.0)
    return Scene(camera=camera, lights=(light,), media=(medium,), meshes=meshes)


def cloud_density(shape=(600, 400, 200), seed: int = 3) -> np.ndarray:
    """A cumulus-like cloud filling an (nx, ny, nz) grid (z up), values in [0, 1]: ellipsoidal
    puffs over a flat base, eroded by smooth noise at two scales. Built at a quarter of the
    resolution and upsampled, with fine periodic noise added at full resolution."""
    from scipy import ndimage

    rng = np.random.default_rng(seed)
    shape = tuple(int(s) for s in shape)
    coarse = tuple(max(8, s // 4) for s in shape)
    x, y, z = (np.linspace(0.0, 1.0, c, dtype=np.float32) for c in coarse)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij", sparse=True)
    field = np.full(coarse, -1.0, dtype=np.float32)
    for _ in range(24):
        c = np.array([rng.uniform(0.22, 0.78), rng.uniform(0.25, 0.75), rng.uniform(0.25, 0.5)])
        r = rng.uniform(0.08, 0.17)
        ry = r * shape[0] / shape[1]
        rz = r * shape[0] / shape[2] * rng.uniform(0.5, 0.8)
        q = ((X - c[0]) / r) ** 2 + ((Y - c[1]) / ry) ** 2 + ((Z - c[2]) / rz) ** 2
        field = np.maximum(field, 1.0 - np.sqrt(q))
    field -= np.clip((0.2 - Z) / 0.05, 0.0, 2.0)                  # a flat bottom
    field += 0.16 * smooth_noise_grid(coarse, 2.5, rng) + 0.07 * smooth_noise_grid(coarse, 1.0, rng)
    zoom = [s / c for s, c in zip(shape, coarse, strict=True)]
    full = ndimage.zoom(field, zoom, order=1, output=np.float32, grid_mode=True, mode="nearest")
    tile = smooth_noise_grid((64, 64, 64), 1.5, rng)
    reps = [math.ceil(s / 64) for s in shape]
    full += 0.05 * np.tile(tile, reps)[: shape[0], : shape[1], : shape[2]]
    d = np.clip(full / 0.6, 0.0, 1.0)
    d[0], d[-1], d[:, 0], d[:, -1], d[:, :, 0], d[:, :, -1] = 0, 0, 0, 0, 0, 0
    return d.astype(np.float32)


def cloud_scene(width: int = 320, height: int = 180, shape=(600, 400, 200), sigma_s=(6.0, 6.0, 6.0),
                sigma_a=(0.02, 0.02, 0.02), size_m: float = 12.0, with_ground: bool = True,
                density: np.ndarray | None = None) -> Scene:
    """A cloud 600 x 200 x 400 voxels (the paper's; here 600 wide, 400 deep, 200 tall, z up),
    ``size_m`` wide, floating over a ground plane, lit from high up by a narrow spot (a sun
    stand-in) that casts its shadow on the ground."""
    d = cloud_density(shape) if density is None else density
    h = size_m / max(shape)
    center = np.array([0.0, 0.0, 3.0 + 0.5 * h * shape[2]])
    index_to_world = grid_to_world(shape, size_m, center)
    medium = Medium(sigma_a=sigma_a, sigma_s=sigma_s, density=d, index_to_world=index_to_world)
    light = Light(matrix_world=look_at((-9.0, -6.0, 16.0), tuple(center - [0, 0, 1.5])),
                      power_w=60000.0, spot_size_rad=math.radians(50), spot_blend=0.15, name="Sun")
    meshes = (plane_mesh((0, 0, 0), 40.0, color=(0.5, 0.5, 0.5)),) if with_ground else ()
    camera = Camera(matrix_world=look_at((3.0, -16.0, 2.0), tuple(center - [0, 0, 1.0])), width_px=width,
                    height_px=height, lens_mm=32.0)
    return Scene(camera=camera, lights=(light,), media=(medium,), meshes=meshes)


def dense_smoke_scene(width: int = 320, height: int = 180, n: int = 128, thickness: float = 10.0) -> Scene:
    """The paper's Fig. 7 case: the paper smoke with its sigmas multiplied by ``thickness``, so
    that the transmittance along the light rays falls steeply and a truncated cosine series
    rings (overshoots) without density weighting."""
    base = paper_smoke_scene(width=width, height=height, n=n)
    m = base.media[0]
    medium = Medium(sigma_a=tuple(thickness * s for s in m.sigma_a),
                    sigma_s=tuple(thickness * s for s in m.sigma_s), density=m.density,
                    index_to_world=m.index_to_world, anisotropy=m.anisotropy)
    light = Light(matrix_world=base.lights[0].matrix_world, power_w=base.lights[0].power_w * 4.0,
                      spot_size_rad=base.lights[0].spot_size_rad, spot_blend=base.lights[0].spot_blend)
    return Scene(camera=base.camera, lights=(light,), media=(medium,), meshes=base.meshes)


def gobo_box_scene(width: int = 320, height: int = 180, camera_eye=(3.5, -5.0, 2.5),
                   period_px: int = 4, with_bar: bool = False) -> Scene:
    """The paper's Fig. 5 case: a homogeneous fog box lit through a high-frequency gobo
    (``with_bar``: and a bar that casts a shaft through it)."""
    return homogeneous_box_scene(width=width, height=height, gobo=stripes_gobo(64, period_px),
                                 camera_eye=camera_eye, with_bar=with_bar)


def _rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' rotation of v about the unit axis."""
    return (v * math.cos(angle) + np.cross(axis, v) * math.sin(angle)
            + axis * (axis @ v) * (1 - math.cos(angle)))


def gobo_angle_scene(angle_deg: float, width: int = 160, height: int = 90, distance_m: float = 6.5,
                     period_px: int = 4) -> Scene:
    """A 3 m box of homogeneous fog lit through a ring gobo by a spot aimed at its centre, seen
    by a camera whose view axis makes ``angle_deg`` with the light's axis (0: looking along the
    beam from behind the light; 180: looking into the light). No ground, no solids."""
    center = np.array([0.0, 0.0, 1.5])
    light_pos = np.array([-1.5, -3.5, 4.5])
    axis_l = (center - light_pos) / np.linalg.norm(center - light_pos)
    turn = np.cross(axis_l, [0.0, 0.0, 1.0])
    turn /= np.linalg.norm(turn)
    view = _rotate(axis_l, turn, math.radians(angle_deg))
    eye = center - view * distance_m
    medium = Medium(sigma_a=(0.05, 0.05, 0.05), sigma_s=(0.6, 0.5, 0.4),
                    box_to_world=translate_scale(tuple(center), 1.5))
    light = Light(matrix_world=look_at(tuple(light_pos), tuple(center)), power_w=3000.0,
                      spot_size_rad=math.radians(45), spot_blend=0.1, gobo=stripes_gobo(64, period_px))
    camera = Camera(matrix_world=look_at(tuple(eye), tuple(center)), width_px=width, height_px=height,
                    lens_mm=30.0)
    return Scene(camera=camera, lights=(light,), media=(medium,))


def inside_scene(homogeneous: bool, light_inside: bool, camera_inside: bool, width: int = 160,
                 height: int = 90, n: int = 64) -> Scene:
    """METHOD.md's weak points: a spot light and/or the camera inside the medium (a 2 m puff of
    smoke, or a 2 m box of fog, centred at (0, 0, 1.2) over a ground plane)."""
    center = (0.0, 0.0, 1.2)
    if homogeneous:
        medium = Medium(sigma_a=(0.05, 0.05, 0.05), sigma_s=(0.6, 0.5, 0.4),
                        box_to_world=translate_scale(center, 1.0))
    else:
        medium = Medium(sigma_a=(0.2, 0.2, 0.2), sigma_s=(2.0, 2.0, 2.0), density=smoke_density(n),
                        index_to_world=grid_to_world((n, n, n), 2.0, center))
    if light_inside:
        light = Light(matrix_world=look_at((0.15, -0.1, 1.35), (0.6, 0.5, 0.0)), power_w=300.0,
                          spot_size_rad=math.radians(100), spot_blend=0.2)
    else:
        light = Light(matrix_world=look_at((-2.5, -1.0, 4.0), (0, 0, 1.0)), power_w=2000.0,
                          spot_size_rad=math.radians(40), spot_blend=0.2)
    if camera_inside:
        camera = Camera(matrix_world=look_at((-0.35, -0.5, 1.1), (0.6, 0.6, 0.7)), width_px=width,
                        height_px=height, lens_mm=18.0)
    else:
        camera = Camera(matrix_world=look_at((0.0, -6.5, 1.6), (0, 0, 1.1)), width_px=width,
                        height_px=height, lens_mm=40.0)
    return Scene(camera=camera, lights=(light,), media=(medium,), meshes=(plane_mesh((0, 0, 0), 8.0),))


# --------------------------------------------------------------------------------------------
# Fire: emission, blackbody and colour grids
# --------------------------------------------------------------------------------------------

def fire_grids(density: np.ndarray) -> dict[str, np.ndarray]:
    """Flame and temperature grids for a plume ``density`` (x, y, z index order, z up), made the
    way Mantaflow's fire looks: the flame burns in the lower core and fades with height; the
    temperature grid is in units of 1000 K (Blender's convention: Principled Volume's Temperature
    1000 K times the grid), ignition 1.5 to maximum 3."""
    nz = density.shape[2]
    z = (np.arange(nz) + 0.5) / nz
    core = np.clip(density, 0.0, 1.0) ** 1.5
    flame = core * np.clip(1.0 - z / 0.55, 0.0, 1.0)[None, None, :] ** 1.5
    flame = np.clip(flame / max(float(flame.max()), 1e-12), 0.0, 1.0).astype(np.float32)
    temperature = np.where(flame > 0.01, 1.5 + 1.5 * flame, 0.0).astype(np.float32)
    return {"flame": flame, "temperature": temperature}


def color_grid_for(density: np.ndarray) -> np.ndarray:
    """An (nx, ny, nz, 3) colour grid in [0.1, 1]: warm at the bottom, cold at the top, varying
    across x too, as a coloured smoke simulation leaves it."""
    nx, ny, nz = density.shape
    x = (np.arange(nx) + 0.5) / nx
    z = (np.arange(nz) + 0.5) / nz
    X, _, Z = np.meshgrid(x, np.ones(ny), z, indexing="ij")
    r = 0.25 + 0.75 * (1.0 - Z)
    g = 0.3 + 0.6 * X
    b = 0.2 + 0.8 * Z
    return np.clip(np.stack([r, g, b], axis=-1), 0.1, 1.0).astype(np.float32)


def fire_scene(width: int = 96, height: int = 54, n: int = 32, kind: str = "EMISSION",
               with_light: bool = False, with_occluder: bool = False, with_ground: bool = False) -> Scene:
    """A burning plume in a ``n`` x ``n`` x 3n/2 grid, 3 m tall.

    ``kind``: 'EMISSION' (Emission Strength 4 x flame, an orange Emission Color), 'BLACKBODY'
    (Blackbody Intensity 1, temperature 1500 K x the temperature grid: 2250-4500 K), 'FIRE' (both,
    1000 K x the grid), 'QUICK_FIRE' (Blender's Quick Smoke fire material: Principled Volume,
    Density 5 with its default grey Color (sigma_s = sigma_a = 2.5 per unit density), Blackbody
    Intensity 1, Temperature 1000 K x the temperature grid, Emission Strength 0),
    'COLOR' (no emission, a per-voxel colour grid, black absorption colour so the extinction does
    not depend on it). ``with_light``: a spot from above left; ``with_occluder``: a bar in its beam.
    """
    from .engine.scene import GridValue

    density = plume_density(n, seed=11)
    grids = fire_grids(density)
    fields: dict = {}
    sigma_s, sigma_a = (1.2, 1.2, 1.2), (0.3, 0.3, 0.3)
    if kind in ("EMISSION", "FIRE"):
        fields.update(emission_color=(1.0, 0.45, 0.12), emission_strength=GridValue("flame", 4.0, 0.0))
    if kind in ("BLACKBODY", "FIRE"):
        fields.update(blackbody_intensity=GridValue(offset=1.0),
                      temperature=GridValue("temperature", 1500.0 if kind == "BLACKBODY" else 1000.0, 0.0),
                      blackbody_tint=(1.0, 0.9, 0.8))
    if kind == "QUICK_FIRE":
        fields.update(blackbody_intensity=GridValue(offset=1.0),
                      temperature=GridValue("temperature", 1000.0, 0.0))
        sigma_s, sigma_a = (2.5, 2.5, 2.5), (2.5, 2.5, 2.5)
    if kind == "COLOR":
        grids["color"] = color_grid_for(density)
        fields.update(color_grid="color")
        sigma_s, sigma_a = (2.4, 1.8, 1.2), (0.6, 1.2, 1.8)
    medium = Medium(sigma_a=sigma_a, sigma_s=sigma_s, anisotropy=0.2, density=density,
                    index_to_world=grid_to_world(density.shape, 3.0, (0, 0, 1.5)), grids=grids, **fields)
    lights = ()
    if with_light:
        lights = (Light(matrix_world=look_at((-3.0, -1.5, 4.5), (0.0, 0.0, 1.4)), power_w=3000.0,
                            color=(1.0, 0.95, 0.9), spot_size_rad=math.radians(45), spot_blend=0.2),)
    meshes = []
    if with_occluder:
        meshes.append(box_mesh((-1.9, -0.95, 3.6), (0.15, 1.6, 0.15), color=(0.3, 0.3, 0.3), name="Bar"))
    if with_ground:
        meshes.append(plane_mesh((0, 0, 0), 10.0, color=(0.5, 0.5, 0.5)))
    camera = Camera(matrix_world=look_at((0.0, -7.5, 1.6), (0, 0, 1.5)), width_px=width, height_px=height,
                    lens_mm=35.0)
    return Scene(camera=camera, lights=lights, media=(medium,), meshes=tuple(meshes))


def fire_demo_scene(width: int = 640, height: int = 360, n: int = 64) -> Scene:
    """The demo's burning plume: smoke rising from a fire whose flame glows (Emission Strength from
    the flame grid) and burns (blackbody from the temperature grid), a dim spot raking the smoke,
    a bar cutting a shaft of shadow through it, a ground, a faint night sky."""
    from .engine.scene import GridValue

    density = plume_density(n, seed=11)
    grids = fire_grids(density)
    medium = Medium(sigma_a=(0.25, 0.25, 0.25), sigma_s=(1.6, 1.55, 1.5), anisotropy=0.3, density=density,
                    index_to_world=grid_to_world(density.shape, 3.0, (0, 0, 1.5)), grids=grids,
                    emission_color=(1.0, 0.35, 0.08), emission_strength=GridValue("flame", 6.0, 0.0),
                    blackbody_intensity=GridValue(offset=1.0), blackbody_tint=(1.0, 0.85, 0.7),
                    temperature=GridValue("temperature", 1000.0, 0.0))
    light = Light(matrix_world=look_at((-3.0, -1.5, 4.5), (0.0, 0.0, 1.8)), power_w=1500.0,
                      color=(0.75, 0.85, 1.0), spot_size_rad=math.radians(40), spot_blend=0.3)
    meshes = (box_mesh((-1.9, -0.95, 3.7), (0.12, 1.6, 0.12), color=(0.3, 0.3, 0.3), name="Bar"),
              plane_mesh((0, 0, 0), 12.0, color=(0.45, 0.45, 0.45)))
    camera = Camera(matrix_world=look_at((0.4, -5.8, 1.4), (0, 0, 1.45)), width_px=width, height_px=height,
                    lens_mm=32.0)
    return Scene(camera=camera, lights=(light,), media=(medium,), meshes=meshes, ambient=(0.01, 0.012, 0.02))


def uv_sphere(radius: float = 1.0, segments: int = 32, rings: int = 16, center=(0.0, 0.0, 0.0)):
    """A closed UV sphere as Blender's ``primitive_uv_sphere_add`` makes it: (vertices (n, 3),
    triangles (m, 3)), outward-facing."""
    c = np.asarray(center, dtype=np.float64)
    verts = [c + (0.0, 0.0, radius), c - (0.0, 0.0, radius)]
    for i in range(1, rings):
        theta = math.pi * i / rings
        for j in range(segments):
            phi = 2.0 * math.pi * j / segments
            verts.append(c + radius * np.array([math.sin(theta) * math.cos(phi),
                                                math.sin(theta) * math.sin(phi), math.cos(theta)]))

    def idx(i, j):
        return 2 + (i - 1) * segments + (j % segments)

    tris = []
    for j in range(segments):
        tris.append((0, idx(1, j), idx(1, j + 1)))
        tris.append((1, idx(rings - 1, j + 1), idx(rings - 1, j)))
    for i in range(1, rings - 1):
        for j in range(segments):
            a, b, c2, d = idx(i, j), idx(i, j + 1), idx(i + 1, j), idx(i + 1, j + 1)
            tris += [(a, c2, b), (b, c2, d)]
    return np.array(verts), np.array(tris, dtype=np.int64)


def sky_environment(width: int = 64, height: int = 32) -> np.ndarray:
    """An equirectangular environment (Scene.environment's convention, top row first): a blue sky
    over a dark ground and a warm patch of high radiance 16 degrees wide, 30 degrees up."""
    theta = math.pi * (np.arange(height) + 0.5) / height                 # from +Z, top row first
    phi = math.pi - 2.0 * math.pi * (np.arange(width) + 0.5) / width
    t, p = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)
    rgb = np.where((d[..., 2] > 0)[..., None], [0.25, 0.45, 0.9], [0.05, 0.04, 0.03]).astype(np.float32)
    sun = np.array([0.6, -0.6, 0.5]) / np.linalg.norm([0.6, -0.6, 0.5])
    rgb[(d @ sun) > 0.96] = (40.0, 30.0, 20.0)
    return rgb


def world_lit_box_scene(width: int = 40, height: int = 30, environment: np.ndarray | None = None) -> Scene:
    """A box of smoke (homogeneous, 1.2 m) over a ground, lit only by the world: white, or
    ``environment`` (an equirectangular image, Scene's convention)."""
    from .engine.environment import from_image

    medium = Medium(sigma_a=(0.2, 0.2, 0.2), sigma_s=(2.4, 2.4, 2.4), name="Box",
                    box_to_world=translate_scale((0.0, 0.0, 1.0), 0.6))
    camera = Camera(matrix_world=look_at((0.0, -4.5, 1.8), (0.0, 0.0, 0.6)), width_px=width, height_px=height,
                    lens_mm=35.0)
    env = None if environment is None else from_image(environment)
    ambient = (1.0, 1.0, 1.0) if env is None else env.mean
    return Scene(camera=camera, media=(medium,), meshes=(plane_mesh((0, 0, 0), 8.0),), ambient=ambient,
                 environment=env)
