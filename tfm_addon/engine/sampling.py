"""Antialiasing by samples: subpixel jitter with a one-pixel box filter, a jittered view-march
start, and the running mean of the samples.

Sample k of every frame uses the same offsets (they depend on k alone), so frames rendered by
different processes, in any order, are equal bit for bit. Sample 0 is the pixel centre with the
march at its interval midpoints: one sample is the unjittered image. Light maps do not depend on
the camera or the march offset, so the renderer builds them once for all the samples of a frame.
From ADAPTIVE_FRAME_SAMPLES (12) samples on the sampling is adaptive (adaptive.py): the pixels
whose first samples agree stop early, decided from the frame's own samples (still the same bits in
any process).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Iterator

import numpy as np

from .adaptive import (
    ADAPTIVE_FIRST_SAMPLES,
    ADAPTIVE_FIRST_THRESHOLD,
    ADAPTIVE_MIN_SAMPLES,
    ADAPTIVE_THRESHOLD,
    ActivePixels,
    active_pixels,
    unconverged,
)
from .camera import view_plane
from .camera_effects import lens_camera, moved_scene
from .output import RenderOutput
from .quality import medium_stats
from .renderer import Renderer, effective_settings, prepare_scene
from .scene import Camera, RenderSettings, Scene

_GOLDEN = 0.61803398874989484820  # R1, for the march start
_FRAMES = itertools.count()       # Accumulator keys

AUTO_SAMPLES = 16  # final-render samples when scene.tfm.samples is 0 (automatic)
AUTO_POINTS_PER_STEP = 3  # under AUTO: view-march points per pixel and frame, in units of AUTO's steps
MIN_VIEW_STEPS = 8
VIEW_DEPTH_PER_STEP = 0.25   # under AUTO: the largest optical depth a sample's view step may span
MANY_SAMPLES = 12        # under AUTO, a frame of at least this many samples ...
MANY_SAMPLES_COEFFICIENTS = 4   # ... takes at least this many TFM coefficients (frame_settings)
ADAPTIVE_FRAME_SAMPLES = 12  # frames of at least this many samples are adaptive (ADAPTIVE_MIN_SAMPLES + 4)


AUTO_LENS_SAMPLES = 64   # the most automatic samples a camera's depth of field asks for
AUTO_ALPHA_SAMPLES = 32  # automatic samples of a frame that shows a surface of alpha below 1


def auto_samples(camera: Camera | None, meshes=()) -> int:
    """The final render's samples when Samples is 0 (automatic): AUTO_SAMPLES; AUTO_ALPHA_SAMPLES
    where one of ``meshes`` has a surface of alpha below 1 (a pixel sees it at a whole number of
    its samples: the alpha row of the conformance suite, alpha 0.4, SSIM against Cycles 0.9769 at
    16 samples, 0.9919 at 32, 0.9969 at 64); more for a camera with depth of field. The lens
    points are shared by every pixel of a sample, so a blur of B pixels shows the sample's copies
    of the image; (B / 2)² of them (at most AUTO_LENS_SAMPLES) sit close enough to merge, B the
    blur of a point at infinity (aperture diameter / focus distance, in pixels). The f/0.25 row of
    the conformance suite (B = 15 px at 160x90): SSIM against Cycles 0.9779 at 16 samples, 0.9929
    at 32, 0.9968 at the 55 this gives."""
    alpha = any(m.shading.alpha < 1.0 and m.visible_camera and not m.holdout for m in meshes)
    least = AUTO_ALPHA_SAMPLES if alpha else AUTO_SAMPLES
    ap = None if camera is None else camera.aperture
    if ap is None or ap.radius_m <= 0.0 or camera.projection != "PERSP":
        return least
    plane = view_plane(camera)
    blur_px = 2.0 * ap.radius_m / max(ap.focus_m, 1e-6) / plane.pixel_size
    return int(max(least, min(math.ceil((blur_px / 2.0) ** 2), AUTO_LENS_SAMPLES)))


def radical_inverse(k: int, base: int) -> float:
    """``k``'s digits in ``base`` mirrored about the point: the van der Corput sequence, in [0, 1)."""
    x, f = 0.0, 1.0
    while k > 0:
        f /= base
        x += f * (k % base)
        k //= base
    return x


