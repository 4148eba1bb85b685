"""High-order-difference (HOD) chi-square detector of receiver clock-bias anomalies (SPEC section 4).

The reconstruction of seed 002 (a patent whose formulas were lost in extraction), as SPEC 4 gives it:

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

Batch speed. For all full windows at once, ``T = rowsum((V L^-T)^2)`` with ``V`` the ``(windows, n)``
sliding view of ``df``: one matrix product, computed in chunks of bounded memory; the start-up epochs are
grouped by their ``k``. The streaming :meth:`HodDetector.step` keeps the last two biases and the last
``n`` differences and computes the same quadratic form for one window.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy import linalg, optimize, stats

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.validation import check_array, check_choice, check_scalar

# Windows per matrix product in the batch path: 2**15 windows of n = 20 is 5 MiB per chunk.
_CHUNK_WINDOWS = 1 << 15


# ---------------------------------------------------------------------------------------------------------
# Noise model
# ---------------------------------------------------------------------------------------------------------


def noise_intensities(h0: float, hm2: float, sigma_rho_m: float) -> tuple[float, float, float]:
    """``(q1, q2, s2)`` of SPEC 4: ``q1 = h0/2`` (s), ``q2 = 2 pi^2 h_-2`` (1/s), ``s2 = sigma_rho^2/c^2`` (s^2)."""
    return 0.5 * h0, 2.0 * math.pi**2 * hm2, (sigma_rho_m / SPEED_OF_LIGHT_M_PER_S) ** 2


def _parameters_from_intensities(q, h0, hm2, sigma_rho_m) -> tuple[float, float, float]:
    """Invert :func:`noise_intensities` for the parameters that were not given (None)."""
    q1, q2, s2 = q
    return (
        float(2.0 * q1) if h0 is None else float(h0),
        float(q2 / (2.0 * math.pi**2)) if hm2 is None else float(hm2),
        float(math.sqrt(s2) * SPEED_OF_LIGHT_M_PER_S) if sigma_rho_m is None else float(sigma_rho_m),
    )


def difference_autocorrelation(h0: float, hm2: float, sigma_rho_m: float, interval_s: float) -> np.ndarray:
    """Autocorrelation ``[r(0), r(1), r(2)]`` of ``df`` (dimensionless^2), SPEC 4; ``r(tau >= 3) = 0``.

    ``h0`` (s, white FM), ``hm2`` (1/s, random-walk FM), ``sigma_rho_m`` (m), ``interval_s`` (s).
    """
    q1, q2, s2 = noise_intensities(h0, hm2, sigma_rho_m)
    return _design_matrix(interval_s) @ np.array([q1, q2, s2])


def _design_matrix(interval_s: float) -> np.ndarray:
    """``A`` with ``[r(0), r(1), r(2)] = A [q1, q2, s2]`` (SPEC 4 formulas), shape (3, 3)."""
    ts = interval_s
    return np.array(
        [
            [2.0 * ts, 2.0 / 3.0 * ts**3, 6.0],
            [-ts, 1.0 / 6.0 * ts**3, -4.0],
            [0.0, 0.0, 1.0],
        ]
    ) / ts**2


def empirical_autocorrelation(df: np.ndarray, max_lag: int = 2) -> np.ndarray:
    """Autocorrelation ``r(0..max_lag)`` of ``df`` about zero (the model's mean), NaN pairs left out.

    ``df`` has shape (steps,) or (trials, steps); pairs are pooled over trials. Returns (max_lag + 1,).
    """
    df = np.asarray(df, dtype=np.float64)
    out = np.empty(max_lag + 1)
    for lag in range(max_lag + 1):
        prod = df[..., lag:] * df[..., : df.shape[-1] - lag]
        ok = np.isfinite(prod)
        if not ok.any():
            raise ValueError(f"no pair of valid differences at lag {lag}: the training data are too short or too gappy")
        out[lag] = prod[ok].mean()
    return out


def fit_noise(
    r: np.ndarray,
    interval_s: float,
    *,
    h0: float | None = None,
    hm2: float | None = None,
    sigma_rho_m: float | None = None,
) -> tuple[float, float, float]:
    """Noise parameters ``(h0, hm2, sigma_rho_m)`` from a measured ``r(0..2)`` of ``df``.

    The SPEC 4 formulas are linear in ``(q1, q2, s2)``: three equations, three unknowns. The given
    parameters are held fixed (their contribution is subtracted), and the missing ones are the
    non-negative least-squares solution (``scipy.optimize.nnls`` on unit-norm columns), which is the exact
    solution when that is non-negative and otherwise the closest one with intensities clipped to >= 0.
    """
    a = _design_matrix(interval_s)
    known = noise_intensities(h0 or 0.0, hm2 or 0.0, sigma_rho_m or 0.0)
    given = [h0 is not None, hm2 is not None, sigma_rho_m is not None]
    rhs = np.asarray(r, dtype=np.float64) - a[:, given] @ np.array([k for k, g in zip(known, given) if g])
    free = [not g for g in given]
    q = np.array(known, dtype=np.float64)
    if any(free):
        cols = a[:, free]
        norms = np.linalg.norm(cols, axis=0)
        scale = np.abs(rhs).max() or 1.0
        sol, _ = optimize.nnls(cols / norms, rhs / scale)
        q[free] = sol * scale / norms
    return _parameters_from_intensities(q, h0, hm2, sigma_rho_m)


def _contiguous_runs(df: np.ndarray, min_length: int) -> list[np.ndarray]:
    """The runs of consecutive valid differences (per row of a (steps,) or (trials, steps) array)."""
    runs = []
    for row in np.atleast_2d(df):
        valid = np.isfinite(row)
        edges = np.flatnonzero(np.diff(np.concatenate(([False], valid, [False])).astype(np.int8)))
        for start, stop in zip(edges[::2], edges[1::2]):
            if stop - start >= min_length:
                runs.append(row[start:stop])
    return runs


def fit_noise_whittle(
    df: np.ndarray,
    interval_s: float,
    *,
    h0: float | None = None,
    hm2: float | None = None,
    sigma_rho_m: float | None = None,
) -> tuple[float, float, float]:
    """Noise parameters ``(h0, hm2, sigma_rho_m)`` by Whittle's approximate maximum likelihood on ``df``.

    ``df`` is MA(2) under the model, with spectrum ``S(w) = r(0) + 2 r(1) cos w + 2 r(2) cos 2w``, linear in
    ``(q1, q2, s2)``. The estimate minimises ``sum_j log S(w_j) + I(w_j) / S(w_j)`` over the Fourier
    frequencies ``w_j`` of the periodograms ``I`` of every unbroken run of differences (P. Whittle, "Estimation
    and information in stationary time series", Arkiv för Matematik 2, 1953), with each free intensity
    parametrised by the log of its share of ``r(0)`` (so it stays >= 0), started from :func:`fit_noise`
    and from two balanced points (the best of the three L-BFGS-B fits is kept). Given parameters are
    held fixed.

    Why not only :func:`fit_noise`: the chi-square statistic weighs the low-frequency eigen-directions of
    ``C`` heavily, where white FM (``~ w^2``) and random-walk FM (``~ const``) dominate, while ``r(0..2)`` are
    dominated by the measurement noise (``~ w^4``); fitting the whole spectrum estimates ``q1`` and ``q2``
    where they matter. The measured consequence for P_fa is in ``chronofuse reproduce integrity``.
    """
    runs = _contiguous_runs(df, 8)
    if not runs:
        raise ValueError("no run of at least 8 consecutive valid differences in the training data")
    freqs, pgram = [], []
    for run in runs:
        spec = np.abs(np.fft.rfft(run)) ** 2 / run.size
        freqs.append(2.0 * np.pi * np.arange(1, spec.size) / run.size)
        pgram.append(spec[1:])
    w = np.concatenate(freqs)
    periodogram = np.concatenate(pgram)
    a = _design_matrix(interval_s)
    basis = np.stack([np.ones_like(w), 2.0 * np.cos(w), 2.0 * np.cos(2.0 * w)], axis=1) @ a  # S = basis @ q
    given = np.array([h0 is not None, hm2 is not None, sigma_rho_m is not None])
    q_fixed = np.array(noise_intensities(h0 or 0.0, hm2 or 0.0, sigma_rho_m or 0.0))
    r0 = float(np.mean(np.concatenate(runs) ** 2))
    start = np.array(noise_intensities(*fit_noise(empirical_autocorrelation(np.concatenate(runs)), interval_s,
                                                  h0=h0, hm2=hm2, sigma_rho_m=sigma_rho_m)))
    free = ~given
    if not free.any():
        return float(h0), float(hm2), float(sigma_rho_m)
    share = a[0, free]  # contribution of a unit intensity to r(0)
    s_fixed = basis[:, given] @ q_fixed[given] if given.any() else np.zeros_like(w)
    b_free = basis[:, free]

    def objective(log_c):
        q = np.exp(log_c) / share
        spec = s_fixed + b_free @ q
        if (spec <= 0).any():
            return np.inf, np.zeros_like(log_c)
        value = np.sum(np.log(spec) + periodogram / spec) / w.size
        grad = (b_free.T @ (1.0 / spec - periodogram / spec**2)) / w.size * q
        return value, grad

    lo, hi = math.log(r0) - 35.0, math.log(r0) + 3.0
    starts = [np.log(np.maximum(start[free] * share, r0 * 1e-6)), np.full(free.sum(), math.log(r0 / 3.0)),
              np.log(r0 * np.where(np.arange(3)[free] == 1, 1e-3, 1.0 / 3.0))]
    best = None
    for x0 in starts:
        res = optimize.minimize(objective, np.clip(x0, lo, hi), jac=True, method="L-BFGS-B",
                                bounds=[(lo, hi)] * int(free.sum()))
        if np.isfinite(res.fun) and (best is None or res.fun < best.fun):
            best = res
    if best is None:
        raise ValueError("the Whittle fit found no noise model for the training data")
    q = q_fixed.copy()
    q[free] = np.exp(best.x) / share
    return _parameters_from_intensities(q, h0, hm2, sigma_rho_m)


# ---------------------------------------------------------------------------------------------------------
# Functional core
# ---------------------------------------------------------------------------------------------------------


def high_order_difference(clock_bias_s: np.ndarray, interval_s: float) -> np.ndarray:
    """``df(k) = (t_u(k) - 2 t_u(k-1) + t_u(k-2)) / t_s`` along the last axis (SPEC 4).

    Shape is kept: (..., steps) -> (..., steps); the first two epochs are NaN, and any difference that
    touches a NaN epoch is NaN.
    """
    x = np.asarray(clock_bias_s, dtype=np.float64)
    df = np.full(x.shape, np.nan)
    df[..., 2:] = (x[..., 2:] - 2.0 * x[..., 1:-1] + x[..., :-2]) / interval_s
    return df


def chain_dof(df: np.ndarray, window: int) -> np.ndarray:
    """Degrees of freedom per epoch: the number of consecutive valid differences ending there, at most ``window``.

    ``df`` has shape (..., steps); returns int64 of the same shape (0 where ``df`` is NaN).
    """
    valid = np.isfinite(df)
    steps = df.shape[-1]
    idx = np.arange(steps)
    # index of the last invalid epoch at or before k (-1 if none): run length = k - that index
    last_bad = np.where(valid, -1, idx)
    last_bad = np.maximum.accumulate(last_bad, axis=-1)
    run = idx - last_bad
    return np.minimum(run, window).astype(np.int64)


def toeplitz_whitener(r: np.ndarray, window: int) -> np.ndarray:
    """Whitening filter ``D = L^-1`` (lower triangular, (window, window)) with ``D C D^T = I``.

    ``C = toeplitz(r(0), r(1), r(2), 0, ...)`` of size ``window``. Raises ``ValueError`` when ``C`` is
    not positive definite (all noise intensities zero, or an ``r`` no noise model can produce).
    """
    col = np.zeros(window)
    col[: min(3, window)] = np.asarray(r, dtype=np.float64)[: min(3, window)]
    cov = linalg.toeplitz(col)
    try:
        chol = linalg.cholesky(cov, lower=True)
    except linalg.LinAlgError:
        raise ValueError(
            f"the difference covariance with r = {list(np.asarray(r)[:3])} is not positive definite: "
            "the noise parameters give no noise (all zero?)"
        ) from None
    return linalg.solve_triangular(chol, np.eye(window), lower=True)


def window_statistic(df: np.ndarray, dof: np.ndarray, whitener: np.ndarray) -> np.ndarray:
    """``T(k) = |D_k v_k|^2`` for every epoch, ``v_k`` the last ``dof[k]`` differences (SPEC 4).

    ``df`` and ``dof`` have shape (..., steps) (from :func:`high_order_difference` and :func:`chain_dof`);
    ``whitener`` is (n, n). Full windows (``dof == n``) go through one chunked matrix product over a
    strided ``(windows, n)`` view; shorter windows are grouped by their ``dof = k`` and use the leading
    ``k x k`` block of ``D``. NaN where ``dof == 0``.
    """
    n = whitener.shape[0]
    lead = df.shape[:-1]
    steps = df.shape[-1]
    flat_df = np.where(np.isfinite(df), df, 0.0).reshape(-1, steps)
    flat_dof = dof.reshape(-1, steps)
    out = np.full(flat_df.shape, np.nan)
    dt = np.ascontiguousarray(whitener.T)
    if steps >= n:
        windows = sliding_window_view(flat_df, n, axis=-1)  # (rows, steps - n + 1, n), no copy
        n_win = windows.shape[1]
        per_row = max(1, _CHUNK_WINDOWS // max(n_win, 1))
        for r0 in range(0, flat_df.shape[0], per_row):
            for w0 in range(0, n_win, _CHUNK_WINDOWS):
                block = windows[r0 : r0 + per_row, w0 : w0 + _CHUNK_WINDOWS]
                w = block.reshape(-1, n) @ dt
                out[r0 : r0 + per_row, n - 1 + w0 : n - 1 + w0 + block.shape[1]] = np.einsum(
                    "ij,ij->i", w, w
                ).reshape(block.shape[:2])
    short_rows, short_cols = np.nonzero((flat_dof > 0) & (flat_dof < n))
    if short_rows.size:
        ks = flat_dof[short_rows, short_cols]
        for k in np.unique(ks):
            sel = ks == k
            rows = short_rows[sel]
            cols = short_cols[sel][:, None] + np.arange(-k + 1, 1)
            v = flat_df[rows[:, None], cols]
            w = v @ dt[:k, :k]
            out[rows, short_cols[sel]] = np.einsum("ij,ij->i", w, w)
    out[flat_dof == 0] = np.nan
    return out.reshape(lead + (steps,))


def chi2_thresholds(pfa: float, window: int) -> np.ndarray:
    """``gamma_k = F^-1_chi2(k)(1 - P_fa)`` for ``k = 0 .. window``, shape (window + 1,); ``gamma_0`` is NaN."""
    gamma = np.full(window + 1, np.nan)
    gamma[1:] = stats.chi2.isf(pfa, np.arange(1, window + 1))
    return gamma


# ---------------------------------------------------------------------------------------------------------
# Results
# ---------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class DetectionResult:
    """What a detector's ``run`` returns; arrays have the input's shape (steps,) or (trials, steps).

    Attributes
    ----------
    statistic : ndarray of float
        Test statistic per epoch (NaN where no test is possible).
    alarm : ndarray of bool
        ``statistic > threshold``.
    dof : ndarray of int
        Epochs (differences) in the window; fewer than ``window`` at start-up and after a gap, 0 where no test.
    threshold : ndarray of float
        The threshold that applied at each epoch (NaN where ``dof == 0``).
    skipped : ndarray of bool
        Missing (NaN) input epochs.
    n_skipped : int
        Number of missing input epochs (all trials).
    window : int
    pfa : float
    """

    statistic: np.ndarray
    alarm: np.ndarray
    dof: np.ndarray
    threshold: np.ndarray
    skipped: np.ndarray
    n_skipped: int
    window: int
    pfa: float

    @classmethod
    def from_statistic(cls, stat, dof, threshold, x, window: int, pfa: float) -> "DetectionResult":
        """Assemble a result: alarm where ``stat > threshold`` (never where either is NaN); skipped = NaN in ``x``."""
        skipped = np.isnan(x)
        return cls(
            statistic=stat,
            alarm=np.nan_to_num(stat, nan=-np.inf) > np.nan_to_num(threshold, nan=np.inf),
            dof=dof,
            threshold=threshold,
            skipped=skipped,
            n_skipped=int(skipped.sum()),
            window=int(window),
            pfa=float(pfa),
        )

    @property
    def n_alarms(self) -> int:
        return int(self.alarm.sum())

    def first_alarm(self, start: int = 0) -> np.ndarray:
        """Index of the first alarm at or after epoch ``start`` per trial (-1 if none); shape (...,)."""
        tail = self.alarm[..., start:]
        hit = tail.any(axis=-1)
        return np.where(hit, np.argmax(tail, axis=-1) + start, -1)


@dataclass(frozen=True)
class StepOutput:
    """One epoch of a streaming detector: statistic, alarm, dof, threshold, whether the input was missing,
    and the normalised innovation (last whitened component, NaN where ``dof == 0``)."""

    statistic: float
    alarm: bool
    dof: int
    threshold: float
    skipped: bool
    innovation: float = math.nan


# ---------------------------------------------------------------------------------------------------------
# The detector
# ---------------------------------------------------------------------------------------------------------


class HodDetector:
    """High-order-difference chi-square detector (SPEC 4), scikit-learn style.

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

    Learnt attributes (after :meth:`fit`): ``h0_``, ``hm2_``, ``sigma_rho_m_``, ``r_`` (r(0..2)),
    ``whitener_`` ((n, n), ``D = L^-1``), ``threshold_`` (gamma for ``n`` dof), ``thresholds_`` ((n+1,), per dof).
    """

    def __init__(
        self,
        *,
        interval_s: float,
        window: int = 20,
        pfa: float = 1e-3,
        h0: float | None = None,
        hm2: float | None = None,
        sigma_rho_m: float | None = None,
    ):
        self.interval_s = interval_s
        self.window = window
        self.pfa = pfa
        self.h0 = h0
        self.hm2 = hm2
        self.sigma_rho_m = sigma_rho_m

    # -- fitting ------------------------------------------------------------------------------------------

    def _check_params(self) -> None:
        check_scalar(self.interval_s, "interval_s", min_val=0.0, include_min=False)
        check_scalar(self.window, "window", min_val=1, integer=True)
        check_scalar(self.pfa, "pfa", min_val=0.0, max_val=1.0, include_min=False, include_max=False)
        for name in ("h0", "hm2", "sigma_rho_m"):
            value = getattr(self, name)
            if value is not None:
                check_scalar(value, name, min_val=0.0)

    def fit(self, clock_bias_s=None, *, method: str = "whittle") -> HodDetector:
        """Set the noise model, whitener and thresholds; estimate missing noise parameters from training data.

        ``clock_bias_s``: anomaly-free training clock biases (s), shape (steps,) or (trials, steps), NaN =
        missing; not needed (None) when ``h0``, ``hm2`` and ``sigma_rho_m`` are all given. ``method``:
        ``"whittle"`` (default, :func:`fit_noise_whittle`, the spectrum of ``df``) or ``"autocorrelation"``
        (:func:`fit_noise`, the SPEC 4 ``r(0..2)`` formulas solved for the empirical ``r(0..2)``, clipped >= 0).
        """
        self._check_params()
        params = (self.h0, self.hm2, self.sigma_rho_m)
        if all(p is not None for p in params):
            h0, hm2, sigma = params
        else:
            if clock_bias_s is None:
                missing = [n for n, p in zip(("h0", "hm2", "sigma_rho_m"), params) if p is None]
                raise ValueError(f"{', '.join(missing)} not given: fit() needs anomaly-free training clock biases")
            x = check_array(clock_bias_s, "clock_bias_s", ndim=(1, 2), allow_nan=True, min_length=3)
            check_choice(method, "method", ("whittle", "autocorrelation"))
            df = high_order_difference(x, self.interval_s)
            known = dict(h0=self.h0, hm2=self.hm2, sigma_rho_m=self.sigma_rho_m)
            if method == "whittle":
                h0, hm2, sigma = fit_noise_whittle(df, self.interval_s, **known)
            else:
                h0, hm2, sigma = fit_noise(empirical_autocorrelation(df), self.interval_s, **known)
        self.h0_, self.hm2_, self.sigma_rho_m_ = h0, hm2, sigma
        self.r_ = difference_autocorrelation(h0, hm2, sigma, self.interval_s)
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
        return _last_innovation(df, chain_dof(df, int(self.window)), self.whitener_)

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
        x = math.nan if clock_bias_s is None else float(clock_bias_s)
        p1, p2 = self._prev
        self._prev = [x, p1]
        if math.isnan(x):
            self._count = 0
            return StepOutput(math.nan, False, 0, math.nan, True)
        if math.isnan(p1) or math.isnan(p2):
            self._count = 0
            return StepOutput(math.nan, False, 0, math.nan, False)
        df = (x - 2.0 * p1 + p2) / self.interval_s
        buf = self._buf
        buf[:-1] = buf[1:]
        buf[-1] = df
        n = buf.shape[0]
        k = self._count = min(self._count + 1, n)
        w = self._blocks[k] @ buf[n - k :]
        stat = float(w @ w)
        thr = float(self.thresholds_[k])
        return StepOutput(stat, stat > thr, k, thr, False, float(w[-1]))


def _last_innovation(df: np.ndarray, dof: np.ndarray, whitener: np.ndarray) -> np.ndarray:
    """Last component of ``D_k v_k`` per epoch (see :meth:`HodDetector.innovations`); shape of ``df``."""
    n = whitener.shape[0]
    steps = df.shape[-1]
    flat_df = np.where(np.isfinite(df), df, 0.0).reshape(-1, steps)
    flat_dof = dof.reshape(-1, steps)
    out = np.full(flat_df.shape, np.nan)
    if steps >= n:
        full = sliding_window_view(flat_df, n, axis=-1) @ whitener[n - 1]
        out[:, n - 1 :] = full
    rows, cols = np.nonzero((flat_dof > 0) & (flat_dof < n))
    if rows.size:
        ks = flat_dof[rows, cols]
        for k in np.unique(ks):
            sel = ks == k
            idx = cols[sel][:, None] + np.arange(-k + 1, 1)
            out[rows[sel], cols[sel]] = flat_df[rows[sel][:, None], idx] @ whitener[k - 1, :k]
    out[flat_dof == 0] = np.nan
    return out.reshape(df.shape)
