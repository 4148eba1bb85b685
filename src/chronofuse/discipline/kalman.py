"""The Kalman servo on [phase, fractional frequency, drift], on the ``estimation/`` Kalman core.

Model (Van Dierendonck, McGraw and Brown, 16th PTTI 1984; Brown and Hwang 4th ed. sec. 9.3), with the
correction ``u`` applied over the previous second (held by the DAC) entering as a known input::

    s_k = Phi s_{k-1} + B u_{k-1} + w,   Phi, Q = models.clock (three states),  B = [dt, 0, 0]'
    z_k = H s_k + v,                     H = [1, 0, 0],  v ~ N(0, R)

``Q`` comes from the oscillator's h-coefficients (:func:`effective_clock_noise` folds flicker FM into
white and random-walk FM, half its Allan variance each at ``tau_match_s``, the usual Markov
approximation since flicker has no finite state). With ``gauss_markov`` terms the state is augmented
with first-order Gauss-Markov measurement errors (``m_{k} = phi m_{k-1} + w``, ``phi = exp(-dt/tau)``,
``H`` entry -1): with the receiver's true multipath and wander this is the clairvoyant filter, the
optimality yardstick. After the update the servo steers (a standard GPSDO law)::

    u_k = -(y_hat + d_hat dt / 2) - x_hat / steer_s

cancelling the estimated frequency and pulling the phase in with time constant ``steer_s``. Without a
usable sample the update is skipped: holdover keeps the last frequency and the estimated drift.

Robust variants, each its own module, are a hook on the measurement variance before the update
(innovation ``e = z - H s-``, its variance ``S = H P- H' + R``): :mod:`.kalman_adaptive` (the source
paper's weighted adaptive KF), :mod:`.kalman_gated` (chi-square innovation gate), :mod:`.kalman_huber`
(Huber-weighted update). Each one's compiled backend is :func:`kf_prior`, its hook, then :func:`kf_post`.

Learning (:meth:`KalmanServo.fit`). A Kalman servo given no ``h`` or no ``measurement_sigma_s`` learns
them from a recorded stretch: the free oscillator's offsets (a locked stretch turned open loop by
:func:`~chronofuse.discipline.servo.open_loop_offset_s`) are second-differenced, which removes phase and
frequency, and the white-FM ``h0``, random-walk-FM ``h-2`` and white measurement noise are fitted to the
differences' spectrum by Whittle's likelihood with a tapered periodogram
(:func:`chronofuse.integrity.noise_model.fit_noise_whittle` with ``taper=True``: without the taper the
measurement noise leaks into the lowest frequencies and a weak ``h-2`` comes out many times too large;
the model is the clock-bias detector's ``r(0..2)`` of the second difference); epochs of an outlying
difference are left out first. Given values are held fixed. The fitted ``h_`` has no flicker term (the
three-parameter model has none; flicker is seen as a mix of the two). With ``learn_gauss_markov`` (1 or
2) and nothing given, the reference's correlated errors are learnt too, as that many Gauss-Markov states
(``gauss_markov_``), with the oscillator's noise and the white noise, by the fuller Whittle fit of
:func:`chronofuse.discipline.noise_fit.fit_loop_noise`: a designer who fits only white noise takes the
multipath for oscillator noise and lets the loop follow it.

Numbers: per loop the compiled backend and the numpy core (:meth:`KalmanServo._control` on
:mod:`chronofuse.estimation.kalman`) do the same arithmetic in the same order
(:mod:`chronofuse.estimation.kalman_kernel` is the compiled core); tests compare them.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from pydantic import Field

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.discipline.dac import Dac
from chronofuse.discipline.servo import Servo
from chronofuse.discipline.servo_kernel import SAMPLE
from chronofuse.estimation import kalman_kernel as kk
from chronofuse.estimation.kalman import predict, update
from chronofuse.models.clock import clock_process_noise, clock_transition
from chronofuse.models.oscillator import PowerLaw
from chronofuse.registry import Config
from chronofuse.validation import check_scalar

__all__ = ["effective_clock_noise", "KalmanServo", "KalmanServoConfig", "build_kalman", "kf_prior", "kf_post",
           "sample_kf", "AdaptiveKalmanServo", "GatedKalmanServo", "HuberKalmanServo"]

#: The compiled backends' parameter header: n, dt, steer_s, r, where the scratch starts in the state, and
#: four slots for a variant's constants; then F (n*n), Q (n*n) and h (n). The state: x (n), P (n*n), a
#: variant's own, then scratch (the shifted state, the prior and the Kalman kernel's work space), so that
#: a step allocates nothing.
HEADER = 9


def effective_clock_noise(h: PowerLaw, tau_match_s: float = 1000.0) -> tuple[float, float]:
    """``(h0, hm2)`` of a white-FM + random-walk-FM model standing in for ``h`` (flicker FM folded in).

    Flicker FM's Allan variance ``2 ln2 h_-1`` is split equally at ``tau_match_s``:
    ``h0 += 2 ln2 h_-1 tau_match`` and ``hm2 += 3 ln2 h_-1 / (2 pi^2 tau_match)`` (SP 1065 Table 3 terms).
    """
    check_scalar(tau_match_s, "tau_match_s", min_val=0.0, include_min=False)
    ln2 = math.log(2.0)
    return (h.h0 + 2.0 * ln2 * h.hm1 * tau_match_s,
            h.hm2 + 3.0 * ln2 * h.hm1 / (2.0 * math.pi**2 * tau_match_s))


# -- the compiled core every Kalman backend shares --------------------------------------------------------


def scratch_size(n: int) -> int:
    """Floats of scratch at the end of a Kalman backend's state row (module constants above)."""
    return 2 * n + n * n + kk.work_size(n)


