"""Image comparison, one convention everywhere (benchmarks, tests, README figures).

Both images are scene-linear RGB. They are mapped to display values the same way: divided by
the reference's 99.9th percentile of per-pixel maximum channel (its "white"), clipped to [0, 1]
and encoded with gamma 1/2.2. SSIM is then scikit-image's, Gaussian-weighted (sigma 1.5, the
Wang et al. 2004 setting), over the three channels, data range 1; PSNR is over the same
display values. The second argument is always the reference.
"""

from __future__ import annotations

import numpy as np


def _display(image: np.ndarray, white: float) -> np.ndarray:
    return np.clip(np.asarray(image, dtype=np.float64)[..., :3] / white, 0.0, 1.0) ** (1 / 2.2)


def _white(reference: np.ndarray) -> float:
    w = float(np.percentile(np.asarray(reference)[..., :3].max(axis=-1), 99.9))
    return w if w > 0 else 1.0


def ssim(image: np.ndarray, reference: np.ndarray) -> float:
    """Structural similarity in [.., 1] of two (h, w, 3+) linear images."""
    from skimage.metrics import structural_similarity

    w = _white(reference)
    return float(structural_similarity(_display(image, w), _display(reference, w), channel_axis=-1,
                                       data_range=1.0, gaussian_weights=True, sigma=1.5,
                                       use_sample_covariance=False))


def psnr(image: np.ndarray, reference: np.ndarray) -> float:
    """Peak signal-to-noise ratio in dB of two (h, w, 3+) linear images."""
    from skimage.metrics import peak_signal_noise_ratio

    w = _white(reference)
    return float(peak_signal_noise_ratio(_display(reference, w), _display(image, w), data_range=1.0))


def brightness_ratio(image: np.ndarray, reference: np.ndarray) -> float:
    """Total linear radiance of the image over the reference's."""
    return float(np.asarray(image)[..., :3].sum() / max(np.asarray(reference)[..., :3].sum(), 1e-30))
