"""EXR round trip and the metric convention."""

import numpy as np

from tfm_addon.engine.exr import output_channels, read_exr, write_output
from tfm_addon.engine.metrics import brightness_ratio, psnr, ssim
from tfm_addon.engine.output import RenderOutput


def test_exr_round_trip_keeps_every_pass_bit_exact(tmp_path):
    rng = np.random.default_rng(0)
    h, w = 12, 20
    passes = [rng.uniform(0, 50, (h, w, 3)).astype(np.float32) for _ in range(3)]
    out = RenderOutput.compose(passes[0], passes[1], passes[2] / 50, rng.uniform(size=(h, w)) > 0.5)
    path = write_output(tmp_path / "frame.exr", out)
    back = read_exr(path)
    assert set(back) == set(output_channels(out))
    np.testing.assert_array_equal(back["R"], out.combined[:, :, 0])
    np.testing.assert_array_equal(back["A"], out.combined[:, :, 3])
    np.testing.assert_array_equal(back["scattering.B"], out.passes["scattering"][:, :, 2])
    # The top row stays the top row.
    assert back["surfaces.G"][0, 0] == out.passes["surfaces"][0, 0, 1]


def test_metrics_rank_images_by_their_error():
    rng = np.random.default_rng(1)
    y, x = np.mgrid[0:64, 0:96] / 64.0
    ref = np.stack([np.sin(3 * x) ** 2, np.cos(2 * y) ** 2, x * y], axis=2) * 5.0
    slight = ref + rng.normal(0, 0.005, ref.shape)
    strong = ref + rng.normal(0, 0.3, ref.shape)
    assert ssim(ref, ref) == 1.0 and psnr(slight, ref) > psnr(strong, ref) + 10
    assert 0.99 < ssim(slight, ref) < 1.0 and ssim(strong, ref) < 0.6
    assert abs(brightness_ratio(ref * 1.1, ref) - 1.1) < 1e-9


def test_multi_part_exr_channels_are_named_by_part(tmp_path):
    """Blender writes one part per pass; every part's channels come back, named by part."""
    import OpenEXR

    from tfm_addon.engine.exr import read_exr

    a = np.arange(20, dtype=np.float32).reshape(4, 5)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    parts = [OpenEXR.Part({**header, "name": "Combined"}, {"R": a, "G": 2 * a}),
             OpenEXR.Part({**header, "name": "Scattering"}, {"R": 3 * a})]
    with OpenEXR.File(parts) as f:
        f.write(str(tmp_path / "multi.exr"))
    back = read_exr(tmp_path / "multi.exr")
    assert set(back) == {"Combined.R", "Combined.G", "Scattering.R"}
    np.testing.assert_array_equal(back["Scattering.R"], 3 * a)
