"""The HOD detector's noise model: the autocorrelation of the clock bias's second difference, and
its fit to training data.

White FM ``h0``, random-walk FM ``h_-2`` and white measurement noise from the mean pseudorange noise
``sigma_rho`` (m): ``q1 = h0/2``, ``q2 = 2 pi^2 h_-2`` (:func:`chronofuse.models.clock.clock_intensities`),
``s2 = sigma_rho^2 / c^2``, and the autocorrelation of ``df`` (exact for the two-state clock model, Brown &
Hwang ch. 9 / Van Dierendonck 1984, plus white phase noise)::

    r(0) = (2 q1 t_s + 2/3 q2 t_s^3 + 6 s2) / t_s^2
    r(1) = (-q1 t_s + 1/6 q2 t_s^3 - 4 s2) / t_s^2
    r(2) = s2 / t_s^2,   r(tau >= 3) = 0

The formulas are linear in ``(q1, q2, s2)``; :func:`fit_noise` solves them for a measured ``r(0..2)`` and
:func:`fit_noise_whittle` fits the whole spectrum of ``df`` (Whittle's likelihood).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.models.clock import clock_intensities
from chronofuse.validation import InputError


def noise_intensities(h0: float, hm2: float, sigma_rho_m: float) -> tuple[float, float, float]:
    """``(q1, q2, s2)`` of the model: ``q1 = h0/2`` (s), ``q2 = 2 pi^2 h_-2`` (1/s), ``s2 = sigma_rho^2/c^2`` (s^2)."""
    return (*clock_intensities(h0, hm2), (sigma_rho_m / SPEED_OF_LIGHT_M_PER_S) ** 2)


def _parameters_from_intensities(q, h0, hm2, sigma_rho_m) -> tuple[float, float, float]:
    """Invert :func:`noise_intensities` for the parameters that were not given (None)."""
    q1, q2, s2 = q
    return (
        float(2.0 * q1) if h0 is None else float(h0),
        float(q2 / (2.0 * math.pi**2)) if hm2 is None else float(hm2),
        float(math.sqrt(s2) * SPEED_OF_LIGHT_M_PER_S) if sigma_rho_m is None else float(sigma_rho_m),
    )


def difference_autocorrelation(h0: float, hm2: float, sigma_rho_m: float, interval_s: float) -> np.ndarray:
    """Autocorrelation ``[r(0), r(1), r(2)]`` of ``df`` (dimensionless^2); ``r(tau >= 3) = 0``.

    ``h0`` (s, white FM), ``hm2`` (1/s, random-walk FM), ``sigma_rho_m`` (m), ``interval_s`` (s).
    """
    q1, q2, s2 = noise_intensities(h0, hm2, sigma_rho_m)
    return _design_matrix(interval_s) @ np.array([q1, q2, s2])


def _design_matrix(interval_s: float) -> np.ndarray:
    """``A`` with ``[r(0), r(1), r(2)] = A [q1, q2, s2]`` (the formulas of :func:`difference_autocorrelation`), shape (3, 3)."""
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
            raise InputError(f"no pair of valid differences at lag {lag}: the training data are too short or too gappy")
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

    The model's formulas are linear in ``(q1, q2, s2)``: three equations, three unknowns. The given
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


#: Robust z-score of a training second difference beyond which its epoch is left out of the noise fit.
OUTLIER_Z = 6.0

_FLOAT_RESOLUTION = 1e3 * np.finfo(np.float64).eps


def training_outliers(clock_bias_s: np.ndarray, z_limit: float = OUTLIER_Z) -> np.ndarray:
    """Epochs of a training stretch to leave out of the noise fit: bool, the shape of ``clock_bias_s``
    ((steps,) or (trials, steps), NaN = missing).

    A second difference ``d2(k) = x(k) - 2 x(k-1) + x(k-2)`` is an outlier when ``|d2 - median| > z_limit
    sigma``, with ``sigma = 1.4826 MAD`` of the row's differences (the median absolute deviation, consistent
    for the Gaussian marginal of ``d2`` whatever its MA(2) correlation; Hampel, "The influence curve and its
    role in robust estimation", JASA 69, 1974); epoch ``k`` of each outlying ``d2(k)`` is left out. One
    spike at ``x(k)`` makes ``d2`` ``(a, -2a, a)`` at ``k, k+1, k+2`` and a step ``(a, -a)`` at ``k, k+1``:
    leaving out the epochs of the outlying differences breaks the chain there, so no difference left spans
    the spike or the step. Under H0 at 6 sigma an epoch is left out with probability ~2e-9 (a few times more
    at 18 differences, where the MAD itself varies by ~30 %), so a clean training is fitted as it is.
    A row whose MAD is at the floating-point rounding of its values (``1e3 eps max|x|``) is not screened:
    there the median difference is rounding, not noise (CODE's reference clock WAB200CHE, written to 1e-18 s
    on a 2e-7 s bias, has second differences of 0 and +-1e-18 s, and the screen would take its ticks for
    outliers).
    """
    x = np.asarray(clock_bias_s, dtype=np.float64)
    rows = np.atleast_2d(x)
    out = np.zeros(rows.shape, dtype=bool)
    for i, row in enumerate(rows):
        d2 = np.full(row.shape, np.nan)
        d2[2:] = row[2:] - 2.0 * row[1:-1] + row[:-2]
        ok = np.isfinite(d2)
        if ok.sum() < 8:
            continue
        centre = np.median(d2[ok])
        scale = 1.4826 * np.median(np.abs(d2[ok] - centre))
        if scale > _FLOAT_RESOLUTION * np.nanmax(np.abs(row)):
            out[i] = ok & (np.abs(d2 - centre) > z_limit * scale)
    return out.reshape(x.shape)


def contiguous_runs(df: np.ndarray, min_length: int) -> list[np.ndarray]:
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
    taper: bool = False,
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

    ``taper``: multiply each run by a Hann window (scaled to unit mean square) before its periodogram
    (the tapered Whittle estimate, R. Dahlhaus, "Small sample effects in time series analysis", J. Time
    Series Anal. 9(2), 1988). Without it the measurement noise's spectrum, rising as ``w^4``, leaks into the
    lowest Fourier frequencies through the rectangular window's sidelobes (about ``S(pi) / n``), which is
    where random-walk FM is seen: a weak ``h_-2`` then comes out too large (67x for ``h0 = 1e-18``,
    ``h_-2 = 7.6e-26``, 1 ns white phase over 4 x 40,000 s; within 1.3x tapered). The servos' noise fit
    uses the taper; the detectors keep the plain periodogram (their statistic barely depends on a weak
    ``h_-2``).
    """
    runs = contiguous_runs(df, 8)
    if not runs:
        raise InputError("no run of at least 8 consecutive valid differences in the training data")
    freqs, pgram = [], []
    for run in runs:
        if taper:
            window = np.hanning(run.size)
            run = run * (window / np.sqrt(np.mean(window**2)))
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
        raise InputError("the Whittle fit found no noise model for the training data")
    q = q_fixed.copy()
    q[free] = np.exp(best.x) / share
    return _parameters_from_intensities(q, h0, hm2, sigma_rho_m)
