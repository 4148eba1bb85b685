"""``doppler-kf``: the two-way link filter on the complete measurement model, with its state and uncertainty.

A Kalman filter whose model is the one the bound uses (:mod:`chronofuse.sync.pcrb`), so that on links drawn
from its prior it reaches the bound:

* state ``[eps, y, g_1 .. g_M]`` and its dynamics: :class:`~chronofuse.models.clock_markov.ClockMarkovModel`
  (white, flicker and random-walk FM of the two clocks), started from the link's prior
  (:class:`~chronofuse.sync.prior.LinkPrior`);
* each exchange's ``z1 = (T_i - T_r + T_B) / 2`` less its geometric terms (the range change between the
  legs from the Doppler velocity, A's motion along the line of sight from its navigation: Sagnac and
  ``d v / c^2``) and less the calibrated URT, observed through ``h = [1, c, c, .., c]``, ``c = (T_B + T_i -
  2 eps) / 2`` (the skew acts over the reply and the light time), with the noise of the exchange's own SNR
  (:mod:`chronofuse.sync.measurement`);
* a chi-square gate on the innovation (probability ``gate_probability`` of rejecting a good exchange),
  which keeps NLOS outliers out; rejected exchanges still reach the URT monitor. The gate acts only once
  the prediction has settled, ``h P h' < gate_settled * r``: before, the innovation measures how far the
  true state lies from the prior (or from a prediction through a gap) more than the measurement's error,
  and a gate would reject every exchange of a link whose offset or skew lies in the prior's tails (a 4.7
  sigma offset: its first 8 exchanges, 280 ns of RMSE; a 6 sigma skew at one exchange a second: one in
  nine exchanges, 250 ns). With the default 0.25 the gate cannot reject a state up to
  ``sqrt(gate * (1 + 1/0.25))`` = 9.9 sigma out. The first exchange thus initialises the filter. A filter that rejects
  ``restart_after`` exchanges in a row (it started from an outlier, or the link changed by far more than its
  noise) starts again from its prior at the next one, instead of rejecting everything after.

Its uncertainty output is ``sqrt(P[eps, eps] + (sigma_cal / 2)^2)``: the filter's posterior and the
calibration's uncertainty, which no exchange can reduce. The node state and the URT monitor are
:mod:`chronofuse.sync.states` and :mod:`chronofuse.sync.monitor`.

The Kalman predict and update are the estimation layer's (:mod:`chronofuse.estimation.kalman`).
"""

from __future__ import annotations

import numpy as np
from pydantic import Field
from scipy.stats import chi2

from chronofuse.estimation.kalman import predict, update
from chronofuse.models.clock_markov import ClockMarkovModel
from chronofuse.models.link import LinkModel
from chronofuse.models.link_noise import TOA_MODELS, toa_sigma_array_s, velocity_sigma_array_m_s
from chronofuse.registry import Config
from chronofuse.sync.base import ExchangeSample, SyncAlgorithm, SyncResult
from chronofuse.sync.doppler_kernel import run_doppler_kernel
from chronofuse.sync.measurement import (
    known_offset_terms_s,
    offset_measurement_s,
    offset_noise_var_s2,
    skew_coefficient_s,
    urt_coefficient,
)
from chronofuse.sync.monitor import MonitorConfig, UrtMonitor
from chronofuse.sync.prior import LinkPrior
from chronofuse.sync.states import NodeStateConfig, NodeStateMachine

__all__ = ["DopplerKfConfig", "DopplerKf"]