_MASK32 = 0xFFFFFFFF
# The seeds of the subpixel sequence's scrambles (x, y): drawn at random (Python's
# random.Random(7)), kept as the best of twelve such draws by the mean sampling error at 16-32
# samples on three scenes other than the benchmark's (docs/benchmark.md); every draw did better
# than the Halton sequence used before at 16, 20, 24 and 32 samples.
SUBPIXEL_SEEDS = (0x269E0D37, 0x6513270E)


def _reverse_bits(x: int) -> int:
    """The 32 bits of ``x`` in reverse order."""
    x = ((x >> 1) & 0x55555555) | ((x & 0x55555555) << 1)
    x = ((x >> 2) & 0x33333333) | ((x & 0x33333333) << 2)
    x = ((x >> 4) & 0x0F0F0F0F) | ((x & 0x0F0F0F0F) << 4)
    x = ((x >> 8) & 0x00FF00FF) | ((x & 0x00FF00FF) << 8)
    return ((x >> 16) | (x << 16)) & _MASK32


def _owen_scramble(x: int, seed: int) -> int:
    """A nested uniform (Owen) scramble of the 32-bit binary fraction ``x``, by Laine and
    Karras' hash on the reversed bits: each digit is flipped or not according to the digits
    above it alone, so a (t, m, 2)-net stays one."""
    x = (_reverse_bits(x) + seed) & _MASK32
    for c in (0x6C50B47C, 0xB82F1E52, 0xC7AFE638, 0x8D22F6E6):
        x ^= (x * c) & _MASK32
    return _reverse_bits(x)


def _sobol_2d(k: int) -> tuple[int, int]:
    """Point ``k`` of the first two dimensions of the Sobol sequence, as 32-bit binary fractions."""
    x, y, v = 0, 0, 1 << 31
    for bit in range(32):
        if not k >> bit:
            break
        if (k >> bit) & 1:
            x ^= 1 << (31 - bit)
            y ^= v
        v ^= v >> 1
    return x, y


_SUBPIXEL_SHIFT = tuple(_owen_scramble(0, seed) ^ (1 << 31) for seed in SUBPIXEL_SEEDS)


def subpixel_offset(k: int) -> tuple[float, float]:
    """Where sample ``k`` looks inside its pixel: (x, y) in [0, 1) pixels from the lower-left
    corner; sample 0 is the centre (0.5, 0.5). Uniform over the pixel: a one-pixel box filter.
    The first two dimensions of the Sobol sequence, Owen-scrambled with fixed seeds (the same
    offsets in every process) and moved by a digital shift (an XOR, which keeps the net property)
    so that point 0 is the centre: for every m, the first 2^m samples put one point in each of the
    2^m cells of any 2^a x 2^(m-a) grid of the pixel, and so do the later blocks of 2^m. On the
    smoke with the bar and the ground, against Cycles at 4096 spp, 12 samples score about what
    the Halton(2, 3) sequence used before needed 18 for, 16 what it needed 32 for (SSIM 0.99972
    and 0.99986; docs/benchmark.md)."""
    if k == 0:
        return 0.5, 0.5
    sx, sy = _sobol_2d(k)
    x = _owen_scramble(sx, SUBPIXEL_SEEDS[0]) ^ _SUBPIXEL_SHIFT[0]
    y = _owen_scramble(sy, SUBPIXEL_SEEDS[1]) ^ _SUBPIXEL_SHIFT[1]
    return x / 2.0**32, y / 2.0**32


