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
``resolution_max`` on the longest side (at least 4 voxels a side), then the object's matrix.
"""

from __future__ import annotations

import os

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


def base_resolution(size: np.ndarray, resolution_max: int) -> np.ndarray:
    """Voxels per axis of a domain of local ``size`` (Blender's rule: ``resolution_max`` on the
    longest side, the others in proportion, rounded, at least 4)."""
    size = np.asarray(size, dtype=np.float64)
    longest = int(np.argmax(size))
    scale = resolution_max / size[longest]
    res = np.maximum((size * scale + 0.5).astype(int), 4)
    res[longest] = resolution_max
    return res


def domain_index_to_object(corner_min, corner_max, resolution_max: int) -> np.ndarray:
    """Matrix from a domain's voxel index to its object space."""
    lo, hi = np.asarray(corner_min, np.float64), np.asarray(corner_max, np.float64)
    cell = (hi - lo) / base_resolution(hi - lo, resolution_max)
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
    path = cache_file(directory, frame)
    if not os.path.isfile(path):
        raise FluidCacheMissing(f"Fluid domain '{label}': no baked data for frame {frame} in cache "
                                f"folder '{directory}' (expected {os.path.relpath(path, directory)})")
    if settings.use_noise:
        warnings.append(f"Fluid domain '{label}': the noise (high resolution) cache is not read; "
                        f"rendering the base resolution")
    if settings.use_adaptive_domain:
        warnings.append(f"Fluid domain '{label}': the adaptive domain's offset is not read; the smoke "
                        f"may be placed wrongly")
    grid = cache.read_path(path, "density", label, _CACHE_GRIDS)
    mesh = ob.original.data
    corners = np.empty(len(mesh.vertices) * 3, dtype=np.float64)
    mesh.vertices.foreach_get("co", corners)
    corners = corners.reshape(-1, 3)
    to_object = domain_index_to_object(corners.min(axis=0), corners.max(axis=0), settings.resolution_max)
    # The file's voxel index ijk is the domain's voxel index (its transform is a voxel size only).
    shift = np.eye(4)
    shift[:3, 3] = grid.first_index
    attributes = render_attributes(grid.extras, grid.density, float(settings.flame_ignition),
                                   float(settings.flame_max_temp))
    # Cycles draws a domain by its cube: voxels 0 .. res - 1 of the domain, centres at integers.
    res = base_resolution(corners.max(axis=0) - corners.min(axis=0), settings.resolution_max)
    first = np.asarray(grid.first_index, np.float64)
    bounds = (tuple(-0.5 - first), tuple(np.asarray(res, np.float64) - 0.5 - first))
    placed = DensityGrid(density=grid.density, index_to_object=to_object @ shift, grid_name="density",
                         extras={k: v for k, v in attributes.items() if k in wanted},
                         key=grid.key + f"|fluid {settings.flame_ignition} {settings.flame_max_temp}",
                         warnings=grid.warnings, first_index=grid.first_index, bounds=bounds)
    return placed, attributes, warnings
