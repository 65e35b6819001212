"""The one object that owns the OpenGL context, and the shader sources."""

from __future__ import annotations

import ctypes
import os
import sys
import threading
import time
from pathlib import Path

import numpy as np

from .errors import GLUnavailableError

SHADER_DIR = Path(__file__).parent / "shaders"
GLSL_VERSION = "#version 330 core\n"
RECT_ARRAYS = 16                  # vertex arrays draw_rects keeps (programs x rectangle sets)


def _backends() -> list[str | None]:
    """Context backends to try, best first: EGL on Linux (headless), the platform default else."""
    if sys.platform.startswith("linux"):
        return ["egl", None]
    return [None]


EGL_DEVICE_ENV = "TFM_EGL_DEVICE"   # which EGL device (GPU) renders: its index, 0 the first
# What the last create_context did with TFM_EGL_DEVICE, for the render log ('' when not set).
device_note = ""


def egl_device_request() -> tuple[int | None, str]:
    """The EGL device index TFM_EGL_DEVICE asks for (None: not set, or not an index) and a note
    saying why it is not used ('' when it is used or not set)."""
    raw = os.environ.get(EGL_DEVICE_ENV, "").strip()
    if not raw:
        return None, ""
    try:
        index = int(raw)
    except ValueError:
        return None, f"{EGL_DEVICE_ENV}={raw!r} is not a device index (0, 1, ...); the default device is used"
    if index < 0:
        return None, f"{EGL_DEVICE_ENV}={raw!r} is negative; the default device is used"
    if not sys.platform.startswith("linux"):
        return None, f"{EGL_DEVICE_ENV} is ignored on {sys.platform} (no EGL); the default device is used"
    return index, ""


def foreign_wheels(paths: list[str] | None = None) -> list[str]:
    """Compiled modules of moderngl or glcontext on ``paths`` (default sys.path) built for another
    CPython than this one (``mgl.cpython-313-...so``, ``mgl.cp313-win_amd64.pyd``)."""
    mine = (f"cpython-{sys.version_info.major}{sys.version_info.minor}",
            f"cp{sys.version_info.major}{sys.version_info.minor}")
    found = []
    for base in sys.path if paths is None else paths:
        for package in ("moderngl", "glcontext"):
            folder = os.path.join(base, package)
            if not os.path.isdir(folder):
                continue
            for name in sorted(os.listdir(folder)):
                tagged = ".cpython-3" in name or (name.endswith(".pyd") and ".cp3" in name)
                if tagged and not any(f".{tag}" in name for tag in mine):
                    found.append(os.path.join(folder, name))
    return found


def create_context():
    """A standalone OpenGL >= 3.3 context, current on the calling thread, whose slow GL calls
    release Python's GIL (``ReleasingLoader``, its ``extra``). On Linux the EGL device
    is TFM_EGL_DEVICE's index when set (glcontext's ``device_index``: the order of
    eglQueryDevicesEXT); a device that cannot be used falls back to the default one and
    ``device_note`` says so."""
    global device_note
    try:
        import moderngl
    except ImportError as exc:  # a packaging error: say which, not "the graphics driver"
        foreign = foreign_wheels()
        if foreign:
            raise GLUnavailableError(
                f"The moderngl installed with the add-on was built for another Python ({foreign[0]}) than "
                f"Blender's Python {sys.version_info.major}.{sys.version_info.minor}: this Blender installed "
                f"the extension's wheels without matching them to its Python (Blender 4.2.0 does). Install "
                f"the extension built for Python {sys.version_info.major}.{sys.version_info.minor} "
                f"(scripts/build_extension.py --python {sys.version_info.major}.{sys.version_info.minor}) "
                f"or use Blender 4.2.1 or later.") from exc
        raise GLUnavailableError(f"the moderngl package is missing ({exc})") from exc
    index, device_note = egl_device_request()
    errors = []
    attempts = []
    for backend in _backends():
        if backend == "egl" and index is not None:
            attempts.append((backend, {"backend": "egl", "device_index": index}))
        attempts.append((backend, {"backend": backend} if backend else {}))
    for backend, kwargs in attempts:
        try:
            loader = _standalone(**kwargs)
            ctx = moderngl.create_standalone_context(require=330, context=loader)
        except Exception as exc:  # moderngl raises plain Exceptions (glcontext too)
            errors.append(f"{backend or 'default'}: {exc}")
            if "device_index" in kwargs:
                device_note = (f"{EGL_DEVICE_ENV}={index} cannot be used ({exc}); "
                               "the default device renders")
            continue
        ctx.extra = loader          # the ReleasingLoader moderngl calls the GL through
        return ctx
    hint = ("install an OpenGL driver with EGL (on Debian/Ubuntu: apt install libegl1 libgl1-mesa-dri)"
            if sys.platform.startswith("linux") else "update the graphics driver")
    raise GLUnavailableError(
        "The TFM renderer needs OpenGL 3.3, but no OpenGL context could be created ("
        + "; ".join(errors) + f"). To fix: {hint}.")