# Seeds of the lens and shutter sequences: (index shuffle, x, y) and (index shuffle, t), drawn at
# random (random.Random(11)), the best of twelve draws by the largest correlation between any two
# of the subpixel, lens and shutter dimensions at 16, 64 and 256 samples (|r| sqrt(n) <= 2.2).
LENS_SEEDS = (0x28518867, 0x9F8558A6, 0x03D71684)
SHUTTER_SEEDS = (0xD4EA65D0, 0x8743FEB6)


def _shuffled_sobol(k: int, seeds: tuple[int, ...]) -> tuple[float, ...]:
    """Point ``k`` of the Sobol sequence's first len(seeds) - 1 dimensions with its index shuffled
    (a nested uniform scramble of k's bits, Burley 2020: a block of 2^m indices from a multiple of
    2^m maps to such a block, so each block still puts one point in each cell of the net) and each
    dimension Owen-scrambled, then shifted so that point 0 is the centre: sequences with other
    seeds are independent of the subpixel offsets and of each other."""
    def point(j: int) -> tuple[int, ...]:
        xy = _sobol_2d(_owen_scramble(j, seeds[0]))
        return tuple(_owen_scramble(xy[d], s) for d, s in enumerate(seeds[1:]))

    shift = tuple(p ^ (1 << 31) for p in point(0))
    return tuple((p ^ s) / 2.0**32 for p, s in zip(point(k), shift, strict=True))


def lens_sample(k: int) -> tuple[float, float]:
    """Where sample ``k`` looks through the aperture, (u, v) in [0, 1)^2; sample 0 the centre."""
    return (0.5, 0.5) if k == 0 else _shuffled_sobol(k, LENS_SEEDS)


def shutter_time(k: int) -> float:
    """When sample ``k`` is taken, as a fraction of the shutter; sample 0 its middle."""
    return 0.5 if k == 0 else _shuffled_sobol(k, SHUTTER_SEEDS)[0]


def march_offset(k: int) -> float | None:
    """The view-march start of sample ``k`` as a fraction of a step (each pixel adds its own
    hash to it), or None for sample 0 (samples at the step midpoints)."""
    return None if k == 0 else (k * _GOLDEN) % 1.0


def jittered_camera(camera: Camera, k: int) -> Camera:
    """``camera`` with its image window moved by sample ``k``'s subpixel offset (through the lens
    shift, which moves the window by whole-image fractions for either projection)."""
    if k == 0:
        return camera
    ox, oy = subpixel_offset(k)
    w, h = camera.width_px, camera.height_px
    fit = camera.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if w >= h else "VERTICAL"
    viewfac = w if fit == "HORIZONTAL" else h
    return dataclasses.replace(camera, shift_x=camera.shift_x + (ox - 0.5) / viewfac,
                               shift_y=camera.shift_y + (oy - 0.5) / viewfac)


def sample_scene(scene: Scene, settings: RenderSettings, k: int) -> tuple[Scene, RenderSettings]:
    """The scene and settings of sample ``k``: its subpixel offset, lens point (depth of field),
    shutter time (motion blur) and march start."""
    scene = moved_scene(scene, shutter_time(k))
    camera = jittered_camera(scene.camera, k)
    if camera.aperture is not None:
        camera = lens_camera(camera, *lens_sample(k)) if k else dataclasses.replace(camera, aperture=None)
    return (dataclasses.replace(scene, camera=camera),
            dataclasses.replace(settings, view_jitter=march_offset(k)))


