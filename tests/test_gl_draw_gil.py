"""A program's first draw, where llvmpipe compiles its machine code (~180-250 ms for a variant of
the light pass on a cold shader cache), runs with Python's GIL released (gl_context._draw_triangles:
glDrawArrays through ctypes), so a host UI thread keeps running: inside moderngl's render it was
stopped for the whole compile (the viewport's 0.2 s stalls on edits that change a program).
Asserted against the draw's own duration, never on wall-clock limits."""

import random
import time

import numpy as np

from tfm_addon import scenes
from tfm_addon.engine import Renderer, RenderSettings, gl_context


def _first_frame(monkeypatch, timed_with_ticker):
    """(longest draw call, longest gap of a 1 ms ticker thread, image) of a frame whose programs
    are all new (a fresh #define in every source defeats the shader caches)."""
    monkeypatch.setattr(gl_context, "GLSL_VERSION",
                        gl_context.GLSL_VERSION + f"#define TFM_NONCE {random.getrandbits(48)}\n")
    draws = []
    inner = gl_context._draw_triangles

    def timed(vao, vertices):
        t0 = time.perf_counter()
        inner(vao, vertices)
        draws.append(time.perf_counter() - t0)
    monkeypatch.setattr(gl_context, "_draw_triangles", timed)
    r = Renderer()
    out = []
    try:
        _, gap = timed_with_ticker(lambda: out.append(r.render(
            scenes.demo_scene(96, 54), RenderSettings(coefficients=6, view_steps=48, light_steps=48,
                                                      map_resolution=128))))
    finally:
        r.release()
    return max(draws), gap, out[0].combined


def test_a_new_program_s_first_draw_lets_other_threads_run(monkeypatch, timed_with_ticker):
    if gl_context._gl_function("glDrawArrays", gl_context._DRAW_ARGS) is None:
        return      # moderngl draws on this platform
    draw, gap, image = _first_frame(monkeypatch, timed_with_ticker)
    print(f"longest first draw {1e3 * draw:.0f} ms, the other thread's longest gap {1e3 * gap:.0f} ms")
    assert float(image[..., :3].max()) > 0.05 and np.all(np.isfinite(image))
    if draw > 0.05:         # a compile long enough to tell
        assert gap < 0.5 * draw
