"""High-order-difference (HOD) chi-square detector of receiver clock-bias anomalies.

The reconstruction of the detection patent (its formulas are lost from the text we have; docs/sources.md):

* second difference of the clock bias ``t_u`` sampled every ``t_s``::

      df(k) = (t_u(k) - 2 t_u(k-1) + t_u(k-2)) / t_s

* noise model: white FM ``h0``, random-walk FM ``h_-2`` and white measurement noise from the mean
  pseudorange noise ``sigma_rho`` (m): ``q1 = h0/2``, ``q2 = 2 pi^2 h_-2``, ``s2 = sigma_rho^2 / c^2``, and
  the autocorrelation of ``df`` (exact for the two-state clock model, Brown & Hwang ch. 9 / Van
  Dierendonck 1984, plus white phase noise)::

      r(0) = (2 q1 t_s + 2/3 q2 t_s^3 + 6 s2) / t_s^2
      r(1) = (-q1 t_s + 1/6 q2 t_s^3 - 4 s2) / t_s^2
      r(2) = s2 / t_s^2,   r(tau >= 3) = 0

* ``C = toeplitz(r(0) .. r(n-1))`` and the whitening filter ``D = L^-1`` (``C = L L^T``, Cholesky), so
  ``D C D^T = I``; the statistic over the last ``n`` differences ``v`` is
  ``T(k) = |D v|^2 = v^T C^-1 v ~ chi2(n)`` under H0, threshold ``gamma = F^-1_chi2(n)(1 - P_fa)``.

Start-up and gaps. The window holds the differences of one unbroken chain. A difference needs three
consecutive valid clock biases, so the first two epochs of the record (and of every chain) have no
statistic (``dof = 0``, statistic NaN, never an alarm). With ``k < n`` differences available the test uses
those ``k``: the leading ``k x k`` block of ``C`` (Toeplitz, so the covariance of any ``k`` consecutive
differences), whitened by ``L[:k, :k]^-1`` (the leading block of ``L^-1``), chi-square with ``k`` dof and
threshold ``gamma_k``. A missing epoch (NaN) breaks the difference chain: the window restarts after it
(no difference spans a gap, since its noise would not follow the model). The NaN epochs are counted in
``n_skipped``.

Changed sampling interval. ``r(0..2)`` depend on ``t_s``, so a detector is built for one ``interval_s``; data
at another interval need a new detector (the command line checks its time column and names the line
where the interval changes).

Layout. The noise model and its fit are in :mod:`chronofuse.integrity.noise_model`, the pure statistic
(differences, chains, whitener, thresholds, the batched quadratic form) in
:mod:`chronofuse.integrity.statistic`, the result types in :mod:`chronofuse.integrity.result`; this module
holds the detector, which implements the :mod:`chronofuse.estimation.interface` contract. Its batch
:meth:`HodDetector.run` computes the whitened windows of every epoch at once; the streaming
:meth:`HodDetector.step` keeps the last two biases and the last ``n`` differences and computes the same
quadratic form for one window (both take the second difference from
:func:`chronofuse.estimation.process.second_difference`).
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from scipy import stats

from chronofuse.estimation.interface import nan_if_none
from chronofuse.estimation.process import second_difference
from chronofuse.integrity.noise_model import (
    contiguous_runs,
    difference_autocorrelation,
    empirical_autocorrelation,
    fit_noise,
    fit_noise_whittle,
    noise_intensities,
    training_outliers,
)
from chronofuse.integrity.result import DetectionResult, StepOutput
from chronofuse.integrity.statistic import (
    chain_dof,
    chi2_thresholds,
    high_order_difference,
    last_innovation,
    toeplitz_whitener,
    window_statistic,
)
from chronofuse.validation import check_array, check_choice, check_scalar

# The names callers import from here (the module's public surface before it was split by idea).
__all__ = [
    "DetectionResult",
    "HodDetector",
    "StepOutput",
    "chain_dof",
    "chi2_thresholds",
    "difference_autocorrelation",
    "effective_squares",
    "empirical_autocorrelation",
    "fit_noise",
    "fit_noise_whittle",
    "high_order_difference",
    "last_innovation",
    "noise_intensities",
    "toeplitz_whitener",
    "training_inflation",
    "window_statistic",
]


def effective_squares(m: int, r, n_free: int = 0) -> float:
    """The number of independent squares a mean square of ``m`` consecutive differences of autocorrelation
    ``r = [r(0), r(1), r(2)]`` is worth, less ``n_free`` fitted parameters: ``(m - n_free) / (1 + 2 (rho1^2 +
    rho2^2))``, ``rho_k = r(k) / r(0)``, at least 1.

    Bartlett's variance of a sample autocovariance of a Gaussian series, ``Var(r_hat(0)) = (2 r(0)^2 / m)
    sum_k rho_k^2`` over all lags (M. S. Bartlett, "On the theoretical specification and sampling properties of
    autocorrelated time-series", JRSS Suppl. 8, 1946; M. B. Priestley, "Spectral Analysis and Time Series",
    1981, eq. 5.3.21), equals that of ``chi2(m_eff) / m_eff`` with ``m_eff = m / (1 + 2 sum_{k>=1} rho_k^2)``;
    the differences are MA(2), so the sum stops at lag 2. The fitted parameters are taken off as the
    residual degrees of freedom of a regression (an approximation whose effect on P_fa is checked by
    simulation in ``tests/integrity/test_detector.py`` at 18, 100, 1000 and 10000 training differences).
    """
    r = np.asarray(r, dtype=np.float64)
    rho = r[1:3] / r[0] if r[0] > 0 else np.zeros(2)
    return max(1.0, (m - n_free) / (1.0 + 2.0 * float(rho @ rho)))


def training_inflation(m: int, r, n_free: int, confidence: float) -> float:
    """Scale of a fitted covariance that keeps P_fa at or below nominal in ``confidence`` of trainings.

    The upper ``confidence`` bound of a variance estimated from ``m_eff`` independent squares
    (:func:`effective_squares`): ``m_eff / F^-1_chi2(m_eff)(1 - confidence)`` (the one-sided chi-square
    confidence interval of a variance, NIST/SEMATECH e-Handbook of Statistical Methods 7.2.3.1, with
    Bartlett's equivalent degrees of freedom). ``m`` training differences, ``r`` the fitted ``r(0..2)``,
    ``n_free`` the noise parameters fitted.
    """
    m_eff = effective_squares(m, r, n_free)
    return float(m_eff / stats.chi2.ppf(1.0 - confidence, m_eff))


class HodDetector:
    """High-order-difference chi-square detector, scikit-learn style.

    Parameters
    ----------
    interval_s : float
        Sampling interval ``t_s`` of the clock bias (s). A different interval needs a new detector.
    window : int
        Window length ``n`` (differences).
    pfa : float
        False-alarm probability per epoch.
    h0, hm2, sigma_rho_m : float or None
        White FM level (s), random-walk FM level (1/s), mean pseudorange noise (m). Those left None are
        estimated by :meth:`fit` from an anomaly-free training stretch.
    confidence : float or None
        When the noise is fitted from training data: keep the false-alarm rate at or below ``pfa`` with
        this probability over trainings. The fitted covariance ``C`` is scaled up by
        :func:`training_inflation`: the upper ``confidence`` bound of a variance estimated from the
        training's effective number of independent squares (its ``m`` correlated differences, less the
        parameters fitted), so an underestimated noise level (the cause of the excess false alarms after
        short trainings) is covered. None (default): the fitted model as it is. The scale is ``inflation_``.

    Notes
    -----
    Learnt attributes (after :meth:`fit`): ``h0_``, ``hm2_``, ``sigma_rho_m_``, ``r_`` (r(0..2)),
    ``whitener_`` ((n, n), ``D = L^-1``), ``threshold_`` (gamma for ``n`` dof), ``thresholds_`` ((n+1,), per dof).

    It implements :class:`chronofuse.estimation.interface.Estimator` with no extra input (``inputs = ()``).
    """

    inputs: ClassVar[tuple[str, ...]] = ()

    def __init__(
        self,
        *,
        interval_s: float,
        window: int = 20,
        pfa: float = 1e-3,
        h0: float | None = None,
        hm2: float | None = None,
        sigma_rho_m: float | None = None,
        confidence: float | None = None,
    ):
        self.interval_s = interval_s
        self.window = window
        self.pfa = pfa
        self.h0 = h0
        self.hm2 = hm2
        self.sigma_rho_m = sigma_rho_m
        self.confidence = confidence

    # -- fitting ------------------------------------------------------------------------------------------

    def _check_params(self) -> None:
        check_scalar(self.interval_s, "interval_s", min_val=0.0, include_min=False)
        check_scalar(self.window, "window", min_val=1, integer=True)
        check_scalar(self.pfa, "pfa", min_val=0.0, max_val=1.0, include_min=False, include_max=False)
        for name in ("h0", "hm2", "sigma_rho_m"):
            value = getattr(self, name)
            if value is not None:
                check_scalar(value, name, min_val=0.0)
        if getattr(self, "confidence", None) is not None:
            check_scalar(self.confidence, "confidence", min_val=0.0, max_val=1.0, include_min=False,
                         include_max=False)

    def fit(self, clock_bias_s=None, *, method: str = "whittle", robust: bool = True) -> HodDetector:
        """Set the noise model, whitener and thresholds; estimate missing noise parameters from training data.

        ``clock_bias_s``: anomaly-free training clock biases (s), shape (steps,) or (trials, steps), NaN =
        missing; not needed (None) when ``h0``, ``hm2`` and ``sigma_rho_m`` are all given. ``method``:
        ``"whittle"`` (default, :func:`fit_noise_whittle`, the spectrum of ``df``) or ``"autocorrelation"``
        (:func:`fit_noise`, the ``r(0..2)`` formulas of :mod:`~chronofuse.integrity.noise_model` solved for the empirical ``r(0..2)``, clipped >= 0).
        ``robust`` (default): epochs with an outlying second difference are left out of the fit
        (:func:`chronofuse.integrity.noise_model.training_outliers`: one spike or step in training would
        otherwise inflate the fitted noise and blind the detector); ``training_outliers_`` marks them (bool,
        the input's shape). When no unbroken run of 8 differences is left for Whittle's fit, the
        autocorrelation fit (which takes gaps) is used.
        """
        self._check_params()
        params = (self.h0, self.hm2, self.sigma_rho_m)
        inflation = 1.0
        if all(p is not None for p in params):
            h0, hm2, sigma = params
            self.training_outliers_ = np.zeros(0, dtype=bool)
        else:
            if clock_bias_s is None:
                missing = [n for n, p in zip(("h0", "hm2", "sigma_rho_m"), params) if p is None]
                raise ValueError(f"{', '.join(missing)} not given: fit() needs anomaly-free training clock biases")
            x = check_array(clock_bias_s, "clock_bias_s", ndim=(1, 2), allow_nan=True, min_length=3)
            check_choice(method, "method", ("whittle", "autocorrelation"))
            outliers = training_outliers(x) if robust else np.zeros(x.shape, dtype=bool)
            self.training_outliers_ = outliers
            x = np.where(outliers, np.nan, x)
            df = high_order_difference(x, self.interval_s)
            known = dict(h0=self.h0, hm2=self.hm2, sigma_rho_m=self.sigma_rho_m)
            if method == "whittle" and not (outliers.any() and not contiguous_runs(df, 8)):
                h0, hm2, sigma = fit_noise_whittle(df, self.interval_s, **known)
            else:
                h0, hm2, sigma = fit_noise(empirical_autocorrelation(df), self.interval_s, **known)
            confidence = getattr(self, "confidence", None)
            if confidence is not None:
                r_fit = difference_autocorrelation(h0, hm2, sigma, self.interval_s)
                n_free = sum(p is None for p in params)
                inflation = training_inflation(int(np.isfinite(df).sum()), r_fit, n_free, confidence)
        self.h0_, self.hm2_, self.sigma_rho_m_ = h0, hm2, sigma
        self.inflation_ = inflation
        self.r_ = inflation * difference_autocorrelation(h0, hm2, sigma, self.interval_s)
        self.whitener_ = toeplitz_whitener(self.r_, int(self.window))
        self.thresholds_ = chi2_thresholds(self.pfa, int(self.window))
        self.threshold_ = float(self.thresholds_[-1])
        self.reset()
        return self

    def _check_fitted(self) -> None:
        if not hasattr(self, "whitener_"):
            raise RuntimeError("this HodDetector is not fitted yet: call fit() first")

    # -- batch ----------------------------------------------------------------------------------------------

    def run(self, clock_bias_s) -> DetectionResult:
        """Test every epoch of ``clock_bias_s`` (s), shape (steps,) or (trials, steps), NaN = missing epoch.

        Does not change the detector (the streaming state is untouched).
        """
        self._check_fitted()
        x = check_array(clock_bias_s, "clock_bias_s", ndim=(1, 2), allow_nan=True)
        df = high_order_difference(x, self.interval_s)
        dof = chain_dof(df, int(self.window))
        stat = window_statistic(df, dof, self.whitener_)
        thr = self.thresholds_[dof]
        return DetectionResult.from_statistic(stat, dof, thr, x, self.window, self.pfa)

    def innovations(self, clock_bias_s) -> np.ndarray:
        """Normalised one-step innovations of ``df``: the last component of ``D_k v_k`` (N(0, 1) under H0).

        It is the prediction error of ``df(k)`` from the ``k - 1`` differences before it, divided by its
        standard deviation (the last row of the inverse Cholesky factor). Shape as the input; NaN where
        ``dof == 0``. Used by the CUSUM baseline.
        """
        self._check_fitted()
        x = check_array(clock_bias_s, "clock_bias_s", ndim=(1, 2), allow_nan=True)
        df = high_order_difference(x, self.interval_s)
        return last_innovation(df, chain_dof(df, int(self.window)), self.whitener_)

    # -- streaming ----------------------------------------------------------------------------------------

    def reset(self) -> None:
        """Forget the streaming state (the last two biases and the difference window)."""
        n = int(self.window)
        self._prev = [math.nan, math.nan]
        self._buf = np.zeros(n)
        self._count = 0
        self._blocks = None
        if hasattr(self, "whitener_"):
            d = self.whitener_
            self._blocks = [None] + [np.ascontiguousarray(d[:k, :k]) for k in range(1, n + 1)]

    def step(self, clock_bias_s: float) -> StepOutput:
        """Take one clock bias (s; NaN or None = missing) and test the window ending here.

        Gives the same numbers as :meth:`run` over the same sequence.
        """
        self._check_fitted()
        x = nan_if_none(clock_bias_s)
        p1, p2 = self._prev
        self._prev = [x, p1]
        if math.isnan(x):
            self._count = 0
            return StepOutput(math.nan, False, 0, math.nan, True)
        if math.isnan(p1) or math.isnan(p2):
            self._count = 0
            return StepOutput(math.nan, False, 0, math.nan, False)
        df = second_difference(x, p1, p2, self.interval_s)
        buf = self._buf
        buf[:-1] = buf[1:]
        buf[-1] = df
        n = buf.shape[0]
        k = self._count = min(self._count + 1, n)
        w = self._blocks[k] @ buf[n - k :]
        stat = float(w @ w)
        thr = float(self.thresholds_[k])
        return StepOutput(stat, stat > thr, k, thr, False, float(w[-1]))
