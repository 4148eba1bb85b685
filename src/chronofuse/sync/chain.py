"""The seed's proposed chain and our improvements (seed 001 sections 2.1-2.2, eqs. 22-37).

Stages, per exchange, on the :mod:`chronofuse.estimation.kalman` core:

1. RVC: the velocity-compensated offset (seed eq. 9, or its exact-light-time form);
2. URT: :class:`~chronofuse.sync.urt.UrtCompensation` (``paper`` as the seed, or ``calibrated``);
3. Kalman filter, one of

   * ``filter="seed"``: state ``[eps, eps_dot, v]`` (eq. 23), ``A`` of eq. (29), ``B = [0 0 1]'`` with
     the control ``u = v_doppler - v`` (the velocity state follows the Doppler velocity), ``H = [1 0 0]``
     (eq. 32) on the URT-compensated offset, ``R`` the offset's variance (TOA noise, URT jitter and the
     Doppler velocity's share ``(T_B sigma_v / 2c)^2``; the seed takes the sample variance of the whole
     run, which a causal filter cannot), ``Q = diag(beta R, q_y, sigma_v^2)`` with ``beta = 1e-3``
     (eq. 35); ``q_y`` is the two clocks' random-walk-FM frequency variance per step. The velocity
     state is unobservable with this ``H`` and does not touch ``eps``.
   * ``filter="doppler"`` (ours): the same state observed by two measurements, the URT-compensated
     two-way offset of seed eq. (1), ``z1 = eps + eps_dot T_B / 2 - v (T_B - T_i) / (2c)`` (the exact light-time form of
     :func:`~chronofuse.sync.twoway.rvc_offset_exact_s`, so ``H1 = [1, T_B/2, -(T_B - T_i)/(2c)]``), and the
     Doppler velocity ``z2 = v`` (``H2 = [0 0 1]``); the clock block of ``Q`` from the oscillators'
     ``h0`` and ``h-2`` (:func:`~chronofuse.models.clock.clock_process_noise`), the velocity a random
     walk driven by white acceleration of spectral density ``accel_psd``.
   * ``filter="doppler-accel"`` (ours): as ``doppler`` with an acceleration state ``[eps, eps_dot, v, a]``
     driven by white jerk of density ``jerk_psd`` (the seed's stated limitation, section 3.1).

4. Optionally a residual model (``residual_model``: ``window`` exchanges of the nine inputs of
   :data:`FEATURES` -> residual, s; the BP 9-32-1 network or the LSTM of :mod:`chronofuse.sync.network`)
   adds its prediction clipped to ``clip_s`` after a warm-up fraction of the run (seed pseudo-code
   lines 18-28).
"""

from __future__ import annotations

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C
from chronofuse.estimation.kalman import predict, update
from chronofuse.models.clock import clock_process_noise
from chronofuse.sync.base import ExchangeSample, SyncAlgorithm
from chronofuse.sync.rvc import rvc_offset
from chronofuse.sync.twoway import ptp_delay_s, ptp_offset_s, urt_sensitivity
from chronofuse.sync.urt import UrtCompensation
from chronofuse.validation import check_choice, check_scalar

__all__ = ["ProposedChain", "FILTERS", "FEATURES", "residual_features"]

FILTERS = ("seed", "doppler", "doppler-accel")


