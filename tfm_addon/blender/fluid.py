"""Mantaflow smoke and fire domains, read from their baked OpenVDB cache files.

The engine never asks Blender for a domain's voxels (``domain_settings.density_grid`` and the
other grid properties): it reads the cache Mantaflow wrote, in Blender's layout
(``<cache_directory>/data/fluid_data_####.vdb``, frame zero-padded to four digits, every grid of
the frame in one file when ``cache_data_format`` is 'OPENVDB'), and maps the grids to the
attributes Cycles' shaders see, as Blender's RNA getters do:

==============  ==========================================================================
attribute        from the cache
==============  ==========================================================================
density          ``density``
flame            ``flame``
heat             ``temperature`` (Mantaflow's heat) x 0.5
temperature      ``flame_ignition + flame * (flame_max_temp - flame_ignition)`` where flame
                 > 0.01, else 0 (units of 1000 K: the Principled Volume's Temperature
                 1000 K times it gives kelvin)
color            (``color_r``, ``color_g``, ``color_b``): the cache's own colour, where the
                 density is above 1e-6 (else the colour x density, about 0)
==============  ==========================================================================

Blender hands Cycles a domain's colour premultiplied, (color_r * density, ..., density), and
Cycles un-premultiplies it after its lookup (``volume_attribute_value_to_float3`` in
``intern/cycles/kernel/geom/volume.h``: divided by the alpha where it is above 1e-6 and not 1).
Cycles 5 looks each attribute up at one voxel drawn with the trilinear weights, so what a render
converges to is the trilinear blend of each voxel's un-premultiplied colour: the cache's colour
per voxel, which the engine blends like any colour grid.

Voxel i of the domain sits at the domain's local p0 + (i + 0.5) * cell_size, p0 the minimum of
the domain mesh's local bounding box, cell_size = (p1 - p0) / base_res with base_res derived from
``resolution_max`` on the longest side (at least 4 voxels a side), then the object's matrix. An
adaptive domain (``use_adaptive_domain``) holds res_max - res_min voxels from the frame's
configuration file, placed over the box Blender draws it as (``adaptive_index_to_object``). The
frame read is the scene's frame less ``cache_frame_offset`` (``data_frame``).
"""

from __future__ import annotations

import dataclasses
import gzip
import os
import struct

import numpy as np

from .volumes import DensityGrid, GridCache, VolumeReadError


class FluidCacheMissing(VolumeReadError):
    """A domain without cache data for the frame (not baked, or another folder)."""


def domain_modifier(ob, render: bool | None = None):
    """The Fluid modifier of ``ob`` when it is a gas (smoke / fire) domain enabled for the final
    render (``render`` True) or the viewport (False), else None; ``render`` None: either."""
    original = ob.original if ob.original is not None else ob
    for m in original.modifiers:
        if m.type == 'FLUID' and m.fluid_type == 'DOMAIN' and m.domain_settings is not None:
            enabled = {None: True, True: m.show_render, False: m.show_viewport}[render]
            if m.domain_settings.domain_type == 'GAS' and enabled:
                return m
    return None


def cache_file(directory: str, frame: int) -> str:
    """Where Mantaflow keeps a frame's grids."""
    return os.path.join(directory, "data", f"fluid_data_{int(frame):04d}.vdb")


def noise_file(directory: str, frame: int) -> str:
    """Where Mantaflow keeps a frame's noise (high resolution) grids: density_noise, flame_noise,
    color_r_noise..., ``noise_scale`` times the domain's resolution."""
    return os.path.join(directory, "noise", f"fluid_noise_{int(frame):04d}.vdb")


def config_file(directory: str, frame: int) -> str:
    """Where Mantaflow keeps a frame's domain configuration (gzip, MANTA::writeConfiguration)."""
    return os.path.join(directory, "config", f"config_{int(frame):04d}.uni")


# MANTA::writeConfiguration (intern/mantaflow/intern/MANTA_main.cpp), native byte order: active
# fields, res, dx, dt, p0, p1, dp0, shift, obj_shift_f, obmat (4x4, columns), base_res, res_min,
# res_max, active_color, time_total, cache version.
_CONFIG = struct.Struct("<i3iff3f3f3f3i3f16f3i3i3i3fi4s")
_CONFIG_FIELDS = (("active_fields", 1), ("res", 3), ("dx", 1), ("dt", 1), ("p0", 3), ("p1", 3),
                  ("dp0", 3), ("shift", 3), ("obj_shift_f", 3), ("obmat", 16), ("base_res", 3),
                  ("res_min", 3), ("res_max", 3), ("active_color", 3), ("time_total", 1),
                  ("version", 1))