class DopplerKfConfig(Config):
    """What the node knows: its link's noise model, both clocks' noise, the prior, the calibration."""

    interval_s: float = Field(0.01, gt=0.0, description="exchange interval (s)")
    toa_model: str = Field("table", description="TOA noise model: table, crb or none (choice)")
    rms_bandwidth_hz: float = Field(28.47e6, gt=0.0, description="RMS bandwidth of the Cramér-Rao TOA model (Hz)")
    carrier_hz: float = Field(1.0e9, gt=0.0, description="carrier of the Doppler measurement (Hz)")
    urt_jitter_s: float = Field(2e-9, ge=0.0, description="sigma of the reply-delay jitter (s)")
    h0_s: float = Field(4e-24, ge=0.0, description="white FM of the clock offset (both clocks) (s)")
    hm1: float = Field(3.5e-23, ge=0.0, description="flicker FM of the clock offset, both clocks (dimensionless)")
    hm2_per_s: float = Field(7.6e-27, ge=0.0, description="random-walk FM of the clock offset (1/s)")
    flicker_lo_hz: float = Field(5e-3, gt=0.0, description="lowest corner of the flicker model (Hz)")
    flicker_hi_hz: float = Field(100.0, gt=0.0, description="highest corner of the flicker model (Hz)")
    prior: LinkPrior = Field(LinkPrior(), description="the link's prior (section)")
    urt_s: float | tuple[float, ...] = Field(20e-9, description="calibrated fixed URT, s (one per trial allowed)")
    calibration_sigma_s: float | tuple[float, ...] = Field(0.0, description="1-sigma of that calibration (s)")
    gate_probability: float = Field(1e-5, ge=0.0, lt=1.0, description="false-rejection probability of the gate (dimensionless)")
    gate_settled: float = Field(0.25, gt=0.0,
                                description="the gate acts once h P h' is below this share of r (dimensionless)")
    restart_after: int = Field(8, ge=2, description="rejected exchanges in a row after which the filter restarts (exchanges)")
    monitor: MonitorConfig = Field(MonitorConfig(), description="the URT monitor (section)")
    states: NodeStateConfig = Field(NodeStateConfig(), description="the node state machine (section)")

    @classmethod
    def from_models(cls, link: LinkModel, clock: ClockMarkovModel, prior: LinkPrior, urt_s, calibration_sigma_s=0.0,
                    **extra) -> "DopplerKfConfig":
        """The configuration of a node on ``link`` with clocks ``clock`` under ``prior``."""
        as_field = (lambda v: float(v) if np.ndim(v) == 0 else tuple(float(a) for a in np.ravel(v)))
        return cls(interval_s=link.interval_s, toa_model=link.toa_model, rms_bandwidth_hz=link.rms_bandwidth_hz,
                   carrier_hz=link.carrier_hz, urt_jitter_s=link.urt_jitter_s, h0_s=clock.h0_s, hm1=clock.hm1,
                   hm2_per_s=clock.hm2_per_s, flicker_lo_hz=clock.flicker_lo_hz, flicker_hi_hz=clock.flicker_hi_hz,
                   prior=prior, urt_s=as_field(urt_s), calibration_sigma_s=as_field(calibration_sigma_s), **extra)

    @property
    def clock(self) -> ClockMarkovModel:
        return ClockMarkovModel(self.h0_s, self.hm1, self.hm2_per_s, self.flicker_lo_hz, self.flicker_hi_hz)