@numba.njit(cache=True)
def kf_prior(offset_s, shift_s, applied, state, params):
    """Predict one second: the phase state follows the step ``shift_s``, then ``x- = F x + B u`` with
    ``B u = [dt applied, 0, ...]``, ``P- = F P F' + Q``, into the state's scratch; returns the innovation
    ``e = z - h' x-`` (NaN without a sample) and ``h' P- h``."""
    n = int(params[0])
    nn = n * n
    k = int(params[4])  # the scratch: shifted x (n), x- (n), P- (n*n), the kernel's work space
    shifted, x_prior, P_prior = state[k:k + n], state[k + n:k + 2 * n], state[k + 2 * n:k + 2 * n + nn]
    h = params[HEADER + 2 * nn:HEADER + 2 * nn + n]
    for a in range(n):
        shifted[a] = state[a]
    shifted[0] = shifted[0] + shift_s
    kk.predict_flat(shifted, state[n:n + nn], params[HEADER:HEADER + nn], params[HEADER + nn:HEADER + 2 * nn],
                    x_prior, P_prior, state[k + 2 * n + nn:])
    x_prior[0] = x_prior[0] + params[1] * applied
    hx = 0.0
    for a in range(n):
        hx += x_prior[a] * h[a]
    return offset_s - hx, kk.innovation_variance_flat(P_prior, h)


@numba.njit(cache=True)
def kf_post(offset_s, accept, r_k, e, state, params, out):
    """Update the prior of :func:`kf_prior` with variance ``r_k`` when ``accept`` (else keep the prediction),
    store the posterior, write the backend outputs and return the steering ``-(y + d dt / 2) - x / steer_s``."""
    n = int(params[0])
    nn = n * n
    k = int(params[4])
    x, P = state[:n], state[n:n + nn]
    x_prior, P_prior = state[k + n:k + 2 * n], state[k + 2 * n:k + 2 * n + nn]
    if accept:
        kk.update_flat(x_prior, P_prior, offset_s, params[HEADER + 2 * nn:HEADER + 2 * nn + n], r_k, x, P,
                       state[k + 2 * n + nn:])
    else:
        for a in range(n):
            x[a] = x_prior[a]
        kk.symmetrize_flat(P_prior, P)
    dt = params[1]
    out[0] = x[0]
    out[1] = e if accept else math.nan
    out[2] = 1.0 if accept else 0.0
    return -(x[1] + 0.5 * dt * x[2]) - x[0] / params[2]


