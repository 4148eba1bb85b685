"""Summary metrics over simulated or measured runs: binomial intervals, pooled stability, usability.

Each is a plain function of arrays, used by the experiments and the command line alike.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import stats

import chronofuse.analysis.stability as st
from chronofuse.analysis.stability.edf import chi2_interval

__all__ = ["clopper_pearson", "pooled_oadev", "trial_avar", "pooled_dev", "gdop_over_5_fraction"]


def clopper_pearson(k: int, n: int, level: float = 0.99) -> tuple[float, float]:
    """Exact binomial confidence interval of ``k`` successes in ``n`` trials (Clopper & Pearson 1934)."""
    a = 1.0 - level
    lo = stats.beta.ppf(a / 2, k, n - k + 1) if k > 0 else 0.0
    hi = stats.beta.ppf(1 - a / 2, k + 1, n - k) if k < n else 1.0
    return float(lo), float(hi)


def pooled_oadev(x_s: np.ndarray, rate_hz: float, tau_s: np.ndarray | None = None, ci: float = 0.683) -> st.Deviation:
    """OADEV of independent trials pooled: mean AVAR over the trials, EDF = trials x one trial's EDF.

    ``x_s`` (trials, N) phase in seconds (NaN: a gap); ``tau_s`` (k,) averaging times (default: the octave
    grid). The trials are independent, so the mean of their Allan variances has the sum of their EDFs
    (chi-square interval of NIST SP 1065 eq. (45) on that EDF); at a tau where a trial's gaps leave no
    term, that trial is left out of the mean and of the EDF (NaN where every trial is). ``n`` is the total
    number of terms. Returns a :class:`Deviation`.
    """
    if x_s.ndim != 2:
        raise ValueError(f"x_s has shape {x_s.shape}, must be (trials, N)")
    taus = st.tau_grid("octave", x_s.shape[1], rate_hz, "oadev") if tau_s is None else np.asarray(tau_s, float)
    per_trial = [st.oadev(row, rate_hz, taus, ci=ci) for row in x_s]
    avar = np.array([d.dev**2 for d in per_trial])
    dev = pooled_dev(avar)
    count = np.isfinite(avar).sum(axis=0)
    edf = count * np.asarray(per_trial[0].edf)
    lo, hi = chi2_interval(dev, edf, ci)
    return dataclasses.replace(
        per_trial[0], dev=dev, edf=edf, lo=lo, hi=hi, n=np.sum([d.n for d in per_trial], axis=0)
    )


def trial_avar(x_s: np.ndarray, rate_hz: float, tau_s: np.ndarray) -> np.ndarray:
    """Each trial's overlapping Allan variance (trials, k) at ``tau_s`` (NaN where a trial has no term): what
    :func:`pooled_oadev` pools, for a caller that runs its trials in blocks and pools them with :func:`pooled_dev`."""
    if x_s.ndim != 2:
        raise ValueError(f"x_s has shape {x_s.shape}, must be (trials, N)")
    taus = np.asarray(tau_s, float)
    return np.array([st.oadev(row, rate_hz, taus).dev ** 2 for row in x_s]).reshape(x_s.shape[0], taus.size)


def pooled_dev(avar: np.ndarray) -> np.ndarray:
    """The pooled deviation of :func:`pooled_oadev` from the trials' Allan variances ``avar`` (trials, k): the
    square root of their mean over the trials with a finite value at each tau (NaN where none has)."""
    avar = np.asarray(avar, dtype=float)
    ok = np.isfinite(avar)
    count = ok.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, np.sqrt(np.where(ok, avar, 0.0).sum(axis=0) / np.maximum(count, 1)), np.nan)


def gdop_over_5_fraction(gdop: np.ndarray) -> float:
    """Fraction of the epochs with a fix (finite GDOP) whose GDOP exceeds 5 (source qualification's usability limit)."""
    with_fix = gdop[np.isfinite(gdop)]
    return float(np.mean(with_fix > 5)) if with_fix.size else float("nan")


def horizontal_cep_m(north_east_m: np.ndarray, percent: float) -> float:
    """Circular error probable: the ``percent`` percentile of the horizontal error norm (NaN epochs left out).

    ``north_east_m`` (..., 2). CEP50 is the median radius, CEP95 the radius holding 95 % of the fixes
    (the empirical definition, no distribution assumed).
    """
    radius = np.hypot(north_east_m[..., 0], north_east_m[..., 1])
    radius = radius[np.isfinite(radius)]
    return float(np.percentile(radius, percent)) if radius.size else float("nan")


def vertical_95_m(down_m: np.ndarray) -> float:
    """The 95th percentile of the absolute vertical error (NaN epochs left out)."""
    v = np.abs(down_m[np.isfinite(down_m)])
    return float(np.percentile(v, 95.0)) if v.size else float("nan")


def outage_bridging_s(horizontal_m: np.ndarray, outage: np.ndarray, interval_s: float,
                      thresholds_m=(2.0, 10.0)) -> dict[str, float]:
    """How long the error stays under each threshold once an outage starts, worst case over trials and outages.

    ``horizontal_m`` (trials, epochs) horizontal error; ``outage`` (epochs,) bool, True where no fix could be
    had. For each outage and trial: the time from the outage's start until the error first exceeds the
    threshold (the outage's length if it never does; 0 if it already did at the start). Outages cut by the
    end of the record are left out (their length is unknown). Returns ``{"2m": seconds, "10m": seconds}``,
    the minimum over every (trial, outage); NaN when there is no complete outage.
    """
    edges = np.flatnonzero(np.diff(np.r_[0, outage.astype(np.int8), 0]))
    spans = [(s, e) for s, e in zip(edges[::2], edges[1::2]) if e < outage.size]
    out = {}
    for limit in thresholds_m:
        worst = float("nan")
        for start, end in spans:
            over = horizontal_m[:, start:end] > limit
            first = np.where(over.any(axis=1), over.argmax(axis=1), end - start)
            worst = float(np.nanmin([worst, first.min() * interval_s]))
        out[f"{limit:g}m"] = worst
    return out
