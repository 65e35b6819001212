"""Adaptive sampling: after the first samples of a frame, only the pixels whose samples still
differ (mesh edges, shadow edges, the jittered march through the medium) take more.

Two decisions per frame, each from the samples alone (so that frames rendered by different
processes stay equal bit for bit), each kept for the rest of the frame:

1. After ``ADAPTIVE_FIRST_SAMPLES`` samples, a pixel goes on if, in any of R, G, B and alpha, the
   standard deviation of its samples or the contrast of its 3x3 neighbourhood in their mean
   (largest minus smallest) exceeds ``ADAPTIVE_FIRST_THRESHOLD``, colours in units of the frame's
   white (the 99.9th percentile of the mean image's largest colour channel), alpha as it is: flat
   regions (an unlit ground, the empty background) stop there, edges (alpha's too: a transparent
   film) and the medium go on.
2. After ``ADAPTIVE_MIN_SAMPLES`` samples, a pixel still going goes on if the standard deviation
   of its samples exceeds ``ADAPTIVE_THRESHOLD`` (same units).

Each decision also keeps the 8 neighbours of a pixel that goes on (an edge the first samples
barely touched). A pixel that stops keeps the mean of its samples. A sub-pixel feature that the
first samples all miss (a wire thinner than a pixel between the pixel centres) is not found.

The camera's light passes then draw only the active pixels: rectangles of whole TILE x TILE
blocks (the blocks llvmpipe shades together; a fragment ``discard`` does not spare them the
shader's work, geometry that does not cover them does), merged along each row of blocks. The
pixels of an active block all take the sample.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

ADAPTIVE_FIRST_SAMPLES = 2    # samples every pixel takes before the first decision
ADAPTIVE_FIRST_THRESHOLD = 0.005   # its standard deviation and neighbourhood contrast, in units of the white
ADAPTIVE_MIN_SAMPLES = 8      # samples a pixel that went on takes before the second decision
ADAPTIVE_THRESHOLD = 0.01     # its standard deviation, in units of the frame's white
TILE = 4                      # pixels per side of the blocks the passes draw


@dataclass(frozen=True, eq=False)
class ActivePixels:
    """The pixels a sample shades: ``mask`` (h, w) bool, top row first, made of whole TILE x TILE
    blocks counted from the image's lower-left corner (GL's window origin). ``key`` names the
    content (the renderer caches the rectangles' vertex buffer by it)."""

    mask: np.ndarray
    key: str = field(default="")

    @cached_property
    def fraction(self) -> float:
        """The fraction of the image's pixels shaded."""
        return float(self.mask.mean()) if self.mask.size else 0.0

    @cached_property
    def vertices(self) -> np.ndarray:
        """Two triangles per run of active blocks along a row, (n, 2) float32 window pixels."""
        h, w = self.mask.shape
        gl_mask = self.mask[::-1]                        # row 0 at the bottom, as GL counts
        blocks = gl_mask[::TILE, ::TILE]                 # a block's corner pixel tells (whole blocks)
        out = []
        for by in range(blocks.shape[0]):
            row = np.concatenate([[False], blocks[by], [False]])
            edges = np.flatnonzero(row[1:] != row[:-1])
            y0, y1 = by * TILE, min((by + 1) * TILE, h)
            for a, b in zip(edges[::2], edges[1::2], strict=True):
                x0, x1 = a * TILE, min(b * TILE, w)
                out += [(x0, y0), (x1, y0), (x1, y1), (x0, y0), (x1, y1), (x0, y1)]
        return np.asarray(out, dtype=np.float32).reshape(-1, 2)


def active_pixels(mask: np.ndarray) -> ActivePixels:
    """``mask`` (h, w, top row first) grown to whole TILE x TILE blocks."""
    import hashlib

    mask = np.asarray(mask, dtype=bool)
    h, w = mask.shape
    gl_mask = mask[::-1]
    ph, pw = -h % TILE, -w % TILE
    padded = np.pad(gl_mask, ((0, ph), (0, pw)))
    blocks = padded.reshape(padded.shape[0] // TILE, TILE, padded.shape[1] // TILE, TILE).any(axis=(1, 3))
    grown = np.repeat(np.repeat(blocks, TILE, axis=0), TILE, axis=1)[:h, :w][::-1]
    grown = np.ascontiguousarray(grown)
    return ActivePixels(grown, hashlib.blake2b(np.packbits(grown).tobytes() + bytes(str((h, w)), "ascii"),
                                               digest_size=16).hexdigest())


def unconverged(mean: np.ndarray, square_mean: np.ndarray, threshold: float = ADAPTIVE_THRESHOLD,
                contrast: bool = False) -> np.ndarray:
    """The pixels that go on sampling: (h, w) bool from the per-pixel mean and mean square of the
    samples so far ((h, w, 4) each, linear RGB in units of the frame's white and alpha as it is,
    or (h, w, 3) without alpha); ``contrast``: the neighbourhood's contrast counts too (the first
    decision). See the module's docstring."""
    from scipy import ndimage

    mean = np.asarray(mean, dtype=np.float64)
    top = mean[..., :3].max(axis=-1)
    white = float(np.percentile(top, 99.9)) if top.size else 0.0
    white = white if white > 0 else 1.0
    scale = np.ones(mean.shape[-1])
    scale[:3] = white                 # alpha (a 4th channel) is measured against 1
    sd = np.sqrt(np.maximum(np.asarray(square_mean, np.float64) - mean ** 2, 0.0)) / scale
    going = sd.max(axis=-1) > threshold
    if contrast:
        lo = ndimage.minimum_filter(mean, size=(3, 3, 1), mode="nearest")
        hi = ndimage.maximum_filter(mean, size=(3, 3, 1), mode="nearest")
        going |= ((hi - lo) / scale).max(axis=-1) > threshold
    return ndimage.maximum_filter(going, size=3, mode="constant", cval=False)
