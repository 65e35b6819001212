"""The peers benchmark's arithmetic (tfm_addon/bench/peers.py), without rendering: the time a peer
takes to reach an SSIM, the 1920x1080 images averaged down to 320x180, and the summary table."""

import math

import numpy as np

from tfm_addon.bench import peers


def test_a_peer_reaches_an_ssim_between_its_samples_in_log_time():
    curve = [(1.0, 0.90), (4.0, 0.98), (16.0, 0.99)]
    assert peers.equal_quality_seconds(curve, 0.85) == 1.0           # already at its first point
    assert math.isclose(peers.equal_quality_seconds(curve, 0.94), 2.0)  # halfway in log time
    assert math.isclose(peers.equal_quality_seconds(curve, 0.99), 16.0)
    assert peers.equal_quality_seconds(curve, 0.995) is None            # never


def test_a_full_hd_image_is_averaged_down_in_blocks():
    image = np.zeros((1080, 1920, 4), np.float32)
    image[:6, :6, :3] = 1.0
    small = peers._downsampled(image, peers.BASE_SIZE)
    assert small.shape == (180, 320, 3)
    assert small[0, 0].tolist() == [1.0, 1.0, 1.0] and small[0, 1:].max() == 0.0 and small[1:].max() == 0.0


def test_the_summary_compares_tfm_s_default_frame_with_cycles_at_its_quality():
    rows = [dict(name="Cycles 4 spp + OIDN", engine="CYCLES", samples=4, seconds=1.0, ssim=0.95),
            dict(name="Cycles 16 spp + OIDN", engine="CYCLES", samples=16, seconds=4.0, ssim=0.99),
            dict(name="EEVEE default, 1 sample", engine="EEVEE", samples=1, seconds=3.0, ssim=0.8),
            dict(name="TFM Auto, 16 samples (default)", engine="TFM", samples=16, seconds=0.5, ssim=0.97)]
    text = peers.summarise({"scenes": {"cloud": {"320x180": rows}}})
    line = text.splitlines()[2]
    # Cycles reaches 0.97 halfway between 1 s and 4 s in log time: 2 s, 4x TFM's 0.5 s
    assert "| cloud | 320x180 | 0.50 s, SSIM 0.970 | 2.00 s | 4.0× |" in line
    assert "4.00 s, SSIM 0.990" in line and "3.00 s, SSIM 0.800" in line