class Accumulator:
    """The float32 mean of a frame's samples (combined image and passes), per pixel over the
    samples that pixel took (adaptive sampling: ``add`` with ``active``), and the mean square of
    the combined RGBA, which the adaptive decisions read. The samples iter_samples renders are
    summed on the GPU (passes/accumulate.SampleSums, named by ``key``) and read back only when
    ``output`` or ``square_mean`` is asked for (the decisions, a progress image, the end); a
    RenderOutput with arrays is folded in with numpy (a running mean)."""

    def __init__(self):
        self.count = 0
        self.pixel_samples: np.ndarray | None = None   # (h, w) samples each pixel took
        self.active: ActivePixels | None = None        # the pixels still sampling, once decided
        self.decisions = 0                             # adaptive decisions taken (0, 1, 2)
        self.key = ("frame", next(_FRAMES))            # names the renderer's sums of this frame
        self._output: RenderOutput | None = None
        self._square_mean: np.ndarray | None = None    # (h, w, 4) float32
        self._renderer: Renderer | None = None         # holds the sums when they are newer
        self._stale = False

    @property
    def output(self) -> RenderOutput | None:
        """The mean so far (None before the first sample)."""
        return self.fetch()

    def fetch(self) -> RenderOutput | None:
        """``output``, read back from the GPU sums if they are newer (on the renderer's thread)."""
        if self._stale:
            self._read()
        return self._output

    @property
    def square_mean(self) -> np.ndarray | None:
        """(h, w, 4) float32: the mean of the combined RGBA squared, per pixel over its samples."""
        if self._stale:
            self._read()
        return self._square_mean

    def add(self, out: RenderOutput, active: np.ndarray | None = None, spread: bool = True,
            renderer: Renderer | None = None) -> None:
        """Fold one sample in; ``active`` (h, w bool, top row first): the pixels it shaded (None:
        all); the other pixels keep their mean. ``out.combined`` None: ``renderer`` added the
        sample into its sums named ``key`` (Renderer.render's ``accumulate``). ``spread`` (numpy
        path): update the mean square too."""
        self.count += 1
        if out.combined is None:
            sums = renderer.sample_sums(self.key)
            if sums is None or sums.count != self.count:
                raise RuntimeError("the frame's sample sums were released or added to by another frame")
            self._renderer, self._stale = renderer, True
            if self.pixel_samples is None:
                self.pixel_samples = np.ones(sums.size[::-1], dtype=np.int32)
                self._output = RenderOutput(combined=None, warnings=list(out.warnings),
                                            timings_s=dict(out.timings_s), chosen=dict(out.chosen))
                return
            self.pixel_samples += 1 if active is None else active
            self._merge(out)
            return
        if self._output is None:
            self._output = RenderOutput(combined=out.combined.astype(np.float32, copy=True),
                                        passes={k: v.astype(np.float32, copy=True)
                                                for k, v in out.passes.items()},
                                        warnings=list(out.warnings), timings_s=dict(out.timings_s),
                                        chosen=dict(out.chosen))
            self.pixel_samples = np.ones(out.combined.shape[:2], dtype=np.int32)
            self._square_mean = np.square(self._output.combined)
            return
        acc = self.output
        if active is None:
            self.pixel_samples += 1
            w = np.float32(1.0 / self.count)
        else:
            self.pixel_samples += active
            w = np.zeros(active.shape + (1,), dtype=np.float32)
            np.divide(np.float32(1.0), self.pixel_samples[..., None], out=w, where=active[..., None])
        if spread:
            self._square_mean += (np.square(out.combined) - self._square_mean) * w
        acc.combined += (out.combined - acc.combined) * w
        for name, image in out.passes.items():
            if name in acc.passes:
                acc.passes[name] += (image - acc.passes[name]) * w
        self._merge(out)

    def _merge(self, out: RenderOutput) -> None:
        acc = self._output
        for name, seconds in out.timings_s.items():
            acc.timings_s[name] = acc.timings_s.get(name, 0.0) + seconds
        for message in out.warnings:
            if message not in acc.warnings:
                acc.warnings.append(message)

    def _read(self) -> None:
        """The means from the renderer's sums (on its GL thread)."""
        renderer = self._renderer
        renderer.gl.check_thread()
        sums = renderer.sample_sums(self.key)
        if sums is None or sums.count != self.count:
            raise RuntimeError("the frame's sample sums were released before they were read")
        # The previous means go before the new ones are read: one copy of the frame at a time.
        self._output.combined, self._output.passes, self._square_mean = None, {}, None
        with renderer.gl.ctx:
            renderer.gl.finish()      # the GIL-free wait: the read then only copies
            total, square, passes = sums.read()
        n = self.pixel_samples[..., None].astype(np.float32)
        for image in (total, square, *passes.values()):   # in place: no second copy of the frame
            np.divide(image, n, out=image)
        self._output.combined = total
        self._output.passes = passes
        self._square_mean = square
        self._stale = False

    def snapshot(self) -> RenderOutput:
        """The mean so far, as a RenderOutput whose arrays are copies."""
        acc = self.output
        return RenderOutput(combined=acc.combined.copy(),
                            passes={k: v.copy() for k, v in acc.passes.items()},
                            warnings=list(acc.warnings), timings_s=dict(acc.timings_s),
                            chosen=dict(acc.chosen))


