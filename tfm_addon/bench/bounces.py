"""Multiple scattering against Cycles with volume bounces: media, references, comparison.

Runs inside a process that imported ``bpy``. Each medium is a small scene built as the
conformance suite builds its rows (``conformance.base``: camera at 64x48, black World, grey ground,
a light), rendered by Cycles with ``volume_bounces = N`` (and ``max_bounces = N``; every other
bounce kind 0, BLENDER.md's film settings) and by TFM with the same bounce count.

``FIT`` are the media the octave constants (``engine/multiple_scattering.py``) were fitted on;
``HELD_OUT`` the media they were not fitted on, whose error the docs report.

References: ``scripts/make_bounce_refs.py`` stores ``tests/data/bounces/<medium>_<N>.npz``;
``scripts/fit_octaves.py`` fits the constants; ``tests/blender/test_multiple_scattering.py``
checks held-out media.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from . import conformance as cf

REF_DIR = Path(__file__).resolve().parents[2] / "tests" / "data" / "bounces"


def _puff(tmpdir: str, *, density: float, color: float, light: str = 'POINT', anisotropy: float = 0.0,
          light_at=None) -> None:
    mat, nt, out = cf.material()
    cf.principled(nt, out, Density=density, Color=(color, color, color, 1.0), Anisotropy=anisotropy)
    cf.base(lights=light if light_at is None else None)
    if light_at is not None:
        cf.light(light, location=light_at)
    cf.volume_object(tmpdir, mat=mat)


def _noise_cloud(tmpdir: str, *, density: float, color: float, light: str | None = 'POINT',
                 world=(0.0, 0.0, 0.0), anisotropy: float = 0.0, light_at=None) -> None:
    mat, nt, out = cf.material("Cloud")
    pv = cf.principled(nt, out, **{"Density Attribute": "", "Color": (color, color, color, 1.0),
                                   "Anisotropy": anisotropy})
    coords = nt.nodes.new('ShaderNodeTexCoord')
    tex = nt.nodes.new('ShaderNodeTexNoise')
    nt.links.new(coords.outputs["Object"], tex.inputs["Vector"])
    mr = nt.nodes.new('ShaderNodeMapRange')
    mr.inputs["From Min"].default_value = 0.45
    mr.inputs["From Max"].default_value = 0.7
    mr.inputs["To Max"].default_value = density
    nt.links.new(tex.outputs["Fac"], mr.inputs["Value"])
    nt.links.new(mr.outputs["Result"], pv.inputs["Density"])
    cf.base(lights=light if light_at is None else None, world=world)
    if light_at is not None:
        cf.light(light, location=light_at)
    cf.cube_medium(mat)


def cumulus_grid(n: int = 64, *, noise_scale: float = 2.0, detail: float = 1.0,
                 ramp=(0.95, 1.35)) -> np.ndarray:
    """A cumulus-like density in [0, 1] on n^3 voxels: Blender's Noise Texture (engine/textures.py,
    the same function) plus a spherical Gradient, over [-1, 1]^3, through a clamped Map Range
    ``ramp`` -> 0..1."""
    from ..engine import textures

    x = np.linspace(-1.0, 1.0, n)
    p = np.stack(np.meshgrid(x, x, x, indexing="ij"), axis=-1).reshape(-1, 3)
    value = textures.noise(p, scale=noise_scale, detail=detail, color=False)[0] + textures.gradient(
        p, 'SPHERICAL')
    return np.clip((value - ramp[0]) / (ramp[1] - ramp[0]), 0.0, 1.0).reshape(n, n, n).astype(np.float32)


def _production_cloud(tmpdir: str, *, density: float, size: float = 40.0, **shape) -> None:
    """A white cloud ``size`` metres wide (a .vdb written here from ``cumulus_grid``) under a sun,
    ``density`` per metre at its densest; the conformance scene (camera, ground) scaled by
    size / 2 m around it, the camera nearer by half."""
    import bpy

    scale = size / 2.0
    mat, nt, out = cf.material("Cumulus")
    cf.principled(nt, out, Density=density, Color=(1.0, 1.0, 1.0, 1.0))
    cf.base(lights='SUN')
    grid = cumulus_grid(**shape)
    cf.volume_object(tmpdir, "Cumulus", {"density": grid}, mat=mat, voxel=size / (grid.shape[0] - 1))
    cam = bpy.context.scene.camera
    cam.location = cam.location * (0.5 * scale)
    cam.data.clip_end = 1000.0
    ground = bpy.data.objects["Plane"]
    ground.location = ground.location * scale
    ground.scale = (scale,) * 3


def _glowing_smoke(tmpdir: str, *, density: float, color: float, glow: float = 6.0,
                   light: str | None = None) -> None:
    """A smoke puff that glows in its dense core (Emission Strength from the density through a Map
    Range up to ``glow``), lit by ``light`` (None: nothing else, a black world). What lights the
    smoke around the core is its own emission, scattered (Cycles scatters it at every bounce
    count)."""
    mat, nt, out = cf.material("Glow")
    pv = cf.principled(nt, out, Density=density, Color=(color, color, color, 1.0),
                       **{"Emission Color": (1.0, 0.5, 0.15, 1.0)})
    mr = nt.nodes.new('ShaderNodeMapRange')
    mr.inputs["From Min"].default_value = 1.6
    mr.inputs["From Max"].default_value = 2.6
    mr.inputs["To Max"].default_value = glow
    nt.links.new(cf.attribute(nt).outputs["Fac"], mr.inputs["Value"])
    nt.links.new(mr.outputs["Result"], pv.inputs["Emission Strength"])
    cf.base(lights=light)
    cf.volume_object(tmpdir, mat=mat)


def _fog(tmpdir: str, *, density: float, color: float, light: str = 'POINT') -> None:
    mat, nt, out = cf.material("Fog")
    cf.principled(nt, out, Density=density, Color=(color, color, color, 1.0))
    cf.base(lights=light)
    cf.cube_medium(mat)


# name: (builder, title, albedo). Densities are Principled Volume Density (the puff's grid peaks
# at 2.5, the noise cloud's Map Range at the density given); Color is the scattering albedo.
MEDIA: dict[str, tuple[Callable[[str], None], str, float]] = {
    "thin_smoke": (lambda d: _puff(d, density=0.4, color=0.8),
                   "smoke puff, Density 0.4, Color 0.8 (optical depth through the middle ~1)", 0.8),
    "thick_smoke": (lambda d: _puff(d, density=4.0, color=0.8),
                    "smoke puff, Density 4, Color 0.8 (optical depth ~10)", 0.8),
    "cloud": (lambda d: _noise_cloud(d, density=3.0, color=1.0),
              "noise cloud (Noise Texture → Map Range 0–3), white (albedo 1)", 1.0),
    "fog_box": (lambda d: _fog(d, density=0.8, color=0.9), "2 m fog box, Density 0.8, Color 0.9", 0.9),
    "dense_smoke": (lambda d: _puff(d, density=12.0, color=1.0),
                    "smoke puff, Density 12, white (optical depth ~30), point light", 1.0),
    "dark_smoke": (lambda d: _puff(d, density=6.0, color=0.5),
                   "smoke puff, Density 6, Color 0.5 (optical depth ~15), point light", 0.5),
    "cloud_sun": (lambda d: _noise_cloud(d, density=3.0, color=1.0, light='SUN'),
                  "noise cloud, Map Range 0–3, white, lit by a sun", 1.0),
    # held out
    "white_smoke": (lambda d: _puff(d, density=1.5, color=1.0),
                    "smoke puff, Density 1.5, white (albedo 1), point light", 1.0),
    "dense_cloud_sun": (lambda d: _noise_cloud(d, density=8.0, color=1.0, light='SUN'),
                        "noise cloud, Map Range 0–8, white, lit by a sun", 1.0),
    "grey_smoke_spot": (lambda d: _puff(d, density=2.0, color=0.6, light='SPOT'),
                        "smoke puff, Density 2, Color 0.6, spot light", 0.6),
    "fog_sun": (lambda d: _fog(d, density=1.5, color=1.0, light='SUN'),
                "2 m fog box, Density 1.5, white, lit by a sun", 1.0),
    "cumulus": (lambda d: _production_cloud(d, density=12.0),
                "40 m cloud (a 64^3 .vdb of noise rounded by a spherical gradient), white, up to "
                "Density 12 (optical depths of tens to hundreds), lit by a sun", 1.0),
    "glowing_smoke": (lambda d: _glowing_smoke(d, density=1.5, color=0.9),
                      "smoke puff, Density 1.5, Color 0.9, its core emitting (Emission Strength up to "
                      "6, orange), no lamp: lit by its own emission", 0.9),
    "cloud_sun_forward": (lambda d: _noise_cloud(d, density=3.0, color=1.0, light='SUN', anisotropy=0.6),
                          "noise cloud, Map Range 0–3, white, Anisotropy 0.6 (forward), lit by a sun", 1.0),
    "cloud_backlit": (lambda d: _noise_cloud(d, density=3.0, color=1.0, light='SUN', anisotropy=0.6,
                                             light_at=(0.8, 4.0, 2.0)),
                      "noise cloud, Map Range 0–3, white, Anisotropy 0.6, lit by a sun from behind", 1.0),
    "smoke_forward": (lambda d: _puff(d, density=2.5, color=0.9, anisotropy=0.5, light_at=(-1.5, 3.0, 2.5)),
                      "smoke puff, Density 2.5, Color 0.9, Anisotropy 0.5, a point light behind it", 0.9),
    "smoke_area": (lambda d: _puff(d, density=2.5, color=0.9, light='AREA'),
                   "smoke puff, Density 2.5, Color 0.9, an area light (1 m square, soft shadows)", 0.9),
    "cloud_sky": (lambda d: _noise_cloud(d, density=3.0, color=1.0, light=None, world=(0.4, 0.5, 0.7)),
                  "noise cloud, Map Range 0–3, white, lit by the world alone (a blue-grey sky, "
                  "World Color (0.4, 0.5, 0.7)), no lamp", 1.0),
    "glowing_smoke_sun": (lambda d: _glowing_smoke(d, density=3.0, color=0.7, glow=12.0, light='SUN'),
                          "smoke puff, Density 3, Color 0.7, its core emitting (up to 12, orange), "
                          "lit by a sun too", 0.7),
}
FIT = ("thin_smoke", "thick_smoke", "cloud", "fog_box", "dense_smoke", "dark_smoke", "cloud_sun",
       "glowing_smoke", "cloud_sun_forward", "cloud_backlit")
HELD_OUT = ("white_smoke", "dense_cloud_sun", "grey_smoke_spot", "fog_sun", "cumulus", "glowing_smoke_sun",
            "cloud_sky", "smoke_area", "smoke_forward")
# the media that scatter anisotropically (the octaves' anisotropy factor c changes their images)
ANISOTROPIC = ("cloud_sun_forward", "cloud_backlit", "smoke_forward")


def build(medium: str, tmpdir: str, bounces: int) -> None:
    """An empty scene holding ``medium``, with Cycles' Volume Bounces set to ``bounces`` (what
    TFM reads)."""
    import bpy

    cf.reset()
    os.makedirs(tmpdir, exist_ok=True)
    MEDIA[medium][0](tmpdir)
    bpy.context.scene.cycles.volume_bounces = bounces


def cycles_with_bounces(bl_scene, bounces: int, samples: int) -> None:
    """BLENDER.md's single-scattering settings but ``volume_bounces`` (and ``max_bounces``) N."""
    from ..blender.scene_builder import cycles_single_scattering

    cycles_single_scattering(bl_scene, samples=samples)
    bl_scene.cycles.volume_bounces = bounces
    bl_scene.cycles.max_bounces = bounces


