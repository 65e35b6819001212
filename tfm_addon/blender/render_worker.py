"""The add-on's one RenderWorker: the GL thread every render and viewport draw goes through.

Created on first use, closed when the add-on is unregistered (no GL context outlives it).
"""

from __future__ import annotations

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


def close_worker() -> None:
    """Stop the GL thread and release its context, if one was started."""
    global _worker
    with _lock:
        worker, _worker = _worker, None
    if worker is not None:
        worker.close()


def is_running() -> bool:
    return _worker is not None and _worker.alive