def view_steps_per_sample(view_steps: int, samples: int, optical_depth: float = 0.0) -> int:
    """Under AUTO, the view steps of each of ``samples`` samples: the jittered starts stratify the
    march across samples, so the frame keeps at least AUTO_POINTS_PER_STEP x ``view_steps`` points
    per pixel with fewer steps per sample (never below MIN_VIEW_STEPS, never above ``view_steps``).
    A sample's transmittance is the exponential of its own march's sum, which jitter does not
    average out where a step is optically deep: each sample keeps at least ``optical_depth`` /
    VIEW_DEPTH_PER_STEP steps (the medium's largest optical depth)."""
    if samples <= AUTO_POINTS_PER_STEP:
        return view_steps
    floor = max(MIN_VIEW_STEPS, math.ceil(optical_depth / VIEW_DEPTH_PER_STEP))
    return max(min(view_steps, floor), math.ceil(AUTO_POINTS_PER_STEP * view_steps / samples))


def frame_settings(scene: Scene, settings: RenderSettings | None, samples: int) -> RenderSettings:
    """The settings every sample of a frame renders with: the quality rule applied once, on the
    unjittered view (so that all samples march alike), and under AUTO the view steps spread over
    the samples (view_steps_per_sample) and, from MANY_SAMPLES samples on, at least
    MANY_SAMPLES_COEFFICIENTS coefficients: once the samples have averaged the edges and the march
    noise out, what is left of the error is the truncation of a 2-coefficient TFM (on the smoke
    with the bar, against Cycles at 4096 spp: SSIM 0.99973 with 2, 0.99987 with 4 at 32 samples;
    with the Sobol offsets 12 samples get there: 0.99961 with 2, 0.99972 with 4; docs/benchmark.md)."""
    settings = settings or RenderSettings()
    chosen = effective_settings(scene, settings)
    if settings.quality == "AUTO":
        stats = medium_stats(scene)
        depth = 0.0 if stats is None else stats.optical_depth
        steps = view_steps_per_sample(chosen.view_steps, samples, depth)
        chosen = dataclasses.replace(chosen, view_steps=steps)
        if samples >= MANY_SAMPLES and chosen.coefficients < MANY_SAMPLES_COEFFICIENTS:
            chosen = dataclasses.replace(chosen, coefficients=MANY_SAMPLES_COEFFICIENTS)
    return dataclasses.replace(chosen, quality="CUSTOM", frame_samples=max(int(samples), 1))


