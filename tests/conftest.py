"""Shared fixtures: one renderer (one GL context) for the whole session, on the main thread, and
a fresh one per test for tests that count what it builds."""

import os
import sys
import threading
import time

import pytest

# pytest runs with --import-mode=importlib: make the tests' shared modules (references.py) importable.
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from tfm_addon.engine import Renderer


@pytest.fixture(scope="session")
def renderer():
    r = Renderer()
    yield r
    r.release()


@pytest.fixture
def fresh():
    r = Renderer()
    yield r
    r.release()


def _timed_with_ticker(work) -> tuple[float, float]:
    """(seconds ``work`` took on this thread, the longest gap between the 1 ms wake-ups of another
    Python thread meanwhile): how long ``work`` kept Python's GIL, as a host UI thread sees it."""
    gaps, running = [], [True]

    def ticker():
        last = time.perf_counter()
        while running[0]:
            time.sleep(0.001)
            now = time.perf_counter()
            gaps.append(now - last)
            last = now
    th = threading.Thread(target=ticker)
    th.start()
    time.sleep(0.02)
    t0 = time.perf_counter()
    try:
        work()
    finally:
        call = time.perf_counter() - t0
        time.sleep(0.02)
        running[0] = False
        th.join()
    return call, max(gaps)


@pytest.fixture
def timed_with_ticker():
    """``_timed_with_ticker``: (work's seconds, another thread's longest gap meanwhile)."""
    return _timed_with_ticker