_ENUM, _INT, _PTR, _SIZE = ctypes.c_uint, ctypes.c_int, ctypes.c_void_p, ctypes.c_ssize_t
# The GL calls that can take long on a software GL, with their arguments: llvmpipe compiles a
# program's GLSL at glLinkProgram (20-80 ms for the light pass) and its machine code at the first
# draw of each variant, rasterises until a read or glFinish, allocates and copies in the texture and
# buffer calls. moderngl calls them holding Python's GIL; GLContext's moderngl context calls them
# through ctypes, which releases it (``ReleasingLoader``).
RELEASED_CALLS = {
    "glCompileShader": (_ENUM,), "glLinkProgram": (_ENUM,), "glFinish": (), "glClear": (_ENUM,),
    "glDrawArrays": (_ENUM, _INT, _INT), "glDrawArraysInstanced": (_ENUM, _INT, _INT, _INT),
    "glDrawElements": (_ENUM, _INT, _ENUM, _PTR),
    "glDrawElementsInstanced": (_ENUM, _INT, _ENUM, _PTR, _INT),
    "glReadPixels": (_INT, _INT, _INT, _INT, _ENUM, _ENUM, _PTR),
    "glGetTexImage": (_ENUM, _INT, _ENUM, _ENUM, _PTR),
    "glTexImage2D": (_ENUM, _INT, _INT, _INT, _INT, _INT, _ENUM, _ENUM, _PTR),
    "glTexImage3D": (_ENUM, _INT, _INT, _INT, _INT, _INT, _INT, _ENUM, _ENUM, _PTR),
    "glTexSubImage2D": (_ENUM, _INT, _INT, _INT, _INT, _INT, _ENUM, _ENUM, _PTR),
    "glTexSubImage3D": (_ENUM,) + (_INT,) * 7 + (_ENUM, _ENUM, _PTR),
    "glGenerateMipmap": (_ENUM,),
    "glBufferData": (_ENUM, _SIZE, _PTR, _ENUM), "glBufferSubData": (_ENUM, _SIZE, _SIZE, _PTR),
    "glGetBufferSubData": (_ENUM, _SIZE, _SIZE, _PTR),
}
_FUNCTION_TYPE = ctypes.WINFUNCTYPE if sys.platform == "win32" else ctypes.CFUNCTYPE


class ReleasingLoader:
    """A glcontext context for moderngl (``create_context(context=...)``) whose GL entry points
    named in ``RELEASED_CALLS`` are ctypes callbacks calling the GL through ctypes: moderngl's C
    code calls them with the GIL held, the callback's ctypes call releases it while the GL works
    (so a compile, a first draw or a read-back on the GL thread stops no other Python thread).
    Everything else is the wrapped context's. ``released`` counts the calls made so and
    ``longest`` keeps the longest one's seconds, by name."""

    def __init__(self, inner):
        self.inner = inner
        self.released = dict.fromkeys(RELEASED_CALLS, 0)
        self.longest = dict.fromkeys(RELEASED_CALLS, 0.0)
        self._callbacks = []            # kept alive as long as moderngl may call them

    def __getattr__(self, name):        # release, __enter__, __exit__, load ...
        return getattr(self.inner, name)

    def load_opengl_function(self, name: str) -> int:
        address = self.inner.load_opengl_function(name)
        args = RELEASED_CALLS.get(name)
        if not address or args is None:
            return address
        kind = _FUNCTION_TYPE(None, *args)
        gl = kind(address)

        def call(*values):
            start = time.perf_counter()
            gl(*values)                 # a ctypes call: the GIL is released while the GL works
            self.released[name] += 1
            self.longest[name] = max(self.longest[name], time.perf_counter() - start)
        callback = kind(call)
        self._callbacks.append(callback)
        return ctypes.cast(callback, ctypes.c_void_p).value


