"""What the renderer consumes: one frozen dataclass per thing in the scene.

Conventions (Blender's, so that images compare with Cycles pixel for pixel):
- world space in metres, right-handed, Z up; 4x4 matrices are row-major numpy arrays that act
  on column vectors (``world = matrix @ local``), like ``mathutils.Matrix``;
- a camera looks along its local -Z with +Y up; a spot light shines along its local -Z;
- colours are scene-linear RGB triples;
- images are numpy arrays with the top row first.
"""

from __future__ import annotations

import hashlib
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Literal

import numpy as np

from .camera_effects import Motion
from .multiple_scattering import Octaves
from .surface import Surface

if TYPE_CHECKING:
    from .environment import Environment

RGB = tuple[float, float, float]


def _matrix(m) -> np.ndarray:
    a = np.asarray(m, dtype=np.float64).reshape(4, 4)
    a.setflags(write=False)
    return a


# Bytes of arrays hashed into cache keys, for tests ('bytes', 'arrays').
HASHED = Counter()


def _digest(*parts) -> str:
    """A content hash of numbers and arrays, used as a cache key."""
    h = hashlib.blake2b(digest_size=16)
    for p in parts:
        if isinstance(p, np.ndarray):
            HASHED["arrays"] += 1
            HASHED["bytes"] += p.nbytes
            h.update(str(p.dtype).encode() + str(p.shape).encode())
            h.update(np.ascontiguousarray(p).tobytes())
        else:
            h.update(repr(p).encode())
    return h.hexdigest()


@dataclass(frozen=True)
class Aperture:
    """A thin lens (Blender's Depth of Field, as Cycles samples it): ``radius_m`` is Cycles'
    aperture size, the lens's focal length over twice its f-stop; ``focus_m`` the distance of the
    plane in focus along the view axis; ``blades`` (0, or 3 and more: a regular polygon whose
    corners lie on the radius) turned by ``rotation_rad``; ``ratio`` squeezes the aperture's x by
    1 / ratio (anamorphic bokeh)."""

    radius_m: float
    focus_m: float
    blades: int = 0
    rotation_rad: float = 0.0
    ratio: float = 1.0


@dataclass(frozen=True, eq=False)
class Camera:
    """A Blender camera.

    ``matrix_world`` places the camera (local -Z is the view direction, +Y up).
    ``lens_mm`` and ``sensor_*_mm`` follow Blender: with ``sensor_fit='AUTO'`` the sensor width spans
    the larger image axis; ``'HORIZONTAL'`` / ``'VERTICAL'`` pin it to the width / height (the
    latter using ``sensor_height_mm``). ``shift_x``/``shift_y`` are fractions of the fitted
    image side. ``ortho_scale`` (metres) is the fitted side of an orthographic view.
    ``clip_start``/``clip_end`` in metres. ``border`` = (xmin, ymin, xmax, ymax) in [0, 1] of the
    full frame (Blender's render border, y up) or None. ``aperture``: depth of field (a thin lens,
    sampled across the antialiasing samples; engine/camera_effects.py), None for a pinhole.
    """

    matrix_world: np.ndarray
    width_px: int
    height_px: int
    projection: Literal["PERSP", "ORTHO"] = "PERSP"
    lens_mm: float = 50.0
    sensor_width_mm: float = 36.0
    sensor_height_mm: float = 24.0
    sensor_fit: Literal["AUTO", "HORIZONTAL", "VERTICAL"] = "AUTO"
    shift_x: float = 0.0
    shift_y: float = 0.0
    ortho_scale: float = 6.0
    clip_start: float = 0.1
    clip_end: float = 100.0
    border: tuple[float, float, float, float] | None = None
    aperture: Aperture | None = None

    def __post_init__(self):
        object.__setattr__(self, "matrix_world", _matrix(self.matrix_world))

    @cached_property
    def key(self) -> str:
        return _digest(self.matrix_world, self.width_px, self.height_px, self.projection,
                       self.lens_mm, self.sensor_width_mm, self.sensor_height_mm, self.sensor_fit,
                       self.shift_x, self.shift_y, self.ortho_scale, self.clip_start,
                       self.clip_end, self.border, self.aperture)

    @property
    def position(self) -> np.ndarray:
        return np.array(self.matrix_world[:3, 3])


