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


def print_rows(rows, name_width: int = 48) -> None:
    """Print the rows of a command-timing benchmark (name, ours, baseline, target, verdict, note), one a line."""
    for r in rows:
        base = "-" if r["baseline_s"] is None else f"{r['baseline_s']:.2f} s"
        print(f"{r['name']:<{name_width}} {r['ours_s']:10.2f}  {r['baseline'] or '-':<28} {base:>8}  target {r['target']:<18}"
              f" {'ok' if r['passed'] else 'FAIL'}  {r['note']}", flush=True)
