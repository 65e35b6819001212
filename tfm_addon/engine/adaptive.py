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


def _neighbourhood(a: np.ndarray, pick) -> np.ndarray:
    """``pick`` (np.maximum or np.minimum) over each pixel's 3x3 neighbourhood of ``a`` (h, w, ...),
    edges repeated."""
    h, w = a.shape[:2]
    pad = np.pad(a, ((1, 1), (1, 1)) + ((0, 0),) * (a.ndim - 2), mode="edge")
    out = pad[1:h + 1, 1:w + 1].copy()
    for dy in range(3):
        for dx in range(3):
            if dy != 1 or dx != 1:
                pick(out, pad[dy:dy + h, dx:dx + w], out=out)
    return out


def _channel_max(a: np.ndarray) -> np.ndarray:
    """``a.max(axis=-1)``, the same values, channel by channel (numpy reduces a short last axis
    some twenty times slower)."""
    out = a[..., 0].copy()
    for c in range(1, a.shape[-1]):
        np.maximum(out, a[..., c], out=out)
    return out


def white_rank(pixels: int) -> int:
    """How many of a frame's ``pixels`` brightest values its white is the least of: the white is
    the 99.9th percentile (nearest rank) of the pixels' largest colour channel."""
    return pixels - int(0.999 * (pixels - 1)) if pixels else 0


def brightest(mean: np.ndarray, count: int) -> np.ndarray:
    """The ``count`` largest values of the largest colour channel of ``mean`` (h, w, c), unsorted:
    what a frame rendered in tiles keeps of each tile to find the frame's white (frame_white)."""
    return largest(_channel_max(np.asarray(mean, np.float32)[..., :3]).ravel(), count)


def largest(values: np.ndarray, count: int) -> np.ndarray:
    """The ``count`` largest of ``values`` (1-D), unsorted."""
    if values.size <= count:
        return values
    return np.partition(values, values.size - count)[values.size - count:]


def frame_white(values: np.ndarray, pixels: int) -> float:
    """The white of a frame of ``pixels`` pixels from (at least) its ``white_rank`` brightest
    largest-channel values; 1 where it is not positive."""
    values = np.asarray(values, np.float32).ravel()
    n = white_rank(pixels)
    white = float(np.partition(values, values.size - n)[values.size - n]) if n else 0.0
    return white if white > 0 else 1.0


def unconverged(mean: np.ndarray, square_mean: np.ndarray, threshold: float = ADAPTIVE_THRESHOLD,
                contrast: bool = False, white: float | None = None) -> np.ndarray:
    """The pixels that go on sampling: (h, w) bool from the per-pixel mean and mean square of the
    samples so far ((h, w, 4) each, linear RGB in units of the frame's white and alpha as it is,
    or (h, w, 3) without alpha); ``contrast``: the neighbourhood's contrast counts too (the first
    decision); ``white``: the frame's white where ``mean`` is a tile of it (None: ``mean``'s own).
    See the module's docstring."""
    mean = np.asarray(mean, dtype=np.float32)
    if white is None:
        pixels = mean.shape[0] * mean.shape[1]
        white = frame_white(brightest(mean, white_rank(pixels)), pixels)
    scale = np.ones(mean.shape[-1], dtype=np.float32)
    scale[:3] = white                 # alpha (a 4th channel) is measured against 1
    variance = np.maximum(np.asarray(square_mean, np.float32) - mean * mean, 0.0)
    going = _channel_max(variance / (scale * scale)) > threshold * threshold
    if contrast:
        spread = (_neighbourhood(mean, np.maximum) - _neighbourhood(mean, np.minimum)) / scale
        going |= _channel_max(spread) > threshold
    return _neighbourhood(going, np.logical_or)
