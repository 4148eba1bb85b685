"""An oscillator characterised from a measured record: h-coefficients, drift and temperature coefficient
fitted, the fit shown against the measured ADEV, a loop recommended, holdover predicted.

What :func:`characterize` does with a phase or fractional-frequency record against a reference (optionally
with the oscillator's temperature beside it):

1. **Deterministic terms.** The fractional frequency ``y`` (the phase's first difference) is regressed by
   least squares on ``[1, t]`` (and the temperature ``T - mean(T)`` when given): the linear drift ``D``
   and the temperature coefficient; both are removed before the noise is looked at.
2. **Measured ADEV.** The overlapping ADEV of the residual phase on the octave grid
   (:func:`chronofuse.analysis.stability.compute`, Greenhall's EDF and chi-square intervals). The intervals
   are simultaneous: each is at ``1 - (1 - family) / k`` for the ``k`` averaging times (Bonferroni), so that
   a true model lies inside all of them at once with probability at least ``family`` (95 %). A 68 %
   interval per tau would reject the true model at one tau or another in most records.
3. **Fit.** The model Allan variance is linear in its coefficients: the five power-law terms of
   :func:`chronofuse.analysis.theory.avar_components` (``h2 .. h-2``), plus, where the record shows them,

   * periodic FM (spurs): ``y0 sin(2 pi f t)`` has ``AVAR = y0^2 sin^4(pi f tau) / (pi f tau)^2``
     (NIST SP 1065 sec. 5.2.10, exact for the sampled phase); a spur is a Welch periodogram bin of the
     residual frequency above its running median by more than the chi-square level of false-alarm
     probability ``1e-3`` over the bins searched (``f`` above ``SPUR_MIN_FRACTION`` of the rate);
   * phase-measurement noise correlated between neighbouring samples (a counter's interpolator): lag-one
     covariance ``R1 < 0`` adds ``-4 R1`` to the Allan variance at ``tau0`` and nothing beyond (the
     autocovariance form of SP 1065 eq. (7)); bounded by ``|R1| <= R0 / 2`` with ``R0`` the white PM
     variance (a valid covariance), reported when it is used.

   Non-negative least squares on the variances, weighted by their standard deviations ``AVAR sqrt(2 / edf)``,
   starts a least-squares fit of the logarithms of the coefficients to the logarithms of the measured
   variances, each residual in units of its interval's half-width on its own side: what the check of
   step 2 asks.
4. **Loop** for a receiver of white phase noise ``sigma_r``: the crossover ``tau_c`` where the model's ADEV
   meets the receiver's ``sqrt(3) sigma_r / tau``; the steady-state gains of the Kalman servo designed
   with the fitted ``h`` and ``sigma_r`` (:class:`~chronofuse.discipline.kalman.KalmanServo`, the discrete
   Riccati equation); and the PI of natural frequency ``1 / (2 pi tau_c)``
   (:meth:`~chronofuse.discipline.pi.PiServo.from_bandwidth`).
5. **Holdover** at 1, 4 and 24 h after the record's end, by a parametric bootstrap: the fitted oscillator
   is simulated (:func:`chronofuse.models.oscillator.simulate_oscillator`) for the record's length plus
   the horizon, the same estimator is applied to the record part (drift from the whole record, frequency
   from the last ``min(h, T / 2)`` seconds), and the prediction's error at ``h`` is taken over the trials:
   its rms with a 95 % interval (:func:`chronofuse.analysis.montecarlo.rms_ci`) and its 2.5..97.5 %
   spread. The same trials give the drift's and the temperature coefficient's standard errors. Beside
   it, the analytic ``sqrt(2 h^2 sigma_y^2(h) + sigma_D^2 h^4)``: the error of a frequency averaged over the
   last ``h`` (exactly ``2 h^2 AVAR(h)``: AVAR is half the mean square of the next average less the last)
   plus the drift's, taken as independent (an approximation: both come
   from the same record, and for random-walk FM the bootstrap's error is larger, see
   :func:`predict_holdover`).

Refused (:class:`~chronofuse.validation.InputError`): a record with fewer than :data:`MIN_SAMPLES` samples or
:data:`MIN_TAUS` octaves of tau; a phase record bluer than white PM (the lag-one autocorrelation of its
differenced phase says ``alpha >= 3``, which no clock's phase has and a frequency record read as phase
does: its counter's white PM becomes ``alpha = 4``); a phase record whose steps imply a fractional
frequency above ``1e-3`` (a frequency in Hz read as phase). What is not caught: a frequency record whose
short-term noise is white FM read as phase looks like white PM phase.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import optimize, stats
from scipy.ndimage import median_filter
from scipy.signal import welch

from chronofuse.analysis.theory import avar_components
from chronofuse.models.oscillator import OscillatorModel, PowerLaw
from chronofuse.validation import InputError, check_array, check_choice, check_scalar

__all__ = ["Characterization", "LoopAdvice", "characterize", "fit_adev", "model_adev", "recommend_loop",
           "predict_holdover", "oscillator_document", "oscillator_from_document", "read_oscillator_file",
           "characterize_file", "MIN_SAMPLES", "MIN_TAUS",
           "HOLDOVER_HORIZONS_S"]

#: Fewest samples a record may have (about 17 minutes at 1 Hz).
MIN_SAMPLES = 1000
#: Fewest octave averaging times of the overlapping ADEV the fit needs (it has up to seven coefficients).
MIN_TAUS = 8
#: Spurs are searched above this fraction of the sample rate (periods under 50 samples): below it the
#: power-law slopes make a running median a poor background.
SPUR_MIN_FRACTION = 0.02
#: At most this many spurs enter the model.
MAX_SPURS = 3
#: False-alarm probability of the spur search, over all the bins searched.
SPUR_PFA = 1e-3
#: Family confidence of the simultaneous ADEV intervals.
FAMILY_CI = 0.95
HOLDOVER_HORIZONS_S = (3600.0, 4 * 3600.0, 86_400.0)
#: A fractional frequency above this is no clock's (a frequency in Hz read as phase).
PLAUSIBLE_Y = 1e-3
_TERMS = ("h2", "h1", "h0", "hm1", "hm2")


@dataclass(frozen=True)
class LoopAdvice:
    """The loop :func:`recommend_loop` recommends for a receiver of white noise ``receiver_sigma_s``."""

    receiver_sigma_s: float
    crossover_s: float
    kalman_gains: tuple[float, float, float]
    kalman_phase_time_constant_s: float
    pi_natural_hz: float
    pi_kp: float
    pi_ki: float
    pi_time_constant_s: float

    def to_dict(self) -> dict:
        return {"receiver_sigma_s": self.receiver_sigma_s, "crossover_s": self.crossover_s,
                "kalman_gains": {"phase": self.kalman_gains[0], "frequency_per_s": self.kalman_gains[1],
                                 "drift_per_s2": self.kalman_gains[2]},
                "kalman_phase_time_constant_s": self.kalman_phase_time_constant_s,
                "pi": {"natural_hz": self.pi_natural_hz, "kp": self.pi_kp, "ki": self.pi_ki,
                       "time_constant_s": self.pi_time_constant_s}}


@dataclass(frozen=True)
class Characterization:
    """What :func:`characterize` found (module docstring). ``adev`` is the measured overlapping ADEV
    (a :class:`~chronofuse.analysis.stability.result.Deviation` with the simultaneous intervals),
    ``model_adev`` the fitted model's at the same taus, ``inside`` whether it lies in each interval."""

    rate_hz: float
    n_samples: int
    h: PowerLaw
    drift_per_s: float
    drift_sigma_per_s: float
    temp_coeff_per_K: float | None
    temp_coeff_sigma_per_K: float | None
    temp_ref_K: float | None
    spurs: tuple[tuple[float, float], ...]
    tau0_excess_avar: float
    adev: object
    model_adev: np.ndarray
    inside: np.ndarray
    loop: LoopAdvice
    holdover: list[dict] = field(default_factory=list)
    notes: tuple[str, ...] = ()

    @property
    def fits(self) -> bool:
        """Whether the model's ADEV lies in every simultaneous interval."""
        return bool(np.all(self.inside))

    def to_dict(self) -> dict:
        a = self.adev
        return {"rate_hz": self.rate_hz, "n_samples": self.n_samples, "h": self.h.as_dict(),
                "drift_per_s": self.drift_per_s, "drift_sigma_per_s": self.drift_sigma_per_s,
                "temp_coeff_per_K": self.temp_coeff_per_K, "temp_coeff_sigma_per_K": self.temp_coeff_sigma_per_K,
                "temp_ref_K": self.temp_ref_K,
                "spurs": [{"frequency_hz": f, "amplitude": y0} for f, y0 in self.spurs],
                "tau0_excess_avar": self.tau0_excess_avar,
                "adev": {"ci": float(a.ci), "family_ci": FAMILY_CI, "tau_s": a.tau_s.tolist(), "measured": a.dev.tolist(),
                         "lo": a.lo.tolist(), "hi": a.hi.tolist(), "edf": a.edf.tolist(), "alpha": a.alpha.tolist(),
                         "model": self.model_adev.tolist(), "inside": self.inside.tolist()},
                "fits": self.fits, "loop": self.loop.to_dict(), "holdover": self.holdover, "notes": list(self.notes)}


