"""Timing shared by the benchmarks: the best wall time of a few repeats (the least disturbed by a busy machine)."""

from __future__ import annotations

import time


def best_of(fn, repeats: int) -> float:
    """The shortest of ``repeats`` wall-clock times of ``fn()``, in seconds."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best
