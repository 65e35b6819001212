"""A program's first draw, where llvmpipe compiles its machine code (~180-250 ms for a variant of
the light pass on a cold shader cache), runs with Python's GIL released (the draw calls are among
gl_context.RELEASED_CALLS), so a host UI thread keeps running: with the GIL held it was stopped for
the whole compile (the viewport's 0.2 s stalls on edits that change a program). Asserted against
the draw's own duration, never on wall-clock limits."""

import random

import numpy as np

from tfm_addon import scenes
from tfm_addon.engine import Renderer, RenderSettings, gl_context

DRAWS = ("glDrawArrays", "glDrawArraysInstanced", "glDrawElements", "glDrawElementsInstanced")


def test_a_new_program_s_first_draw_lets_other_threads_run(monkeypatch, timed_with_ticker):
    # a fresh #define in every source defeats the shader caches: every program is new
    monkeypatch.setattr(gl_context, "GLSL_VERSION",
                        gl_context.GLSL_VERSION + f"#define TFM_NONCE {random.getrandbits(48)}\n")
    r = Renderer()
    out = []
    try:
        _, gap = timed_with_ticker(lambda: out.append(r.render(
            scenes.demo_scene(96, 54), RenderSettings(coefficients=6, view_steps=48, light_steps=48,
                                                      map_resolution=128))))
        draw = max(r.gl.loader.longest[name] for name in DRAWS)
        assert sum(r.gl.loader.released[name] for name in DRAWS) > 0
    finally:
        r.release()
    image = out[0].combined
    print(f"longest first draw {1e3 * draw:.0f} ms, the other thread's longest gap {1e3 * gap:.0f} ms")
    assert float(image[..., :3].max()) > 0.05 and np.all(np.isfinite(image))