def read_config(path: str) -> dict:
    """A frame's domain configuration as Mantaflow wrote it: lists of numbers by field name (single
    values unwrapped), ``obmat`` as a 4x4 array (rows, translation in the last column)."""
    with gzip.open(path, "rb") as f:
        raw = f.read(_CONFIG.size)
    values = list(_CONFIG.unpack(raw))
    out, i = {}, 0
    for name, n in _CONFIG_FIELDS:
        out[name] = values[i] if n == 1 else list(values[i:i + n])
        i += n
    out["obmat"] = np.asarray(out["obmat"], np.float64).reshape(4, 4).T   # Blender's m[column][row]
    return out


def write_config(path: str, *, res, p0, p1, base_res, res_min, res_max, obmat=None, dx: float = 0.0,
                 active_fields: int = 0, shift=(0, 0, 0), dp0=None) -> str:
    """Write a domain configuration in Mantaflow's layout (tests, demos: baking does not run in the
    bpy module). ``obmat``: the domain's matrix when it was baked (default identity)."""
    m = np.eye(4) if obmat is None else np.asarray(obmat, np.float64)
    values = [int(active_fields), *map(int, res), float(dx), 0.0, *map(float, p0), *map(float, p1),
              *map(float, p0 if dp0 is None else dp0), *map(int, shift), 0.0, 0.0, 0.0,
              *m.T.ravel().tolist(), *map(int, base_res), *map(int, res_min), *map(int, res_max),
              0.0, 0.0, 0.0, 0, b"0.10"]
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with gzip.open(path, "wb") as f:
        f.write(_CONFIG.pack(*values))
    return path


def which_frame(frame: int, cached: int) -> str:
    """A scene frame and, where they differ, the cache frame it reads, for messages."""
    return f"frame {frame}" if cached == frame else f"frame {frame} (cache frame {cached})"


def data_frame(settings, frame: int) -> int:
    """The cache frame Blender reads at scene ``frame``: the frame less the domain's
    ``cache_frame_offset`` for a baked cache (All, Modular); Replay reads the frame itself
    (``fluid_modifier_processDomain`` in blenkernel/intern/fluid.cc)."""
    if getattr(settings, "cache_type", 'ALL') == 'REPLAY':
        return int(frame)
    return int(frame) - int(getattr(settings, "cache_frame_offset", 0))