def _standalone(backend: str | None = None, **kwargs) -> ReleasingLoader:
    """A standalone glcontext context (what moderngl makes for ``backend``, ``kwargs``) for
    moderngl through ``ReleasingLoader``."""
    import glcontext

    if backend == "egl":
        _initialise_egl(kwargs.get("device_index", 0))
    make = glcontext.get_backend_by_name(backend) if backend else glcontext.default_backend()
    return ReleasingLoader(make(mode="standalone", glversion=330, **kwargs))


EGL_PLATFORM_DEVICE_EXT = 0x313F


def _initialise_egl(index: int) -> bool:
    """Initialise the EGL display of device ``index`` (the one glcontext's EGL backend opens)
    through ctypes, with the GIL released: there the driver is loaded (for llvmpipe, LLVM: 20-60
    ms), which inside glcontext's create would stop every other Python thread; glcontext's own
    eglInitialize of that display then finds it initialised. False where it could not (glcontext
    then does it all)."""
    import ctypes.util

    try:
        egl = ctypes.CDLL(ctypes.util.find_library("EGL") or "libEGL.so.1")
        address = egl.eglGetProcAddress
        address.restype, address.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
        entries = address(b"eglQueryDevicesEXT"), address(b"eglGetPlatformDisplayEXT")
        if not all(entries):
            return False
        pointer = ctypes.c_void_p
        query = ctypes.CFUNCTYPE(ctypes.c_uint, ctypes.c_int, pointer, ctypes.POINTER(ctypes.c_int))(
            entries[0])
        display = ctypes.CFUNCTYPE(pointer, ctypes.c_uint, pointer, pointer)(entries[1])
        initialise = egl.eglInitialize
        initialise.restype, initialise.argtypes = ctypes.c_uint, [pointer] * 3
        devices, count = (pointer * 32)(), ctypes.c_int(0)
        if not query(32, devices, ctypes.byref(count)) or not 0 <= index < count.value:
            return False
        return bool(initialise(display(EGL_PLATFORM_DEVICE_EXT, devices[index], None), None, None))
    except (OSError, AttributeError, TypeError, ValueError):   # no libEGL, no device extension
        return False


def shader_source(name: str) -> str:
    """A file of shaders/ with its ``#include "file"`` lines replaced by those files."""
    lines = []
    for line in (SHADER_DIR / name).read_text().splitlines():
        if line.startswith("#include "):
            lines.append(shader_source(line.split('"')[1]))
        else:
            lines.append(line)
    return "\n".join(lines) + "\n"


