"""Depth of field and motion blur as the samples draw them (engine/camera_effects.py, sampling.py),
checked by geometry without a GL context; the images against Cycles are conformance rows (dof,
dof_blades, motion_blur_volume, motion_blur_camera)."""

import math

import numpy as np
import pytest

from tfm_addon.engine import sampling
from tfm_addon.engine.camera import clip_matrix
from tfm_addon.engine.camera_effects import Motion, ObjectMotion, aperture_point, interpolate, lens_camera
from tfm_addon.engine.scene import Aperture, Camera, Medium, Mesh, Scene


def _camera(aperture=None) -> Camera:
    m = np.eye(4)
    m[:3, 3] = (0.3, -0.2, 5.0)      # looks down -Z from z = 5
    return Camera(matrix_world=m, width_px=160, height_px=90, aperture=aperture)


def _pixel(camera: Camera, p) -> np.ndarray:
    c = clip_matrix(camera) @ np.array([*p, 1.0])
    ndc = c[:2] / c[3]
    return (ndc + 1.0) / 2.0 * np.array([camera.width_px, camera.height_px])


def test_the_lens_keeps_the_plane_in_focus_and_blurs_the_rest_by_the_thin_lens_circle():
    ap = Aperture(radius_m=0.1, focus_m=3.0)
    cam = _camera(ap)
    in_focus, far = (0.5, 0.1, 2.0), (0.4, 0.3, -3.0)    # 3 m and 8 m in front of the camera
    pixel_size = 36.0 / 50.0 / 160
    for uv in ((0.9, 0.5), (0.1, 0.7), (0.5, 0.05)):
        lensed = lens_camera(cam, *uv)
        assert lensed.aperture is None
        assert np.allclose(_pixel(lensed, in_focus), _pixel(cam, in_focus), atol=1e-6)
        x, y = aperture_point(0, 0.0, 1.0, *uv)
        # thin lens: a point at depth z moves by lens * (1/focus - 1/z) at unit depth
        expect = np.array([x, y]) * 0.1 * (1 / 3.0 - 1 / 8.0) / pixel_size
        assert np.allclose(_pixel(lensed, far) - _pixel(cam, far), expect, atol=1e-6)


def test_aperture_points_fill_the_disk_or_the_polygon_as_cycles_samples_them():
    rng = np.random.default_rng(1)
    uv = rng.random((2000, 2))
    disk = np.array([aperture_point(0, 0.0, 1.0, u, v) for u, v in uv])
    radius = np.hypot(*disk.T)
    assert radius.max() <= 1.0 + 1e-9 and radius.mean() == pytest.approx(2 / 3, abs=0.02)
    squeezed = np.array([aperture_point(0, 0.0, 2.0, u, v) for u, v in uv])
    assert np.abs(squeezed[:, 0]).max() <= 0.5 + 1e-9 and np.abs(squeezed[:, 1]).max() > 0.95
    rot = math.radians(20.0)
    pent = np.array([aperture_point(5, rot, 1.0, u, v) for u, v in uv])
    # inside the pentagon whose corners lie on the unit circle at rot + (k + 1/2) 72 degrees
    for k in range(5):
        mid = rot + k * 2 * math.pi / 5
        assert (pent @ np.array([math.cos(mid), math.sin(mid)])).max() <= math.cos(math.pi / 5) + 1e-9
    assert aperture_point(0, 0.0, 1.0, 0.5, 0.5) == (0.0, 0.0)


def test_lens_and_shutter_sequences_are_stratified_and_start_at_the_centre():
    lens = np.array([sampling.lens_sample(k) for k in range(16)])
    assert tuple(lens[0]) == (0.5, 0.5)
    cells = (lens * 4).astype(int)
    assert len({(a, b) for a, b in cells}) == 16
    times = np.array([sampling.shutter_time(k) for k in range(16)])
    assert times[0] == 0.5 and sorted((times * 16).astype(int)) == list(range(16))
    sub = np.array([sampling.subpixel_offset(k) for k in range(64)])
    lens64 = np.array([sampling.lens_sample(k) for k in range(64)])
    assert abs(np.corrcoef(sub[:, 0], lens64[:, 0])[0, 1]) < 0.3


def test_automatic_samples_grow_with_the_blur_of_the_lens():
    assert sampling.auto_samples(_camera()) == sampling.AUTO_SAMPLES
    assert sampling.auto_samples(_camera(Aperture(0.001, 3.0))) == sampling.AUTO_SAMPLES
    # f/0.25 at 50 mm focused at 3 m, 160 px: a point at infinity is blurred over 14.8 px
    assert sampling.auto_samples(_camera(Aperture(0.1, 3.0))) == 55
    assert sampling.auto_samples(_camera(Aperture(1.0, 3.0))) == sampling.AUTO_LENS_SAMPLES


def _rotation_z(deg: float, t=(0.0, 0.0, 0.0)) -> np.ndarray:
    a = math.radians(deg)
    m = np.eye(4)
    m[:2, :2] = [[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]
    m[:3, 3] = t
    return m


def test_motion_steps_interpolate_translation_linearly_and_rotation_by_slerp():
    steps = (_rotation_z(0.0, (0, 0, 0)), _rotation_z(60.0, (2, 0, 0)), _rotation_z(90.0, (2, 2, 0)))
    assert np.allclose(interpolate(steps, 0.25), _rotation_z(30.0, (1, 0, 0)))
    assert np.allclose(interpolate(steps, 0.75), _rotation_z(75.0, (2, 1, 0)))
    scaled = (np.diag([1.0, 1.0, 1.0, 1.0]), np.diag([3.0, 1.0, 1.0, 1.0]))
    assert np.allclose(interpolate(scaled, 0.5), np.diag([2.0, 1.0, 1.0, 1.0]))


def test_a_sample_moves_the_named_objects_and_the_camera_to_its_shutter_time():
    still = np.eye(4)
    moving = ObjectMotion((_rotation_z(0, (-1, 0, 0)), still, _rotation_z(0, (1, 0, 0))), still)
    medium = Medium(density=np.ones((4, 4, 4), np.float32), name="Smoke")
    mesh = Mesh(vertices=np.zeros((3, 3)), triangles=np.array([[0, 1, 2]]), name="Ground")
    scene = Scene(camera=_camera(), media=(medium,), meshes=(mesh,),
                  motion=Motion(camera=moving, objects={"Smoke": moving}))
    for k in range(1, 8):
        s, _ = sampling.sample_scene(scene, sampling.RenderSettings(), k)
        x = 2.0 * sampling.shutter_time(k) - 1.0
        assert s.motion is None
        assert s.media[0].index_to_world[0, 3] == pytest.approx(x)
        assert s.meshes[0] is mesh
        assert s.camera.matrix_world[0, 3] == pytest.approx(0.3 + x)