LIGHT_KINDS = ("SPOT", "POINT", "SUN", "AREA")


@dataclass(frozen=True, eq=False)
class Light:
    """A Blender light: one concept whose ``kind`` chooses its emission and the projection of
    its maps (light.py turns it into map faces).

    ``kind``:
    - 'SPOT': a cone; ``power_w`` watts, radiant intensity I = power_w / (4 pi) W/sr whatever the
      cone; ``spot_size_rad`` is the full cone angle, ``spot_blend`` Blender's blend in [0, 1];
      ``gobo`` is an optional projected texture, an (h, w, 3) float32 array (top row first)
      stretched over the square that bounds the cone. One perspective map face.
    - 'POINT': I = power_w / (4 pi) W/sr in every direction. Six cube faces.
    - 'AREA': a rectangle (or ellipse) of ``size_m`` = (size, size_y) metres in its local XY plane,
      emitting along local -Z with the radiance power_w / (pi A): P / pi W/sr on its axis far
      away (measured against Cycles), the solid angle it fills near it; its soft shadows.
      Five cube faces (the back one emits nothing).
    - 'SUN': parallel light travelling along local -Z; ``power_w`` is Blender's strength, the
      irradiance in W/m^2 on a surface facing it. One orthographic face fitted to the media.
    Shadows: every kind is shadowed by the solids and the media.
    Spot only: ``cone_scale`` = (sx / sz, sy / sz) of the light object's scale: Cycles renders a
    spot of a non-uniformly scaled object as an elliptical cone whose half-widths at unit
    distance are tan(spot_size / 2) times these. ``cast_shadow`` False (Blender's
    ``use_shadow``): nothing shadows the light, neither the solids nor the media (as Cycles
    renders it), for every kind. ``lights_medium`` / ``lights_surfaces`` False: the light lights no
    medium / no surface (the light object's Ray Visibility ▸ Volume Scatter / Diffuse off in
    Blender, or its Light Linking receiver collection excluding every medium / every solid), though
    it is still seen and still shadowed. ``from_world``: a sun standing in for
    part of the world's light (engine/world_light.py), not a light of the scene; its
    ``angle_rad``, the angular diameter of the cone of directions it stands for, softens the
    shadows it casts on surfaces (shaders/world_soft.glsl) instead of the generic soft shadows.
    Size (soft shadows, light.soft_extent; none of it enters ``key``, so a size edit rebuilds no
    map): ``radius_m`` a spot's or point light's radius, metres; ``angle_rad`` a sun's angular
    diameter; an area light's ``size_m``, an ellipse (Blender's Disk and Ellipse) where
    ``round_shape``, and its ``spread_rad`` (Blender's Spread: below pi, Cycles' soft-box grid).
    Light linking that lights some media (solids) and not others: ``lit_media`` the names of the
    media it lights (None: all), ``unlit_solids`` those of the solids it does not light.
    Shadow linking (Blender's Object ▸ Shading ▸ Shadow Linking): ``shadow_solids`` the names of
    the solids that shadow the light (None: all that cast shadows); ``media_shadow_surfaces``
    False: the media cast no shadow from it on the surfaces, while each still shadows its own
    samples (as Cycles renders a medium left out of the light's blockers).
    """

    matrix_world: np.ndarray
    color: RGB = (1.0, 1.0, 1.0)
    power_w: float = 1000.0
    spot_size_rad: float = np.pi / 4
    spot_blend: float = 0.15
    gobo: np.ndarray | None = None
    use_tfm: bool = True
    name: str = "Spot"
    kind: Literal["SPOT", "POINT", "SUN", "AREA"] = "SPOT"
    size_m: tuple[float, float] = (0.0, 0.0)
    cone_scale: tuple[float, float] = (1.0, 1.0)
    cast_shadow: bool = True
    from_world: bool = False
    lights_medium: bool = True
    lights_surfaces: bool = True
    radius_m: float = 0.0
    angle_rad: float = 0.0
    round_shape: bool = False
    spread_rad: float = float(np.pi)
    media_shadow_surfaces: bool = True
    shadow_solids: tuple[str, ...] | None = None
    lit_media: tuple[str, ...] | None = None
    unlit_solids: tuple[str, ...] = ()

    def __post_init__(self):
        if self.kind not in LIGHT_KINDS:
            raise ValueError(f"light kind must be one of {LIGHT_KINDS}, got {self.kind!r}")
        object.__setattr__(self, "matrix_world", _matrix(self.matrix_world))
        if self.gobo is not None:
            g = np.asarray(self.gobo, dtype=np.float32)
            if g.ndim == 2:
                g = np.repeat(g[:, :, None], 3, axis=2)
            g = np.ascontiguousarray(g[:, :, :3])
            g.setflags(write=False)
            object.__setattr__(self, "gobo", g)

    @cached_property
    def key(self) -> str:
        """Everything the light's shadow maps and TFMs depend on: its kind and geometry
        (placement, cone) and the solids that shadow it. Colour, power, blend, gobo and use_tfm
        do not change what those maps hold."""
        cone = (self.spot_size_rad, tuple(float(s) for s in self.cone_scale)) if self.kind == "SPOT" else None
        blockers = () if self.shadow_solids is None else (self.shadow_solids,)
        return _digest(self.kind, self.matrix_world, cone, *blockers)

    @cached_property
    def gobo_key(self) -> str | None:
        """What the gobo texture depends on (None without a gobo)."""
        return None if self.gobo is None else _digest(self.gobo)

    @property
    def position(self) -> np.ndarray:
        return np.array(self.matrix_world[:3, 3])

    @property
    def direction(self) -> np.ndarray:
        d = -self.matrix_world[:3, 2]
        return d / np.linalg.norm(d)

    @property
    def intensity_w_per_sr(self) -> np.ndarray:
        """Per colour channel: the radiant intensity in W/sr (on the axis for an area light), or
        for a sun the irradiance in W/m^2."""
        c = np.asarray(self.color, dtype=np.float64)
        if self.kind == "SUN":
            return c * self.power_w
        if self.kind == "AREA":
            return c * self.power_w / np.pi
        return c * self.power_w / (4.0 * np.pi)


