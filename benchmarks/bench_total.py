"""Total family and Theo1 through the public call: absolute targets on 1e5 points, ratios against allantools.

Cases (octave averaging factors, phase at 1 Hz):

- MTOTDEV and HTOTDEV on 1e5 points, target < 10 s each; Theo1 on 1e5 points, target < 30 s.
  allantools evaluates these term by term in Python loops and would take hours there, so those rows
  carry no baseline; their note gives allantools' time extrapolated from its own per-term rate
  measured below (the number of terms is known exactly).
- The same statistics on a size allantools finishes in the same run (2000 points; 500 in quick mode),
  ours and allantools on the same record: the like-for-like ratio.

``quick`` uses 2e4 points for the absolute cases. Data: a seeded random walk plus white phase noise
(the running time does not depend on the noise). Every row times ``chronofuse.api.<statistic>(x_s, rate_hz,
tau_s)``: gap handling, kernel, noise identification, bias correction, EDF and confidence interval. Numba
compilation (cached) is excluded by a warm-up call.

Run alone: ``.venv/bin/python benchmarks/bench_total.py [--quick]``.
"""

from __future__ import annotations

import sys
import time

import allantools
import numpy as np

from chronofuse import api
from chronofuse.analysis.stability import kernels_theo as kth
from chronofuse.analysis.stability import kernels_total as ktot
from chronofuse.analysis.stability.taus import averaging_factors

SEED = 20240611

# name -> (our kernel, our max_m, allantools function, allantools' number of inner terms for N, m)
CASES = {
    "mtotdev": (ktot.mtotdev_raw, ktot.max_m_mtotdev, allantools.mtotdev, lambda n, m: (n - 3 * m + 1) * 6 * m),
    "htotdev": (ktot.htotdev_raw, ktot.max_m_htotdev, allantools.htotdev, lambda n, m: (n - 3 * m) * 6 * m),
    "theo1": (kth.theo1_raw, kth.max_m_theo1, allantools.theo1, lambda n, m: (n - m) * m // 2),
}
TARGET_S = {"mtotdev": 10.0, "htotdev": 10.0, "theo1": 30.0}


def phase_record(n_points: int, seed: int = SEED) -> np.ndarray:
    """Seeded test phase (s), shape (n_points,): random-walk FM integrated plus white PM."""
    rng = np.random.default_rng(seed)
    y = np.cumsum(rng.standard_normal(n_points)) * 1e-14 + rng.standard_normal(n_points) * 1e-11
    return np.cumsum(y) + rng.standard_normal(n_points) * 1e-10


def octave_factors(name: str, n_points: int) -> np.ndarray:
    m = averaging_factors(CASES[name][1](n_points))
    return m[m % 2 == 0] if name == "theo1" else m


def timed(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def _row(name, ours_s, baseline, baseline_s, target, passed, note):
    return {
        "name": name,
        "ours_s": float(ours_s),
        "baseline": baseline,
        "baseline_s": None if baseline_s is None else float(baseline_s),
        "ratio": None if baseline_s is None else float(baseline_s) / float(ours_s),
        "target": target,
        "passed": bool(passed),
        "note": note,
    }


def run(quick: bool = False) -> list[dict]:
    n_big = 20_000 if quick else 100_000
    n_small = 500 if quick else 2_000
    big = phase_record(n_big)
    small = phase_record(n_small)
    rows = []
    for name, (_, _, theirs, terms) in CASES.items():
        public = getattr(api, name)
        tau_factor = 0.75 if name == "theo1" else 1.0
        public(small[:256], 1.0, tau_factor * octave_factors(name, 256))  # warm-up: load the cached numba code
        m_small = octave_factors(name, n_small)
        ours_small = min(timed(lambda: public(small, 1.0, tau_factor * m_small)) for _ in range(3))
        theirs_small = timed(lambda: theirs(small, rate=1.0, data_type="phase", taus=m_small.astype(float)))
        per_term_s = theirs_small / sum(terms(n_small, int(mk)) for mk in m_small)
        m_big = octave_factors(name, n_big)
        ours_big = timed(lambda: public(big, 1.0, tau_factor * m_big))
        extrapolated_s = per_term_s * sum(terms(n_big, int(mk)) for mk in m_big)
        target = TARGET_S[name]
        rows.append(
            _row(
                f"{name} N={n_big} octave (m up to {m_big[-1]})",
                ours_big,
                "allantools (not run at this size)",
                None,
                f"< {target:g} s" + (" (full size: N=1e5)" if quick else ""),
                ours_big < target,
                f"allantools extrapolated from its measured per-term rate at N={n_small}: "
                f"~{extrapolated_s / 3600:.1f} h ({extrapolated_s / ours_big:.0f}x ours)",
            )
        )
        rows.append(
            _row(
                f"{name} N={n_small} octave, same record both",
                ours_small,
                f"allantools {name}",
                theirs_small,
                "ratio >= 1",
                theirs_small >= ours_small,
                f"public api.{name} with noise id and CI; like-for-like size allantools finishes in this run "
                f"(N={n_small}); ours best of 3, allantools once",
            )
        )
    return rows


if __name__ == "__main__":
    for row in run(quick="--quick" in sys.argv[1:]):
        ratio = "-" if row["ratio"] is None else f"{row['ratio']:.0f}x"
        baseline = "-" if row["baseline_s"] is None else f"{row['baseline_s']:.3f} s"
        print(
            f"{row['name']:<48} ours {row['ours_s']:8.3f} s  baseline {baseline:>10}  ratio {ratio:>7}  "
            f"target {row['target']:<28} {'PASS' if row['passed'] else 'FAIL'}  {row['note']}"
        )
