"""Kalman-filter servos on [phase, fractional frequency, drift], on the ``estimation/`` core.

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

Robust variants, each a hook on the measurement variance before the update (innovation ``e = z - H s-``,
its variance ``S = H P- H' + R``):

* :class:`AdaptiveKalmanServo`, the source paper's weighted adaptive KF (section 5.2, eqs. (4-5)-(4-6)):
  ``sigma_e`` = standard deviation of the innovations over a sliding window; ``R_k = lambda R`` with
  ``lambda = lambda_max`` if ``sigma_e > sigma_th`` else ``lambda_min``; optional AR(1) drift
  (eq. (4-4): ``d_k = alpha d_{k-1} + w``, ``Phi[2, 2] = alpha``).
* :class:`GatedKalmanServo`: skip the update when ``e^2 / S`` exceeds the chi-square(1) quantile at
  ``gate_pfa`` (accept again after ``max_rejects`` consecutive rejections: a persistent step is real).
* :class:`HuberKalmanServo`: Huber's weight ``w = min(1, c / |e / sqrt(S)|)`` applied as ``R / w``
  (one iteratively-reweighted step, Z. M. Durovic and B. D. Kovacevic, IEEE TAC 44(6), 1999).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from chronofuse.discipline.dac import Dac
from chronofuse.discipline.kernels import MODES
from chronofuse.discipline.servo import Servo
from chronofuse.estimation.kalman import predict, update
from chronofuse.models.clock import clock_process_noise, clock_transition
from chronofuse.models.oscillator import PowerLaw
from chronofuse.validation import check_scalar

__all__ = ["effective_clock_noise", "KalmanServo", "AdaptiveKalmanServo", "GatedKalmanServo", "HuberKalmanServo"]


def effective_clock_noise(h: PowerLaw, tau_match_s: float = 1000.0) -> tuple[float, float]:
    """``(h0, hm2)`` of a white-FM + random-walk-FM model standing in for ``h`` (flicker FM folded in).

    Flicker FM's Allan variance ``2 ln2 h_-1`` is split equally at ``tau_match_s``:
    ``h0 += 2 ln2 h_-1 tau_match`` and ``hm2 += 3 ln2 h_-1 / (2 pi^2 tau_match)`` (SP 1065 Table 3 terms).
    """
    check_scalar(tau_match_s, "tau_match_s", min_val=0.0, include_min=False)
    ln2 = math.log(2.0)
    return (h.h0 + 2.0 * ln2 * h.hm1 * tau_match_s,
            h.hm2 + 3.0 * ln2 * h.hm1 / (2.0 * math.pi**2 * tau_match_s))


class KalmanServo(Servo):
    """Kalman servo on [phase, frequency, drift] (+ optional Gauss-Markov measurement states).

    Parameters
    ----------
    h : PowerLaw — the oscillator's noise (its design value; flicker folded at ``tau_match_s``).
    measurement_sigma_s : float — white measurement noise ``sqrt(R)`` (s), > 0.
    drift_psd_per_s3 : spectral density of the random-walk drift (1/s^3), >= 0.
    gauss_markov : tuple of ``(sigma_s, tau_s)`` — correlated measurement errors modelled as states.
    steer_s : phase steering time constant (s), > 0.
    tau_match_s : where flicker FM is folded (s): near the loop's crossover, where it matters (default 1000 s).
    sigma_phase0_s, sigma_freq0, sigma_drift0_per_s : prior standard deviations (after the jam sync).
    drift_ar1 : AR(1) coefficient of the drift (1 = random walk), in (0, 1].
    """

    name = "kf"

    def __init__(self, h: PowerLaw, measurement_sigma_s: float, *, drift_psd_per_s3: float = 1e-40,
                 gauss_markov: tuple = (), steer_s: float = 300.0, tau_match_s: float = 1000.0,
                 sigma_phase0_s: float = 1e-7, sigma_freq0: float = 1e-8, sigma_drift0_per_s: float = 1e-14,
                 drift_ar1: float = 1.0, interval_s: float = 1.0, dac: Dac | None = None,
                 step_threshold_s: float | None = 1e-6, fast: bool = True):
        super().__init__(interval_s=interval_s, dac=dac, step_threshold_s=step_threshold_s, fast=fast)
        self.h = h
        self.measurement_sigma_s = measurement_sigma_s
        self.drift_psd_per_s3 = drift_psd_per_s3
        self.gauss_markov = gauss_markov
        self.steer_s = steer_s
        self.tau_match_s = tau_match_s
        self.sigma_phase0_s = sigma_phase0_s
        self.sigma_freq0 = sigma_freq0
        self.sigma_drift0_per_s = sigma_drift0_per_s
        self.drift_ar1 = drift_ar1

    # -- the model ---------------------------------------------------------------------------------------

    def _check(self) -> None:
        super()._check()
        if not isinstance(self.h, PowerLaw):
            raise TypeError(f"h == {self.h!r}, must be a PowerLaw")
        check_scalar(self.measurement_sigma_s, "measurement_sigma_s", min_val=0.0, include_min=False)
        check_scalar(self.steer_s, "steer_s", min_val=0.0, include_min=False)
        check_scalar(self.drift_ar1, "drift_ar1", min_val=0.0, max_val=1.0, include_min=False)
        for name in ("sigma_phase0_s", "sigma_freq0", "sigma_drift0_per_s"):
            check_scalar(getattr(self, name), name, min_val=0.0)
        for sigma, tau in self.gauss_markov:
            check_scalar(sigma, "gauss_markov sigma_s", min_val=0.0)
            check_scalar(tau, "gauss_markov tau_s", min_val=0.0, include_min=False)

    def model(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(F, Q, H)`` of the (augmented) state over one interval."""
        dt = float(self.interval_s)
        h0, hm2 = effective_clock_noise(self.h, self.tau_match_s)
        n = 3 + len(self.gauss_markov)
        F = np.zeros((n, n))
        Q = np.zeros((n, n))
        F[:3, :3] = clock_transition(dt, 3)
        F[2, 2] = self.drift_ar1
        Q[:3, :3] = clock_process_noise(dt, h0=h0, hm2=hm2, drift_psd_per_s3=self.drift_psd_per_s3, states=3)
        H = np.zeros((1, n))
        H[0, 0] = 1.0
        for i, (sigma, tau) in enumerate(self.gauss_markov):
            phi = math.exp(-dt / tau)
            F[3 + i, 3 + i] = phi
            Q[3 + i, 3 + i] = sigma**2 * (1.0 - phi * phi)
            H[0, 3 + i] = -1.0
        return F, Q, H

    def _initial(self, n_loops):
        F, Q, H = self.model()
        n = F.shape[0]
        P0 = np.zeros((n, n))
        P0[0, 0], P0[1, 1], P0[2, 2] = self.sigma_phase0_s**2, self.sigma_freq0**2, self.sigma_drift0_per_s**2
        for i, (sigma, _) in enumerate(self.gauss_markov):
            P0[3 + i, 3 + i] = sigma**2
        return {"x": np.zeros((n_loops, n)), "P": np.broadcast_to(P0, (n_loops, n, n)).copy(),
                "model": (F, Q, H, self.measurement_sigma_s**2)}

    def _kernel_model(self, state):
        F, Q, H, r = state["model"]
        return (F, Q, np.ascontiguousarray(H[0]), float(r), MODES[self.name], float(self.interval_s),
                float(self.steer_s), self._step_thr()) + self._robust_params()

    def _robust_params(self) -> tuple:
        """(wakf_th, lam_min, lam_max, gamma, max_rejects, huber_c, kp, ki) for the kernel."""
        return (0.0, 1.0, 1.0, 0.0, 0, 1.0, 0.0, 0.0)

    # -- the robust hook (plain KF: the nominal R, every sample accepted) --------------------------------

    def _weigh(self, state, e, s0, r, valid):
        """``(R_k (N,), accept (N,), extra state)`` from innovation ``e``, ``s0 = H P- H'`` and nominal ``r``."""
        return np.full(e.shape, r), valid, {}

    def _control(self, state, z, valid, shift):
        F, Q, H, r = state["model"]
        dt = float(self.interval_s)
        x = state["x"].copy()
        x[:, 0] += shift  # the regenerated 1PPS was stepped: the phase state follows
        prior = predict(x, state["P"], F, Q)
        x_prior = prior.x.copy()
        x_prior[:, 0] += dt * state["u"]  # B u, the correction applied over the last second
        # A loop's first sample jam-syncs the 1PPS: its phase starts there (zero); no prior phase existed.
        if self.step_threshold_s is not None:
            x_prior[:, 0] = np.where(valid & ~state["started"], z, x_prior[:, 0])
        e = z - x_prior @ H[0]
        s0 = np.einsum("i,nij,j->n", H[0], prior.P, H[0])
        r_k, accept, extra = self._weigh(state, np.where(valid, e, np.nan), s0, r, valid)
        zz = np.where(accept, z, np.nan)[:, None]
        post = update(x_prior, prior.P, zz, H, r_k[:, None, None])
        xs = post.x
        y_cmd = -(xs[:, 1] + 0.5 * dt * xs[:, 2]) - xs[:, 0] / self.steer_s
        new = {"x": xs, "P": post.P, "model": state["model"], **extra}
        innovation = np.where(accept, e, np.nan)
        return new, y_cmd, xs[:, 0].copy(), innovation, accept


