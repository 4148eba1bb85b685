"""Sync metrics: RMSE (the swarm paper's eq. 47) with its confidence interval, its ratio to a bound,
convergence epochs, robustness, communication overhead (eqs. 48-51), and a follower's time-error
statistics (percentiles, MTIE and TDEV against an ITU-T mask).

Intervals are percentile bootstraps over trials (Efron and Tibshirani, *An Introduction to the Bootstrap*,
1993, ch. 13): each trial is one link with its own prior draw and its own calibration, so resampling trials
carries the calibration-to-calibration spread into the interval. A ratio to the bound resamples the
trials' mean-square errors and their bounds together.

An algorithm and its bound are averaged over the same exchanges: those where the algorithm gave an
estimate (:func:`per_trial_bound_var`). An algorithm that gives no estimate before its first exchange got
through (or before it has enough of them) would otherwise be scored only where it knows the offset to a
nanosecond while the bound is averaged over the exchanges before that too, where it is the prior's
microsecond: with half of the exchanges lost in bursts of 20 the paper's chain came out at 0.02x "the bound".
The bound of the exchanges an algorithm is scored on is still a bound there (the Bayesian bound holds at
each exchange, for any estimator); which exchanges those are is set by the losses and by how many exchanges
the algorithm needs before its first output, and both are reported (an algorithm that waits long for its
first output is compared with a bound that waits with it, so its convergence time K* says what it costs).

A trial in which an algorithm never produced an estimate (every exchange lost, or too few for it to start)
has no mean-square error: :func:`per_trial_mse` gives NaN there and :func:`scored_trials` finds them; the
callers count and report such trials and leave them out of the RMSE and the ratio, never silently.

Fewer than :data:`MIN_INTERVAL_TRIALS` trials give no interval (NaN bounds): a percentile bootstrap over one
trial has zero width, and over a handful it misses far more often than its nominal 5 %.
"""

from __future__ import annotations

import numpy as np

from chronofuse.validation import check_array, check_scalar

__all__ = ["rmse_s", "running_rmse_s", "convergence_epochs", "robustness", "overhead", "per_trial_mse",
           "rmse_interval", "ratio_interval", "per_trial_bound_var", "time_error_statistics", "scored_trials",
           "MIN_INTERVAL_TRIALS"]

_BOOT = 2000
#: The fewest trials a bootstrap interval is given for (below it the interval's bounds are NaN). Measured
#: on 400 links of the default scenario (``tests/sync/test_metrics.py`` checks the rule): the 95 %
#: percentile-bootstrap interval of the RMSE covers the truth in ~0.5 of runs at 2 trials and ~0.8 at 5.
MIN_INTERVAL_TRIALS = 10


def _nanmean_rows(x: np.ndarray, axis: int) -> np.ndarray:
    """``nanmean`` along ``axis`` that gives NaN for an all-NaN slice without a RuntimeWarning."""
    ok = np.isfinite(x)
    count = ok.sum(axis=axis)
    total = np.where(ok, x, 0.0).sum(axis=axis)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def rmse_s(error_s) -> float:
    """Eq. (47): ``sqrt(mean(err^2))`` over every trial and exchange (NaN = no estimate yet, left out)."""
    err = check_array(error_s, "error_s", ndim=2, allow_nan=True)
    return float(np.sqrt(_nanmean_rows(err.ravel() ** 2, axis=0)))


def per_trial_mse(error_s) -> np.ndarray:
    """Each trial's mean-square error over its exchanges (trials,), s^2 (NaN left out); NaN for a trial
    with no estimate at all (:func:`scored_trials`)."""
    err = check_array(error_s, "error_s", ndim=2, allow_nan=True)
    return _nanmean_rows(err**2, axis=1)


def per_trial_bound_var(bound_var_s2, error_s) -> np.ndarray:
    """The bound's mean over the exchanges each trial's ``error_s`` (trials, steps) is scored on (finite
    there), (trials,), s^2: the denominator of that trial's ratio (module docstring); NaN where the trial has
    no estimate at all, as :func:`per_trial_mse` is."""
    bnd = check_array(bound_var_s2, "bound_var_s2", ndim=2)
    err = check_array(error_s, "error_s", ndim=2, allow_nan=True)
    if bnd.shape != err.shape:
        raise ValueError(f"bound_var_s2 {bnd.shape} and error_s {err.shape} must agree")
    return _nanmean_rows(np.where(np.isfinite(err), bnd, np.nan), axis=1)


def scored_trials(mse_per_trial) -> np.ndarray:
    """The trials (a bool mask) that have a mean-square error: those where the algorithm gave an estimate."""
    return np.isfinite(check_array(mse_per_trial, "mse_per_trial", ndim=1, allow_nan=True))


def _boot_index(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, n, size=(_BOOT, n))


def rmse_interval(mse_per_trial, confidence: float = 0.95, seed: int = 0) -> tuple[float, float, float]:
    """``(rmse, lo, hi)``: ``sqrt(mean(mse))`` and its percentile-bootstrap interval over trials (``lo`` and
    ``hi`` NaN below :data:`MIN_INTERVAL_TRIALS` trials)."""
    mse = check_array(mse_per_trial, "mse_per_trial", ndim=1)
    check_scalar(confidence, "confidence", min_val=0.0, max_val=1.0, include_min=False, include_max=False)
    if mse.size < MIN_INTERVAL_TRIALS:
        return float(np.sqrt(mse.mean())), float("nan"), float("nan")
    idx = _boot_index(mse.size, seed)
    boot = np.sqrt(mse[idx].mean(axis=1))
    a = (1.0 - confidence) / 2.0
    return float(np.sqrt(mse.mean())), float(np.quantile(boot, a)), float(np.quantile(boot, 1.0 - a))