def iter_samples(renderer: Renderer, scene: Scene, settings: RenderSettings | None, samples: int,
                 cancel: Callable[[], bool] | None = None, passes: bool = True,
                 progress: Callable[[float], None] | None = None,
                 first: int = 0, accumulator: Accumulator | None = None,
                 client: str = "final",
                 adaptive_threshold: float | None = ADAPTIVE_THRESHOLD,
                 until: int | None = None,
                 whites: tuple[float | None, float | None] = (None, None)) -> Iterator[Accumulator]:
    """Render samples ``first`` .. ``samples - 1`` of ``scene`` into ``accumulator`` and yield it
    after each. ``progress`` gets the fraction of all ``samples`` done; ``cancel`` is the renderer's
    (checked between passes); ``client`` is the renderer's cache client. ``adaptive_threshold``:
    when ``samples`` is at least ADAPTIVE_FRAME_SAMPLES, adaptive sampling (engine/adaptive.py:
    after ADAPTIVE_FIRST_SAMPLES and after ADAPTIVE_MIN_SAMPLES samples, only the pixels whose
    samples still vary take more; this is the second decision's threshold); None: every pixel takes
    every sample. ``until``: stop before that sample (a tile's first samples, tiles.py);
    ``whites``: the frame's white at each decision where ``scene`` is a tile of it (None: the
    image's own). A frame whose every pixel has stopped at a decision ends there: its sample count
    is decided by its samples (never by time, so that frames rendered apart stay equal). The
    frame's GPU sums are released once the last sample is yielded: a frame continued later
    (``first``) with the same ``accumulator`` is refused."""
    n = max(int(samples), 1)
    scene = prepare_scene(scene, settings)     # node graphs evaluated once, here on the render thread
    settings = frame_settings(scene, settings, n)
    acc = accumulator or Accumulator()
    # The adaptive decisions read the first samples as the pixel's spread; with depth of field or
    # motion blur the first samples have seen only a few lens points and times (a pixel beside a
    # blurred edge is black in them and would stop): every pixel takes every sample.
    blurred = (scene.camera.aperture is not None and scene.camera.aperture.radius_m > 0.0) or scene.motion
    adaptive = adaptive_threshold is not None and n >= ADAPTIVE_FRAME_SAMPLES and not blurred
    for k in range(first, n if until is None else min(n, until)):
        if adaptive and acc.count == k:
            if k == ADAPTIVE_FIRST_SAMPLES and acc.decisions == 0:
                acc.active = active_pixels(unconverged(acc.output.combined, acc.square_mean,
                                                       ADAPTIVE_FIRST_THRESHOLD, contrast=True,
                                                       white=whites[0]))
                acc.decisions = 1
            elif k == ADAPTIVE_MIN_SAMPLES and acc.decisions == 1:
                going = unconverged(acc.output.combined, acc.square_mean, adaptive_threshold,
                                    white=whites[1])
                acc.active = active_pixels(going & acc.active.mask)
                acc.decisions = 2
        active = acc.active
        if active is not None and not active.mask.any():
            break       # every pixel has converged: the frame ends with the samples it took
        sub = None if progress is None else (lambda f, k=k: progress((k + f) / n))
        s_scene, s_settings = sample_scene(scene, settings, k)
        acc.add(renderer.render(s_scene, s_settings, cancel, sub, passes, client=client, active=active,
                                accumulate=acc.key),
                None if active is None else active.mask, spread=acc.decisions < 2, renderer=renderer)
        yield acc
    if acc.count:
        acc.fetch()           # the mean, read before the sums are released
    renderer.release_sums(acc.key)


def render_samples(renderer: Renderer, scene: Scene, settings: RenderSettings | None, samples: int,
                   cancel: Callable[[], bool] | None = None,
                   progress: Callable[[float], None] | None = None, passes: bool = True,
                   client: str = "final",
                   adaptive_threshold: float | None = ADAPTIVE_THRESHOLD,
                   until: int | None = None,
                   whites: tuple[float | None, float | None] = (None, None)) -> RenderOutput:
    """The mean of ``samples`` jittered samples of ``scene`` (one: the pixel-centre image),
    adaptively sampled (iter_samples; ``until`` and ``whites`` as there)."""
    acc = Accumulator()
    for _ in iter_samples(renderer, scene, settings, samples, cancel, passes, progress, accumulator=acc,
                          client=client, adaptive_threshold=adaptive_threshold, until=until,
                          whites=whites):
        pass
    return acc.output
