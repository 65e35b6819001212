"""Adaptive sampling: after the first samples of a frame, only the pixels whose samples still
differ (mesh edges, shadow edges, the jittered march through the medium) take more.

Every pixel takes ``ADAPTIVE_MIN_SAMPLES`` samples. Then a pixel goes on sampling when the
standard deviation of its samples so far (the largest over R, G, B) exceeds ``ADAPTIVE_THRESHOLD``
times the frame's white (the 99.9th percentile of the mean image's largest channel), or when one
of its 8 neighbours' does (an edge the first samples barely touched); the others keep the mean
of their first samples. The decision is taken once per frame, from the samples alone, so that
frames rendered by different processes stay equal bit for bit.

The camera's light passes then draw only the active pixels: rectangles of whole TILE x TILE
blocks (the blocks llvmpipe shades together; a fragment ``discard`` does not spare them the
shader's work, geometry that does not cover them does), merged along each row of blocks. The
pixels of an active block all take the sample.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

ADAPTIVE_MIN_SAMPLES = 8      # samples every pixel takes before the decision
ADAPTIVE_THRESHOLD = 0.01     # standard deviation, in units of the frame's white, below which a pixel stops
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


def unconverged(mean: np.ndarray, square_mean: np.ndarray,
                threshold: float = ADAPTIVE_THRESHOLD) -> np.ndarray:
    """The pixels that go on sampling: (h, w) bool from the per-pixel mean and mean square of the
    samples so far ((h, w, 3) each, linear RGB), see the module's docstring."""
    from scipy import ndimage

    top = np.asarray(mean, dtype=np.float64).max(axis=-1)
    white = float(np.percentile(top, 99.9)) if top.size else 0.0
    white = white if white > 0 else 1.0
    variance = np.maximum(np.asarray(square_mean, np.float64) - np.asarray(mean, np.float64) ** 2, 0.0)
    spread = np.sqrt(variance).max(axis=-1) / white
    return ndimage.maximum_filter(spread > threshold, size=3, mode="constant", cval=False)
