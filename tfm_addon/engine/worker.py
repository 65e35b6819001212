"""A thread that owns a Renderer and its GL context, so hosts can call it from any thread."""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable
from concurrent.futures import Future

from .output import RenderOutput
from .renderer import Renderer
from .scene import RenderSettings, Scene


class RenderWorker:
    """Runs every renderer call on one dedicated thread (an EGL context is current on the
    thread that made it, and must not displace the host's own GL context)."""

    def __init__(self):
        self._queue: queue.Queue = queue.Queue()
        self._thread = threading.Thread(target=self._run, name="tfm-gl", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        renderer = Renderer()
        try:
            while True:
                item = self._queue.get()
                if item is None:
                    return
                fn, future = item
                if not future.set_running_or_notify_cancel():
                    continue
                try:
                    future.set_result(fn(renderer))
                except BaseException as exc:  # handed to the caller
                    future.set_exception(exc)
        finally:
            renderer.release()

    def call(self, fn: Callable[[Renderer], object]):
        """Run ``fn(renderer)`` on the GL thread and return its result (or raise its error)."""
        if not self._thread.is_alive():
            raise RuntimeError("the render worker is closed")
        future: Future = Future()
        self._queue.put((fn, future))
        return future.result()

    def render(self, scene: Scene, settings: RenderSettings | None = None,
               cancel: Callable[[], bool] | None = None,
               progress: Callable[[float], None] | None = None, passes: bool = True) -> RenderOutput:
        """Renderer.render on the GL thread; ``cancel`` and ``progress`` are called there."""
        return self.call(lambda r: r.render(scene, settings, cancel, progress, passes))

    @property
    def counters(self) -> dict:
        return self.call(lambda r: dict(r.counters))

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    def close(self, timeout_s: float = 10.0) -> None:
        """Release the GL context and stop the thread."""
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join(timeout_s)
