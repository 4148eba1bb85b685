"""The paper's chain, ``rtt-rvc-kf`` (and ``-bp``, ``-lstm``): RVC -> URT compensation -> Kalman filter ->
residual network (the swarm paper's sections 2.1-2.2, eqs. 22-46), kept as the paper writes it.

Stages, per exchange, on the :mod:`chronofuse.estimation.kalman` core:

1. RVC: the velocity-compensated offset, the paper's eq. (9) (``light_time="paper"``) or its exact-light-time
   form with A at rest (``"exact"``, :func:`~chronofuse.sync.twoway.rvc_offset_exact_s`);
2. URT: :class:`~chronofuse.sync.urt.UrtCompensation` (``paper`` as the paper, or ``calibrated``);
3. Kalman filter: state ``[eps, eps_dot, v]`` (eq. 23), ``A`` of eq. (29), ``B = [0 0 1]'`` with the control
   ``u = v_doppler - v`` (the velocity state follows the Doppler velocity), ``H = [1 0 0]`` (eq. 32) on the
   URT-compensated offset, ``R`` the offset's variance (TOA noise, URT jitter and the Doppler velocity's
   share ``(T_B sigma_v / 2c)^2``; the paper takes the sample variance of the whole run, which a causal
   filter cannot), ``Q = diag(beta R, q_y, sigma_v^2)`` with ``beta = 1e-3`` (eq. 35); ``q_y`` is the two
   clocks' random-walk-FM frequency variance per step. The velocity state is unobservable with this ``H``
   and does not touch ``eps``; the skew's action over the exchange and the light time is not modelled.
4. Optionally a residual model (``residual_model``: ``window`` exchanges of the nine inputs of
   :data:`FEATURES` -> residual, s; the BP 9-32-1 network or the LSTM of :mod:`chronofuse.sync.residual`)
   adds its prediction clipped to ``clip_s`` after a warm-up fraction of the run (pseudo-code lines 18-28).

The network inputs follow eq. (38) with one change: no input carries the absolute clock offset (the paper
feeds ``eps_corr`` and ``eps_hat`` themselves, so a network trained near zero offset learns the offset's
size: at a 1 us offset such a network made the chain 3.6x worse). ``eps_corr`` enters relative to the
filter's estimate, the estimate itself is replaced by the filter's skew, and ``T_i``, ``T_r`` by the path
delay ``(T_i + T_r - T_B)/2`` and the reply stamp ``T_B``; a test checks that shifting the true offset by
1 us leaves every input unchanged.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C
from chronofuse.estimation.kalman import predict, update
from chronofuse.models.clock import clock_process_noise
from chronofuse.registry import Config
from chronofuse.sync.base import ExchangeSample, SyncAlgorithm
from chronofuse.sync.rvc import rvc_offset
from chronofuse.sync.twoway import ptp_delay_s
from chronofuse.sync.urt import UrtCompensation

__all__ = ["RvcKfConfig", "RvcKfChain", "FEATURES", "residual_features"]


class RvcKfConfig(Config):
    """The paper's chain's settings; fields carry their units."""

    interval_s: float = Field(0.01, gt=0.0, description="exchange interval (s)")
    light_time: str = Field("paper", pattern="^(paper|exact)$", description="RVC formula: the paper's eq. (9) or exact (choice)")
    urt_mode: str = Field("calibrated", pattern="^(paper|calibrated|none)$", description="URT compensation: paper, calibrated or none (choice)")
    urt_batch: int = Field(100, ge=50, le=200, description="URT batch M (exchanges)")
    urt_refresh_s: float = Field(10.0, gt=0.0, description="URT batch refresh period (s)")
    urt_s: float | tuple[float, ...] = Field(0.0, description="calibrated fixed URT, s (one per trial allowed)")
    toa_sigma_s: float = Field(1.25e-9, ge=0.0, description="TOA noise sigma (s)")
    urt_jitter_s: float = Field(2e-9, ge=0.0, description="URT jitter sigma (s)")
    velocity_sigma_m_s: float = Field(20.0, ge=0.0, description="Doppler velocity sigma (m/s)")
    reply_delay_s: float = Field(4e-3, gt=0.0, description="reply slot T_B (s)")
    snr_db: float = Field(10.0, description="the link's SNR, a network input (dB)")
    hm2_per_s: float = Field(7.6e-27, ge=0.0, description="random-walk FM of the clock offset (1/s)")
    h0_s: float = Field(4e-24, ge=0.0, description="white FM of the clock offset (s)")
    beta: float = Field(1e-3, gt=0.0, description="the paper's q_eps = beta R, eq. 35 (dimensionless)")
    frequency_sigma: float = Field(1e-6, gt=0.0, description="prior sigma of the frequency offset (fractional)")
    warmup_fraction: float = Field(0.6, ge=0.0, le=1.0, description="network warm-up (fraction of the run)")
    steps: int = Field(2000, ge=1, description="run length, for the warm-up (exchanges)")
    clip_s: float = Field(5e-9, ge=0.0, description="the network's output is clipped to +-clip_s (s)")


class RvcKfChain(SyncAlgorithm):
    """RVC -> URT compensation -> Kalman filter (-> residual model); see the module docstring."""

    name = "rtt-rvc-kf"

    def __init__(self, config: RvcKfConfig = RvcKfConfig(), residual_model=None):
        self.config = config
        self.residual_model = residual_model
        self.interval_s = config.interval_s

    def _check_params(self):
        cfg = self.config
        self.urt_ = UrtCompensation(cfg.urt_mode, cfg.urt_batch, cfg.urt_refresh_s,
                                    np.atleast_1d(np.asarray(cfg.urt_s, dtype=np.float64)))
        dt = cfg.interval_s
        self.offset_var_s2_ = (2.0 * cfg.toa_sigma_s**2 + cfg.urt_jitter_s**2) / 4.0
        v_share = (cfg.reply_delay_s * cfg.velocity_sigma_m_s / (2.0 * C)) ** 2
        clock_q = clock_process_noise(dt, h0=cfg.h0_s, hm2=cfg.hm2_per_s)
        r = self.offset_var_s2_ + v_share
        self.R_ = np.array([[r]])
        self.F_ = np.array([[1.0, dt, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
        self.Q_ = np.diag([cfg.beta * r, max(clock_q[1, 1], 1e-30), cfg.velocity_sigma_m_s**2])
        self.P0_ = np.diag([r, cfg.frequency_sigma**2, cfg.velocity_sigma_m_s**2])
        self.warmup_steps_ = max(20, int(np.floor(cfg.warmup_fraction * int(cfg.steps))))

    def init_state(self, trials):
        n = self.F_.shape[0]
        window = int(getattr(self.residual_model, "window", 1))
        return {"urt": self.urt_.init_state(trials), "x": np.full((trials, n), np.nan),
                "P": np.broadcast_to(self.P0_, (trials, n, n)).copy(), "s0": np.zeros(trials),
                "v0": np.zeros(trials), "hist": np.zeros((trials, window, len(FEATURES))),
                "features": np.zeros((trials, len(FEATURES)))}

    def update(self, state, sample):
        cfg = self.config
        eps_rvc = rvc_offset(sample, cfg.light_time)
        urt_state, eps_corr, tp = self.urt_.update(state["urt"], sample.k, self.interval_s, eps_rvc,
                                                   sample.velocity_m_s)
        x, P = state["x"], state["P"]
        s0, v0 = state["s0"], state["v0"]
        # A trial starts its filter at its first exchange that arrives (k = 0 unless that one was lost): until
        # then its state is NaN, and a lost first exchange must not leave it NaN for the whole run.
        fresh = np.isnan(x[:, 0]) if sample.k > 0 else np.ones(x.shape[0], dtype=bool)
        if not fresh.all():
            prior = predict(x, P, self.F_, self.Q_)
            x = prior.x.copy()
            # x- = A x + B u with u = v_doppler - v (no control when the exchange is missing)
            x[:, 2] = np.where(np.isnan(sample.velocity_m_s), x[:, 2], sample.velocity_m_s)
            post = update(x, prior.P, eps_corr[:, None], np.array([[1.0, 0.0, 0.0]]), self.R_)
            x, P = post.x, post.P
        if fresh.any():
            n = self.F_.shape[0]
            x0 = np.zeros((eps_corr.shape[0], n))
            x0[:, 0] = eps_corr
            x0[:, 2] = sample.velocity_m_s
            x = np.where(fresh[:, None], x0, x)
            P = np.where(fresh[:, None, None], np.broadcast_to(self.P0_, (x.shape[0], n, n)), P)
            s0 = np.where(fresh, C * ptp_delay_s(sample.t_i_s, sample.t_b_s, sample.t_r_s), s0)
            v0 = np.where(fresh, sample.velocity_m_s, v0)
        features = residual_features(eps_corr, x[:, 0], x[:, 1], x[:, 2], cfg.snr_db, sample, s0, v0, tp)
        hist = np.concatenate([state["hist"][:, 1:], features[:, None, :]], axis=1)
        est = x[:, 0].copy()
        if self.residual_model is not None and sample.k >= self.warmup_steps_:
            r = self.residual_model.predict_residual_s(hist)
            est = est + np.clip(r, -cfg.clip_s, cfg.clip_s)
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


#: The residual model's inputs (the paper's eq. 38 made offset-invariant, module docstring), scaled to order one.
FEATURES = ("eps_corr_minus_eps_kf_ns", "skew_kf_ppb", "v_kf_km_s", "snr_scaled", "path_delay_ms", "t_b_ms",
            "s0_100km", "v0_km_s", "t_p_10ns")


def residual_features(eps_corr, eps_kf, skew_kf, v_kf, snr_db, sample, s0_m, v0_m_s, tp_s) -> np.ndarray:
    """The nine inputs of one exchange, shape (trials, 9), in the units of :data:`FEATURES`."""
    n = eps_corr.shape[0]
    return np.stack([
        (eps_corr - eps_kf) * 1e9, skew_kf * 1e9, v_kf / 1e3, np.full(n, (snr_db - 12.0) / 8.0),
        ptp_delay_s(sample.t_i_s, sample.t_b_s, sample.t_r_s) * 1e3, sample.t_b_s * 1e3, s0_m / 1e5, v0_m_s / 1e3,
        np.broadcast_to(tp_s, (n,)) * 1e8,
    ], axis=1)
