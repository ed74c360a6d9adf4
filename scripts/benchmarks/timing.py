"""Shared timing helper of the benchmark scripts (median of repeated runs)."""
from __future__ import annotations

import statistics
import time


def median_time(fn, repeats: int, warmup: bool = False, clock=time.perf_counter) -> float:
    """Median wall time of ``fn()`` over ``repeats`` calls, in seconds;
    ``warmup`` runs it once first (setup, first factorisation).  ``clock``:
    ``time.process_time`` for the CPU time instead (on a loaded machine a call
    longer than a time slice shares the cores: its wall time is not its cost)."""
    if warmup:
        fn()
    times = []
    for _ in range(repeats):
        t0 = clock()
        fn()
        times.append(clock() - t0)
    return statistics.median(times)