@dataclass(frozen=True)
class GridValue:
    """A quantity that varies over a medium: ``scale * max(G(p), 0) + offset``, with G the grid of
    ``Medium.grids`` named ``grid`` (trilinear like the density), or the constant ``offset`` when
    ``grid`` is None. Units are those of the quantity it gives."""

    grid: str | None = None
    scale: float = 1.0
    offset: float = 0.0

    @property
    def is_zero(self) -> bool:
        return (self.grid is None or self.scale == 0.0) and self.offset == 0.0


@dataclass(frozen=True, eq=False)
class GlowBlocks:
    """Blocks of a grid's index space, boxes of ``side`` voxels (a number, or one per axis): block
    (i, j, k) spans ``origin + side * (i, j, k)`` to ``origin + side * (i + 1, j + 1, k + 1)``
    and is in where ``mask[i, j, k]``."""

    origin: tuple[float, float, float]
    side: tuple[float, float, float]
    mask: np.ndarray

    def __post_init__(self):
        m = np.ascontiguousarray(self.mask, dtype=bool)
        side = tuple(float(x) for x in np.broadcast_to(np.asarray(self.side, np.float64), (3,)))
        if m.ndim != 3 or not m.any() or min(side) <= 0.0 or len(self.origin) != 3:
            raise ValueError("GlowBlocks needs a 3D mask with a block in, sides > 0 and a 3D origin")
        m.setflags(write=False)
        object.__setattr__(self, "mask", m)
        object.__setattr__(self, "origin", tuple(float(x) for x in self.origin))
        object.__setattr__(self, "side", side)

    @property
    def box(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """The index-space box of the blocks that are in."""
        where = np.argwhere(self.mask)
        lo = np.asarray(self.origin) + np.asarray(self.side) * where.min(axis=0)
        hi = np.asarray(self.origin) + np.asarray(self.side) * (where.max(axis=0) + 1)
        return tuple(float(x) for x in lo), tuple(float(x) for x in hi)

    def contains(self, idx: np.ndarray) -> np.ndarray:
        """Whether the index-space points (n, 3) lie in a block that is in."""
        b = np.floor((np.asarray(idx, np.float64) - np.asarray(self.origin)) / np.asarray(self.side))
        b = b.astype(np.int64)
        ok = np.all((b >= 0) & (b < np.asarray(self.mask.shape)), axis=1)
        out = np.zeros(len(b), bool)
        out[ok] = self.mask[tuple(b[ok].T)]
        return out


@dataclass(frozen=True, eq=False)
class Medium:
    """A participating medium of one material at varying density D.

    sigma(p) = D(p) * sigma_per_density, with ``sigma_a`` and ``sigma_s`` in 1/m per unit
    density, per colour channel; ``anisotropy`` is the Henyey-Greenstein g.

    Heterogeneous: ``density`` is an (nx, ny, nz) float32 grid in x, y, z index order whose
    voxel centres sit at integer index coordinates; ``index_to_world`` maps index space to
    world space. The density is trilinear between voxel centres and falls to zero one voxel
    beyond the outermost centres.

    Homogeneous (``density`` is None): D = 1 inside ``box_to_world``'s image of the cube
    [-1, 1]^3, or everywhere when ``box_to_world`` is None (fog filling the scene, up to the
    camera's clip_end).

    ``clipping``: grid densities below it are empty (Blender's volume ``render.clipping``, which
    Cycles applies; 0.001 by default in Blender, 0 here). NaN, infinite and negative densities are
    rendered as 0 (``medium_grid.clean_density``, with a warning each).

    ``grids``: more grids by name on the density's lattice (same shape, same ``index_to_world``):
    (nx, ny, nz) float32 scalars or (nx, ny, nz, 3) colours. ``color_grid`` names an RGB grid
    that scales sigma_s per channel (Principled Volume's Color Attribute; the extinction is
    unchanged, which is exact for a black Absorption Color and colours <= 1).

    Emission (Cycles' volume emission, not scaled by density), radiance per metre of ray,
    W/(sr m^2) per m: ``emission_color * max(emission_strength, 0)`` plus the blackbody term
    ``blackbody_tint * sigma_SB / pi * 1e-6 * mix(1, T^4, blackbody_intensity) * bb(T)`` where
    ``blackbody_intensity`` > 0, T = ``temperature`` in kelvin and bb Cycles' Rec.709 blackbody
    colour. Emission is added along view rays, and lights the solids where ``lights_surfaces``.

    ``source_key``: when given, a key that changes whenever ``density``, ``index_to_world`` or
    ``grids`` change (the file, frame and grid names they were read from); the arrays are then
    not hashed for the cache keys.

    ``glow``: where the medium emits when a part of its emission reads no grid and so glows where
    there is no density (a constant Emission Strength): Cycles glows over the volume's mesh, the
    8³ leaf blocks of its grids' active voxels (blender/extract.glow_blocks), ``GlowBlocks`` in
    the density's index space. None: the grid's box one voxel wider, [-1, n].

    ``emission_grid``: an RGB grid of ``grids`` holding emitted radiance per metre per voxel (a
    node graph evaluated per voxel, engine/shading.py), added to the emission above times
    ``blackbody_tint``.

    ``shader``: a node graph still to be evaluated over the medium's lattice (an
    ``engine.shading.ShaderSource``; the density is then a one-voxel stand-in and ``source_key``
    the source's key): ``shading.resolve_scene`` turns it into a plain medium on the render
    thread, so that the host's thread never evaluates a graph.

    ``lights_surfaces``: the emission lights the solids too (Cycles does, even with no bounces,
    unless the object's Diffuse ray visibility is off), approximated by engine/fire_light.py.
    ``lights_medium``: the emission lights the media, which scatter it (Cycles does, even with no
    bounces, unless the object's Volume Scatter ray visibility is off; engine/diffusion.py).

    ``sparse``: the density at full resolution as bricks (an ``engine.sparse_grid.SparseGrid``,
    a big grid that is mostly empty), which the renderer uploads in place of ``density``; the
    ``density`` is then a coarser copy (block means) that everything else reads (statistics,
    bounds), and ``sparse.index_to_medium`` maps the bricks' index space into its own.
    """

    sigma_a: RGB = (0.1, 0.1, 0.1)
    sigma_s: RGB = (1.0, 1.0, 1.0)
    anisotropy: float = 0.0
    density: np.ndarray | None = None
    index_to_world: np.ndarray | None = None
    box_to_world: np.ndarray | None = None
    name: str = "Medium"
    clipping: float = 0.0
    grids: Mapping[str, np.ndarray] = field(default_factory=dict)
    color_grid: str | None = None
    emission_color: RGB = (1.0, 1.0, 1.0)
    emission_strength: GridValue = field(default_factory=lambda: GridValue(offset=0.0))
    blackbody_intensity: GridValue = field(default_factory=lambda: GridValue(offset=0.0))
    blackbody_tint: RGB = (1.0, 1.0, 1.0)
    temperature: GridValue = field(default_factory=lambda: GridValue(offset=1000.0))
    source_key: str | None = None
    glow: GlowBlocks | None = None
    emission_grid: str | None = None
    shader: object | None = None
    lights_surfaces: bool = False
    lights_medium: bool = False
    sparse: object | None = None

    def __post_init__(self):
        if self.density is not None:
            d = np.ascontiguousarray(self.density, dtype=np.float32)
            if d.ndim != 3:
                raise ValueError(f"density must be a 3D grid, got shape {d.shape}")
            d.setflags(write=False)
            object.__setattr__(self, "density", d)
            m = np.eye(4) if self.index_to_world is None else self.index_to_world
            object.__setattr__(self, "index_to_world", _matrix(m))
        if self.box_to_world is not None:
            object.__setattr__(self, "box_to_world", _matrix(self.box_to_world))

        grids = {}
        for name, g in dict(self.grids).items():
            a = np.ascontiguousarray(g, dtype=np.float32)
            if self.density is None or a.shape[:3] != self.density.shape or a.ndim not in (3, 4):
                raise ValueError(f"grid '{name}' of shape {a.shape} is not on the density's lattice")
            a.setflags(write=False)
            grids[name] = a
        object.__setattr__(self, "grids", grids)
        for value in (self.emission_strength, self.blackbody_intensity, self.temperature):
            if value.grid is not None and (value.grid not in grids or grids[value.grid].ndim != 3):
                raise ValueError(f"no scalar grid '{value.grid}' in the medium's grids")
        for name in (self.color_grid, self.emission_grid):
            if name is not None and (name not in grids or grids[name].ndim != 4):
                raise ValueError(f"no colour grid '{name}' in the medium's grids")

    @property
    def has_emission(self) -> bool:
        """Whether the medium emits light anywhere."""
        strength = self.emission_strength
        glows = any(c != 0.0 for c in self.emission_color) and (
            strength.offset > 0.0 or (strength.grid is not None and strength.scale > 0.0))
        bb = self.blackbody_intensity
        burns = any(c != 0.0 for c in self.blackbody_tint) and (
            bb.offset > 0.0 or (bb.grid is not None and bb.scale > 0.0) or self.emission_grid is not None)
        return glows or burns

    @cached_property
    def emission_key(self) -> str:
        """What the emission term depends on besides the grids (no light map depends on it)."""
        return _digest(self.emission_color, self.emission_strength, self.blackbody_intensity,
                       self.blackbody_tint, self.temperature, self.emission_grid,
                       None if self.glow is None else (self.glow.origin, self.glow.side, self.glow.mask))

    @cached_property
    def grids_key(self) -> str:
        """The extra grids' content (the attribute textures depend on it)."""
        if self.source_key is not None:
            return _digest("source", self.source_key, self.index_to_world, sorted(self.grids))
        return _digest(*[x for name in sorted(self.grids) for x in (name, self.grids[name])])

    @property
    def is_homogeneous(self) -> bool:
        return self.density is None

    @property
    def sigma_t(self) -> np.ndarray:
        """Extinction per unit density, 1/m, per channel."""
        return np.asarray(self.sigma_a, dtype=np.float64) + np.asarray(self.sigma_s, dtype=np.float64)

    @cached_property
    def grid_key(self) -> str | None:
        """What the density texture holds: the grid's values, not where it is placed (instances
        of one volume share it). None for a homogeneous medium."""
        if self.density is None:
            return None
        if self.source_key is not None:
            return _digest("source", self.source_key, self.density.shape, float(self.clipping))
        return _digest(self.density, float(self.clipping), *self._sparse_parts)

    @property
    def _sparse_parts(self) -> tuple:
        """What the bricks add to a content key (nothing without them)."""
        s = self.sparse
        return () if s is None else ("sparse", s.shape, s.cells, s.bricks, s.index_to_medium)

    @cached_property
    def density_key(self) -> str:
        """What the light-side maps depend on: the density field, not sigma."""
        if self.density is None:
            return _digest("homogeneous", self.box_to_world)
        if self.source_key is not None:
            return _digest("source", self.source_key, self.index_to_world, self.density.shape,
                           float(self.clipping))
        return _digest(self.density, self.index_to_world, float(self.clipping), *self._sparse_parts)

    @cached_property
    def key(self) -> str:
        return _digest(self.density_key, self.sigma_a, self.sigma_s, self.anisotropy,
                       self.grids_key, self.color_grid, self.emission_key)


@dataclass(frozen=True, eq=False)
class Mesh:
    """A solid object: ``vertices`` (n, 3) float in object space, ``triangles`` (m, 3) int vertex
    indices, placed by ``matrix_world``; ``color`` is the diffuse albedo, ``surface`` its shading
    (engine/surface.py; None: a Lambertian surface of albedo ``color``), ``uv`` its UV map,
    ``normals`` its corner normals where it is smooth-shaded (None: the faces' normals).

    Visibility, as Cycles' object settings: ``visible_camera`` False hides it from the camera
    (it still casts shadows); ``cast_shadow`` False keeps it out of the shadow maps (no shadow
    on surfaces, no shaft in the medium); ``holdout`` makes it a hole: seen by the camera, it
    hides what is behind it, has no radiance and leaves alpha as the medium in front of it does.
    """

    vertices: np.ndarray
    triangles: np.ndarray
    matrix_world: np.ndarray = field(default_factory=lambda: np.eye(4))
    color: RGB = (0.8, 0.8, 0.8)
    name: str = "Mesh"
    visible_camera: bool = True
    cast_shadow: bool = True
    holdout: bool = False
    surface: Surface | None = None
    uv: np.ndarray | None = None      # (m, 3, 2) float32: each triangle corner's UV (textures)
    normals: np.ndarray | None = None  # (m, 3, 3) float32: object-space corner normals (smooth shading)

    def __post_init__(self):
        v = np.ascontiguousarray(self.vertices, dtype=np.float32).reshape(-1, 3)
        t = np.ascontiguousarray(self.triangles, dtype=np.int32).reshape(-1, 3)
        v.setflags(write=False)
        t.setflags(write=False)
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "triangles", t)
        object.__setattr__(self, "matrix_world", _matrix(self.matrix_world))

    @cached_property
    def key(self) -> str:
        """What its vertex buffer holds (the visibility flags choose the sets it is in)."""
        return _digest(self.vertices, self.triangles, self.matrix_world, self.color, self.holdout,
                       repr(self.surface), self.uv if self.uv is not None else (),
                       self.normals if self.normals is not None else ())

    @property
    def shading(self) -> Surface:
        """The surface the renderer shades (a Lambertian ``color`` when ``surface`` is None)."""
        return self.surface if self.surface is not None else Surface.lambert(self.color)

    @cached_property
    def shape_key(self) -> str:
        """What shadow maps depend on (not the colour)."""
        return _digest(self.vertices, self.triangles, self.matrix_world)

    def world_vertices(self) -> np.ndarray:
        v = np.c_[self.vertices.astype(np.float64), np.ones(len(self.vertices))]
        return (v @ self.matrix_world.T)[:, :3]

    @cached_property
    def world_bounds(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(lo, hi) of the world vertices (None: no vertex), found once per Mesh."""
        if not len(self.vertices):
            return None
        v = self.world_vertices()
        return v.min(axis=0), v.max(axis=0)


@dataclass(frozen=True)
class RenderSettings:
    """How to render.

    ``view_steps``: samples along each view ray through the medium.
    ``light_steps``: samples along each light ray when building a TFM (and per view sample in
    the brute-force march).
    ``coefficients``: DCT coefficients stored per TFM texel, 1-16.
    ``density_weight``: the paper's alpha (>= 1, dimensionless, relative to the optical depth of
    the most extinguishing channel), or None for automatic (the largest density integral found
    along the light rays; the map then does not depend on sigma).
    ``map_resolution``: shadow map and TFM side, texels.
    ``tfm_resolution``: the TFM's side when it differs: None (``map_resolution``), texels, or
    'FOOTPRINT' (one texel per voxel where the medium is nearest to the light, at most
    ``map_resolution`` and the image's larger side; passes/tfm.footprint_resolution; AUTO's
    choice).
    ``sampling``: 'WORLD' or 'PROJECTIVE' spacing of view samples in a homogeneous medium.
    ``method``: 'TFM' (the product), 'BRUTE_FORCE' (GPU double march reference), 'UNSHADOWED'
    (the floor: transmittance 1 from the light through the medium, solids' shadow maps kept, no
    TFM built; what no transmittance representation can beat, for the benchmark).
    ``tfm_filter``: 'EXACT' reconstructs the 2x2 nearest TFM texels each in its own [K_in, K_out]
    and blends the results; 'LINEAR' lets the hardware blend coefficients and domains (about a
    quarter of the lookups; mixes domains at the medium's edges as seen from the light).
    ``ambient``: whether the world colour lights the medium and the surfaces.
    ``max_grid_bytes``: memory budget for the density texture; larger grids are downsampled.
    ``view_jitter``: None marches view rays at the step midpoints; a fraction of a step in
    [0, 1) starts each pixel's march there plus a per-pixel hash (sampling.march_offset: a
    different start per antialiasing sample). No map depends on it.
    ``quality``: 'CUSTOM' renders with the fields above; 'AUTO' lets
    ``quality.auto_settings(scene, settings)`` choose the coefficient count, density weighting,
    steps and sampling for the scene (the rule of docs/benchmark.md).
    ``film_transparent``: Blender's Film > Transparent. True: alpha is 1 where a solid is seen,
    else 1 - mean view transmittance, and the world is not seen (premultiplied RGB over a
    transparent background, as Cycles writes it). False (Blender's default): alpha is 1 and where
    no solid is seen the world (``Scene.world``) shows behind the medium, attenuated by it.
    ``alpha_from_probe``: set by ``quality.auto_settings`` (and kept in the per-sample settings a
    frame renders with, whose quality reads 'CUSTOM'): automatic alpha for a spot reaching one grid
    medium is the largest density integral of AUTO's numpy probe, not a GPU pass and its read-back.
    ``world_light``: how the world colour (``Scene.ambient``) lights the media and the surfaces:
    'UNSHADOWED' adds it as is; 'SHADOWED' as ``world_directions`` suns over the sphere, each
    shadowed by the media and the solids like any light (engine/world_light.py: what Cycles does).
    ``volume_bounces``: Cycles' Volume Bounces, how many times light may scatter in the media: 0
    renders single scattering; more adds the octaves of ``multiple_scattering.octaves`` (from the
    same maps: no map depends on it). ``octaves``: those octaves given outright (None: the fitted
    rule for ``volume_bounces``; for fitting and benchmarks). ``lattice`` False: the fields of
    engine/diffusion.py are read where already built and none is built (the viewport's coarse
    image: after a light move or a medium edit the light's slab term stands in for them from 16
    bounces on, and the media's emission is not scattered for that image).
    ``frame_samples``: the antialiasing samples of the frame this render is one of
    (sampling.frame_settings): a world sun's cone of directions on surfaces is read over them, a
    few directions a sample (passes/scattering.world_taps); no map depends on it.
    """

    view_steps: int = 100
    light_steps: int = 100
    coefficients: int = 8
    density_weight: float | None = None
    map_resolution: int = 512
    tfm_resolution: int | Literal["FOOTPRINT"] | None = None
    sampling: Literal["WORLD", "PROJECTIVE"] = "WORLD"
    method: Literal["TFM", "BRUTE_FORCE", "UNSHADOWED"] = "TFM"
    tfm_filter: Literal["EXACT", "LINEAR"] = "LINEAR"
    ambient: bool = True
    max_grid_bytes: int = 512 * 1024 * 1024
    quality: Literal["CUSTOM", "AUTO"] = "CUSTOM"
    film_transparent: bool = True
    view_jitter: float | None = None
    alpha_from_probe: bool = False
    world_light: Literal["UNSHADOWED", "SHADOWED"] = "UNSHADOWED"
    world_directions: int = 16
    volume_bounces: int = 0
    octaves: Octaves | None = None
    lattice: bool = True
    frame_samples: int = 1


@dataclass(frozen=True, eq=False)
class Scene:
    """Everything to render one frame. ``ambient`` is the world colour (radiance, W/(sr m^2))
    that lights the media and the solids, ``world`` the constant radiance seen behind everything
    with an opaque film (None: the environment, or without one ``ambient``).

    ``environment``: the world's radiance by direction (engine/environment.Environment: the
    world's node graph, an HDRI through its mapping, a baked sky...), or None for a constant
    world; the shadowed world light (engine/world_light.py) is made from it, the camera sees it
    behind everything, and ``ambient`` holds its mean.
    ``media``: every participating medium (None entries are dropped); where they overlap their
    coefficients add up.
    ``world_lights_medium`` / ``world_lights_surfaces`` False: the world's light reaches no medium
    / no surface (the World's Ray Visibility ▸ Volume Scatter / Diffuse off in Blender; Camera off
    is a black ``world``).
    ``motion``: where the camera and the objects move across the shutter (motion blur, sampled
    across the antialiasing samples; engine/camera_effects.py), None: nothing moves.
    """

    camera: Camera
    lights: tuple[Light, ...] = ()
    meshes: tuple[Mesh, ...] = ()
    ambient: RGB = (0.0, 0.0, 0.0)
    media: tuple[Medium, ...] = ()
    world: RGB | None = None
    environment: Environment | None = None
    world_lights_medium: bool = True
    world_lights_surfaces: bool = True
    motion: Motion | None = None

    def __post_init__(self):
        object.__setattr__(self, "lights", tuple(self.lights))
        object.__setattr__(self, "meshes", tuple(self.meshes))
        object.__setattr__(self, "media", tuple(m for m in self.media if m is not None))

    @cached_property
    def solids_key(self) -> str:
        """What shadow maps depend on: the shapes of the meshes that cast shadows."""
        return _digest(*[m.shape_key for m in self.shadow_casters])

    @property
    def background(self) -> RGB | Environment:
        """The world radiance seen where no solid is (with an opaque film): a constant, or the
        environment by direction."""
        if self.world is None and self.environment is not None:
            return self.environment
        return tuple(float(c) for c in (self.ambient if self.world is None else self.world))

    @property
    def camera_meshes(self) -> tuple[Mesh, ...]:
        """The meshes the camera sees (holdouts included)."""
        return tuple(m for m in self.meshes if m.visible_camera)

    @property
    def shadow_casters(self) -> tuple[Mesh, ...]:
        """The meshes in the lights' shadow maps."""
        return tuple(m for m in self.meshes if m.cast_shadow)

