"""Shared timing helper of the benchmark scripts (median of repeated runs)."""
from __future__ import annotations

import statistics
import time


def median_time(fn, repeats: int, warmup: bool = False) -> float:
    """Median wall time of ``fn()`` over ``repeats`` calls, in seconds;
    ``warmup`` runs it once first (setup, first factorisation)."""
    if warmup:
        fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)
