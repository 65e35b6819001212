"""The world's radiance by direction (tfm_addon/engine/environment.py) and the images it reads
(tfm_addon/engine/shading.py): the equirectangular mapping, averaging down, sRGB, the memo."""

import math

import numpy as np

from tfm_addon.engine import environment, shading


def test_a_direction_reads_the_pixel_the_equirectangular_mapping_puts_it_on():
    """+X is the image's centre column, +Y a quarter to the left of it, +Z the top row (Cycles'
    direction_to_equirectangular); the image is given top row first."""
    h, w = 32, 64
    img = np.zeros((h, w, 3), np.float32)
    img[h // 2 - 1: h // 2 + 1, w // 2 - 1: w // 2 + 1] = (1.0, 0.0, 0.0)     # +X
    img[h // 2 - 1: h // 2 + 1, w // 4 - 1: w // 4 + 1] = (0.0, 1.0, 0.0)     # +Y
    img[0] = (0.0, 0.0, 1.0)                                                   # the zenith row
    env = environment.from_image(img)
    rgb = env.radiance(np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]))
    assert rgb[0, 0] > 0.9 and rgb[1, 1] > 0.9 and rgb[2, 2] > 0.9, rgb


def test_averaging_down_keeps_the_mean_and_the_zenith():
    """An image whose size does not divide keeps every row: the 4 bright rows at the top of a
    1000x500 image (stored bottom row first) still light the averaged image."""
    img = np.zeros((500, 1000, 1))
    img[-4:] = 1000.0
    small = shading.area_resize(img, 63, 125)
    assert math.isclose(float(small.mean()), float(img.mean()), rel_tol=1e-5)
    assert small[-1].mean() > 0.0


def test_srgb_images_are_averaged_in_linear_light():
    """Alternating black and white columns of an 8-bit sRGB image: 0.5 of white on average, not
    the decoded mean of the encoded 0.5 (0.214)."""
    px = np.zeros((256, 512, 4), np.float32)
    px[:, ::2, :3] = 1.0
    px[..., 3] = 1.0
    shading.register_image("test srgb columns", px, True)
    env = environment.of_graph(environment.with_texture("test srgb columns").graph)
    assert abs(env.mean[0] - 0.5) < 0.01, env.mean


def test_an_environment_keeps_its_image_when_other_textures_push_it_out():
    px = np.random.default_rng(1).random((16, 32, 4)).astype(np.float32)
    shading.register_image("test world image", px, False)
    env = environment.of_graph(environment.with_texture("test world image").graph)
    for k in range(shading.IMAGES_KEPT + 4):
        shading.register_image(f"test other {k}", px[:2, :2], False)
    assert "test world image" not in shading.IMAGES
    pano = env.panorama(256)
    assert not np.allclose(pano[0, 0], (1.0, 0.0, 1.0))         # not Cycles' missing-image pink
    assert abs(float(pano.mean()) - float(px[..., :3].mean())) < 0.05
