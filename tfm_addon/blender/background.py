"""Work the add-on runs beside Blender's thread: a Sky Texture bake or a big grid's read is a
thread waiting on a child process, with a timer on Blender's thread that tags the Blender data
once the result is there. All of it ends when the add-on's memos are cleared (unregister calls
``engine.caches.REGISTRY.clear()``): the timers are unregistered, the child processes killed and
the threads joined (a bounded wait), so that nothing of an unregistered add-on runs on."""

from __future__ import annotations

import threading

from ..engine import caches

JOIN_TIMEOUT_S = 5.0

_lock = threading.Lock()
_threads: set[threading.Thread] = set()
_processes: set = set()
_timers: set = set()
_ending = False         # ``end`` is running: a child process started meanwhile is killed at once


def start(thread: threading.Thread) -> threading.Thread:
    """Start ``thread`` as the add-on's background work."""
    with _lock:
        _threads.add(thread)
    thread.start()
    return thread


def child(process):
    """Count ``process`` (a subprocess.Popen) as the add-on's until ``finished(process)`` (killed
    at once while ``end`` runs: its thread was started before and is being joined)."""
    with _lock:
        _processes.add(process)
        if _ending:
            process.kill()
    return process


def finished(process) -> None:
    with _lock:
        _processes.discard(process)


def timer(poll, first_interval: float) -> None:
    """``bpy.app.timers.register(poll)``, unregistered by ``end`` if still running."""
    import bpy

    with _lock:
        _timers.add(poll)
    bpy.app.timers.register(poll, first_interval=first_interval)


def running() -> int:
    """Background threads still alive, timers still registered and child processes still running."""
    import bpy

    with _lock:
        return (sum(t.is_alive() for t in _threads) + sum(bpy.app.timers.is_registered(f) for f in _timers)
                + sum(p.poll() is None for p in _processes))


def end() -> None:
    """Unregister the timers, kill the child processes, join the threads (JOIN_TIMEOUT_S each)."""
    import bpy

    global _ending
    with _lock:
        _ending = True
        timers, processes, threads = list(_timers), list(_processes), list(_threads)
        _timers.clear()
        _processes.clear()
    try:
        for poll in timers:
            if bpy.app.timers.is_registered(poll):
                bpy.app.timers.unregister(poll)
        for process in processes:
            if process.poll() is None:
                process.kill()
        for thread in threads:
            if thread is not threading.current_thread():
                thread.join(JOIN_TIMEOUT_S)
    finally:
        with _lock:
            _threads.difference_update(t for t in threads if not t.is_alive())
            _processes.difference_update(p for p in list(_processes) if p.poll() is not None)
            _ending = False


caches.REGISTRY.on_clear(end)
