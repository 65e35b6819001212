"""Sizes of a benchmark run: ``QUICK`` (the tests), ``FULL`` (this 2-core llvmpipe machine, under an
hour) and ``GPU`` (the paper's 1280x720 with 1024^2 maps, renderer only, no Blender)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Config:
    name: str
    width: int                     # method table images
    height: int
    cloud_width: int               # the cloud may render smaller (its grid keeps its size)
    cloud_height: int
    smoke_n: int
    suzanne_n: int
    cloud_shape: tuple[int, int, int]
    map_resolution: int
    repeats: int                   # timed repetitions per method (after one warm-up)
    ground_truth: str              # 'numpy' (CPU double march) or 'brute force' (GPU, many steps)
    gt_steps_per_voxel: float      # ground-truth steps per voxel crossed (view and light)
    gt_min_steps: int
    gt_max_steps: int
    gt_homogeneous_steps: int      # view steps of the ground truth in a homogeneous medium
    brute_force_steps: tuple[int, ...]
    homogeneous_steps: tuple[int, ...]
    # Sweeps
    sweep: bool
    sweep_width: int
    sweep_height: int
    sweep_smoke_n: int
    sweep_suzanne_n: int
    sweep_taus: tuple[float, ...]
    sweep_alphas: tuple[float, ...]
    sweep_angles_deg: tuple[float, ...]
    sweep_angle_steps: tuple[int, ...]
    sweep_steps: tuple[int, ...]
    # Paper's Table 1
    table1: bool
    # Blender (Cycles, EEVEE), in a subprocess
    blender: bool
    blender_width: int
    blender_height: int
    blender_smoke_n: int
    cycles_samples: tuple[int, ...]
    cycles_gt_samples: int
    eevee_runs: tuple[tuple[str, int], ...]   # (preset, TAA render samples)
    caps: tuple[str, ...] = field(default=())  # what was capped, said in the output


QUICK = Config(
    name="quick", width=96, height=54, cloud_width=96, cloud_height=54,
    smoke_n=32, suzanne_n=64, cloud_shape=(150, 100, 50), map_resolution=64, repeats=1,
    ground_truth="numpy", gt_steps_per_voxel=1.0, gt_min_steps=64, gt_max_steps=128,
    gt_homogeneous_steps=256,
    brute_force_steps=(25, 100), homogeneous_steps=(16, 64),
    sweep=True, sweep_width=64, sweep_height=36, sweep_smoke_n=32, sweep_suzanne_n=64,
    sweep_taus=(1.0, 16.0), sweep_alphas=(1.0, 16.0, 4096.0), sweep_angles_deg=(10.0, 90.0),
    sweep_angle_steps=(16,), sweep_steps=(16, 64),
    table1=True,
    blender=True, blender_width=64, blender_height=36, blender_smoke_n=32,
    cycles_samples=(4, 16, 64), cycles_gt_samples=256, eevee_runs=(("default", 1), ("high", 1)),
    caps=("quick run: grids 32^3 smoke, 64^3 Suzanne, 150x100x50 cloud (not the full run's sizes)",
          "Cycles ground truth 256 samples, EEVEE 1 TAA sample"),
)

FULL = Config(
    name="full", width=320, height=180, cloud_width=320, cloud_height=180,
    smoke_n=128, suzanne_n=256, cloud_shape=(600, 400, 200), map_resolution=256, repeats=3,
    ground_truth="numpy", gt_steps_per_voxel=1.0, gt_min_steps=128, gt_max_steps=512,
    gt_homogeneous_steps=1024,
    brute_force_steps=(25, 50, 100, 200), homogeneous_steps=(8, 16, 32, 64, 128),
    sweep=True, sweep_width=160, sweep_height=90, sweep_smoke_n=128, sweep_suzanne_n=256,
    sweep_taus=(0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0),
    sweep_alphas=(1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 512.0, 2048.0, 8192.0, 32768.0, 131072.0),
    sweep_angles_deg=(5.0, 20.0, 40.0, 60.0, 90.0, 120.0, 150.0, 170.0),
    sweep_angle_steps=(16, 32), sweep_steps=(16, 32, 64, 128, 256),
    table1=True,
    blender=True, blender_width=160, blender_height=90, blender_smoke_n=128,
    cycles_samples=(16, 64, 256, 1024), cycles_gt_samples=4096,
    eevee_runs=(("default", 1), ("default", 64), ("high", 1), ("high", 16)),
    caps=("shadow maps and TFMs 256^2 (the paper: 1024^2); images 320x180 (the paper: 1280x720)",
          "Cycles at 160x90, ground truth 4096 samples; EEVEE 'high' capped at 16 TAA samples "
          "(Blender's default 64)"),
)

GPU = Config(
    name="gpu", width=1280, height=720, cloud_width=1280, cloud_height=720,
    smoke_n=128, suzanne_n=256, cloud_shape=(600, 400, 200), map_resolution=1024, repeats=5,
    ground_truth="brute force", gt_steps_per_voxel=1.0, gt_min_steps=128, gt_max_steps=512,
    gt_homogeneous_steps=1024,
    brute_force_steps=(25, 50, 100, 200), homogeneous_steps=(8, 16, 32, 64, 128),
    sweep=False, sweep_width=320, sweep_height=180, sweep_smoke_n=128, sweep_suzanne_n=256,
    sweep_taus=(), sweep_alphas=(), sweep_angles_deg=(), sweep_angle_steps=(), sweep_steps=(),
    table1=True,
    blender=False, blender_width=0, blender_height=0, blender_smoke_n=0,
    cycles_samples=(), cycles_gt_samples=0, eevee_runs=(),
    caps=("GPU run: no numpy reference (too slow at 1280x720); the ground truth is the GPU brute "
          "force at one step per voxel crossed", "no Blender"),
)

CONFIGS = {c.name: c for c in (QUICK, FULL, GPU)}
