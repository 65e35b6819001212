"""Analytic checks of the CPU brute-force reference (no GPU)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from tfm_addon.engine.reference import render_reference
from tfm_addon.engine.scene import Camera, Light, Medium, Mesh, RenderSettings, Scene

# Camera rotated to look along +X with +Z up: local x -> -Y, local y -> +Z, local z -> -X.
LOOK_PLUS_X = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
# Light / camera rotated to shine along -Y (local -Z -> -Y): rotation of -90 degrees about X.
SHINE_MINUS_Y = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def pose(position, rotation=None, scale: float = 1.0) -> np.ndarray:
    m = np.eye(4)
    if rotation is not None:
        m[:3, :3] = rotation
    m[:3, :3] *= scale
    m[:3, 3] = position
    return m


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    eye = np.asarray(eye, float)
    f = np.asarray(target, float) - eye
    f /= np.linalg.norm(f)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    return pose(eye, np.stack([r, u, -f], axis=1))


def quad(center, half: float, normal_axis: int = 2, color=(0.8, 0.8, 0.8)) -> Mesh:
    """A square of side 2*half centred at ``center``, perpendicular to a world axis."""
    a, b = [k for k in range(3) if k != normal_axis]
    corners = []
    for sa, sb in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        c = np.array(center, float)
        c[a] += sa * half
        c[b] += sb * half
        corners.append(c)
    return Mesh(np.array(corners), np.array([[0, 1, 2], [0, 2, 3]]), color=color)


def centre(img: np.ndarray) -> np.ndarray:
    h, w = img.shape[:2]
    assert h % 2 == 1 and w % 2 == 1
    return img[h // 2, w // 2]


SIGMA_A = np.array([0.1, 0.3, 0.05])
SIGMA_S = np.array([0.6, 0.4, 1.2])
SIGMA_T = SIGMA_A + SIGMA_S


# (a) homogeneous box, ambient only ------------------------------------------------------------

def test_homogeneous_box_ambient_matches_analytic():
    ambient = np.array([0.7, 1.1, 0.4])
    medium = Medium(sigma_a=tuple(SIGMA_A), sigma_s=tuple(SIGMA_S),
                    box_to_world=pose((0.3, -0.2, 0.0), scale=1.0))
    # orthographic straight down -Z through the box: every pixel crosses 2 m of medium
    cam = Camera(pose((0.3, -0.2, 5.0)), 7, 5, projection="ORTHO", ortho_scale=1.5)
    out = render_reference(Scene(cam, media=(medium,), ambient=tuple(ambient)), view_steps=64)
    length = 2.0
    expect_t = np.exp(-SIGMA_T * length)
    expect_s = SIGMA_S / SIGMA_T * ambient * (1.0 - expect_t)
    np.testing.assert_allclose(out.passes["transmittance"], np.broadcast_to(expect_t, (5, 7, 3)),
                               rtol=1e-5)
    np.testing.assert_allclose(out.passes["scattering"], np.broadcast_to(expect_s, (5, 7, 3)),
                               rtol=1e-3)
    assert not out.passes["surfaces"].any()
    np.testing.assert_allclose(out.combined[..., 3], 1.0 - expect_t.mean(), rtol=1e-5)


def test_homogeneous_box_perspective_centre_and_miss():
    ambient = np.array([1.0, 1.0, 1.0])
    box = pose((0.0, 0.0, 0.0), scale=1.0) @ np.diag([1.0, 1.0, 1.5, 1.0])  # z half-size 1.5
    medium = Medium(sigma_a=tuple(SIGMA_A), sigma_s=tuple(SIGMA_S), box_to_world=box)
    cam = Camera(pose((0.0, 0.0, 6.0)), 21, 21, lens_mm=18.0)
    out = render_reference(Scene(cam, media=(medium,), ambient=tuple(ambient)))
    expect_t = np.exp(-SIGMA_T * 3.0)
    np.testing.assert_allclose(centre(out.passes["transmittance"]), expect_t, rtol=1e-5)
    np.testing.assert_allclose(centre(out.passes["scattering"]),
                               SIGMA_S / SIGMA_T * ambient * (1 - expect_t), rtol=1e-3)
    # the corner ray (slope 0.95 in x and y) misses the box
    np.testing.assert_array_equal(out.passes["transmittance"][0, 0], 1.0)
    np.testing.assert_array_equal(out.passes["scattering"][0, 0], 0.0)
    # ambient off
    off = render_reference(Scene(cam, media=(medium,), ambient=tuple(ambient)),
                           RenderSettings(ambient=False))
    assert not off.passes["scattering"].any()


# (b) constant-density grid == homogeneous -----------------------------------------------------

def grid_medium(shape=(9, 9, 16), voxel=0.125, origin=(-0.5, -0.5, 1.5), value=1.0) -> Medium:
    i2w = np.eye(4)
    i2w[:3, :3] *= voxel
    i2w[:3, 3] = origin
    return Medium(sigma_a=tuple(SIGMA_A), sigma_s=tuple(SIGMA_S),
                  density=np.full(shape, value, np.float32), index_to_world=i2w)


def test_constant_grid_view_transmittance():
    medium = grid_medium()
    # straight down through the dense column: the integral of D along z over the index box
    # [-1, 16] is 15 (dense part, centre to centre) + 2 * 1/2 (the linear fades) = 16 voxels
    cam = Camera(pose((0.0, 0.0, 6.0)), 3, 3, projection="ORTHO", ortho_scale=0.6)
    ambient = np.array([0.5, 0.25, 2.0])
    out = render_reference(Scene(cam, media=(medium,), ambient=tuple(ambient)), view_steps=136)
    length = 16 * 0.125
    expect_t = np.exp(-SIGMA_T * length)
    np.testing.assert_allclose(out.passes["transmittance"], np.broadcast_to(expect_t, (3, 3, 3)),
                               rtol=1e-6)
    # scattering over the fades is not the homogeneous formula, but close to it
    expect_s = SIGMA_S / SIGMA_T * ambient * (1 - expect_t)
    np.testing.assert_allclose(out.passes["scattering"], np.broadcast_to(expect_s, (3, 3, 3)),
                               rtol=0.05)


def test_constant_grid_shadows_surface_through_light_march():
    medium = grid_medium(shape=(17, 17, 16), voxel=0.125, origin=(-1.0, -1.0, 1.5))
    light = Light(pose((0.0, 0.0, 10.0)), power_w=4000.0, spot_size_rad=math.radians(40),
                      spot_blend=0.0)
    floor = quad((0.0, 0.0, 0.0), 4.0, color=(0.5, 0.6, 0.7))
    cam = Camera(look_at((0.0, -6.0, 2.0), (0.0, 0.0, 0.0)), 21, 15)
    out = render_reference(Scene(cam, (light,), meshes=(floor,), media=(medium,)), light_steps=136)
    intensity = 4000.0 / (4 * math.pi)
    t_light = np.exp(-SIGMA_T * 16 * 0.125)  # vertical light ray through the whole column
    expect = np.array([0.5, 0.6, 0.7]) / math.pi * intensity * t_light / 100.0
    assert centre(out.passes["transmittance"]).tolist() == [1.0, 1.0, 1.0]  # view misses grid
    np.testing.assert_allclose(centre(out.passes["surfaces"]), expect, rtol=1e-4)


# (c), (d) lit and shadowed quad ---------------------------------------------------------------

def test_quad_lit_head_on():
    albedo = np.array([0.9, 0.5, 0.2])
    ambient = np.array([0.1, 0.2, 0.3])
    light = Light(pose((0.0, 0.0, 5.0)), color=(1.0, 0.5, 0.25), power_w=1000.0,
                      spot_size_rad=math.radians(60), spot_blend=0.3)
    floor = quad((0.0, 0.0, 0.0), 4.0, color=tuple(albedo))
    cam = Camera(pose((0.0, 0.0, 8.0)), 11, 9)
    out = render_reference(Scene(cam, (light,), (floor,), ambient=tuple(ambient)))
    intensity = np.array([1.0, 0.5, 0.25]) * 1000.0 / (4 * math.pi)
    expect = albedo / math.pi * intensity / 25.0 + albedo * ambient
    np.testing.assert_allclose(centre(out.passes["surfaces"]), expect, rtol=1e-6)
    np.testing.assert_allclose(centre(out.rgb), expect, rtol=1e-6)
    assert out.combined[..., 3].min() == 1.0  # the quad fills the frame
    assert not out.passes["scattering"].any()
    # seen from below (two-sided, normal turned to the camera) the light is behind: ambient only
    below = Camera(pose((0.0, 0.0, -8.0), np.diag([1.0, -1.0, -1.0])), 11, 9)
    out = render_reference(Scene(below, (light,), (floor,), ambient=tuple(ambient)))
    np.testing.assert_allclose(centre(out.passes["surfaces"]), albedo * ambient, rtol=1e-6)


def test_quad_shadowed_by_occluder():
    albedo = np.array([0.8, 0.8, 0.8])
    ambient = np.array([0.05, 0.05, 0.05])
    light = Light(pose((0.0, 0.0, 5.0)), power_w=1000.0, spot_size_rad=math.radians(90),
                      spot_blend=0.0)
    floor = quad((0.0, 0.0, 0.0), 3.0, color=tuple(albedo))
    blocker = quad((0.0, 0.0, 2.5), 0.1)
    cam = Camera(look_at((3.0, 0.0, 4.0), (0.0, 0.0, 0.0)), 31, 31)  # blocker off to the side
    scene = Scene(cam, (light,), (floor, blocker), ambient=tuple(ambient))
    out = render_reference(scene)
    np.testing.assert_allclose(centre(out.passes["surfaces"]), albedo * ambient, rtol=1e-6)
    lit = render_reference(Scene(cam, (light,), (floor,), ambient=tuple(ambient)))
    intensity = 1000.0 / (4 * math.pi)
    np.testing.assert_allclose(centre(lit.passes["surfaces"]),
                               albedo / math.pi * intensity / 25.0 + albedo * ambient, rtol=1e-6)
    # the blocker is out of frame: it only darkens a small patch around the centre
    darker = out.passes["surfaces"][..., 0] < lit.passes["surfaces"][..., 0]
    assert (out.passes["surfaces"] <= lit.passes["surfaces"]).all()
    assert 9 <= darker.sum() < 0.1 * darker.size


def test_dark_lights_contribute_nothing():
    floor = quad((0.0, 0.0, 0.0), 2.0)
    medium = Medium(box_to_world=pose((0.0, 0.0, 1.0)))
    lights = (Light(pose((0.0, 0.0, 5.0)), power_w=0.0),
              Light(pose((0.0, 0.0, 5.0)), spot_size_rad=0.0))
    out = render_reference(Scene(Camera(pose((0.0, 0.0, 8.0)), 5, 5), lights, (floor,), media=(medium,)),
                           view_steps=16, light_steps=16)
    assert np.isfinite(out.combined).all()
    assert not out.rgb.any()


# (e) cone falloff and gobo ---------------------------------------------------------------------

def one_pixel_down(x: float, y: float = 0.0) -> Camera:
    """A 1x1 orthographic camera looking straight down at the ground point (x, y, 0)."""
    return Camera(pose((x, y, 10.0)), 1, 1, projection="ORTHO", ortho_scale=0.01)


@pytest.mark.parametrize("angle_deg, blend", [(25.0, 0.5), (29.0, 0.5), (31.0, 0.5),
                                              (29.0, 0.0), (31.0, 0.0), (10.0, 0.5)])
def test_spot_blend_smoothstep(angle_deg: float, blend: float):
    light = Light(pose((0.0, 0.0, 5.0)), power_w=800.0, spot_size_rad=math.radians(60),
                      spot_blend=blend)
    floor = quad((0.0, 0.0, 0.0), 10.0, color=(1.0, 1.0, 1.0))
    theta = math.radians(angle_deg)
    out = render_reference(Scene(one_pixel_down(5.0 * math.tan(theta)), (light,), (floor,)))
    cos_half = math.cos(math.radians(30))
    if math.cos(theta) <= cos_half:
        spot = 0.0
    elif blend == 0:
        spot = 1.0
    else:
        x = min(1.0, (math.cos(theta) - cos_half) / ((1 - cos_half) * blend))
        spot = x * x * (3 - 2 * x)
    if angle_deg == 25.0:
        assert 0.3 < spot < 0.9  # a value on the ramp, not a plateau
    r = 5.0 / math.cos(theta)
    expect = 1.0 / math.pi * 800.0 / (4 * math.pi) * spot * math.cos(theta) / r**2
    np.testing.assert_allclose(out.passes["surfaces"][0, 0], expect, rtol=1e-6, atol=1e-12)


def test_gobo_orientation_and_bilinear():
    gobo = np.array([[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],     # top row: red, green
                     [[0.0, 0.0, 1.0], [1.0, 1.0, 1.0]]])    # bottom row: blue, white
    size = math.radians(60)
    light = Light(pose((0.0, 0.0, 5.0)), power_w=1000.0, spot_size_rad=size, spot_blend=0.0,
                      gobo=gobo)
    floor = quad((0.0, 0.0, 0.0), 10.0, color=(1.0, 1.0, 1.0))
    tan_half = math.tan(size / 2)

    def radiance(x: float, y: float) -> np.ndarray:
        out = render_reference(Scene(one_pixel_down(x, y), (light,), (floor,)))
        r2 = x * x + y * y + 25.0
        base = 1.0 / math.pi * 1000.0 / (4 * math.pi) * (5.0 / math.sqrt(r2)) / r2
        return out.passes["surfaces"][0, 0] / base

    a = 0.5 * 5.0 * tan_half  # u = v = 0.75: exactly on the outer texel centres
    np.testing.assert_allclose(radiance(a, a), [0.0, 1.0, 0.0], atol=1e-6)  # +x +y: top right
    np.testing.assert_allclose(radiance(-a, a), [1.0, 0.0, 0.0], atol=1e-6)  # top left
    np.testing.assert_allclose(radiance(-a, -a), [0.0, 0.0, 1.0], atol=1e-6)  # bottom left
    np.testing.assert_allclose(radiance(0.0, 0.0), [0.5, 0.5, 0.5], atol=1e-6)  # all four
    b = 0.25 * 5.0 * tan_half  # u = 0.625, v = 0.5: column 0.75, rows averaged
    np.testing.assert_allclose(radiance(b, 0.0), [0.5, 0.75, 0.5], atol=1e-6)


# in-scattering from a spot in fog, against quadrature --------------------------------------------

def test_fog_single_scattering_matches_quadrature():
    g = 0.5
    sig_a, sig_s = 0.05, 0.3
    sig_t = sig_a + sig_s
    medium = Medium(sigma_a=(sig_a,) * 3, sigma_s=(sig_s,) * 3, anisotropy=g)  # fills the scene
    light = Light(pose((0.0, 1.0, 0.0), SHINE_MINUS_Y), power_w=500.0,
                      spot_size_rad=math.radians(179), spot_blend=0.0)
    cam = Camera(pose((0.0, 0.0, 5.0)), 1, 1, projection="ORTHO", ortho_scale=0.01,
                 clip_start=0.5, clip_end=8.0)
    out = render_reference(Scene(cam, (light,), media=(medium,)), view_steps=256)
    intensity = 500.0 / (4 * math.pi)

    def integrand(t: float) -> float:
        z = 5.0 - t  # sample at (0, 0, z); light at (0, 1, 0)
        r = math.hypot(1.0, z)
        cos = z / r  # dot(unit(p - light), -view_dir) with view_dir = -Z
        phase = (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * cos) ** 1.5)
        return (math.exp(-sig_t * (t - 0.5)) * sig_s * phase * intensity
                * math.exp(-sig_t * r) / r**2)

    expect, _ = integrate.quad(integrand, 0.5, 8.0, points=[5.0], limit=200)
    np.testing.assert_allclose(out.passes["scattering"][0, 0], expect, rtol=2e-3)
    np.testing.assert_allclose(out.passes["transmittance"][0, 0], math.exp(-sig_t * 7.5),
                               rtol=1e-9)


# (f) camera convention -----------------------------------------------------------------------

def only_pixel(out) -> tuple[int, int]:
    rows, cols = np.nonzero(out.combined[..., 3] == 1.0)
    assert len(rows) == 1, list(zip(rows.tolist(), cols.tolist(), strict=True))
    return int(rows[0]), int(cols[0])


def marker(cam_pose: np.ndarray, local_point, half: float) -> Mesh:
    """A small square facing the camera at a camera-local point."""
    rot = cam_pose[:3, :3] / np.linalg.norm(cam_pose[:3, :3], axis=0)
    corners = [np.array(local_point) + half * np.array([sx, sy, 0.0])
               for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    world = [cam_pose[:3, 3] + rot @ c for c in corners]
    return Mesh(np.array(world), np.array([[0, 1, 2], [0, 2, 3]]))


def test_camera_perspective_vertical_fit_and_shift():
    # 40x30, VERTICAL fit: viewfac = 30, sensor = 24 mm -> 0.016 per pixel at unit distance.
    # Pixel (i=27, j=5) with shift_x = 0.1: x = (27.5 - 20 + 3) * 0.016 = 0.168,
    # y = (15 - 5.5) * 0.016 = 0.152. At depth 10: (1.68, 1.52, -10).
    m = pose((1.0, 2.0, 3.0), LOOK_PLUS_X, scale=2.0)  # scale is ignored
    cam = Camera(m, 40, 30, lens_mm=50.0, sensor_width_mm=36.0, sensor_height_mm=24.0,
                 sensor_fit="VERTICAL", shift_x=0.1)
    out = render_reference(Scene(cam, meshes=(marker(m, (1.68, 1.52, -10.0), 0.03),)))
    assert only_pixel(out) == (5, 27)
    # the same camera with AUTO fit (landscape -> horizontal, 36 mm over 40 px: 0.018 per px)
    cam = Camera(m, 40, 30, lens_mm=50.0, sensor_fit="AUTO", shift_x=0.1, shift_y=-0.05)
    # pixel (i=6, j=20): x = (6.5 - 20 + 4) * 0.018 = -0.171, y = (15 - 20.5 - 2) * 0.018 = -0.135
    out = render_reference(Scene(cam, meshes=(marker(m, (-1.71, -1.35, -10.0), 0.03),)))
    assert only_pixel(out) == (20, 6)


def test_camera_portrait_auto_fit():
    # 30x40, AUTO -> VERTICAL fit, but the sensor size stays the width (36 mm): 0.018 per px
    m = pose((0.0, 0.0, 0.0))
    cam = Camera(m, 30, 40, lens_mm=50.0, sensor_width_mm=36.0, sensor_height_mm=24.0)
    # pixel (i=3, j=33): x = (3.5 - 15) * 0.018 = -0.207, y = (20 - 33.5) * 0.018 = -0.243
    out = render_reference(Scene(cam, meshes=(marker(m, (-2.07, -2.43, -10.0), 0.03),)))
    assert only_pixel(out) == (33, 3)


def test_camera_orthographic_shift():
    # 40x30 ortho, scale 4 over the width: 0.1 m per px. Pixel (i=3, j=22) with shift_x = -0.25:
    # x = (3.5 - 20 - 10) * 0.1 = -2.65, y = (15 - 22.5) * 0.1 = -0.75
    m = pose((5.0, -1.0, 0.5), SHINE_MINUS_Y)
    cam = Camera(m, 40, 30, projection="ORTHO", ortho_scale=4.0, shift_x=-0.25)
    out = render_reference(Scene(cam, meshes=(marker(m, (-2.65, -0.75, -3.0), 0.02),)))
    assert only_pixel(out) == (22, 3)


def test_camera_clip_range():
    m = pose((0.0, 0.0, 0.0))
    near = marker(m, (0.0, 0.0, -0.05), 0.5)  # in front of clip_start = 0.1
    far = marker(m, (0.0, 0.0, -200.0), 500.0)  # beyond clip_end = 100
    cam = Camera(m, 9, 7)
    out = render_reference(Scene(cam, meshes=(near, far)))
    assert not out.combined[..., 3].any()
    inside = marker(m, (0.0, 0.0, -50.0), 500.0)
    out = render_reference(Scene(cam, meshes=(near, far, inside)))
    assert out.combined[..., 3].min() == 1.0


def test_clip_range_is_depth_not_distance():
    m = pose((0.0, 0.0, 0.0))
    cam = Camera(m, 9, 7, lens_mm=18.0, clip_start=1.0, clip_end=3.0)
    # a plane at depth 0.95 is in front of clip_start for every pixel, although corner rays
    # (slope ~0.9) reach it at a distance of ~1.3 m
    out = render_reference(Scene(cam, meshes=(marker(m, (0.0, 0.0, -0.95), 5.0),)))
    assert not out.combined[..., 3].any()
    # fog everywhere: each ray crosses depths 1 -> 3, a distance of 2 |(x, y, -1)|
    sig_t = 0.4
    medium = Medium(sigma_a=(0.1,) * 3, sigma_s=(sig_t - 0.1,) * 3)
    out = render_reference(Scene(cam, media=(medium,), ambient=(1.0, 1.0, 1.0)), view_steps=8)
    pix = 36.0 / 18.0 / 9
    slope = np.hypot((0.5 - 4.5) * pix, (3.5 - 0.5) * pix)
    np.testing.assert_allclose(out.passes["transmittance"][0, 0],
                               math.exp(-sig_t * 2.0 * math.hypot(1.0, slope)), rtol=1e-9)