def adaptive_index_to_object(config: dict, matrix_world, upres: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """An adaptive domain's voxel index to its object space, and its resolution: Blender draws the
    domain as the box p0 + cell_size * res_min .. p0 + cell_size * res_max (``create_smoke_geometry``
    in fluid.cc, p0 and the resolutions from the frame's configuration, cell_size = (p1 - p0) /
    base_res), moved by the domain's move since the bake, and Cycles spreads the res_max - res_min
    voxels over that box (``upres`` times as many of the noise grids)."""
    p0, p1 = np.asarray(config["p0"], np.float64), np.asarray(config["p1"], np.float64)
    base = np.maximum(np.asarray(config["base_res"], np.float64), 1.0)
    cell = (p1 - p0) / base
    lo = p0 + cell * np.asarray(config["res_min"], np.float64)
    res = (np.asarray(config["res_max"], np.int64) - np.asarray(config["res_min"], np.int64)) * int(upres)
    cell = cell / int(upres)
    # obj_shift_f: the bake-time location less the current one, in the object's local axes
    m = np.asarray(matrix_world, np.float64)
    shift_world = np.asarray(config["obmat"], np.float64)[:3, 3] - m[:3, 3]
    try:
        lo = lo + np.linalg.solve(m[:3, :3], shift_world)
    except np.linalg.LinAlgError:
        pass
    to_object = np.diag([*cell, 1.0])
    to_object[:3, 3] = lo + 0.5 * cell
    return to_object, res


def base_resolution(size: np.ndarray, resolution_max: int) -> np.ndarray:
    """Voxels per axis of a domain of local ``size`` (Blender's rule: ``resolution_max`` on the
    longest side, the others in proportion, rounded, at least 4)."""
    size = np.asarray(size, dtype=np.float64)
    longest = int(np.argmax(size))
    scale = resolution_max / size[longest]
    res = np.maximum((size * scale + 0.5).astype(int), 4)
    res[longest] = resolution_max
    return res


def domain_index_to_object(corner_min, corner_max, resolution_max: int, upres: int = 1) -> np.ndarray:
    """Matrix from a domain's voxel index to its object space (``upres``: the noise grids'
    factor, voxels ``upres`` times smaller)."""
    lo, hi = np.asarray(corner_min, np.float64), np.asarray(corner_max, np.float64)
    cell = (hi - lo) / base_resolution(hi - lo, resolution_max) / int(upres)
    m = np.diag([*cell, 1.0])
    m[:3, 3] = lo + 0.5 * cell
    return m


def render_attributes(raw: dict[str, np.ndarray], density: np.ndarray, ignition: float,
                      max_temp: float) -> dict[str, np.ndarray]:
    """The attributes Cycles' shaders read, from the cache's grids (see the module's table)."""
    out = {}
    if "flame" in raw:
        flame = raw["flame"]
        out["flame"] = flame
        out["temperature"] = np.where(flame > 0.01, ignition + flame * (max_temp - ignition),
                                      0.0).astype(np.float32)
    if "temperature" in raw:
        out["heat"] = (raw["temperature"] * 0.5).astype(np.float32)
    if all(f"color_{c}" in raw for c in "rgb"):
        # Cycles' (c d, d) un-premultiplied per voxel: c where d > 1e-6, else c d (module docstring)
        d = np.asarray(density, np.float32)
        out["color"] = np.stack([np.where(d > 1e-6, raw[f"color_{c}"], raw[f"color_{c}"] * d)
                                 for c in "rgb"], axis=-1).astype(np.float32)
    return out


_CACHE_GRIDS = ("flame", "temperature", "color_r", "color_g", "color_b")


def read_domain(ob, frame: int, cache: GridCache, wanted: tuple[str, ...], label: str
                ) -> tuple[DensityGrid, dict[str, np.ndarray], list[str]]:
    """A domain's density (on a DensityGrid whose ``index_to_object`` is in the domain object's
    space), the render attributes named in ``wanted`` and warnings. Raises FluidCacheMissing /
    VolumeReadError with a message naming the cache folder."""
    import bpy

    modifier = domain_modifier(ob)
    settings = modifier.domain_settings
    directory = os.path.normpath(bpy.path.abspath(settings.cache_directory))
    warnings = []
    if settings.cache_data_format != 'OPENVDB':
        raise VolumeReadError(f"Fluid domain '{label}': cache format {settings.cache_data_format} is "
                              f"not read (only OpenVDB); cache folder '{directory}'")
    cached = data_frame(settings, frame)
    path = cache_file(directory, cached)
    if not os.path.isfile(path):
        which = which_frame(frame, cached)
        raise FluidCacheMissing(f"Fluid domain '{label}': no baked data for {which} in cache "
                                f"folder '{directory}' (expected {os.path.relpath(path, directory)})")
    upres = 1
    grid = None
    if settings.use_noise:           # Blender renders the noise grids where the domain has them
        npath = noise_file(directory, cached)
        if os.path.isfile(npath):
            upres = max(1, int(settings.noise_scale))
            noise = cache.read_path(npath, "density_noise", label, tuple(f"{g}_noise" for g in _CACHE_GRIDS))
            grid = dataclasses.replace(noise, extras={k.removesuffix("_noise"): v
                                                      for k, v in noise.extras.items()})
        else:
            warnings.append(f"Fluid domain '{label}': no noise cache for {which_frame(frame, cached)} "
                            f"('{npath}'); rendering the base resolution")
    if grid is None:
        grid = cache.read_path(path, "density", label, _CACHE_GRIDS)
    mesh = ob.original.data
    corners = np.empty(len(mesh.vertices) * 3, dtype=np.float64)
    mesh.vertices.foreach_get("co", corners)
    corners = corners.reshape(-1, 3)
    to_object = domain_index_to_object(corners.min(axis=0), corners.max(axis=0), settings.resolution_max,
                                       upres)
    # Cycles draws a domain by its cube: voxels 0 .. res - 1 of the domain, centres at integers.
    res = base_resolution(corners.max(axis=0) - corners.min(axis=0), settings.resolution_max) * upres
    key = grid.key + f"|fluid {settings.flame_ignition} {settings.flame_max_temp}"
    if settings.use_adaptive_domain:
        config_path = config_file(directory, cached)
        try:
            config = read_config(config_path)
        except (OSError, EOFError, struct.error) as ex:
            warnings.append(f"Fluid domain '{label}': the adaptive domain's configuration "
                            f"'{config_path}' cannot be read ({ex}); the smoke is placed as in a "
                            f"domain that does not adapt")
        else:
            to_object, res = adaptive_index_to_object(config, ob.matrix_world, upres)
            key += f"|adaptive {config['res_min']} {config['res_max']}"
    # The file's voxel index ijk is the domain's voxel index (its transform is a voxel size only).
    shift = np.eye(4)
    shift[:3, 3] = grid.first_index
    attributes = render_attributes(grid.extras, grid.density, float(settings.flame_ignition),
                                   float(settings.flame_max_temp))
    first = np.asarray(grid.first_index, np.float64)
    bounds = (tuple(-0.5 - first), tuple(np.asarray(res, np.float64) - 0.5 - first))
    placed = DensityGrid(density=grid.density, index_to_object=to_object @ shift, grid_name="density",
                         extras={k: v for k, v in attributes.items() if k in wanted},
                         key=key, warnings=grid.warnings, first_index=grid.first_index, bounds=bounds)
    return placed, attributes, warnings
