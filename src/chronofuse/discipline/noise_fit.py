"""A loop's noise from its own record: oscillator white and random-walk FM beside the reference's white
noise and its correlated (Gauss-Markov) errors, by Whittle's likelihood on the second differences.

The free oscillator's offsets against the reference, ``z = x_free - e`` (a locked record turned open loop
by :func:`~chronofuse.discipline.servo.open_loop_offset_s`), are second-differenced (removing phase and
frequency; the drift leaves a constant). The second difference ``d`` has the spectrum, at ``w`` in
``(0, pi]`` with ``dt`` the interval, of a sum of independent parts:

* white phase (the reference's white noise, variance ``s2``): ``s2 (2 - 2 cos w)^2``;
* white FM (``q1 = h0 dt / 2`` per step of phase): ``q1 (2 - 2 cos w)``;
* random-walk FM (``q2 = 2 pi^2 h-2``, the integrated Wiener process: ``var d = 2 q2 dt^3 / 3``, lag-one
  covariance ``q2 dt^3 / 6``): ``q2 dt^3 (2 + cos w) / 3``;
* each first-order Gauss-Markov error (variance ``v``, ``phi = exp(-dt / tau)``): the AR(1) spectrum
  ``v (1 - phi^2) / (1 - 2 phi cos w + phi^2)`` times ``(2 - 2 cos w)^2``.

Whittle's estimate minimises ``sum_j log S(w_j) + I(w_j) / S(w_j)`` over the Fourier frequencies of the
Hann-tapered periodogram of every unbroken run (P. Whittle, Arkiv för Matematik 2, 1953; the taper as in
R. Dahlhaus, J. Time Series Anal. 9, 1988, so that the ``w^4`` white phase does not leak into the lowest
frequencies), over the logarithms of the parameters, from several starts (L-BFGS-B; the best is kept).
Flicker FM has no term: it is seen as a mix of white FM, random-walk FM and the slow Gauss-Markov term,
which is what a servo with these states can use. Epochs of outlying differences are left out first
(:func:`chronofuse.integrity.noise_model.training_outliers`), and every gap of at most ``max_fill_s``
(those epochs, and seconds without a usable reference) is bridged by linear interpolation of the phase
before differencing: otherwise 2 % outliers, or an urban canyon's short fix losses, cut the record into
runs of a few dozen seconds, the slow terms are no longer seen, and random-walk FM came out three
orders of magnitude too large (measured: urban canyon 6.9e-21 against 3.8e-27). A bridge alone is
smoother than the record (with 2 % outliers on each of three receivers 11 % of the epochs are bridged,
and the white noise came out as a 3 s Gauss-Markov term, 1e-15 s white), so each bridged epoch also
gets white noise of the record's own short-term level, ``1.4826 MAD(d) / sqrt(6)`` (the white phase
noise a second difference of variance ``6 s2`` implies), scaled by ``sqrt(2 w (1 - w))`` at the fraction
``w`` of the way across (the bridge already carries ``w^2 + (1 - w)^2`` of it from its two ends), drawn
from a fixed seed: a single imputation. What is still wrong: with 2 % outliers and 1 % missing epochs
the white noise comes out 27 % high with a spurious 3 s Gauss-Markov term of 10 ns beside it (tested),
and a day does not tell the slow wander from random-walk FM (it comes out as ``h-2``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from chronofuse.validation import check_array, check_scalar

__all__ = ["LoopNoise", "fit_loop_noise", "OUTLIER_Z"]

#: Second differences beyond this many robust standard deviations are left out of the fit. Lower than
#: the detectors' 6: an outlier of a few noise levels left in makes the white noise look like a 3 s
#: Gauss-Markov error of twice its size (measured with 2 % outliers of 300 ns on three receivers); a
#: good second difference is beyond 4 sigma with probability 6e-5, and its epochs are bridged.
OUTLIER_Z = 4.0


@dataclass(frozen=True)
class LoopNoise:
    """What :func:`fit_loop_noise` found: ``h0`` (s), ``hm2`` (1/s), the white measurement noise
    ``sigma_s`` (s), ``gauss_markov`` ((sigma_s, tau_s), ...) and the number of differences used."""

    h0: float
    hm2: float
    sigma_s: float
    gauss_markov: tuple[tuple[float, float], ...]
    n_differences: int


def _spectrum(theta, cw, dt, n_gm):
    q1, q2, s2 = np.exp(theta[:3])
    d2 = (2.0 - 2.0 * cw) ** 2
    s = s2 * d2 + q1 * (2.0 - 2.0 * cw) + q2 * dt**3 * (2.0 + cw) / 3.0
    for i in range(n_gm):
        v, tau = math.exp(theta[3 + 2 * i]), math.exp(theta[4 + 2 * i])
        phi = math.exp(-dt / tau)
        s = s + v * (1.0 - phi * phi) / (1.0 - 2.0 * phi * cw + phi * phi) * d2
    return s


def _bridge(z: np.ndarray, max_fill: int) -> np.ndarray:
    """Each row with its NaN gaps of at most ``max_fill`` samples (inside the row) linearly interpolated,
    plus white noise at the row's short-term level (module docstring)."""
    out = np.array(z, dtype=float, copy=True)
    rng = np.random.default_rng(0)
    for row in np.atleast_2d(out):
        bad = ~np.isfinite(row)
        if not bad.any() or bad.all():
            continue
        d2 = np.diff(row, 2)
        d2 = d2[np.isfinite(d2)]
        level = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(6.0) if d2.size else 0.0
        edges = np.flatnonzero(np.diff(np.concatenate(([False], bad, [False])).astype(np.int8)))
        good = np.flatnonzero(~bad)
        filled = np.interp(np.arange(row.size), good, row[good])
        for start, stop in zip(edges[::2], edges[1::2]):
            if start > 0 and stop < row.size and stop - start <= max_fill:
                # the bridge carries the white noise of its two ends, weights w and 1 - w: add the rest
                w = np.arange(1, stop - start + 1) / (stop - start + 1)
                row[start:stop] = filled[start:stop] + level * np.sqrt(2.0 * w * (1.0 - w)) * rng.standard_normal(w.size)
    return out