class DopplerKf(SyncAlgorithm):
    """The complete-model link filter (module docstring); ``config`` a :class:`DopplerKfConfig`."""

    name = "doppler-kf"

    def __init__(self, config: DopplerKfConfig = DopplerKfConfig()):
        self.config = config
        self.interval_s = config.interval_s

    def _check_params(self):
        cfg = self.config
        if cfg.toa_model not in TOA_MODELS:
            raise ValueError(f"toa_model == {cfg.toa_model!r}, must be one of {list(TOA_MODELS)}")
        self.Phi_, self.Q_ = cfg.clock.discrete(cfg.interval_s)
        n = self.Phi_.shape[0]
        self.x0_ = np.zeros(n)
        self.x0_[0], self.x0_[1] = cfg.prior.offset_mean_s, cfg.prior.skew_mean
        P0 = np.zeros((n, n))
        P0[0, 0], P0[1, 1] = cfg.prior.offset_sigma_s**2, cfg.prior.skew_sigma**2
        P0[2:, 2:] = np.diag(cfg.clock.flicker_variances())
        self.P0_ = P0
        self.gate_ = float(chi2.isf(cfg.gate_probability, 1)) if cfg.gate_probability > 0.0 else np.inf
        self.urt_ = np.atleast_1d(np.asarray(cfg.urt_s, dtype=np.float64))
        self.cal_sigma_ = np.atleast_1d(np.asarray(cfg.calibration_sigma_s, dtype=np.float64))
        self.monitor_ = UrtMonitor(cfg.monitor, self.Phi_, self.Q_, self.x0_, self.P0_, self.gate_, cfg.restart_after,
                                   cfg.gate_settled)
        self.states_ = NodeStateMachine(cfg.states)

    def _per_trial(self, a: np.ndarray, trials: int) -> np.ndarray:
        if trials == 1:
            return a[:1]  # streaming: one link, the first calibration
        if a.size not in (1, trials):
            raise ValueError(f"urt_s/calibration_sigma_s have {a.size} values, this run has {trials} trials")
        return np.broadcast_to(a, (trials,))

    def init_state(self, trials):
        n = self.Phi_.shape[0]
        return {"x": np.broadcast_to(self.x0_, (trials, n)).copy(), "P": np.broadcast_to(self.P0_, (trials, n, n)).copy(),
                "monitor": self.monitor_.init_state(trials), "states": self.states_.init_state(trials),
                "urt": self._per_trial(self.urt_, trials).copy(), "gated_run": np.zeros(trials, dtype=np.int64),
                "cal": self._per_trial(self.cal_sigma_, trials).copy()}

    def measurement(self, x_pred: np.ndarray, sample: ExchangeSample, urt_s: np.ndarray):
        """``(z, h, r)``: the URT- and geometry-corrected ``z1`` (trials,), its row (trials, n) and variance."""
        cfg = self.config
        eps = x_pred[:, 0]
        z = (offset_measurement_s(sample.t_i_s, sample.t_b_s, sample.t_r_s)
             - known_offset_terms_s(sample.t_i_s, sample.t_b_s, sample.velocity_m_s, sample.a_los_velocity_m_s, eps)
             - urt_coefficient(sample.velocity_m_s) * urt_s)
        c = skew_coefficient_s(sample.t_i_s, sample.t_b_s, eps)
        h = np.ones_like(x_pred)
        h[:, 1:] = c[:, None]
        toa = toa_sigma_array_s(sample.snr_db, cfg.toa_model, cfg.rms_bandwidth_hz)
        r = offset_noise_var_s2(toa, cfg.urt_jitter_s, velocity_sigma_array_m_s(sample.snr_db, cfg.carrier_hz),
                                sample.t_i_s, sample.t_b_s)
        return z, np.nan_to_num(h), r

    def update(self, state, sample):
        x, P = state["x"], state["P"]
        if sample.k > 0:
            prior = predict(x, P, self.Phi_, self.Q_)
            x, P = prior.x, prior.P
        z, h, r = self.measurement(x, sample, state["urt"])
        h_c = np.where(np.isfinite(z), h[:, 1], np.nan)
        y = z - np.einsum("ti,ti->t", h, x)
        hph = np.einsum("ti,tij,tj->t", h, P, h)
        s = hph + r
        d2 = y * y / s
        gated = (d2 > self.gate_) & (hph < self.config.gate_settled * r)  # once settled (module docstring)
        run = np.where(np.isfinite(z), np.where(gated, state["gated_run"] + 1, 0), state["gated_run"])
        restart = run >= self.config.restart_after  # start again from the prior with this exchange
        gated = gated & ~restart
        run = np.where(restart, 0, run)
        x_use = np.where(restart[:, None], self.x0_, x)
        P_use = np.where(restart[:, None, None], self.P0_, P)
        post = update(x_use, P_use, np.where(gated | ~np.isfinite(z), np.nan, z)[:, None], h[:, None, :],
                      np.where(np.isfinite(r), r, 1.0)[:, None, None])
        ref_e = None
        if sample.reference_offset_s is not None:  # the filter's offset against a GNSS time comparison
            ref_e = post.x[:, 0] - sample.reference_offset_s
        mon = self.monitor_.update(state["monitor"], sample.k, sample.t_s, z, h_c, r, ref_e, post.P[:, 0, 0])
        sigma = np.sqrt(post.P[:, 0, 0] + (state["cal"] * 0.5) ** 2)
        states = self.states_.update(state["states"], sigma, np.isfinite(z) & ~gated, mon["alarm"], self.interval_s)
        return ({"x": post.x, "P": post.P, "monitor": mon, "states": states, "urt": state["urt"], "cal": state["cal"],
                 "gated_run": run, "sigma": sigma}, post.x[:, 0].copy())

    def run(self, Z, reference_offset_s=None) -> SyncResult:
        """Batch run through the numba loop of :mod:`chronofuse.sync.doppler_kernel`, the numpy twin of
        :meth:`update` (``SyncAlgorithm.run(self, Z)`` is the numpy path; the tests compare them)."""
        Z, ref = self._check_run(Z, reference_offset_s)
        off, sig, code = run_doppler_kernel(self, Z, ref)
        return SyncResult(offset_s=off, uncertainty_s=sig, node_state=code, algorithm=self.name)

    def uncertainty(self, state):
        return state.get("sigma")

    def node_state(self, state):
        return state["states"]["code"]