@numba.njit(SAMPLE, cache=True)
def sample_kf(offset_s, local_ts_s, weight, shift_s, applied, state, params, out):
    """Backend kernel of the plain Kalman servo: every sample accepted with ``R / weight``."""
    e, _ = kf_prior(offset_s, shift_s, applied, state, params)
    return kf_post(offset_s, not math.isnan(offset_s), params[3] / weight, e, state, params, out)


# -- the servo ----------------------------------------------------------------------------------------------


class KalmanServoConfig(Config):
    """Settings of the Kalman servo. ``h`` and ``measurement_sigma_s`` left None come from the caller's
    design (the registry's context: the oscillator's ``h``, the receivers' ``measurement_sigma_s``) or,
    without one, are learnt by :meth:`KalmanServo.fit`."""

    h: PowerLaw | None = Field(None, description="oscillator noise: h2 (s^3), h1 (s^2), h0 (s), hm1 (dimensionless), "
                                                 "hm2 (1/s); None: the design's, or learnt (PowerLaw)")
    measurement_sigma_s: float | None = Field(None, gt=0.0, description="white measurement noise sqrt(R) (s)")
    drift_psd_per_s3: float = Field(1e-40, ge=0.0, description="spectral density of the random-walk drift (1/s^3)")
    gauss_markov: tuple[tuple[float, float], ...] = Field(
        (), description="correlated measurement errors modelled as states, each (sigma_s, tau_s) (s, s)")
    steer_s: float = Field(300.0, gt=0.0, description="phase steering time constant (s)")
    tau_match_s: float = Field(1000.0, gt=0.0, description="where flicker FM is folded into white and random-walk FM (s)")
    learn_gauss_markov: int = Field(0, ge=0, le=2, description="Gauss-Markov measurement errors fit() learns when "
                                                               "nothing is given (count)")
    sigma_phase0_s: float = Field(1e-7, ge=0.0, description="prior standard deviation of the phase after the jam sync (s)")
    sigma_freq0: float = Field(1e-8, ge=0.0, description="prior standard deviation of the frequency (dimensionless)")
    sigma_drift0_per_s: float = Field(1e-14, ge=0.0, description="prior standard deviation of the drift (1/s)")
    drift0_per_s: float = Field(0.0, description="prior mean of the drift (1/s): the aging known beforehand")
    drift_ar1: float = Field(1.0, gt=0.0, le=1.0, description="AR(1) coefficient of the drift, 1: random walk "
                                                              "(dimensionless)")
    step_threshold_s: float | None = Field(1e-6, ge=0.0,
                                           description="jam-sync threshold after a gap; None: never step (s)")


def build_kalman(cls):
    """The registry's builder for a Kalman servo class: settings, plus the design's ``h`` and
    ``measurement_sigma_s`` from the context where the settings leave them None."""

    def build(config, context):
        settings = config.settings()
        h = settings.pop("h")
        sigma = settings.pop("measurement_sigma_s")
        h = context.get("h") if h is None else h
        sigma = context.get("measurement_sigma_s") if sigma is None else sigma
        return cls(h, sigma, interval_s=context.get("interval_s", 1.0), dac=context.get("dac"), **settings)

    return build


