"""The add-on's one RenderWorker: the GL thread every render and viewport draw goes through.

Created on first use, closed when the add-on is unregistered (no GL context outlives it).
"""

from __future__ import annotations

import atexit
import threading

_lock = threading.Lock()
_worker = None


def get_worker():
    """The shared RenderWorker, started on first call."""
    global _worker
    with _lock:
        if _worker is None or not _worker.alive:
            from ..engine.worker import RenderWorker

            _worker = RenderWorker()
        return _worker


CLOSE_TIMEOUT_S = 5.0  # the longest unregister waits for the GL thread's current pass


def close_worker() -> bool:
    """Stop the GL thread and release its context, if one was started: queued and waiting jobs
    fail at once; the running one stops at its next check. True when the thread has ended
    (otherwise it ends by itself after its current pass and takes no new work)."""
    global _worker
    with _lock:
        worker, _worker = _worker, None
    if worker is None:
        return True
    ended = worker.close(CLOSE_TIMEOUT_S)
    if not ended:
        print(f"TFM: the render thread is still finishing a pass after {CLOSE_TIMEOUT_S} s; "
              "it ends by itself and takes no new work")
    return ended


def is_running() -> bool:
    return _worker is not None and _worker.alive


# Python's exit (Blender quitting, a script ending, Ctrl+C in a script) ends the GL job and
# releases the context too, as unregister does; close_worker is a no-op when nothing runs.
atexit.register(close_worker)
