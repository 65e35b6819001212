"""The world's radiance by direction: one node graph, read for the light and for the background.

A world whose Background colour varies with the direction (an Environment Texture, aimed or not by
a Mapping node; a Sky Texture baked by Cycles; a gradient made of nodes) is a ``shading.ShaderGraph``
whose output is the Background's radiance, evaluated with the direction as its Generated and
Object coordinates, as Cycles evaluates a world shader. Two images are read from it:

- ``image``: LIGHT_SIZE pixels over the sphere, each the radiance averaged over its part of it (an
  Environment Texture is read from its image averaged down to that size). The world's light
  (engine/world_light.py) is made from it.
- ``panorama``: the background behind everything, as wide as the camera's pixels need
  (``panorama_width``), read by the compose shader (shaders/compose.glsl) in each pixel's direction
  at the level of detail of the pixel's size.

The same graph, through the same mapping, gives both: what lights the scene is what the camera sees.
A sun disc (a Sky Texture's) is far smaller than a pixel of either: it is kept apart (``discs``: its
direction and the irradiance it sends) and its light shared among the four pixels around its
direction at each image's own resolution, so that their light-weighted mean direction is the
sun's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from . import caches, shading
from .scene import Camera, _digest

LIGHT_SIZE = (64, 128)          # (rows, columns) of the image the world's light is made from
PANORAMA_WIDTHS = (256, 4096)   # the narrowest and widest background panorama
GRAPH_DETAIL = 2048             # the widest a world without images is drawn from (its nodes are smooth)
CHUNK = 1 << 19                 # directions evaluated at once


def band_directions(size: tuple[int, int], r0: int, r1: int) -> np.ndarray:
    """The directions of rows r0..r1 of an equirectangular image of ``size`` (``directions``)."""
    h, w = size
    theta = math.pi * (np.arange(r0, r1) + 0.5) / h
    phi = math.pi - 2.0 * math.pi * (np.arange(w) + 0.5) / w
    t, p = np.meshgrid(theta, phi, indexing="ij")
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)


def directions(size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(directions (h w, 3), solid angles (h w,)) of the pixel centres of an equirectangular image
    of ``size`` = (rows, columns), top row first (Cycles' mapping: shading.equirectangular)."""
    h, w = size
    sin_theta = np.sin(math.pi * (np.arange(h) + 0.5) / h)                  # from +Z, top row first
    omega = np.repeat((2.0 * math.pi / w) * (math.pi / h) * sin_theta, w)
    return band_directions(size, 0, h), omega


_images = caches.memo("environment.images", 8)      # (graph key, size) -> radiance image


Disc = tuple[tuple[float, float, float], tuple[float, float, float]]   # (unit direction, W/m^2 RGB)


