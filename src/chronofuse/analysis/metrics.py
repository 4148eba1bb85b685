"""Summary metrics over simulated or measured runs: binomial intervals, pooled stability, usability.

Each is a plain function of arrays, used by the experiments and the command line alike.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import stats

import chronofuse.analysis.stability as st
from chronofuse.analysis.stability.edf import chi2_interval

__all__ = ["clopper_pearson", "pooled_oadev", "gdop_over_5_fraction"]


def clopper_pearson(k: int, n: int, level: float = 0.99) -> tuple[float, float]:
    """Exact binomial confidence interval of ``k`` successes in ``n`` trials (Clopper & Pearson 1934)."""
    a = 1.0 - level
    lo = stats.beta.ppf(a / 2, k, n - k + 1) if k > 0 else 0.0
    hi = stats.beta.ppf(1 - a / 2, k + 1, n - k) if k < n else 1.0
    return float(lo), float(hi)


def pooled_oadev(x_s: np.ndarray, rate_hz: float, ci: float = 0.683) -> st.Deviation:
    """OADEV of independent trials pooled: mean AVAR, EDF = trials x one trial's EDF.

    ``x_s`` (trials, N) phase in seconds. The trials are independent, so the mean of their Allan
    variances has the sum of their EDFs (chi-square interval of NIST SP 1065 eq. (45) on that EDF);
    ``n`` is the total number of terms. Returns a :class:`Deviation` on the octave grid.
    """
    if x_s.ndim != 2:
        raise ValueError(f"x_s has shape {x_s.shape}, must be (trials, N)")
    per_trial = [st.oadev(row, rate_hz, st.tau_grid("octave", x_s.shape[1], rate_hz, "oadev"), ci=ci) for row in x_s]
    avar = np.mean([d.dev**2 for d in per_trial], axis=0)
    edf = x_s.shape[0] * np.asarray(per_trial[0].edf)
    dev = np.sqrt(avar)
    lo, hi = chi2_interval(dev, edf, ci)
    return dataclasses.replace(
        per_trial[0], dev=dev, edf=edf, lo=lo, hi=hi, n=np.sum([d.n for d in per_trial], axis=0)
    )


def gdop_over_5_fraction(gdop: np.ndarray) -> float:
    """Fraction of the epochs with a fix (finite GDOP) whose GDOP exceeds 5 (SPEC 3.1's usability limit)."""
    with_fix = gdop[np.isfinite(gdop)]
    return float(np.mean(with_fix > 5)) if with_fix.size else float("nan")