def _spur_avar(tau: np.ndarray, f_hz: float) -> np.ndarray:
    """Allan variance per unit ``y0^2`` of periodic FM ``y0 sin(2 pi f t)`` (SP 1065 sec. 5.2.10)."""
    a = math.pi * f_hz * tau
    return np.sin(a) ** 4 / a**2


def _basis(tau: np.ndarray, rate_hz: float, spurs_hz, tau0_term: bool) -> tuple[np.ndarray, list[str]]:
    cols = [avar_components(PowerLaw(**{k: 1.0}), tau, rate_hz)[k] for k in _TERMS]
    names = list(_TERMS)
    for f in spurs_hz:
        cols.append(_spur_avar(tau, f))
        names.append(f"spur:{f!r}")
    if tau0_term:
        cols.append(np.isclose(tau, 1.0 / rate_hz).astype(float))
        names.append("tau0")
    return np.column_stack(cols), names


def model_adev(h: PowerLaw, tau_s, rate_hz: float, spurs=(), tau0_excess_avar: float = 0.0) -> np.ndarray:
    """The model's ADEV at ``tau_s``: :func:`~chronofuse.analysis.theory.avar_components` of ``h`` plus each
    spur ``(f_hz, y0)`` and the excess variance at ``tau0`` (module docstring, step 3)."""
    tau = np.asarray(tau_s, dtype=float)
    avar = sum(avar_components(h, tau, rate_hz).values())
    for f, y0 in spurs:
        avar = avar + y0**2 * _spur_avar(tau, f)
    avar = avar + tau0_excess_avar * np.isclose(tau, 1.0 / rate_hz)
    return np.sqrt(avar)


