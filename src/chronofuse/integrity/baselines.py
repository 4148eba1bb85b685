"""Simple detectors to beat: single-epoch threshold, CUSUM, comparison with a reference clock.

All implement the :mod:`chronofuse.estimation.interface` contract, as the
:class:`~chronofuse.integrity.detector.HodDetector` does: ``__init__`` stores its arguments, ``fit`` learns
(``_``-suffixed attributes), ``run`` takes (steps,) or (trials, steps) with NaN for a missing epoch and
returns a frozen :class:`~chronofuse.integrity.result.DetectionResult` with read-only arrays, and ``step`` is
the streaming path with the same numbers. The reference-clock detector's extra input, the reference
reading ``reference_s``, is declared in its ``inputs`` and passed by keyword like any estimator input.

* :class:`SingleEpochDetector`: ``|df(k)| / sqrt(r(0)) > z``, ``z = Phi^-1(1 - P_fa / 2)`` (two-sided normal).
  It equals the HOD test with a window of one (``df^2 / r(0) ~ chi2(1)``).
* :class:`CusumDetector`: two-sided CUSUM (Page 1954; Basseville & Nikiforov 1993, eq. 2.2.11) on the
  normalised one-step innovations of ``df`` (the last whitened component of the HOD window, N(0, 1) under
  H0): ``S+(k) = max(0, S+(k-1) + e(k) - drift)``, ``S-(k) = max(0, S-(k-1) - e(k) - drift)``, statistic
  ``max(S+, S-)``. The threshold ``h`` makes the per-epoch false-alarm rate P_fa; it is calibrated by
  simulating the fitted noise model (:mod:`chronofuse.integrity.simulate`) with a fixed seed
  (``calibration_steps`` epochs, raised to ``400 / P_fa`` up to 4e6), taking the ``1 - P_fa`` quantile of the
  stationary statistic. A gap resets the sums. CUSUM alarms come in runs (the sums carry over), so its
  per-epoch rate is matched on average, not epoch by independent epoch.
* :class:`ReferenceClockDetector`: with a reference clock's reading of the same receiver clock, the
  residual ``d = bias - reference`` is white under H0 (measurement noise only); the statistic is
  ``|mean of the last k residuals - offset| / (sigma / sqrt(k))`` against ``z``, ``k`` up to ``window``.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import ClassVar

import numba
import numpy as np
from scipy import stats

from chronofuse.estimation.interface import nan_if_none
from chronofuse.estimation.process import second_difference
from chronofuse.integrity.detector import HodDetector
from chronofuse.integrity.result import DetectionResult, StepOutput
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
from chronofuse.integrity.statistic import chain_dof, high_order_difference
from chronofuse.validation import check_array, check_scalar

# ---------------------------------------------------------------------------------------------------------
# Single-epoch threshold
# ---------------------------------------------------------------------------------------------------------


class SingleEpochDetector:
    """Alarm when one difference exceeds ``z sqrt(r(0))``; noise parameters as :class:`HodDetector`."""

    inputs: ClassVar[tuple[str, ...]] = ()
    window: ClassVar[int] = 1  # one difference per test

    def __init__(self, *, interval_s: float, pfa: float = 1e-3, h0=None, hm2=None, sigma_rho_m=None):
        self.interval_s = interval_s
        self.pfa = pfa
        self.h0 = h0
        self.hm2 = hm2
        self.sigma_rho_m = sigma_rho_m

    def fit(self, clock_bias_s=None) -> SingleEpochDetector:
        """Set ``r(0)`` from the given or estimated noise parameters (see :meth:`HodDetector.fit`)."""
        model = HodDetector(interval_s=self.interval_s, window=1, pfa=self.pfa, h0=self.h0, hm2=self.hm2,
                            sigma_rho_m=self.sigma_rho_m).fit(clock_bias_s)
        self.h0_, self.hm2_, self.sigma_rho_m_ = model.h0_, model.hm2_, model.sigma_rho_m_
        self.r_, self.inflation_, self.training_outliers_ = model.r_, model.inflation_, model.training_outliers_
        self.sigma_df_ = float(math.sqrt(model.r_[0]))
        self.threshold_ = float(stats.norm.isf(self.pfa / 2.0))
        self.reset()
        return self

    def run(self, clock_bias_s) -> DetectionResult:
        """Test every epoch; (steps,) or (trials, steps), NaN = missing."""
        x = check_array(clock_bias_s, "clock_bias_s", ndim=(1, 2), allow_nan=True)
        df = high_order_difference(x, self.interval_s)
        stat = np.abs(df) / self.sigma_df_
        dof = np.isfinite(df).astype(np.int64)
        return DetectionResult.from_statistic(stat, dof, np.where(dof > 0, self.threshold_, np.nan), x, 1, self.pfa)

    def reset(self) -> None:
        self._prev = [math.nan, math.nan]

    def step(self, clock_bias_s: float) -> StepOutput:
        """One epoch of :meth:`run`."""
        x = nan_if_none(clock_bias_s)
        p1, p2 = self._prev
        self._prev = [x, p1]
        df = second_difference(x, p1, p2, self.interval_s)
        if math.isnan(df):
            return StepOutput(math.nan, False, 0, math.nan, math.isnan(x))
        stat = abs(df) / self.sigma_df_
        return StepOutput(stat, stat > self.threshold_, 1, self.threshold_, False, df / self.sigma_df_)


# ---------------------------------------------------------------------------------------------------------
# CUSUM
# ---------------------------------------------------------------------------------------------------------


@numba.njit(cache=True)
def cusum_kernel(e: np.ndarray, drift: float) -> np.ndarray:
    """Two-sided CUSUM ``max(S+, S-)`` along axis 1 of ``e`` (rows, steps); NaN in ``e`` resets, gives NaN."""
    out = np.empty_like(e)
    for i in range(e.shape[0]):
        sp = 0.0
        sm = 0.0
        for k in range(e.shape[1]):
            v = e[i, k]
            if np.isnan(v):
                sp = 0.0
                sm = 0.0
                out[i, k] = np.nan
                continue
            sp = max(0.0, sp + v - drift)
            sm = max(0.0, sm - v - drift)
            out[i, k] = max(sp, sm)
    return out


def cusum_reference(e: np.ndarray, drift: float) -> np.ndarray:
    """Readable twin of :func:`cusum_kernel` (plain Python loop over one (rows, steps) array)."""
    out = np.full(e.shape, np.nan)
    for i, row in enumerate(e):
        s_plus = s_minus = 0.0
        for k, v in enumerate(row):
            if np.isnan(v):
                s_plus = s_minus = 0.0
                continue
            s_plus = max(0.0, s_plus + v - drift)
            s_minus = max(0.0, s_minus - v - drift)
            out[i, k] = max(s_plus, s_minus)
    return out


# Calibration length: at least 400 expected exceedances of the threshold, at most this many epochs.
_MAX_CALIBRATION_STEPS = 4_000_000


@lru_cache(maxsize=64)
def _calibrated_threshold(params: tuple, interval_s: float, window: int, drift: float, pfa: float, steps: int,
                          seed: int) -> float:
    model = HodDetector(interval_s=interval_s, window=window, h0=params[0], hm2=params[1], sigma_rho_m=params[2]).fit()
    chains = 4
    sim = simulate_clock_bias(ClockNoise(*params), interval_s=interval_s, steps=steps // chains + 1000, trials=chains,
                              seed=seed)
    s = cusum_kernel(model.innovations(sim.measured_s), drift)[:, 1000:]
    return float(np.quantile(s, 1.0 - pfa))


class CusumDetector:
    """Two-sided CUSUM on the normalised innovations of ``df`` (module docstring), threshold calibrated to P_fa.

    ``drift`` is the reference value (in innovation standard deviations), tuned to a mean shift of
    ``2 drift``; ``window`` is the HOD window that predicts each difference.
    """

    inputs: ClassVar[tuple[str, ...]] = ()

    def __init__(self, *, interval_s: float, window: int = 20, pfa: float = 1e-3, drift: float = 0.5, h0=None,
                 hm2=None, sigma_rho_m=None, calibration_steps: int = 400_000, calibration_seed: int = 20_240):
        self.interval_s = interval_s
        self.window = window
        self.pfa = pfa
        self.drift = drift
        self.h0 = h0
        self.hm2 = hm2
        self.sigma_rho_m = sigma_rho_m
        self.calibration_steps = calibration_steps
        self.calibration_seed = calibration_seed

    def fit(self, clock_bias_s=None) -> CusumDetector:
        check_scalar(self.drift, "drift", min_val=0.0)
        check_scalar(self.calibration_steps, "calibration_steps", min_val=10_000, integer=True)
        check_scalar(self.pfa, "pfa", min_val=10.0 / self.calibration_steps, max_val=0.5)
        self.model_ = HodDetector(interval_s=self.interval_s, window=self.window, pfa=self.pfa, h0=self.h0,
                                  hm2=self.hm2, sigma_rho_m=self.sigma_rho_m).fit(clock_bias_s)
        self.h0_, self.hm2_, self.sigma_rho_m_ = self.model_.h0_, self.model_.hm2_, self.model_.sigma_rho_m_
        self.r_, self.inflation_ = self.model_.r_, self.model_.inflation_
        self.training_outliers_ = self.model_.training_outliers_
        steps = max(int(self.calibration_steps), min(int(400 / self.pfa), _MAX_CALIBRATION_STEPS))
        self.threshold_ = _calibrated_threshold((self.h0_, self.hm2_, self.sigma_rho_m_), float(self.interval_s),
                                                int(self.window), float(self.drift), float(self.pfa), steps,
                                                int(self.calibration_seed))
        self.reset()
        return self

    def run(self, clock_bias_s) -> DetectionResult:
        x = check_array(clock_bias_s, "clock_bias_s", ndim=(1, 2), allow_nan=True)
        e = self.model_.innovations(x)
        stat = cusum_kernel(np.atleast_2d(e), float(self.drift)).reshape(e.shape)
        dof = chain_dof(high_order_difference(x, self.interval_s), int(self.window))
        return DetectionResult.from_statistic(stat, dof, np.where(dof > 0, self.threshold_, np.nan), x, int(self.window), self.pfa)

    def reset(self) -> None:
        self._s = [0.0, 0.0]
        if hasattr(self, "model_"):
            self.model_.reset()

    def step(self, clock_bias_s: float) -> StepOutput:
        out = self.model_.step(clock_bias_s)
        if out.dof == 0:
            self._s = [0.0, 0.0]
            return StepOutput(math.nan, False, 0, math.nan, out.skipped)
        e = out.innovation
        sp = max(0.0, self._s[0] + e - self.drift)
        sm = max(0.0, self._s[1] - e - self.drift)
        self._s = [sp, sm]
        stat = max(sp, sm)
        return StepOutput(stat, stat > self.threshold_, out.dof, self.threshold_, False, e)


# ---------------------------------------------------------------------------------------------------------
# Reference clock
# ---------------------------------------------------------------------------------------------------------


class ReferenceClockDetector:
    """Window mean of ``bias - reference`` against its H0 spread; ``offset_s`` and ``sigma_s`` learnt if None.

    ``fit(clock_bias_s, reference_s=...)``, ``run(clock_bias_s, reference_s=...)`` and
    ``step(clock_bias_s, reference_s=...)`` take the reference clock's reading of the receiver clock (s)
    beside the receiver's clock bias, the extra input it declares in ``inputs``; NaN in either = missing epoch.
    """

    inputs: ClassVar[tuple[str, ...]] = ("reference_s",)

    def __init__(self, *, interval_s: float, window: int = 20, pfa: float = 1e-3, sigma_s: float | None = None,
                 offset_s: float | None = None):
        self.interval_s = interval_s
        self.window = window
        self.pfa = pfa
        self.sigma_s = sigma_s
        self.offset_s = offset_s

    def fit(self, clock_bias_s=None, reference_s=None) -> ReferenceClockDetector:
        """Learn the residual's mean and standard deviation from an anomaly-free stretch (unless given)."""
        check_scalar(self.window, "window", min_val=1, integer=True)
        check_scalar(self.pfa, "pfa", min_val=0.0, max_val=1.0, include_min=False, include_max=False)
        if self.sigma_s is None or self.offset_s is None:
            if clock_bias_s is None or reference_s is None:
                raise ValueError("sigma_s or offset_s not given: fit() needs training clock biases and reference")
            d = self._residual(clock_bias_s, reference_s)
            d = d[np.isfinite(d)]
            if d.size < 2:
                raise ValueError("fewer than two valid training residuals")
        self.offset_s_ = float(np.mean(d)) if self.offset_s is None else float(self.offset_s)
        self.sigma_s_ = float(np.std(d, ddof=1)) if self.sigma_s is None else float(self.sigma_s)
        check_scalar(self.sigma_s_, "sigma_s", min_val=0.0, include_min=False)
        self.threshold_ = float(stats.norm.isf(self.pfa / 2.0))
        self.reset()
        return self

    @staticmethod
    def _residual(clock_bias_s, reference_s) -> np.ndarray:
        x = check_array(clock_bias_s, "clock_bias_s", ndim=(1, 2), allow_nan=True)
        ref = check_array(reference_s, "reference_s", ndim=(1, 2), allow_nan=True)
        if ref.shape != x.shape:
            raise ValueError(f"reference_s has shape {ref.shape}, must equal clock_bias_s's {x.shape}")
        return x - ref

    def run(self, clock_bias_s, reference_s) -> DetectionResult:
        x = check_array(clock_bias_s, "clock_bias_s", ndim=(1, 2), allow_nan=True)
        d = self._residual(x, reference_s) - self.offset_s_
        dof = chain_dof(d, int(self.window))
        filled = np.where(np.isfinite(d), d, 0.0)
        csum = np.concatenate([np.zeros(d.shape[:-1] + (1,)), np.cumsum(filled, axis=-1)], axis=-1)
        idx = np.arange(d.shape[-1]) + 1
        window_sum = csum[..., 1:] - np.take_along_axis(csum, idx - dof, axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            stat = np.abs(window_sum / dof) / (self.sigma_s_ / np.sqrt(dof))
        stat = np.where(dof > 0, stat, np.nan)
        skipped = np.isnan(x) | np.isnan(np.asarray(reference_s, dtype=np.float64))
        return DetectionResult.from_statistic(stat, dof, np.where(dof > 0, self.threshold_, np.nan), np.where(skipped, np.nan, x),
                       int(self.window), self.pfa)

    def reset(self) -> None:
        self._buf: list[float] = []

    def step(self, clock_bias_s: float, reference_s: float) -> StepOutput:
        x = nan_if_none(clock_bias_s)
        ref = nan_if_none(reference_s)
        d = x - ref - self.offset_s_
        if math.isnan(d):
            self._buf = []
            return StepOutput(math.nan, False, 0, math.nan, True)
        self._buf.append(d)
        if len(self._buf) > self.window:
            self._buf.pop(0)
        k = len(self._buf)
        stat = abs(math.fsum(self._buf) / k) / (self.sigma_s_ / math.sqrt(k))
        return StepOutput(stat, stat > self.threshold_, k, self.threshold_, False)