class AdaptiveKalmanServo(KalmanServo):
    """The source paper's weighted adaptive KF (section 5.2): ``R_k = lambda R`` from the windowed innovation spread.

    Extra parameters: ``window`` (innovations, >= 2), ``sigma_th_s`` (threshold on their standard
    deviation, s; default ``threshold_factor * measurement_sigma_s``), ``lambda_min`` and ``lambda_max``
    (>= lambda_min > 0). ``drift_ar1`` < 1 gives the source paper's AR(1) drift.
    """

    name = "wakf"

    def __init__(self, h: PowerLaw, measurement_sigma_s: float, *, window: int = 10, sigma_th_s: float | None = None,
                 threshold_factor: float = 2.0, lambda_min: float = 1.0, lambda_max: float = 10.0, **kw):
        super().__init__(h, measurement_sigma_s, **kw)
        self.window = window
        self.sigma_th_s = sigma_th_s
        self.threshold_factor = threshold_factor
        self.lambda_min = lambda_min
        self.lambda_max = lambda_max

    def _check(self) -> None:
        super()._check()
        check_scalar(self.window, "window", min_val=2, integer=True)
        check_scalar(self.lambda_min, "lambda_min", min_val=0.0, include_min=False)
        check_scalar(self.lambda_max, "lambda_max", min_val=self.lambda_min)
        check_scalar(self.threshold_factor, "threshold_factor", min_val=0.0, include_min=False)
        if self.sigma_th_s is not None:
            check_scalar(self.sigma_th_s, "sigma_th_s", min_val=0.0, include_min=False)

    def _initial(self, n_loops):
        state = super()._initial(n_loops)
        state["window"] = np.full((n_loops, int(self.window)), np.nan)
        return state

    def _threshold_s(self) -> float:
        return self.sigma_th_s if self.sigma_th_s is not None else self.threshold_factor * self.measurement_sigma_s

    def _robust_params(self):
        return (float(self._threshold_s()), float(self.lambda_min), float(self.lambda_max), 0.0, 0, 1.0, 0.0, 0.0)

    def _weigh(self, state, e, s0, r, valid):
        buf = np.concatenate([state["window"][:, 1:], e[:, None]], axis=1)  # NaN where no sample
        count = np.isfinite(buf).sum(axis=1)
        filled = np.where(np.isfinite(buf), buf, 0.0)
        mean = filled.sum(axis=1) / np.maximum(count, 1)
        var = (np.where(np.isfinite(buf), buf - mean[:, None], 0.0) ** 2).sum(axis=1) / np.maximum(count - 1, 1)
        sigma_e = np.where(count >= 2, np.sqrt(var), 0.0)
        th = self._threshold_s()
        lam = np.where(sigma_e > th, self.lambda_max, self.lambda_min)
        return lam * r, valid, {"window": buf}