class KalmanServo(Servo):
    """Kalman servo on [phase, frequency, drift] (+ optional Gauss-Markov measurement states).

    Parameters
    ----------
    h : PowerLaw or None — the oscillator's noise (its design value; flicker folded at ``tau_match_s``);
        None: learnt by :meth:`fit`.
    measurement_sigma_s : float or None — white measurement noise ``sqrt(R)`` (s), > 0; None: learnt.
    drift_psd_per_s3 : spectral density of the random-walk drift (1/s^3), >= 0.
    gauss_markov : tuple of ``(sigma_s, tau_s)`` — correlated measurement errors modelled as states.
    steer_s : phase steering time constant (s), > 0.
    tau_match_s : where flicker FM is folded (s): near the loop's crossover, where it matters (default 1000 s).
    sigma_phase0_s, sigma_freq0, sigma_drift0_per_s : prior standard deviations (after the jam sync).
    drift0_per_s : prior mean of the drift (1/s), the aging known beforehand (default 0: none).
    drift_ar1 : AR(1) coefficient of the drift (1 = random walk), in (0, 1].

    learn_gauss_markov : Gauss-Markov measurement errors :meth:`fit` learns when nothing is given (0, 1, 2).

    Notes
    -----
    Learnt by :meth:`fit` (module docstring): ``h_`` and ``measurement_sigma_s_`` (the given values when
    given), ``gauss_markov_`` (with ``learn_gauss_markov``), ``n_fit_differences_``.
    """

    name = "kalman"
    kernel = sample_kf

    def __init__(self, h: PowerLaw | None = None, measurement_sigma_s: float | None = None, *,
                 drift_psd_per_s3: float = 1e-40, gauss_markov: tuple = (), steer_s: float = 300.0,
                 tau_match_s: float = 1000.0, sigma_phase0_s: float = 1e-7, sigma_freq0: float = 1e-8,
                 sigma_drift0_per_s: float = 1e-14, drift0_per_s: float = 0.0, drift_ar1: float = 1.0,
                 interval_s: float = 1.0,
                 dac: Dac | None = None, step_threshold_s: float | None = 1e-6, fast: bool = True,
                 learn_gauss_markov: int = 0):
        super().__init__(interval_s=interval_s, dac=dac, step_threshold_s=step_threshold_s, fast=fast)
        self.learn_gauss_markov = learn_gauss_markov
        self.h = h
        self.measurement_sigma_s = measurement_sigma_s
        self.drift_psd_per_s3 = drift_psd_per_s3
        self.gauss_markov = gauss_markov
        self.steer_s = steer_s
        self.tau_match_s = tau_match_s
        self.sigma_phase0_s = sigma_phase0_s
        self.sigma_freq0 = sigma_freq0
        self.sigma_drift0_per_s = sigma_drift0_per_s
        self.drift0_per_s = drift0_per_s
        self.drift_ar1 = drift_ar1

    # -- the design: given, or learnt ------------------------------------------------------------------------

    def design(self) -> tuple[PowerLaw, float]:
        """``(h, measurement_sigma_s)`` in use: what :meth:`fit` learnt, else the given values."""
        h = getattr(self, "h_", None) or self.h
        sigma = getattr(self, "measurement_sigma_s_", None) or self.measurement_sigma_s
        if h is None or sigma is None:
            missing = [n for n, v in (("h", h), ("measurement_sigma_s", sigma)) if v is None]
            raise ValueError(f"{', '.join(missing)} not given: fit() the servo on a recorded stretch of offsets "
                             "to learn it")
        return h, sigma

    def _gm(self) -> tuple:
        """The Gauss-Markov measurement errors in use: what :meth:`fit` learnt, else the given ones."""
        learnt = getattr(self, "gauss_markov_", None)
        return tuple(learnt) if learnt is not None else tuple(self.gauss_markov)

    def _learn(self, z_open, interval_s):
        from chronofuse.estimation.process import second_difference_series
        from chronofuse.integrity.noise_model import contiguous_runs, fit_noise, empirical_autocorrelation
        from chronofuse.integrity.noise_model import fit_noise_whittle, training_outliers

        if self.h is not None and self.measurement_sigma_s is not None:
            self.h_, self.measurement_sigma_s_ = self.h, self.measurement_sigma_s
            self.n_fit_differences_ = 0
            return
        if self.learn_gauss_markov and self.h is None and self.measurement_sigma_s is None and not self.gauss_markov:
            from chronofuse.discipline.noise_fit import fit_loop_noise

            fitted = fit_loop_noise(z_open, interval_s, gauss_markov=int(self.learn_gauss_markov))
            self.h_ = PowerLaw(h0=fitted.h0, hm2=fitted.hm2)
            self.measurement_sigma_s_ = fitted.sigma_s
            self.gauss_markov_ = fitted.gauss_markov
            self.n_fit_differences_ = fitted.n_differences
            return
        known = {}
        if self.h is not None:
            known["h0"], known["hm2"] = effective_clock_noise(self.h, self.tau_match_s)
        if self.measurement_sigma_s is not None:
            known["sigma_rho_m"] = self.measurement_sigma_s * SPEED_OF_LIGHT_M_PER_S
        x = np.where(training_outliers(z_open), np.nan, z_open)
        df = second_difference_series(x, interval_s)
        if np.isfinite(df).sum() < 30:
            raise ValueError(f"offset_s gives {int(np.isfinite(df).sum())} valid second differences; fitting the "
                             "noise needs at least 30")
        if contiguous_runs(df, 8):
            h0, hm2, sigma_rho_m = fit_noise_whittle(df, interval_s, taper=True, **known)
        else:
            h0, hm2, sigma_rho_m = fit_noise(empirical_autocorrelation(df), interval_s, **known)
        self.h_ = self.h if self.h is not None else PowerLaw(h0=h0, hm2=hm2)
        self.measurement_sigma_s_ = (self.measurement_sigma_s if self.measurement_sigma_s is not None
                                     else sigma_rho_m / SPEED_OF_LIGHT_M_PER_S)
        self.n_fit_differences_ = int(np.isfinite(df).sum())

    # -- the model ---------------------------------------------------------------------------------------

    def _check(self) -> None:
        super()._check()
        h, sigma = self.design()
        if not isinstance(h, PowerLaw):
            raise TypeError(f"h == {h!r}, must be a PowerLaw")
        check_scalar(sigma, "measurement_sigma_s", min_val=0.0, include_min=False)
        check_scalar(self.steer_s, "steer_s", min_val=0.0, include_min=False)
        check_scalar(self.drift_ar1, "drift_ar1", min_val=0.0, max_val=1.0, include_min=False)
        for name in ("sigma_phase0_s", "sigma_freq0", "sigma_drift0_per_s"):
            check_scalar(getattr(self, name), name, min_val=0.0)
        check_scalar(self.drift0_per_s, "drift0_per_s")
        check_scalar(self.learn_gauss_markov, "learn_gauss_markov", min_val=0, max_val=2, integer=True)
        for sigma_gm, tau in self._gm():
            check_scalar(sigma_gm, "gauss_markov sigma_s", min_val=0.0)
            check_scalar(tau, "gauss_markov tau_s", min_val=0.0, include_min=False)

    def model(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(F, Q, H)`` of the (augmented) state over one interval."""
        dt = float(self.interval_s)
        h0, hm2 = effective_clock_noise(self.design()[0], self.tau_match_s)
        n = 3 + len(self._gm())
        F = np.zeros((n, n))
        Q = np.zeros((n, n))
        F[:3, :3] = clock_transition(dt, 3)
        F[2, 2] = self.drift_ar1
        Q[:3, :3] = clock_process_noise(dt, h0=h0, hm2=hm2, drift_psd_per_s3=self.drift_psd_per_s3, states=3)
        H = np.zeros((1, n))
        H[0, 0] = 1.0
        for i, (sigma, tau) in enumerate(self._gm()):
            phi = math.exp(-dt / tau)
            F[3 + i, 3 + i] = phi
            Q[3 + i, 3 + i] = sigma**2 * (1.0 - phi * phi)
            H[0, 3 + i] = -1.0
        return F, Q, H

    def prior_covariance(self) -> np.ndarray:
        """``P0`` (n, n): the prior after the jam sync (phase, frequency, drift, then the Gauss-Markov states)."""
        n = 3 + len(self._gm())
        P0 = np.zeros((n, n))
        P0[0, 0], P0[1, 1], P0[2, 2] = self.sigma_phase0_s**2, self.sigma_freq0**2, self.sigma_drift0_per_s**2
        for i, (sigma, _) in enumerate(self._gm()):
            P0[3 + i, 3 + i] = sigma**2
        return P0

    def prior_mean(self) -> np.ndarray:
        """``x0`` (n,): the prior state after the jam sync; zero but for the drift, :attr:`drift0_per_s`."""
        x0 = np.zeros(self.prior_covariance().shape[0])
        x0[2] = self.drift0_per_s
        return x0

    def _initial(self, n_loops):
        F, Q, H = self.model()
        n = F.shape[0]
        return {"x": np.broadcast_to(self.prior_mean(), (n_loops, n)).copy(),
                "P": np.broadcast_to(self.prior_covariance(), (n_loops, n, n)).copy(),
                "model": (F, Q, H, self.design()[1] ** 2)}

    # -- the compiled backend's constants -------------------------------------------------------------------

    def _variant_params(self) -> tuple[float, float, float, float]:
        """The four variant slots of the parameter header (unused by the plain KF)."""
        return (0.0, 0.0, 0.0, 0.0)

    def _variant_state(self) -> int:
        """Floats of a variant's own state after x and P."""
        return 0

    def _kernel_params(self):
        F, Q, H = self.model()
        n = F.shape[0]
        head = (float(n), float(self.interval_s), float(self.steer_s), float(self.design()[1] ** 2),
                float(n + n * n + self._variant_state()))
        return np.concatenate([np.array(head + self._variant_params()), F.ravel(), Q.ravel(), H[0]])

    def _kernel_initial(self, n_loops):
        P0 = self.prior_covariance()
        n = P0.shape[0]
        state = np.zeros((n_loops, n + n * n + self._variant_state() + scratch_size(n)))
        state[:, :n] = self.prior_mean()
        state[:, n:n + n * n] = P0.ravel()
        return state

    # -- the numpy core (the robust hook: plain KF, the nominal R, every sample accepted) ----------------------

    def _weigh(self, state, e, s0, r, valid):
        """``(R_k (N,), accept (N,), extra state)`` from innovation ``e``, ``s0 = H P- H'`` and nominal ``r``."""
        return np.full(e.shape, r), valid, {}

    def _control(self, state, z, valid, shift, weight):
        F, Q, H, r = state["model"]
        dt = float(self.interval_s)
        x = state["x"].copy()
        x[:, 0] += shift  # the regenerated 1PPS was stepped: the phase state follows
        prior = predict(x, state["P"], F, Q)
        x_prior = prior.x.copy()
        x_prior[:, 0] += dt * state["u"]  # B u, the correction applied over the last second
        e = z - x_prior @ H[0]
        s0 = np.einsum("i,nij,j->n", H[0], prior.P, H[0])
        r_k, accept, extra = self._weigh(state, np.where(valid, e, np.nan), s0, r / weight, valid)
        zz = np.where(accept, z, np.nan)[:, None]
        post = update(x_prior, prior.P, zz, H, r_k[:, None, None])
        xs = post.x
        y_cmd = -(xs[:, 1] + 0.5 * dt * xs[:, 2]) - xs[:, 0] / self.steer_s
        new = {"x": xs, "P": post.P, "model": state["model"], **extra}
        innovation = np.where(accept, e, np.nan)
        return new, y_cmd, xs[:, 0].copy(), innovation, accept
