"""A frame rendered in tiles, so that the renderer's memory follows the tile, not the frame.

Each tile is the camera's pixel window cut like a render border (``Camera.border``): the view plane,
the subpixel offsets and the march's per-pixel start are those of the whole frame (the scatter
pass hashes frame pixels, ``u_window_origin``), and the light maps, which do not depend on the
camera, are built once and shared by every tile (the renderer's caches). A tile renders its core
and an apron of TILE_APRON pixels around it that is dropped, so that the adaptive decisions of its
core pixels see the same neighbours as in the whole frame; tiles start on multiples of the
adaptive blocks (adaptive.TILE), so the blocks fall where they fall in the whole frame. The
decisions measure noise in units of the frame's white: with adaptive sampling the tiles therefore
run three times, to sample 2 (the first decision's white, from every tile's brightest values), to
sample 8 (the second's), and to the end, writing each core as it is done. The quality rule runs
once, on the whole frame. A tiled frame equals the untiled one up to float rounding of the rays
(tests/test_tiles.py).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from .adaptive import (
    ADAPTIVE_FIRST_SAMPLES,
    ADAPTIVE_MIN_SAMPLES,
    TILE,
    brightest,
    frame_white,
    largest,
    white_rank,
)
from .camera import pixel_window
from .output import RenderOutput
from .renderer import prepare_scene
from .sampling import ADAPTIVE_FRAME_SAMPLES, frame_settings
from .scene import Camera, RenderSettings, Scene

TILE_APRON = 16     # pixels rendered around a tile's core for the adaptive decisions, then dropped
BORDER_PAD = 1e-3   # pixels: a border's fractions padded so that floor / ceil give the window


@dataclasses.dataclass(frozen=True)
class Tile:
    """A part of the camera's pixel window: ``core`` (x0, y0, w, h) is what it writes, ``window``
    the rectangle it renders (the core and its apron), both in pixels of the frame's image, y up
    from its lower-left corner."""

    core: tuple[int, int, int, int]
    window: tuple[int, int, int, int]

    def camera(self, camera: Camera) -> Camera:
        """``camera`` rendering this tile's window (a render border of the whole frame)."""
        bx, by, _, _ = pixel_window(camera)
        x0, y0, w, h = self.window
        fw, fh = camera.width_px, camera.height_px
        border = ((bx + x0 + BORDER_PAD) / fw, (by + y0 + BORDER_PAD) / fh,
                  (bx + x0 + w - BORDER_PAD) / fw, (by + y0 + h - BORDER_PAD) / fh)
        return dataclasses.replace(camera, border=border)

    def crop(self, image: np.ndarray) -> np.ndarray:
        """The core of a tile's image (h, w, c), top row first."""
        x0, y0, w, h = self.core
        wx, wy, _, wh = self.window
        top = (wy + wh) - (y0 + h)
        return image[top:top + h, x0 - wx:x0 - wx + w]


def plan_tiles(camera: Camera, side: int, apron: int = TILE_APRON) -> list[Tile]:
    """Tiles of at most ``side`` x ``side`` pixels (rounded down to whole adaptive blocks) covering
    the camera's pixel window, bottom row first."""
    _, _, width, height = pixel_window(camera)
    side = max(TILE, side - side % TILE)
    apron = -(-apron // TILE) * TILE
    tiles = []
    for y0 in range(0, height, side):
        for x0 in range(0, width, side):
            w, h = min(side, width - x0), min(side, height - y0)
            wx, wy = max(0, x0 - apron), max(0, y0 - apron)
            window = (wx, wy, min(width, x0 + w + apron) - wx, min(height, y0 + h + apron) - wy)
            tiles.append(Tile((x0, y0, w, h), window))
    return tiles


# render_tile(scene, settings, until, whites, passes) -> RenderOutput: one tile's samples
# (sampling.render_samples with those arguments, on whatever thread owns the renderer).
RenderTile = Callable[[Scene, RenderSettings, "int | None", tuple, bool], RenderOutput]


def render_tiled(render_tile: RenderTile, scene: Scene, settings: RenderSettings | None, samples: int,
                 side: int, write: Callable[[Tile, RenderOutput], None], passes: bool = True,
                 progress: Callable[[float], None] | None = None) -> RenderOutput:
    """Render ``scene`` in tiles of ``side`` pixels (module doc); ``write(tile, output)`` receives
    each tile's core as it is done (its combined image and passes, top row first). Returns the
    frame's warnings, timings and chosen settings (no images)."""
    samples = max(int(samples), 1)
    fixed = frame_settings(prepare_scene(scene, settings), settings, samples)
    tiles = plan_tiles(scene.camera, side)
    _, _, width, height = pixel_window(scene.camera)
    pixels = width * height
    stages = [ADAPTIVE_FIRST_SAMPLES, ADAPTIVE_MIN_SAMPLES] if samples >= ADAPTIVE_FRAME_SAMPLES else []
    whites: list[float | None] = [None, None]
    cost = sum(stages) + samples
    done = 0
    summary = RenderOutput(combined=None)
    for stage, until in enumerate([*stages, None]):
        top = np.zeros(0, np.float32)
        for i, tile in enumerate(tiles):
            if progress is not None:
                progress((done + (until or samples) * i / len(tiles)) / cost)
            tiled = dataclasses.replace(scene, camera=tile.camera(scene.camera))
            out = render_tile(tiled, fixed, until, tuple(whites), passes and until is None)
            if until is None:
                core = RenderOutput(combined=tile.crop(out.combined),
                                    passes={k: tile.crop(v) for k, v in out.passes.items()})
                write(tile, core)
                for message in out.warnings:
                    if message not in summary.warnings:
                        summary.warnings.append(message)
                for name, seconds in out.timings_s.items():
                    summary.timings_s[name] = summary.timings_s.get(name, 0.0) + seconds
                summary.chosen = dict(out.chosen)
            else:
                rank = white_rank(pixels)
                top = largest(np.concatenate([top, brightest(tile.crop(out.combined), rank)]), rank)
            del out
        if until is not None:
            whites[stage] = frame_white(top, pixels)
        done += until or samples
    return summary