def fit_loop_noise(z_open, interval_s: float = 1.0, gauss_markov: int = 2,
                   taus_start_s: tuple[float, ...] = (10.0, 1000.0), max_fill_s: float = 60.0) -> LoopNoise:
    """Fit ``z_open`` ((steps,) or (trials, steps), s, NaN = missing) with ``gauss_markov`` (0, 1 or 2)
    Gauss-Markov terms, their time constants started at ``taus_start_s`` (and a decade either side);
    gaps up to ``max_fill_s`` are bridged (module docstring)."""
    from chronofuse.estimation.process import second_difference_series
    from chronofuse.integrity.noise_model import contiguous_runs, training_outliers

    check_scalar(interval_s, "interval_s", min_val=0.0, include_min=False)
    check_scalar(gauss_markov, "gauss_markov", min_val=0, max_val=2, integer=True)
    z = check_array(z_open, "z_open", ndim=(1, 2), allow_nan=True)
    check_scalar(max_fill_s, "max_fill_s", min_val=0.0)
    z = _bridge(np.where(training_outliers(z, OUTLIER_Z), np.nan, z), int(max_fill_s / interval_s))
    df = second_difference_series(z, interval_s)
    runs = contiguous_runs(df, 64)
    if not runs:
        raise ValueError("z_open has no run of 64 consecutive valid second differences to fit the noise on")
    cws, pgrams = [], []
    for run in runs:
        run = run - run.mean()  # the drift's constant
        window = np.hanning(run.size)
        spec = np.abs(np.fft.rfft(run * window / np.sqrt(np.mean(window**2)))) ** 2 / run.size
        w = 2.0 * np.pi * np.arange(1, spec.size) / run.size
        cws.append(np.cos(w))
        pgrams.append(spec[1:])
    cw = np.concatenate(cws)
    pgram = np.concatenate(pgrams)
    dt = float(interval_s)
    r0 = float(np.mean(pgram))

    def objective(theta):
        s = _spectrum(theta, cw, dt, gauss_markov)
        return float(np.sum(np.log(s) + pgram / s)) / pgram.size

    starts = []
    for scale in (0.1, 1.0):
        for shift in ((0.0,) if gauss_markov == 0 else (-1.0, 0.0, 1.0)):
            theta = [math.log(scale * r0 / 4.0), math.log(scale * r0 * 1e-4), math.log(scale * r0 / 16.0)]
            for i in range(gauss_markov):
                theta += [math.log(scale * r0), math.log(taus_start_s[i] * 10.0**shift)]
            starts.append(np.array(theta))
    lo_tau, hi_tau = math.log(3.0 * dt), math.log(1e6 * dt)  # shorter is white noise: leave it to s2
    bounds = [(None, None)] * 3 + [(None, None), (lo_tau, hi_tau)] * gauss_markov
    best = None
    for theta0 in starts:
        res = optimize.minimize(objective, theta0, method="L-BFGS-B", bounds=bounds)
        if best is None or res.fun < best.fun:
            best = res
    theta = best.x
    q1, q2, s2 = np.exp(theta[:3])
    gm = tuple(sorted(((math.sqrt(math.exp(theta[3 + 2 * i])), math.exp(theta[4 + 2 * i])) for i in range(gauss_markov)),
                      key=lambda p: p[1]))
    return LoopNoise(h0=float(2.0 * q1 / dt), hm2=float(q2 / (2.0 * math.pi**2)), sigma_s=float(math.sqrt(s2)),
                     gauss_markov=gm, n_differences=int(sum(r.size for r in runs)))
