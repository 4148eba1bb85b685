"""``import chronofuse.api`` in a fresh interpreter against ``import numpy, scipy`` in another.

Both run as ``python -c ...`` subprocesses, alternating, so the machine's load falls on both alike; the
best of ``repeats`` runs of each is kept (the run least disturbed). Target: the API's import costs at most
1.5x the numerical stack's (ratio = baseline_s / ours_s >= 1/1.5). The API is lazy (each name loads its
module on first use), so its import is the interpreter's start plus one small module; the note also gives
an interpreter that imports nothing (``python -c pass``) and one that loads every name of the API.

Run alone: ``.venv/bin/python benchmarks/bench_import.py [--quick] [--repeats R]``.
"""

from __future__ import annotations

import subprocess
import sys
import time

MAX_SLOWDOWN = 1.5
OURS = "import chronofuse.api"
BASELINE = "import numpy, scipy"
NOTHING = "pass"
EVERYTHING = "import chronofuse.api as a; [getattr(a, n) for n in a.__all__]"


def _wall_s(code: str) -> float:
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
    return time.perf_counter() - start


def measure(repeats: int) -> dict[str, float]:
    """Best wall time (s) of each snippet over ``repeats`` alternating runs."""
    best = {code: float("inf") for code in (OURS, BASELINE, NOTHING, EVERYTHING)}
    for _ in range(repeats):
        for code in best:
            best[code] = min(best[code], _wall_s(code))
    return best


def run(quick: bool = False, repeats: int | None = None) -> list[dict]:
    best = measure(repeats or (3 if quick else 10))
    ours, base = best[OURS], best[BASELINE]
    note = (f"python -c pass {best[NOTHING]:.3f} s; every API name loaded {best[EVERYTHING]:.3f} s; "
            f"best of {repeats or (3 if quick else 10)} alternating runs")
    return [{"name": "import chronofuse.api", "ours_s": ours, "baseline": "import numpy, scipy", "baseline_s": base,
             "ratio": base / ours, "target": f"<= {MAX_SLOWDOWN:g}x numpy+scipy", "passed": ours <= MAX_SLOWDOWN * base,
             "note": note}]


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeats", type=int, default=None)
    args = parser.parse_args()
    for row in run(args.quick, args.repeats):
        print(f"{row['name']}: {row['ours_s']:.3f} s, {row['baseline']} {row['baseline_s']:.3f} s, "
              f"{row['ours_s'] / row['baseline_s']:.2f}x ({row['target']}: {'ok' if row['passed'] else 'FAIL'}); "
              f"{row['note']}")