class ProposedChain(SyncAlgorithm):
    """RVC -> URT compensation -> Kalman filter (-> residual model); see the module docstring.

    Parameters
    ----------
    filter : {"seed", "doppler", "doppler-accel"}
    light_time : {"seed", "exact"}
        The RVC formula of stage 1.
    urt_mode : {"paper", "calibrated", "none"}
    urt_batch, urt_refresh_s, urt_fixed_s :
        Of :class:`~chronofuse.sync.urt.UrtCompensation`.
    toa_sigma_s, urt_jitter_s, velocity_sigma_m_s : float
        The link's noise as the receiver knows it (TOA from its SNR, the URT jitter, Doppler velocity).
    reply_delay_s : float
        ``T_B``, s.
    snr_db : float
        The link's SNR, dB (a residual-model input).
    h0, hm2 : float
        White-FM and random-walk-FM coefficients of the two clocks together (``S_y`` of B minus A).
    beta : float
        The seed's ``q_eps = beta R`` (filter "seed").
    accel_psd : float
        White-acceleration spectral density, m^2/s^3 (filter "doppler").
    jerk_psd : float
        White-jerk spectral density, m^2/s^5 (filter "doppler-accel").
    frequency_sigma : float
        Prior sigma of the fractional frequency offset ``eps_dot``.
    residual_model : object with ``window`` and ``predict_residual_s(history (trials, window, 9)) -> (trials,)``
    warmup_fraction, steps : float, int
        The residual model starts after ``warmup_fraction * steps`` exchanges (seed: 0.6 of N).
    clip_s : float
        The residual is clipped to ``+-clip_s`` (seed: 5 ns).
    """

    name = "proposed"

    def __init__(self, filter="seed", light_time="seed", urt_mode="paper", urt_batch=100, urt_refresh_s=10.0,
                 urt_fixed_s=0.0, toa_sigma_s=1.25e-9, urt_jitter_s=2e-9, velocity_sigma_m_s=20.0,
                 reply_delay_s=4e-3, snr_db=10.0, h0=4e-24, hm2=1e-29, beta=1e-3, accel_psd=1.0, jerk_psd=1.0,
                 frequency_sigma=1e-6, residual_model=None, warmup_fraction=0.6, steps=2000, clip_s=5e-9,
                 interval_s=0.01):
        self.filter = filter
        self.light_time = light_time
        self.urt_mode = urt_mode
        self.urt_batch = urt_batch
        self.urt_refresh_s = urt_refresh_s
        self.urt_fixed_s = urt_fixed_s
        self.toa_sigma_s = toa_sigma_s
        self.urt_jitter_s = urt_jitter_s
        self.velocity_sigma_m_s = velocity_sigma_m_s
        self.reply_delay_s = reply_delay_s
        self.snr_db = snr_db
        self.h0 = h0
        self.hm2 = hm2
        self.beta = beta
        self.accel_psd = accel_psd
        self.jerk_psd = jerk_psd
        self.frequency_sigma = frequency_sigma
        self.residual_model = residual_model
        self.warmup_fraction = warmup_fraction
        self.steps = steps
        self.clip_s = clip_s
        self.interval_s = interval_s

    def _check_params(self):
        check_choice(self.filter, "filter", FILTERS)
        check_choice(self.light_time, "light_time", ("seed", "exact"))
        for name in ("toa_sigma_s", "urt_jitter_s", "velocity_sigma_m_s", "h0", "hm2", "accel_psd", "jerk_psd",
                     "clip_s"):
            check_scalar(getattr(self, name), name, min_val=0.0)
        check_scalar(self.beta, "beta", min_val=0.0, include_min=False)
        check_scalar(self.frequency_sigma, "frequency_sigma", min_val=0.0, include_min=False)
        check_scalar(self.warmup_fraction, "warmup_fraction", min_val=0.0, max_val=1.0)
        check_scalar(self.steps, "steps", min_val=1, integer=True)
        self.urt_ = UrtCompensation(self.urt_mode, self.urt_batch, self.urt_refresh_s, self.urt_fixed_s)
        dt = self.interval_s
        self.offset_var_s2_ = (2.0 * self.toa_sigma_s**2 + self.urt_jitter_s**2) / 4.0
        v_share = (self.reply_delay_s * self.velocity_sigma_m_s / (2.0 * C)) ** 2
        clock_q = clock_process_noise(dt, h0=self.h0, hm2=self.hm2)
        if self.filter == "seed":
            r = self.offset_var_s2_ + v_share
            self.R_ = np.array([[r]])
            self.F_ = np.array([[1.0, dt, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
            self.Q_ = np.diag([self.beta * r, max(clock_q[1, 1], 1e-30), self.velocity_sigma_m_s**2])
            self.P0_ = np.diag([r, self.frequency_sigma**2, self.velocity_sigma_m_s**2])
        else:
            n = 3 if self.filter == "doppler" else 4
            F = np.eye(n)
            F[0, 1] = dt
            Q = np.zeros((n, n))
            Q[:2, :2] = clock_q
            if n == 3:
                Q[2, 2] = self.accel_psd * dt
            else:
                F[2, 3] = dt
                q = self.jerk_psd
                Q[2:, 2:] = [[q * dt**3 / 3.0, q * dt**2 / 2.0], [q * dt**2 / 2.0, q * dt]]
            self.F_, self.Q_ = F, Q
            self.R_ = np.diag([self.offset_var_s2_, self.velocity_sigma_m_s**2])
            p0 = [self.offset_var_s2_ + v_share, self.frequency_sigma**2, self.velocity_sigma_m_s**2, 50.0**2][:n]
            self.P0_ = np.diag(p0)
        self.warmup_steps_ = max(20, int(np.floor(self.warmup_fraction * int(self.steps))))

    def init_state(self, trials):
        n = self.F_.shape[0]
        window = int(getattr(self.residual_model, "window", 1))
        return {"urt": self.urt_.init_state(trials), "x": np.full((trials, n), np.nan),
                "P": np.broadcast_to(self.P0_, (trials, n, n)).copy(), "s0": np.zeros(trials),
                "v0": np.zeros(trials), "hist": np.zeros((trials, window, len(FEATURES))),
                "features": np.zeros((trials, len(FEATURES)))}

    def _measure(self, sample, tp):
        """The Doppler filters' measurement z (trials, 2) and H (trials, 2, n) for this exchange."""
        n = self.F_.shape[0]
        trials = sample.t_i_s.shape[0]
        comp = -urt_sensitivity(sample.velocity_m_s) * tp
        z1 = ptp_offset_s(sample.t_i_s, sample.t_b_s, sample.t_r_s) + comp
        H = np.zeros((trials, 2, n))
        H[:, 0, 0] = 1.0
        H[:, 0, 1] = sample.t_b_s / 2.0  # eq. (1) averages eps over the exchange
        H[:, 0, 2] = -(sample.t_b_s - sample.t_i_s) / (2.0 * C)
        H[:, 1, 2] = 1.0
        H = np.nan_to_num(H)  # a missing exchange (NaN) is skipped by the update; keep H finite
        return np.stack([z1, sample.velocity_m_s], axis=1), H

    def update(self, state, sample):
        eps_rvc = rvc_offset(sample, self.light_time)
        urt_state, eps_corr, tp = self.urt_.update(state["urt"], sample.k, self.interval_s, eps_rvc,
                                                   sample.velocity_m_s)
        x, P = state["x"], state["P"]
        s0, v0 = state["s0"], state["v0"]
        if sample.k == 0:
            n = self.F_.shape[0]
            x = np.zeros((eps_corr.shape[0], n))
            x[:, 0] = eps_corr
            x[:, 2] = sample.velocity_m_s
            P = np.broadcast_to(self.P0_, (x.shape[0], n, n)).copy()
            s0 = C * ptp_delay_s(sample.t_i_s, sample.t_b_s, sample.t_r_s)
            v0 = sample.velocity_m_s.copy()
        else:
            prior = predict(x, P, self.F_, self.Q_)
            x, P = prior.x, prior.P
            if self.filter == "seed":
                x = x.copy()
                # x- = A x + B u with u = v_doppler - v (no control when the exchange is missing)
                x[:, 2] = np.where(np.isnan(sample.velocity_m_s), x[:, 2], sample.velocity_m_s)
                post = update(x, P, eps_corr[:, None], np.array([[1.0, 0.0, 0.0]]), self.R_)
            else:
                z, H = self._measure(sample, tp)
                post = update(x, P, z, H, self.R_)
            x, P = post.x, post.P
        features = residual_features(eps_corr, x[:, 0], x[:, 2], self.snr_db, sample, s0, v0, tp)
        hist = np.concatenate([state["hist"][:, 1:], features[:, None, :]], axis=1)
        est = x[:, 0].copy()
        if self.residual_model is not None and sample.k >= self.warmup_steps_:
            r = self.residual_model.predict_residual_s(hist)
            est = est + np.clip(r, -self.clip_s, self.clip_s)
        return {"urt": urt_state, "x": x, "P": P, "s0": s0, "v0": v0, "hist": hist, "features": features}, est

    def run_features(self, Z) -> tuple[np.ndarray, np.ndarray]:
        """The filter's estimates (trials, steps) and the residual model's inputs (trials, steps, 9)
        along ``Z``, through the same core as ``run`` (for training; the object is not changed)."""
        self._check_fitted()
        trials, steps, _ = Z.shape
        state = self.init_state(trials)
        est = np.empty((trials, steps))
        feats = np.empty((trials, steps, len(FEATURES)))
        for k in range(steps):
            state, _ = self.update(state, ExchangeSample.from_array(k, self.interval_s, Z[:, k]))
            est[:, k] = state["x"][:, 0]
            feats[:, k] = state["features"]
        return est, feats


#: The residual model's inputs (seed eq. 38), scaled to order one. ``eps_corr`` enters relative to the
#: filter's estimate so that the network does not depend on the size of the offset itself.
FEATURES = ("eps_corr_minus_eps_kf_ns", "eps_kf_us", "v_kf_km_s", "snr_scaled", "t_i_ms", "t_r_minus_t_b_ms",
            "s0_100km", "v0_km_s", "t_p_10ns")


def residual_features(eps_corr, eps_kf, v_kf, snr_db, sample, s0_m, v0_m_s, tp_s) -> np.ndarray:
    """Seed eq. (38)'s nine inputs of one exchange, shape (trials, 9), in the units of :data:`FEATURES`."""
    n = eps_corr.shape[0]
    return np.stack([
        (eps_corr - eps_kf) * 1e9, eps_kf * 1e6, v_kf / 1e3, np.full(n, (snr_db - 12.0) / 8.0),
        sample.t_i_s * 1e3, (sample.t_r_s - sample.t_b_s) * 1e3, s0_m / 1e5, v0_m_s / 1e3,
        np.broadcast_to(tp_s, (n,)) * 1e8,
    ], axis=1)