def render_cycles(medium: str, bounces: int, tmpdir: str, samples: int,
                  seed: int) -> tuple[np.ndarray, float]:
    import bpy

    build(medium, tmpdir, bounces)
    scene = bpy.context.scene
    cycles_with_bounces(scene, bounces, samples)
    scene.cycles.seed = seed
    t0 = time.perf_counter()
    bpy.ops.render.render()
    seconds = time.perf_counter() - t0
    return cf._read_render(tmpdir, f"{medium}_{bounces}_cycles_{seed}"), seconds


def reference_path(medium: str, bounces: int, directory: Path = REF_DIR) -> Path:
    return directory / f"{medium}_{bounces}.npz"


def stored_counts(medium: str, directory: Path = REF_DIR) -> tuple[int, ...]:
    """The bounce counts above 0 with a stored reference of ``medium``, in order."""
    counts = {p.stem[len(medium) + 1:] for p in directory.glob(f"{medium}_*.npz")}
    return tuple(sorted(int(c) for c in counts if c.isdigit() and int(c) > 0))


def load_reference(medium: str, bounces: int, directory: Path = REF_DIR) -> tuple[np.ndarray, dict]:
    """The stored Cycles reference at ``bounces``: (h, w, 3) float32 and its metadata."""
    return cf.load_reference(reference_path(medium, bounces, directory).stem, directory)


def render_tfm(medium: str, bounces: int, tmpdir: str, samples: int = cf.TFM_SAMPLES) -> cf.TfmResult:
    """``medium`` rendered by TFM at the add-on's defaults, reading Volume Bounces ``bounces``."""
    import bpy

    build(medium, tmpdir, bounces)
    scene = bpy.context.scene
    scene.render.engine = 'TFM'
    scene.render.film_transparent = True
    scene.tfm.samples = samples
    fr = cf.final_render_module()
    t0 = time.perf_counter()
    bpy.ops.render.render()
    seconds = time.perf_counter() - t0
    return cf.TfmResult(cf._read_render(tmpdir, f"{medium}_{bounces}_tfm"), seconds,
                        [m for _, m in fr.last_messages])