def ratio_interval(mse_per_trial, bound_var_per_trial, confidence: float = 0.95, seed: int = 0):
    """``(ratio, lo, hi)``: ``sqrt(mean(mse) / mean(bound))`` (an RMSE over the bound's RMS) and its
    paired percentile-bootstrap interval over trials (``lo`` and ``hi`` NaN below :data:`MIN_INTERVAL_TRIALS`)."""
    mse = check_array(mse_per_trial, "mse_per_trial", ndim=1)
    bnd = check_array(bound_var_per_trial, "bound_var_per_trial", ndim=1)
    if mse.shape != bnd.shape:
        raise ValueError(f"mse_per_trial {mse.shape} and bound_var_per_trial {bnd.shape} must agree")
    if mse.size < MIN_INTERVAL_TRIALS:
        return float(np.sqrt(mse.mean() / bnd.mean())), float("nan"), float("nan")
    idx = _boot_index(mse.size, seed)
    boot = np.sqrt(mse[idx].mean(axis=1) / bnd[idx].mean(axis=1))
    a = (1.0 - confidence) / 2.0
    return float(np.sqrt(mse.mean() / bnd.mean())), float(np.quantile(boot, a)), float(np.quantile(boot, 1.0 - a))


def running_rmse_s(error_s) -> np.ndarray:
    """``RMSE_k``: the RMSE over trials at each exchange ``k``, shape (steps,)."""
    err = check_array(error_s, "error_s", ndim=2, allow_nan=True)
    return np.sqrt(_nanmean_rows(err**2, axis=0))


def convergence_epochs(error_s, threshold_s: float, start: int = 0) -> int | None:
    """Eq. (48)/(50): ``K* = min{k >= start: RMSE_k <= tau}``, counted from ``start``; None if never."""
    check_scalar(threshold_s, "threshold_s", min_val=0.0, include_min=False)
    r = running_rmse_s(error_s)[int(start):]
    hit = np.flatnonzero(r <= threshold_s)
    return int(hit[0]) if hit.size else None


def robustness(error_nominal_s, error_stress_s, threshold_s: float, stress_end: int) -> dict:
    """Eqs. (49)-(50): ``delta_rmse_s = RMSE_stress - RMSE_nominal`` and the recovery epochs after the
    stress ends at exchange ``stress_end`` (None if the RMSE never returns below ``threshold_s``)."""
    return {"delta_rmse_s": rmse_s(error_stress_s) - rmse_s(error_nominal_s),
            "recovery_epochs": convergence_epochs(error_stress_s, threshold_s, start=stress_end)}


def overhead(interval_s: float, request_bits: int = 128, reply_bits: int = 256) -> dict:
    """Eq. (51): messages and bits per second of one link exchanging every ``interval_s``.

    A request carries a header and its slot number (default 128 bits); the reply also carries ``T_i``
    and ``T_B`` as two 64-bit timestamps (default 256 bits). Sizes are assumptions, not the paper's.
    """
    check_scalar(interval_s, "interval_s", min_val=0.0, include_min=False)
    rate = 1.0 / interval_s
    return {"messages_per_s": 2.0 * rate, "bits_per_s": (request_bits + reply_bits) * rate}


def time_error_statistics(te_s, rate_hz: float, mask: str | None = "prtc-b") -> dict:
    """A follower's time-error record ``te_s`` (N,) (NaN: none) summarised: RMS, percentiles of ``|TE|``
    (50, 95, 99 %) and max, and its MTIE and TDEV (:mod:`chronofuse.analysis.stability`, octave taus)
    against the ITU-T ``mask`` (:data:`chronofuse.analysis.masks.MASKS`; None: no mask). All in s."""
    from chronofuse.analysis.masks import MASKS
    from chronofuse.analysis.stability import mtie, tau_grid, tdev

    te = check_array(te_s, "te_s", ndim=1, allow_nan=True)
    ok = np.isfinite(te)
    if ok.sum() < 4:
        raise ValueError("te_s has fewer than 4 valid samples")
    a = np.abs(te[ok])
    out = {"rms_s": float(np.sqrt(np.mean(te[ok] ** 2))), "max_abs_s": float(a.max()),
           "p50_abs_s": float(np.percentile(a, 50)), "p95_abs_s": float(np.percentile(a, 95)),
           "p99_abs_s": float(np.percentile(a, 99))}
    m = mtie(te, rate_hz, tau_grid("octave", te.size, rate_hz, "mtie"))
    t = tdev(te, rate_hz, tau_grid("octave", te.size, rate_hz, "tdev"))
    out["mtie"] = {"tau_s": [float(v) for v in m.tau_s], "mtie_s": [float(v) for v in m.dev]}
    out["tdev"] = {"tau_s": [float(v) for v in t.tau_s], "tdev_s": [float(v) for v in t.dev]}
    if mask is not None:
        clock = MASKS[mask]
        rm, rt = clock.mtie.check(m), clock.tdev.check(t)
        # passed: a complete PASS; status also tells "incomplete" (taus the record does not cover) from "fail"
        out["mask"] = {"name": mask, "mtie_passed": bool(rm.passed), "tdev_passed": bool(rt.passed),
                       "mtie_status": rm.status, "tdev_status": rt.status,
                       "evaluated": bool(rm.evaluated.any() or rt.evaluated.any())}
    return out
