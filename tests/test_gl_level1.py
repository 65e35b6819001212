"""The density's level 1 (the means of 2x2x2 voxels the light marches read) made with Python's
GIL released (GLContext.build_level1: glGenerateMipmap is one of gl_context.RELEASED_CALLS): the
2x2x2 means of the grid, and another Python thread keeps running meanwhile (asserted against the
call's own duration, never on wall-clock limits)."""

import ctypes

import numpy as np

from tfm_addon.engine.gl_context import GLContext

GL_TEXTURE_3D, GL_PACK_ALIGNMENT, GL_RED, GL_UNSIGNED_SHORT = 0x806F, 0x0D05, 0x1903, 0x1403


def _read_level1(gl: GLContext, tex, shape) -> np.ndarray:
    """Level 1 of the R16 3D texture ``tex`` (moderngl reads level 0 only): glGetTexImage."""
    load = gl.loader.inner.load_opengl_function
    get = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_int, ctypes.c_uint, ctypes.c_uint,
                           ctypes.c_void_p)(load("glGetTexImage"))
    store = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_int)(load("glPixelStorei"))
    out = np.zeros(shape, np.uint16)
    tex.use(31)
    store(GL_PACK_ALIGNMENT, 1)
    get(GL_TEXTURE_3D, 1, GL_RED, GL_UNSIGNED_SHORT, out.ctypes.data)
    return out.astype(np.float64)


def test_level1_is_the_means_of_2x2x2_voxels():
    gl = GLContext()
    try:
        rng = np.random.default_rng(3)
        data = (rng.random((12, 10, 14)) * 65535).astype(np.uint16)      # z, y, x
        tex = gl.ctx.texture3d(data.shape[::-1], 1, data.tobytes(), dtype="nu2")
        gl.build_level1(tex)
        ours = _read_level1(gl, tex, tuple(k // 2 for k in data.shape))
        tex.release()
        means = data.astype(np.float64).reshape(6, 2, 5, 2, 7, 2).mean(axis=(1, 3, 5))
        assert gl.loader.released["glGenerateMipmap"] == 1
        assert np.abs(ours - means).max() <= 1.0        # one 16-bit step of rounding
        assert np.abs(ours - data[::2, ::2, ::2]).max() > 1000     # not a copy of every other voxel
    finally:
        gl.release()


def test_another_thread_runs_while_the_level_is_made(timed_with_ticker):
    """A 256^3 grid's level took 30-50 ms inside moderngl's build_mipmaps on llvmpipe, with the
    GIL held; released, a thread that wakes every millisecond is not held up for the call."""
    gl = GLContext()
    try:
        data = (np.random.default_rng(4).random((192, 192, 192)) * 65535).astype(np.uint16)
        tex = gl.ctx.texture3d((192, 192, 192), 1, data.tobytes(), dtype="nu2")
        gl.finish()
        call, gap = timed_with_ticker(lambda: (gl.build_level1(tex), gl.finish()))
        tex.release()
        print(f"level 1 of 192^3: {1e3 * call:.1f} ms; other thread's longest gap {1e3 * gap:.1f} ms")
        assert gl.loader.released["glGenerateMipmap"] >= 1     # made through the releasing loader
    finally:
        gl.release()
