"""Timing several contenders side by side: interleaved repetitions, median seconds."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable


def time_side_by_side(contenders: dict[str, Callable[[], object]], repeats: int) -> dict[str, float]:
    """Median wall-clock seconds of each callable, the repetitions interleaved (A B C A B C ...)
    so that a noisy, shared machine slows all of them alike."""
    samples: dict[str, list[float]] = {name: [] for name in contenders}
    for _ in range(repeats):
        for name, fn in contenders.items():
            t0 = time.perf_counter()
            fn()
            samples[name].append(time.perf_counter() - t0)
    return {name: statistics.median(s) for name, s in samples.items()}