def find_spurs(y: np.ndarray, rate_hz: float, pfa: float = SPUR_PFA, max_spurs: int = MAX_SPURS) -> list[float]:
    """Frequencies (Hz) of the periodic components of ``y`` (module docstring, step 3), strongest first."""
    y = y[np.isfinite(y)]
    nper = int(min(4096, 2 ** int(math.log2(max(y.size // 8, 64)))))
    if y.size < 4 * nper:
        return []
    f, p = welch(y - y.mean(), fs=rate_hz, nperseg=nper)
    background = median_filter(p, size=min(101, p.size // 4 * 2 + 1), mode="nearest")
    ratio = p / np.maximum(background, np.finfo(float).tiny)
    search = np.flatnonzero(f > SPUR_MIN_FRACTION * rate_hz)
    dof = 2 * (y.size // nper)  # non-overlapped segments: a conservative count
    level = stats.chi2.ppf(1.0 - pfa / max(search.size, 1), dof) / dof
    found: list[float] = []
    for i in search[np.argsort(ratio[search])[::-1]]:
        if ratio[i] <= level or len(found) >= max_spurs:
            break
        if all(abs(f[i] - g) > 4 * rate_hz / nper for g in found):
            found.append(float(f[i]))
    return found


def fit_adev(adev, rate_hz: float, spurs_hz=(), tau0_term: bool = True) -> tuple[PowerLaw, tuple, float]:
    """``(h, spurs ((f, y0), ...), tau0 excess variance)`` fitted to a measured ADEV (module docstring,
    step 3); ``adev`` a :class:`~chronofuse.analysis.stability.result.Deviation` with finite intervals."""
    tau, dev, lo, hi, edf = (np.asarray(v, dtype=float) for v in (adev.tau_s, adev.dev, adev.lo, adev.hi, adev.edf))
    ok = np.isfinite(dev) & (dev > 0) & np.isfinite(edf)
    tau, dev, lo, hi, edf = tau[ok], dev[ok], lo[ok], hi[ok], edf[ok]
    B, names = _basis(tau, rate_hz, spurs_hz, tau0_term)
    avar = dev**2
    w = 1.0 / (avar * np.sqrt(2.0 / edf))
    c0, _ = optimize.nnls(B * w[:, None], avar * w)
    # log-domain refinement: each residual in its interval's half-width on its side
    up = np.log(np.where(np.isfinite(hi), hi, dev * 2) / dev)
    down = np.log(dev / np.where(np.isfinite(lo) & (lo > 0), lo, dev / 2))
    scale = np.array([avar.max() / max(np.max(B[:, j]), np.finfo(float).tiny) for j in range(B.shape[1])])
    floor = 1e-12 * scale

    def resid(p):
        m = 0.5 * np.log(B @ np.exp(p) + 1e-300)
        r = m - np.log(dev)
        return np.where(r > 0, r / up, r / down)

    p0 = np.log(np.maximum(c0, floor))
    res = optimize.least_squares(resid, p0, bounds=(np.log(floor) - 1.0, np.log(scale * 1e3)), method="trf")
    best = res.x if np.sum(resid(res.x) ** 2) <= np.sum(resid(p0) ** 2) else p0
    c = np.exp(best)
    c[c <= floor * 1.0001] = 0.0  # at the floor: not in the record
    share = (B * c[None, :]) / np.maximum(B @ c, np.finfo(float).tiny)[:, None]
    c[np.max(share, axis=0) < 1e-4] = 0.0  # under 0.01 % of the variance at every tau: not seen either
    k = len(_TERMS)
    h = PowerLaw(**{name: float(v) for name, v in zip(_TERMS, c[:k])})
    spurs = tuple((float(f), float(math.sqrt(v))) for f, v in zip(spurs_hz, c[k:k + len(spurs_hz)]) if v > 0)
    excess = float(c[-1]) if tau0_term else 0.0
    # a valid covariance: |R1| <= R0 / 2, i.e. the excess at tau0 at most 2/3 of white PM's Allan variance there
    white_pm_tau0 = 3.0 * (rate_hz / 2.0) * h.h2 / (4.0 * math.pi**2) * rate_hz**2
    excess = min(excess, 2.0 / 3.0 * white_pm_tau0)
    return h, spurs, excess


def recommend_loop(h: PowerLaw, receiver_sigma_s: float, rate_hz: float = 1.0) -> LoopAdvice:
    """The loop for a receiver of white phase noise ``receiver_sigma_s`` (module docstring, step 4)."""
    from scipy.linalg import solve_discrete_are

    from chronofuse.discipline.kalman import KalmanServo
    from chronofuse.discipline.pi import PiServo, max_natural_hz

    check_scalar(receiver_sigma_s, "receiver_sigma_s", min_val=0.0, include_min=False)
    tau = np.logspace(0, 7, 1401) / rate_hz
    osc = model_adev(h, tau, rate_hz)
    rx = math.sqrt(3.0) * receiver_sigma_s / tau
    above = np.flatnonzero(osc >= rx)
    crossover = float(tau[above[0]]) if above.size else float(tau[-1])
    servo = KalmanServo(h=h, measurement_sigma_s=receiver_sigma_s, interval_s=1.0 / rate_hz)
    F, Q, H = servo.model()
    R = np.array([[receiver_sigma_s**2]])
    # a tiny regularisation keeps the Riccati solver well posed where a term is zero (no drift noise)
    with np.errstate(invalid="ignore"):  # scipy's balancing casts a NaN scale where a state has no noise
        P = solve_discrete_are(F.T, H.T, Q + 1e-60 * np.eye(F.shape[0]), R)
    K = (P @ H.T / (H @ P @ H.T + R)[0, 0]).ravel()
    natural = 1.0 / (2.0 * math.pi * crossover)
    # A crossover of a few samples asks for more than a sampled PI loop can take: half its stability edge.
    natural = min(natural, 0.5 * max_natural_hz(1.0, 1.0 / rate_hz))
    pi = PiServo.from_bandwidth(natural, interval_s=1.0 / rate_hz)
    return LoopAdvice(receiver_sigma_s=float(receiver_sigma_s), crossover_s=crossover,
                      kalman_gains=(float(K[0]), float(K[1]) * rate_hz, float(K[2]) * rate_hz**2),
                      kalman_phase_time_constant_s=float(1.0 / (K[0] * rate_hz)) if K[0] > 0 else math.inf,
                      pi_natural_hz=float(natural), pi_kp=float(pi.kp), pi_ki=float(pi.ki),
                      pi_time_constant_s=float(pi.time_constant_s))


def _regress(y: np.ndarray, t: np.ndarray, temp: np.ndarray | None) -> np.ndarray:
    """Least-squares ``[offset, drift, (tempco)]`` of ``y`` on ``[1, t, (temp - mean)]``, NaN rows left out."""
    cols = [np.ones_like(t), t - t.mean()]
    if temp is not None:
        cols.append(temp - np.nanmean(temp))
    A = np.column_stack(cols)
    good = np.isfinite(y) & np.all(np.isfinite(A), axis=1)
    coef, *_ = np.linalg.lstsq(A[good], y[good], rcond=None)
    return coef


def _block_mean(v: np.ndarray, m: int) -> np.ndarray:
    n = v.shape[-1] // m * m
    return v[..., :n].reshape(v.shape[:-1] + (-1, m)).mean(axis=-1)


def predict_holdover(h: PowerLaw, drift_per_s: float, record_s: float, rate_hz: float, *, temp_K=None,
                     temp_coeff_per_K: float = 0.0, horizons_s=HOLDOVER_HORIZONS_S, trials: int = 200, seed=0,
                     max_steps: int = 50_000, known_drift: bool = False) -> tuple[list[dict], float, float | None]:
    """``(rows, drift standard error, tempco standard error or None)`` by the parametric bootstrap of the
    module docstring (step 5); the simulation runs at a rate of at most ``max_steps / (record + horizon)``
    (the holdover error does not depend on the phase terms a lower rate drops). ``known_drift``: the
    predictor is given the true drift instead of its estimate (then ``analytic_s`` is exact: ``2 h^2 AVAR(h)``
where the record holds the window;
    with the drift estimated it treats the drift's error as independent of the frequency's, which it is not
    for random-walk FM: 4.2 ns analytic against 3.89 ns [3.59, 4.16] bootstrapped for h0 2e-24, h-2 2e-29,
    a 4 h record and a 1 h horizon)."""
    from chronofuse.analysis.montecarlo import rms_ci
    from chronofuse.models.oscillator import simulate_oscillator

    check_scalar(trials, "trials", min_val=10, integer=True)
    horizons = np.asarray(horizons_s, dtype=float)
    total = record_s + horizons.max()
    sim_rate = min(rate_hz, max_steps / total)
    m = max(1, int(round(rate_hz / sim_rate)))
    sim_rate = rate_hz / m
    n_rec = int(record_s * sim_rate)
    steps = int(math.ceil(total * sim_rate)) + 1
    temp = None
    if temp_K is not None:
        temp = _block_mean(np.asarray(temp_K, dtype=float), m)[:n_rec]
    model = OscillatorModel(name="fit", nominal_hz=10e6, h=replace(h, h2=0.0, h1=0.0), drift_per_s=drift_per_s,
                            temp_coeff_per_K=0.0, efc_gain_per_V=0.0, dac_bits=1, dac_range_V=1.0, source="fit")
    truth = simulate_oscillator(model, steps / sim_rate, sim_rate, seed, trials=trials)
    y = truth.y
    if temp is not None and temp_coeff_per_K:
        y = y.copy()
        y[:, :n_rec] += temp_coeff_per_K * (temp - np.nanmean(temp))
    t = truth.t_s
    drifts, tempcos = [], []
    errors = np.empty((trials, horizons.size))
    for i in range(trials):
        coef = _regress(y[i, :n_rec], t[:n_rec], temp)
        drifts.append(coef[1])
        if temp is not None:
            tempcos.append(coef[2])
        x0 = truth.x_s[i, n_rec]
        for j, hz in enumerate(horizons):
            win = max(1, int(min(hz, record_s / 2.0) * sim_rate))
            y_last = (truth.x_s[i, n_rec] - truth.x_s[i, n_rec - win]) * sim_rate / win  # mean over the window
            d = drift_per_s if known_drift else coef[1]
            y0 = y_last + d * win / sim_rate / 2.0  # from the window's middle to its end
            k = n_rec + int(round(hz * sim_rate))
            errors[i, j] = truth.x_s[i, k] - (x0 + y0 * hz + 0.5 * d * hz**2)
    drift_sigma = float(np.std(drifts, ddof=1))
    tempco_sigma = float(np.std(tempcos, ddof=1)) if tempcos else None
    rows = []
    adev_h = model_adev(h, horizons, rate_hz)
    for j, hz in enumerate(horizons):
        rms, lo, hi = rms_ci(errors[:, j] ** 2)
        analytic = math.sqrt(2.0 * hz**2 * adev_h[j] ** 2 + (0.0 if known_drift else drift_sigma**2 * hz**4))
        rows.append({"horizon_s": float(hz), "rms_s": float(rms), "rms_ci_s": [float(lo), float(hi)],
                     "spread_95_s": [float(np.percentile(errors[:, j], 2.5)), float(np.percentile(errors[:, j], 97.5))],
                     "analytic_s": analytic, "trials": int(trials)})
    return rows, drift_sigma, tempco_sigma


def _refuse_shape(values: np.ndarray, rate_hz: float, kind: str, source: str) -> None:
    """The refusals of the module docstring (too short; a frequency record given as phase)."""
    from chronofuse.analysis.stability.noise_id import lag1_autocorrelation

    finite = int(np.isfinite(values).sum())
    if finite < MIN_SAMPLES:
        raise InputError(f"record too short to fit: {finite} samples, characterizing needs at least {MIN_SAMPLES}",
                         source)
    if kind != "phase":
        return
    d = np.diff(values)
    d = d[np.isfinite(d)]
    implied = float(np.median(np.abs(d))) * rate_hz
    if implied > PLAUSIBLE_Y:
        raise InputError(f"phase steps imply a fractional frequency of {implied:.3g}, no clock's: a frequency record "
                         "(in Hz?) given as phase; give {kind} freq", source, fields=("kind",))
    # Riley-Greenhall: difference while delta = r1 / (1 + r1) >= 0.25; alpha = 2 - 2 (delta + d) for phase
    z = values[np.isfinite(values)]
    z = z - np.polyval(np.polyfit(np.arange(z.size), z, 1), np.arange(z.size))
    for d_count in range(3):
        r1 = lag1_autocorrelation(z)
        delta = r1 / (1.0 + r1)
        if delta < 0.25:
            break
        z = np.diff(z)
    alpha = 2.0 - 2.0 * (delta + d_count)
    if alpha >= 2.5:
        raise InputError(f"as phase, the record is bluer than white PM (noise exponent alpha {alpha:.2g} at tau0, "
                         "above 2: no clock's phase): a frequency record given as phase? give {kind} freq", source,
                         fields=("kind",))


_ALPHA = {"h2": 2, "h1": 1, "h0": 0, "hm1": -1, "hm2": -2}


def _model_intervals(adev, h: PowerLaw, rate_hz: float, n_points: int):
    """``adev`` with the noise type, EDF and interval of every tau that had too few averages for the lag-one
    identification (``alpha_method`` not ``acf``) taken from the fitted model's dominant power-law term
    there. The B1 identification on a handful of averages is unreliable: on a simulated record of white
    PM, white, flicker and random-walk FM (2e5 s) it called tau = 32768 s flicker PM, whose EDF (116) made
    an interval that missed the true ADEV in 4 seeds of 12; with random-walk FM's EDF (5) none did."""
    from chronofuse.analysis.stability.edf import chi2_interval, greenhall_edf

    tau = np.asarray(adev.tau_s, dtype=float)
    parts = avar_components(h, tau, rate_hz)
    stack = np.array([parts[k] for k in _TERMS])
    dominant = np.array([_ALPHA[_TERMS[i]] for i in np.argmax(stack, axis=0)])
    redo = adev.alpha_method != "acf"
    alpha = np.where(redo, dominant, adev.alpha)
    m = np.rint(tau * rate_hz).astype(np.int64)
    edf = np.asarray(adev.edf, dtype=float).copy()
    edf[redo] = greenhall_edf(alpha[redo], 2, m[redo], n_points, overlapping=True, modified=False)
    lo, hi = chi2_interval(adev.dev, edf, adev.ci)
    method = np.where(redo, "model", adev.alpha_method)
    return replace(adev, alpha=alpha, edf=edf, lo=lo, hi=hi, alpha_method=method)


def characterize(values, rate_hz: float, kind: str = "phase", *, temperature_K=None, receiver_sigma_s: float = 10e-9,
                 horizons_s=HOLDOVER_HORIZONS_S, holdover_trials: int = 200, seed: int = 0, family_ci: float = FAMILY_CI,
                 source: str = "record") -> Characterization:
    """Characterise an oscillator from ``values`` (phase in s, or fractional frequency; NaN = missing) at
    ``rate_hz`` (module docstring). ``temperature_K`` (same length) adds the temperature coefficient;
    ``receiver_sigma_s`` is the white noise of the receiver the loop is recommended for; ``source`` names
    the record in errors."""
    from chronofuse.analysis import stability as st

    check_choice(kind, "kind", ("phase", "freq"))
    check_scalar(rate_hz, "rate_hz", min_val=0.0, include_min=False)
    check_scalar(family_ci, "family_ci", min_val=0.0, max_val=1.0, include_min=False, include_max=False)
    v = check_array(values, "values", ndim=1, allow_nan=True)
    _refuse_shape(v, rate_hz, kind, source)
    y = np.diff(v) * rate_hz if kind == "phase" else v.copy()
    temp = None
    if temperature_K is not None:
        temp = check_array(temperature_K, "temperature_K", ndim=1, allow_nan=True)
        if temp.size != v.size:
            raise InputError(f"the temperature has {temp.size} values, the record {v.size}", source)
        temp = temp[: y.size]
    t = np.arange(y.size) / rate_hz
    coef = _regress(y, t, temp)
    resid = y - coef[0] - coef[1] * (t - t.mean())
    if temp is not None:
        resid = resid - coef[2] * (temp - np.nanmean(temp))
    x = st.frequency_to_phase(resid, rate_hz, "remove")
    taus = st.tau_grid("octave", x.size, rate_hz, "oadev")
    if taus.size < MIN_TAUS:
        raise InputError(f"record too short to fit: {taus.size} octaves of tau, characterizing needs {MIN_TAUS}", source)
    per_tau = 1.0 - (1.0 - family_ci) / taus.size
    adev = st.compute("oadev", x, rate_hz, taus, ci=per_tau)
    notes = []
    spurs_hz = find_spurs(resid, rate_hz)
    h, spurs, excess = fit_adev(adev, rate_hz, spurs_hz)
    if adev.alpha_method is not None and np.any(adev.alpha_method != "acf"):
        for _ in range(2):  # the intervals from the fitted noise types, then the fit on those intervals
            adev = _model_intervals(adev, h, rate_hz, x.size)
            h, spurs, excess = fit_adev(adev, rate_hz, spurs_hz)
        held = ", ".join(f"{tau:g} s" for tau in adev.tau_s[adev.alpha_method == "model"])
        notes.append(f"intervals at {held} (fewer than 30 averages) with the fitted model's noise type")
    model = model_adev(h, adev.tau_s, rate_hz, spurs, excess)
    inside = (model >= adev.lo) & (model <= adev.hi)
    for f, y0 in spurs:
        notes.append(f"periodic FM at {f:.4g} Hz, amplitude {y0:.3g} (in the model)")
    if excess > 0:
        notes.append(f"phase-measurement noise correlated over one sample: {excess:.3g} of Allan variance at tau0 "
                     "(in the model; only tau0 sees it)")
    if not inside.all():
        bad = ", ".join(f"{tau:g} s" for tau in adev.tau_s[~inside])
        notes.append(f"the model's ADEV is outside the measured interval at {bad}")
    loop = recommend_loop(h, receiver_sigma_s, rate_hz)
    record_s = y.size / rate_hz
    rows, drift_sigma, tempco_sigma = predict_holdover(
        h, float(coef[1]), record_s, rate_hz, temp_K=temp,
        temp_coeff_per_K=float(coef[2]) if temp is not None else 0.0, horizons_s=horizons_s,
        trials=holdover_trials, seed=seed)
    return Characterization(
        rate_hz=float(rate_hz), n_samples=int(v.size), h=h, drift_per_s=float(coef[1]), drift_sigma_per_s=drift_sigma,
        temp_coeff_per_K=float(coef[2]) if temp is not None else None, temp_coeff_sigma_per_K=tempco_sigma,
        temp_ref_K=float(np.nanmean(temp)) if temp is not None else None, spurs=spurs, tau0_excess_avar=excess,
        adev=adev, model_adev=model, inside=inside, loop=loop, holdover=rows, notes=tuple(notes))


# -- the oscillator file: what `gnssdo` reads ---------------------------------------------------------------

def oscillator_document(result: Characterization, base: OscillatorModel, name: str, source: str) -> dict:
    """The JSON document of the characterised oscillator: the fitted ``h``, drift and temperature
    coefficient; what a record cannot tell (nominal frequency, EFC gain, DAC) from ``base``."""
    doc = {"format": "chronofuse-oscillator/1", "name": name, "nominal_hz": base.nominal_hz, "h": result.h.as_dict(),
           "drift_per_s": result.drift_per_s,
           "temp_coeff_per_K": base.temp_coeff_per_K if result.temp_coeff_per_K is None else result.temp_coeff_per_K,
           "temp_ref_K": base.temp_ref_K if result.temp_ref_K is None else result.temp_ref_K,
           "efc_gain_per_V": base.efc_gain_per_V, "dac_bits": base.dac_bits, "dac_range_V": base.dac_range_V,
           "source": f"characterized from {source}; nominal frequency, EFC and DAC from the {base.name} preset"
                     + ("" if result.temp_coeff_per_K is not None else ", temperature coefficient too")}
    return doc


_DOC_KEYS = ("name", "nominal_hz", "h", "drift_per_s", "temp_coeff_per_K", "efc_gain_per_V", "dac_bits",
             "dac_range_V", "source", "temp_ref_K")


def oscillator_from_document(doc, source: str = "oscillator file") -> OscillatorModel:
    """The :class:`OscillatorModel` of an oscillator document (:func:`oscillator_document`); a missing or
    unknown key, or a value out of range, is an :class:`InputError` naming ``source`` and the key."""
    if not isinstance(doc, dict):
        raise InputError("not an oscillator document (a JSON object)", source)
    unknown = sorted(set(doc) - set(_DOC_KEYS) - {"format"})
    if unknown:
        raise InputError(f"unknown keys {unknown} (known: {', '.join(_DOC_KEYS)})", source)
    missing = [k for k in _DOC_KEYS if k not in doc and k != "temp_ref_K"]
    if missing:
        raise InputError(f"missing keys {missing}", source)
    h = doc["h"]
    if not isinstance(h, dict) or set(h) - set(_TERMS):
        raise InputError(f"h must be an object of {', '.join(_TERMS)}", source)
    try:
        return OscillatorModel(name=str(doc["name"]), nominal_hz=float(doc["nominal_hz"]),
                               h=PowerLaw(**{k: float(v) for k, v in h.items()}), drift_per_s=float(doc["drift_per_s"]),
                               temp_coeff_per_K=float(doc["temp_coeff_per_K"]), efc_gain_per_V=float(doc["efc_gain_per_V"]),
                               dac_bits=int(doc["dac_bits"]), dac_range_V=float(doc["dac_range_V"]),
                               source=str(doc["source"]), temp_ref_K=float(doc.get("temp_ref_K", 298.15)))
    except (TypeError, ValueError) as exc:
        raise InputError(f"{exc}", source) from None


def characterize_file(path, *, kind: str | None = None, rate_hz: float | None = None, column: str | None = None,
                      nominal_hz: float | None = None, temperature_column: str | None = None,
                      receiver_sigma_s: float = 10e-9, holdover_trials: int = 200, seed: int = 0) -> Characterization:
    """:func:`characterize` of a record file read by :func:`chronofuse.io.records.read_record` (its
    options); ``temperature_column`` names a column of the oscillator's temperature beside it, in degC
    unless its name ends in ``_k`` (kelvin)."""
    from chronofuse.io.records import read_record, read_side_column

    record = read_record(path, kind=kind, rate_hz=rate_hz, column=column, nominal_hz=nominal_hz)
    temp = None
    if temperature_column is not None:
        temp = read_side_column(path, temperature_column, record.values.size)
        if not temperature_column.lower().endswith("_k"):
            temp = temp + 273.15
    return characterize(record.values, record.rate_hz, record.kind, temperature_K=temp,
                        receiver_sigma_s=receiver_sigma_s, holdover_trials=holdover_trials, seed=seed,
                        source=str(path))


def read_oscillator_file(path) -> OscillatorModel:
    """The oscillator of a JSON oscillator file (:func:`oscillator_document`); bad JSON or a bad document is
    an :class:`InputError` naming the file."""
    import json
    from pathlib import Path

    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError("no such file", str(path)) from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"not a JSON oscillator file ({exc})", str(path)) from None
    return oscillator_from_document(doc, str(path))