@dataclass(frozen=True, eq=False)
class Environment:
    """The world's radiance by direction: ``graph``, a world's Surface graph (its output a
    Background, read as an emission), with ``texspace`` making its Generated coordinates the
    direction; and ``discs``, sun discs too small for a pixel: (direction toward the sun, the
    irradiance it sends, RGB)."""

    graph: shading.ShaderGraph
    discs: tuple[Disc, ...] = ()
    images: tuple = ()      # (key, pixels, sRGB) of the images it reads: registered again when read

    @cached_property
    def key(self) -> str:
        return _digest("environment", self.graph.key, repr(self.discs))

    def radiance(self, dirs: np.ndarray, footprint: float = 0.0) -> np.ndarray:
        """(n, 3) float32 radiance (W/(sr m^2)) toward unit directions ``dirs`` (n, 3), each standing
        for ``footprint`` radians (shading.evaluate)."""
        n = len(dirs)
        self._register()
        fields = shading.evaluate(self.graph, {}, n, np.asarray(dirs, np.float64), footprint=footprint)
        return np.ascontiguousarray(np.maximum(np.broadcast_to(fields.emission, (n, 3)), 0.0), np.float32)

    def _equirectangular(self, size: tuple[int, int]) -> np.ndarray:
        def make():
            h, w = size
            out = np.empty((h, w, 3), np.float32)
            rows = max(1, CHUNK // w)       # evaluated a band of rows at a time: bounded memory
            for r in range(0, h, rows):
                dirs = band_directions(size, r, min(h, r + rows))
                out[r:r + rows] = self.radiance(dirs, footprint=2.0 * math.pi / w).reshape(-1, w, 3)
            out = with_discs(out, self.discs)
            out.setflags(write=False)
            return out

        return _images.made((self.key, size), make)

    def _register(self) -> None:
        """The images it reads, registered again where the registry let them go (it keeps the last
        few: a scene's other textures may have pushed them out since the world was read)."""
        for key, pixels, srgb in self.images:
            if key not in shading.IMAGES:
                shading.register_image(key, pixels, srgb)

    @cached_property
    def image_sizes(self) -> tuple[tuple[int, int], ...]:
        """(rows, columns) of each image its Environment Textures read."""
        self._register()
        entries = [shading.IMAGES.get(n.param("image", "")) for n in self.graph.nodes
                   if n.kind == "TEX_ENVIRONMENT"]
        return tuple(e[0].shape[:2] for e in entries if e is not None)

    @property
    def light_size(self) -> tuple[int, int]:
        """The size of the image the world's light is made from: LIGHT_SIZE, or an environment
        image's own size where it is smaller (it is read as it is, not interpolated up)."""
        sizes = self.image_sizes
        if not sizes:
            return LIGHT_SIZE
        return (min(LIGHT_SIZE[0], max(h for h, _ in sizes)), min(LIGHT_SIZE[1], max(w for _, w in sizes)))

    @property
    def detail(self) -> int:
        """The widest panorama that shows more of it: its widest image's width rounded up to a
        power of two, or GRAPH_DETAIL for a world of nodes alone."""
        widths = [w for _, w in self.image_sizes]
        if not widths:
            return GRAPH_DETAIL
        return 2 ** math.ceil(math.log2(max(max(widths), 1)))

    def image(self) -> np.ndarray:
        """The (h, w, 3) image of ``light_size`` the world's light is made from, top row first (kept)."""
        return self._equirectangular(self.light_size)

    def panorama(self, width: int) -> np.ndarray:
        """The (width / 2, width, 3) background panorama, top row first (kept)."""
        return self._equirectangular((max(1, width // 2), width))

    @cached_property
    def mean(self) -> tuple[float, float, float]:
        """The radiance averaged over the sphere (what the world is as a constant)."""
        return mean_radiance(self.image())


def with_discs(env: np.ndarray, discs: tuple[Disc, ...]) -> np.ndarray:
    """The equirectangular image ``env`` (top row first) with each disc's light shared bilinearly
    among the four pixels around its direction (their light-weighted mean direction is the
    disc's; the nearest pixel alone would tilt it by up to half a pixel)."""
    if not discs:
        return env
    env = np.array(env, np.float32)
    h, w = env.shape[:2]
    omega = directions((h, w))[1].reshape(h, w)
    for (x, y, z), light in discs:
        row = math.acos(max(-1.0, min(1.0, z))) / math.pi * h - 0.5
        col = (math.pi - math.atan2(y, x)) / (2.0 * math.pi) * w - 0.5
        r0, c0 = math.floor(row), math.floor(col)
        light = np.maximum(np.asarray(light, np.float32), 0.0)
        for dr, fr in ((0, 1.0 - (row - r0)), (1, row - r0)):
            for dc, fc in ((0, 1.0 - (col - c0)), (1, col - c0)):
                r, c = min(max(r0 + dr, 0), h - 1), (c0 + dc) % w
                env[r, c] += light * (fr * fc) / omega[r, c]
    return env


def mean_radiance(env: np.ndarray) -> tuple[float, float, float]:
    """An equirectangular image's radiance averaged over the sphere."""
    _, omega = directions(env.shape[:2])
    rgb = (np.asarray(env, np.float64).reshape(-1, 3) * omega[:, None]).sum(axis=0) / (4.0 * math.pi)
    return tuple(float(c) for c in rgb)


def from_image(pixels: np.ndarray, strength: float = 1.0, interpolation: str = "Linear",
               discs: tuple[Disc, ...] = ()) -> Environment:
    """The environment of an equirectangular image (h, w, 3 or 4), top row first (Cycles' mapping),
    times ``strength``: an Environment Texture feeding a Background, its image registered by its
    content; ``discs`` beside it."""
    px = np.asarray(pixels, np.float32)
    if px.shape[-1] == 3:
        px = np.concatenate([px, np.ones(px.shape[:2] + (1,), np.float32)], axis=-1)
    px = np.ascontiguousarray(px[::-1])              # the registry's images are bottom row first
    key = _digest("environment image", px)
    px.setflags(write=False)
    env = with_texture(key, strength, interpolation, discs)
    return Environment(env.graph, env.discs, ((key, px, False),))


def of_graph(graph: shading.ShaderGraph) -> Environment:
    """The environment of a world's compiled graph, holding the images its Environment Textures
    read now (registered by the node-graph reader) so that it can read them later."""
    keys = dict.fromkeys(n.param("image", "") for n in graph.nodes if n.kind == "TEX_ENVIRONMENT")
    entries = [(k, shading.IMAGES.get(k)) for k in keys]
    return Environment(graph, (), tuple((k, e[0], e[1]) for k, e in entries if e is not None))


def with_texture(key: str, strength: float = 1.0, interpolation: str = "Linear",
                 discs: tuple[Disc, ...] = ()) -> Environment:
    """A Background of ``strength`` whose colour is an Environment Texture of registered image ``key``."""
    from .shading import Input, Link, Node, ShaderGraph

    texture = Node("TEX_ENVIRONMENT", (("image", key), ("interpolation", interpolation)), (), "Environment")
    background = Node("BACKGROUND", (), (Input("Color", "RGBA", Link(0, "Color", "RGBA")),
                                          Input("Strength", "VALUE", float(strength))), "Background")
    return Environment(ShaderGraph((texture, background), Link(1, "Background", "SHADER"),
                                   texspace=((0.5, 0.5, 0.5), (0.5, 0.5, 0.5))), tuple(discs))


def panorama_width(camera: Camera, env: Environment | None = None) -> int:
    """How wide the background panorama is drawn from: a texel no wider than the camera's pixels,
    and no finer than the environment's own detail (its widest image, or GRAPH_DETAIL for a world
    of nodes alone): a power of two within PANORAMA_WIDTHS (an orthographic camera sees one
    direction)."""
    from .camera import view_plane

    plane = view_plane(camera)
    if plane.ortho:
        return PANORAMA_WIDTHS[0]
    texels = 2.0 * math.pi / max(plane.pixel_size, 1e-9)
    width = 2 ** math.ceil(math.log2(max(texels, 1.0)))
    detail = PANORAMA_WIDTHS[1] if env is None else env.detail
    return int(min(max(width, PANORAMA_WIDTHS[0]), PANORAMA_WIDTHS[1], max(detail, PANORAMA_WIDTHS[0])))
