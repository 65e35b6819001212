"""Pass 5 when sampling: each sample composed straight into the frame's sums on the GPU, read
back only when someone asks for the mean."""

from __future__ import annotations

import numpy as np

from ..gl_context import GLContext, set_uniforms
from .bindings import pass_state

PASS_NAMES = ("scattering", "surfaces", "transmittance")
SUMS_POOL = 2      # released sums kept per (size, passes) for the next frames (Renderer's pool)


class SampleSums:
    """RGBA32F textures the size of the pixel window holding, over the samples added so far, the
    sums of the combined image and of its square and, with ``passes``, of the three passes. A
    sample adds only at the pixels it shaded (adaptive sampling); ``count`` is the samples added.
    With a ``pool`` (a dict), ``release`` hands the GL objects back to it for the next frame of the
    same size (``take``) instead of freeing them; ``destroy`` frees them."""

    def __init__(self, gl: GLContext, size: tuple[int, int], passes: bool, pool: dict | None = None):
        ctx = gl.ctx
        self.size, self.passes, self.count, self._pool = size, passes, 0, pool
        self.textures = [ctx.texture(size, 4, dtype="f4") for _ in range(5 if passes else 2)]
        self.fbo = ctx.framebuffer(self.textures)
        self.fbo.clear(0, 0, 0, 0)

    @classmethod
    def take(cls, gl: GLContext, size: tuple[int, int], passes: bool, pool: dict) -> tuple[SampleSums, bool]:
        """Sums for a new frame: released ones of this size from ``pool``, cleared, or new ones;
        and whether they are new."""
        free = pool.get((size, passes))
        if free:
            sums = free.pop()
            sums.count = 0
            sums.fbo.clear(0, 0, 0, 0)
            return sums, False
        return cls(gl, size, passes, pool), True

    def begin_sample(self) -> None:
        """Bind the sums for a lone light pass that adds its sample into them itself
        (scattering.run_light_pass with ``sums``), in place of ``add``."""
        self.count += 1
        self.fbo.use()

    def add(self, gl: GLContext, targets, backdrop, active=None) -> None:
        """Compose the sample in ``targets`` (scattering.ScatteringTargets, with the G-buffer
        bound) and add it (composite.frag with ACCUMULATE); ``active``: None, or (vertex buffer,
        count) of the rectangles of the pixels the sample shaded: only those are added."""
        self.count += 1
        if active is not None and not active[1]:
            return
        defines = {"ACCUMULATE": 1, "PASSES": int(self.passes)}
        if active is not None:
            defines["RECTS"] = 1
        self.fbo.use()
        prog = targets.composite_program(gl, backdrop, defines)
        pass_state(gl.ctx, blend=True)
        if active is None:
            gl.draw_fullscreen(prog)
        else:
            set_uniforms(prog, u_window=(float(self.size[0]), float(self.size[1])))
            gl.draw_rects(prog, *active)
        pass_state(gl.ctx)

    def read(self) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """(sum of combined, sum of its square) as (h, w, 4) float32 and the passes' sums as
        (h, w, 3) float32 ({} without passes), top row first: views of the arrays read (rows
        flipped, the passes' fourth channel left out), not copies, so that a frame's read-back
        holds 16 bytes a pixel per texture and no more."""
        w, h = self.size
        images = []
        for t in self.textures:
            image = np.empty((h, w, 4), np.float32)
            t.read_into(image)
            images.append(image[::-1])
        passes = {name: image[..., :3] for name, image in zip(PASS_NAMES, images[2:], strict=False)}
        return images[0], images[1], passes

    def release(self) -> None:
        """Back to the pool (at most SUMS_POOL free per size), else freed."""
        free = None if self._pool is None else self._pool.setdefault((self.size, self.passes), [])
        if free is not None and len(free) < SUMS_POOL:
            free.append(self)
        else:
            self.destroy()

    def destroy(self) -> None:
        self.fbo.release()
        for t in self.textures:
            t.release()