class GatedKalmanServo(KalmanServo):
    """KF with chi-square innovation gating: reject ``e^2 / S > chi2_1.isf(gate_pfa)``; accept again after
    ``max_rejects`` consecutive rejections."""

    name = "gated"

    def __init__(self, h: PowerLaw, measurement_sigma_s: float, *, gate_pfa: float = 1e-3, max_rejects: int = 30, **kw):
        super().__init__(h, measurement_sigma_s, **kw)
        self.gate_pfa = gate_pfa
        self.max_rejects = max_rejects

    def _check(self) -> None:
        super()._check()
        check_scalar(self.gate_pfa, "gate_pfa", min_val=0.0, max_val=1.0, include_min=False, include_max=False)
        check_scalar(self.max_rejects, "max_rejects", min_val=1, integer=True)

    def _initial(self, n_loops):
        state = super()._initial(n_loops)
        state["rejects"] = np.zeros(n_loops, dtype=np.int64)
        state["gamma"] = float(stats.chi2.isf(self.gate_pfa, 1))
        return state

    def _robust_params(self):
        return (0.0, 1.0, 1.0, float(stats.chi2.isf(self.gate_pfa, 1)), int(self.max_rejects), 1.0, 0.0, 0.0)

    def _weigh(self, state, e, s0, r, valid):
        gamma = state["gamma"]
        with np.errstate(invalid="ignore"):
            outlier = valid & (e * e / (s0 + r) > gamma)
        give_in = state["rejects"] >= self.max_rejects
        reject = outlier & ~give_in
        rejects = np.where(reject, state["rejects"] + 1, np.where(valid, 0, state["rejects"]))
        return np.full(e.shape, r), valid & ~reject, {"rejects": rejects, "gamma": gamma}


class HuberKalmanServo(KalmanServo):
    """KF with a Huber-weighted update: ``R / min(1, c / |e / sqrt(S)|)``, ``c = huber_c`` (default 1.345)."""

    name = "huber"

    def __init__(self, h: PowerLaw, measurement_sigma_s: float, *, huber_c: float = 1.345, **kw):
        super().__init__(h, measurement_sigma_s, **kw)
        self.huber_c = huber_c

    def _check(self) -> None:
        super()._check()
        check_scalar(self.huber_c, "huber_c", min_val=0.0, include_min=False)

    def _robust_params(self):
        return (0.0, 1.0, 1.0, 0.0, 0, float(self.huber_c), 0.0, 0.0)

    def _weigh(self, state, e, s0, r, valid):
        r_norm = np.abs(np.where(valid, e, 0.0)) / np.sqrt(s0 + r)
        weight = np.minimum(1.0, self.huber_c / np.maximum(r_norm, 1e-300))
        return r / weight, valid, {}
