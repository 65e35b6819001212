"""The GL calls that take long on a software GL (llvmpipe compiles a program's GLSL at
glLinkProgram, its machine code at the first draw, rasterises until a read) run with Python's GIL
released: moderngl calls them through gl_context.ReleasingLoader, so a host's UI thread keeps
running while the GL thread compiles or renders. Asserted against the calls' own durations,
never on wall-clock limits; and the images are the same bits as through moderngl's own calls."""

import ctypes
import random
import threading
import time

import numpy as np

from tfm_addon import scenes
from tfm_addon.engine import Renderer, RenderSettings, gl_context


def test_compiling_new_programs_lets_other_threads_run(timed_with_ticker):
    gl = gl_context.GLContext()
    try:
        before = dict(gl.loader.released)
        compiles = []

        def compile_new():
            for _ in range(3):      # a fresh #define defeats the shader caches
                t0 = time.perf_counter()
                gl.program("fullscreen.vert", "scatter.frag",
                           {"N_COEFF": 6, "TFM_NONCE": random.getrandbits(48)})
                compiles.append(time.perf_counter() - t0)
        _, gap = timed_with_ticker(compile_new)
        released = {k: n - before[k] for k, n in gl.loader.released.items()}
    finally:
        gl.release()
    longest = max(compiles)
    print(f"longest compile {1e3 * longest:.0f} ms, the other thread's longest gap {1e3 * gap:.0f} ms")
    assert released["glCompileShader"] == 6 and released["glLinkProgram"] == 3


class _SleepingContext:
    """A stand-in for glcontext's context whose 'glClear' is libc's usleep(microseconds): a
    C call that takes as long as asked, whatever the machine."""

    def load_opengl_function(self, name):
        libc = ctypes.CDLL(None)
        return ctypes.cast(libc.usleep, ctypes.c_void_p).value if name == "glClear" else 0


def test_a_released_call_lets_another_thread_run_while_it_works():
    # What the tests above rely on, checked on any machine: a call made through the loader's
    # callback releases the GIL for the C call's whole duration (a held GIL: no wake-up at all).
    loader = gl_context.ReleasingLoader(_SleepingContext())
    address = loader.load_opengl_function("glClear")
    clear = gl_context._FUNCTION_TYPE(None, *gl_context.RELEASED_CALLS["glClear"])(address)
    wakeups, stop = [0], threading.Event()

    def tick():
        while not stop.is_set():
            time.sleep(0.001)
            wakeups[0] += 1
    thread = threading.Thread(target=tick)
    thread.start()
    time.sleep(0.02)
    before = wakeups[0]
    clear(300_000)                       # 0.3 s in C
    during = wakeups[0] - before
    stop.set()
    thread.join()
    assert loader.released["glClear"] == 1
    assert during >= 10, during


def _image(settings):
    r = Renderer()
    try:
        return r.render(scenes.demo_scene(64, 36), settings).combined
    finally:
        r.release()


def test_images_are_those_of_moderngl_s_own_calls(monkeypatch):
    settings = RenderSettings(coefficients=6, view_steps=32, light_steps=32, map_resolution=64)
    released = _image(settings)
    monkeypatch.setattr(gl_context, "RELEASED_CALLS", {})     # moderngl calls the GL itself
    plain = _image(settings)
    assert float(released[..., :3].max()) > 0.05
    assert np.array_equal(released, plain)