class GLContext:
    """Owns a moderngl context and the programs compiled in it; use it from one thread only.
    ``GLContext.live`` counts the contexts created and not yet released in this process."""

    live = 0

    def __init__(self):
        self.ctx = create_context()
        self.loader = self.ctx.extra        # ReleasingLoader: counts the calls made GIL-free
        self.device_note = device_note
        GLContext.live += 1
        self.thread_id = threading.get_ident()
        self._programs: dict[tuple, object] = {}
        self._fullscreen: dict[int, object] = {}
        # The vertex arrays of draw_rects' recent (program, buffer) pairs, with the buffer they read
        # (held, so that its id names it for as long as the entry lives); oldest first.
        self._rects: dict[tuple[int, int], tuple[object, object]] = {}
        self.max_3d_texture_size = int(self.ctx.info.get("GL_MAX_3D_TEXTURE_SIZE", 256))
        self.max_texture_size = int(self.ctx.info.get("GL_MAX_TEXTURE_SIZE", 4096))

    def describe(self) -> str:
        """'vendor / renderer (OpenGL version)', with the device note when TFM_EGL_DEVICE could
        not be honoured: the GL the render log names."""
        info = self.ctx.info
        text = (f"{info.get('GL_VENDOR', '?')} / {info.get('GL_RENDERER', '?')} "
                f"(OpenGL {info.get('GL_VERSION', '?')})")
        return f"{text}; {self.device_note}" if self.device_note else text

    def check_thread(self) -> None:
        if threading.get_ident() != self.thread_id:
            raise RuntimeError("the GL context is used from a thread that does not own it")

    def program(self, vertex: str, fragment: str, defines: dict[str, int] | None = None):
        """A compiled program from files in shaders/, with #defines; cached."""
        key = (vertex, fragment, tuple(sorted((defines or {}).items())))
        prog = self._programs.get(key)
        if prog is None:
            header = GLSL_VERSION + "".join(f"#define {k} {v}\n" for k, v in sorted((defines or {}).items()))
            vs = header + shader_source(vertex)
            fs = header + shader_source(fragment)
            prog = self.ctx.program(vertex_shader=vs, fragment_shader=fs)
            self._programs[key] = prog
        return prog

    def finish(self) -> None:
        """Wait until the GL work issued so far is done, letting other Python threads run
        meanwhile (glFinish is one of ``RELEASED_CALLS``)."""
        self.ctx.finish()

    def build_level1(self, texture) -> None:
        """Give the 3D ``texture`` its level 1 (the GL's means of 2x2x2 texels), with Python's
        GIL released while the GL makes it (glGenerateMipmap: 30-50 ms on llvmpipe for a 256^3
        grid). The texture's filters are the caller's to set."""
        texture.build_mipmaps(0, 1)

    def texture3d_r16(self, array: np.ndarray, part_bytes: int = 8 * 2 ** 20):
        """An R16 (normalised) 3D texture of ``array`` (z, y, x uint16, x fastest), allocated and
        filled (a part of ``part_bytes`` at a time) with Python's GIL released: the GL's
        allocation of a 130 MB texture takes 160 ms on llvmpipe."""
        d, h, w = array.shape
        texture = self.ctx.texture3d((w, h, d), 1, dtype="nu2")
        step = max(1, part_bytes // max(array[0].nbytes, 1))
        for z in range(0, d, step):
            part = np.ascontiguousarray(array[z:z + step])
            texture.write(part, viewport=(0, 0, z, w, h, part.shape[0]))
        return texture

    def draw_fullscreen(self, prog) -> None:
        """Run ``prog`` over the bound framebuffer with one triangle (fullscreen.vert)."""
        vao = self._fullscreen.get(id(prog))
        if vao is None:
            vao = self._fullscreen[id(prog)] = self.ctx.vertex_array(prog, [])
        vao.render(vertices=3)

    def draw_rects(self, prog, vbo, vertices: int) -> None:
        """Run ``prog`` (fullscreen.vert with RECTS) over the triangles of ``vbo`` (2 floats a
        vertex, window pixels)."""
        key = (id(prog), id(vbo))
        entry = self._rects.get(key)
        if entry is None:
            entry = self._rects[key] = (vbo, self.ctx.vertex_array(prog, [(vbo, "2f", "in_px")]))
            while len(self._rects) > RECT_ARRAYS:   # an adaptive frame's rectangles change twice
                self._rects.pop(next(iter(self._rects)))[1].release()
        entry[1].render(vertices=vertices)

    def release(self) -> None:
        for _, vao in self._rects.values():
            vao.release()
        self._rects.clear()
        for vao in self._fullscreen.values():
            vao.release()
        for prog in self._programs.values():
            prog.release()
        self._programs.clear()
        self.ctx.release()
        GLContext.live -= 1


def set_uniforms(prog, **values) -> None:
    """Set the uniforms the program uses; the compiler drops unused ones, so skip those."""
    for name, value in values.items():
        if prog.get(name, None) is not None:   # a dict look-up (`in` walks every member)
            prog[name].value = value


def mat4_bytes(m) -> bytes:
    """A row-major numpy 4x4 (column vectors) as GLSL's column-major bytes."""
    import numpy as np

    return np.asarray(m, dtype=np.float32).T.copy().tobytes()


def set_matrix(prog, name: str, m) -> None:
    if prog.get(name, None) is not None:
        prog[name].write(mat4_bytes(m))
