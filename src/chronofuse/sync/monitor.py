"""The URT monitor: is the reply delay still the one the calibration measured?

A change ``d`` of the URT after calibration moves the offset measurement ``z1`` by ``-d/2`` and the range
measurement ``z3`` by ``+c d / 2`` at once (:data:`~chronofuse.sync.measurement.URT_SIGNATURE`); a clock
cannot jump, and a range cannot jump either. Two tests look for it:

1. **Two-way consistency** (needs nothing but the link). A small range filter (state ``[R, v_r]``,
   white-acceleration model of density ``accel_psd_m2_s3`` so that manoeuvres pass, measured by ``z3``
   and the Doppler velocity) gives the range innovation; the clock filter gives the offset innovation.
   Their pair ``nu`` (covariance ``C``, the two noises correlated through the URT jitter) is projected on
   the URT signature ``s``: ``u = s' C^-1 nu / sqrt(s' C^-1 s)``, standard normal while nothing changes.
   A two-sided CUSUM (Page 1954) on ``u``, clipped at ``+-clip`` so that one NLOS arrival cannot raise an
   alarm alone, with reference ``cusum_k`` and threshold ``cusum_h``, flags a step. Every exchange enters
   the test, those the filters gate as outliers too (clipped): an outlier is one exchange, a URT step is
   every exchange after it, and a large step would otherwise be gated forever. The range filter itself
   leaves gated exchanges out and restarts from the measurement after ``range_restart`` in a row.
   The average run length to a false alarm of CUSUM ``(k, h)`` on N(0, 1) input is
   ``(exp(2k(h + 1.166)) - 2k(h + 1.166) - 1) / (2 k^2)`` (Siegmund 1985): 4.5e7 exchanges for the
   defaults ``k = 1``, ``h = 8`` (five days at 100 Hz).
2. **Reference residual** (while GNSS time is there). With a reference offset ``r`` (the two nodes'
   GNSS time comparison, every ``reference_interval`` exchanges, NaN otherwise), the residual ``e = z1 -
   model - r`` is ``-d/2`` plus noise. A generalized likelihood ratio over the last ``window`` residuals
   (Willsky and Jones, IEEE Trans. Autom. Control 21(1), 1976) tests a step and a ramp starting at any
   of them: ``max_theta (sum w g e)^2 / sum w g^2`` with ``g = 1`` (step) or ``g = t - theta`` (ramp),
   ``w`` the inverse variances; an alarm when it exceeds ``glr_threshold``. A slow drift shows here long
   before it can be told from the clocks' own wander; how long depends on the reference's noise (see
   docs/sync/notes.md: with 0.5 ns per node at 1 Hz a 1 ns/min ramp is flagged before the offset is 1 ns
   off; with 5 ns it is not).

The alarm is latched (a changed reply delay needs a new calibration).
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C
from chronofuse.sync.measurement import URT_SIGNATURE, offset_range_cov_s_m, range_noise_var_m2
from chronofuse.models.link_noise import toa_sigma_array_s, velocity_sigma_array_m_s

__all__ = ["MonitorConfig", "UrtMonitor", "cusum_average_run_length"]


class MonitorConfig(BaseModel):
    """Settings of the URT monitor (module docstring)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    enabled: bool = True
    cusum_k: float = Field(1.0, gt=0.0, description="CUSUM reference value, standard deviations")
    cusum_h: float = Field(8.0, gt=0.0, description="CUSUM threshold, standard deviations")
    clip: float = Field(4.0, gt=0.0, description="largest |u| one exchange adds, standard deviations")
    accel_psd_m2_s3: float = Field(25.0, gt=0.0, description="white-acceleration density of the range filter")
    range_gate: float = Field(25.0, gt=0.0, description="chi-square(1) gate of the range filter's update")
    range_restart: int = Field(20, ge=1, description="gated exchanges in a row after which the range filter restarts")
    window: int = Field(300, ge=4, le=5000, description="reference residuals the GLR looks back over")
    glr_threshold: float = Field(40.0, gt=0.0, description="GLR alarm threshold (chi-square-like)")
    reference_sigma_s: float = Field(5e-9, ge=0.0, description="each node's GNSS time error, s")
    toa_model: str = "table"
    rms_bandwidth_hz: float = 28.47e6
    carrier_hz: float = 1.0e9
    urt_jitter_s: float = 2e-9


def cusum_average_run_length(k: float, h: float) -> float:
    """Siegmund's approximation of a one-sided CUSUM's run length on N(0, 1) input (module docstring)."""
    b = h + 1.166
    return (np.exp(2.0 * k * b) - 2.0 * k * b - 1.0) / (2.0 * k * k)


class UrtMonitor:
    """The monitor's pure core: ``init_state(trials)`` and ``update(...)`` returning a new state."""

    def __init__(self, config: MonitorConfig, interval_s: float):
        self.config = config
        self.interval_s = float(interval_s)

    def init_state(self, trials: int) -> dict:
        w = int(self.config.window)
        nan = np.full(trials, np.nan)
        return {"R": nan, "v": nan.copy(), "P00": nan.copy(), "P01": nan.copy(), "P11": nan.copy(),
                "gated_run": np.zeros(trials, dtype=np.int64), "pos": np.zeros(trials), "neg": np.zeros(trials), "alarm": np.zeros(trials, dtype=bool),
                "alarm_reason": np.zeros(trials, dtype=np.int64), "u": np.full(trials, np.nan),
                "ref_e": np.full((trials, w), np.nan), "ref_w": np.zeros((trials, w)), "ref_t": np.zeros((trials, w)),
                "glr": np.zeros(trials)}

    def update(self, state: dict, sample, offset_innovation_s, offset_innovation_var_s2, z3_m, skew_estimate,
               offset_noise_var_s2, reference_residual_s=None) -> dict:
        """One exchange: the clock filter's innovation (trials,) and its variance, the range measurement
        ``z3`` (trials,) (NaN: lost), the skew estimate, and optionally the reference residual (NaN: none)."""
        cfg = self.config
        if not cfg.enabled:
            return state
        dt = self.interval_s
        toa = toa_sigma_array_s(sample.snr_db, cfg.toa_model, cfg.rms_bandwidth_hz)
        r3 = range_noise_var_m2(toa, cfg.urt_jitter_s)
        rv = velocity_sigma_array_m_s(sample.snr_db, cfg.carrier_hz) ** 2
        v = sample.velocity_m_s
        # range model: z3 = R (1 + v/2c) + v T_B / 2 - c y T_B / 2 (+ c t_p / 2 and (y_A + y_B) R / 2, in R)
        z = z3_m - (v * sample.t_b_s / 2.0 - C * skew_estimate * sample.t_b_s / 2.0)
        R, vr, P00, P01, P11 = state["R"], state["v"], state["P00"], state["P01"], state["P11"]
        started = np.isfinite(R)
        # predict (white acceleration): F = [[1, dt], [0, 1]]
        q = cfg.accel_psd_m2_s3
        R = R + dt * vr
        P00 = P00 + 2.0 * dt * P01 + dt * dt * P11 + q * dt**3 / 3.0
        P01 = P01 + dt * P11 + q * dt**2 / 2.0
        P11 = P11 + q * dt
        ok = np.isfinite(z) & np.isfinite(v)
        scale = 1.0 + v / (2.0 * C)
        nu3 = z - scale * R
        s3 = scale**2 * P00 + r3
        gated3 = ok & started & (nu3 * nu3 > cfg.range_gate * s3)
        gated_run = np.where(ok, np.where(gated3, state["gated_run"] + 1, 0), state["gated_run"])
        init = ok & (~started | (gated_run >= cfg.range_restart))
        test = ok & started
        use3 = test & ~gated3
        # joint projection on the URT signature (z1 in s, z3 in m), the noises correlated through the jitter
        c13 = offset_range_cov_s_m(cfg.urt_jitter_s)
        s1 = offset_innovation_var_s2
        det = s1 * s3 - c13**2
        a, b = URT_SIGNATURE
        proj = (a * (s3 * offset_innovation_s - c13 * nu3) + b * (s1 * nu3 - c13 * offset_innovation_s)) / det
        norm = (a * a * s3 - 2.0 * a * b * c13 + b * b * s1) / det
        use = test & np.isfinite(offset_innovation_s)
        u = np.where(use, proj / np.sqrt(np.where(use, norm, 1.0)), np.nan)
        uc = np.where(use, np.clip(u, -cfg.clip, cfg.clip), 0.0)
        pos = np.where(use, np.maximum(0.0, state["pos"] + uc - cfg.cusum_k), state["pos"])
        neg = np.where(use, np.maximum(0.0, state["neg"] - uc - cfg.cusum_k), state["neg"])
        # range update with z3 (after the test), then with the Doppler velocity
        k0, k1 = scale * P00 / s3, scale * P01 / s3
        g = np.where(use3, 1.0, 0.0)
        R, vr = R + g * k0 * np.where(use3, nu3, 0.0), vr + g * k1 * np.where(use3, nu3, 0.0)
        P00, P01, P11 = P00 - g * k0 * scale * P00, P01 - g * k0 * scale * P01, P11 - g * k1 * scale * P01
        okv = started & np.isfinite(v)
        sv = P11 + rv
        nuv = np.where(okv, v - vr, 0.0)
        j0, j1 = np.where(okv, P01 / sv, 0.0), np.where(okv, P11 / sv, 0.0)
        R, vr = R + j0 * nuv, vr + j1 * nuv
        P00, P01, P11 = P00 - j0 * P01, P01 - j0 * P11, P11 - j1 * P11
        # first exchange: start the range filter from it
        R = np.where(init, z / scale, R)
        vr = np.where(init, v, vr)
        P00, P01, P11 = np.where(init, r3, P00), np.where(init, 0.0, P01), np.where(init, rv, P11)
        gated_run = np.where(init, 0, gated_run)
        alarm = state["alarm"] | (pos > cfg.cusum_h) | (neg > cfg.cusum_h)
        reason = np.where(state["alarm"], state["alarm_reason"], np.where(alarm, 1, 0))
        out = {"R": R, "v": vr, "P00": P00, "P01": P01, "P11": P11, "gated_run": gated_run, "pos": pos, "neg": neg, "u": u, "alarm": alarm,
               "alarm_reason": reason, "ref_e": state["ref_e"], "ref_w": state["ref_w"], "ref_t": state["ref_t"],
               "glr": state["glr"]}
        if reference_residual_s is not None:
            out = self._reference(out, sample, np.asarray(reference_residual_s, dtype=np.float64), offset_noise_var_s2)
        return out

    def _reference(self, state, sample, e, r1):
        """The GLR step/ramp test on the reference residuals (module docstring)."""
        cfg = self.config
        have = np.isfinite(e)
        if not have.any():
            return state
        var = r1 + 2.0 * cfg.reference_sigma_s**2
        ref_e = np.where(have[:, None], np.concatenate([state["ref_e"][:, 1:], e[:, None]], axis=1), state["ref_e"])
        ref_w = np.where(have[:, None], np.concatenate([state["ref_w"][:, 1:], (1.0 / var)[:, None]], axis=1),
                         state["ref_w"])
        ref_t = np.where(have[:, None], np.concatenate([state["ref_t"][:, 1:], np.full((e.size, 1), sample.t_s)], axis=1),
                         state["ref_t"])
        w = np.where(np.isfinite(ref_e), ref_w, 0.0)
        ee = np.nan_to_num(ref_e)
        t = np.where(w > 0, ref_t - sample.t_s, 0.0)  # relative to now: well conditioned

        def suffix(a):  # sum over the stored epochs from each onset theta_j to the newest
            return np.cumsum(a[:, ::-1], axis=1)[:, ::-1]

        sw, swe, swt, swte, swtt = (suffix(a) for a in (w, w * ee, w * t, w * t * ee, w * t * t))
        onset = w > 0  # an onset is a stored residual
        step = np.where(onset, swe**2 / np.where(onset, sw, 1.0), 0.0)
        # ramp g = t - theta_j: sum w g e = swte - theta swe, sum w g^2 = swtt - 2 theta swt + theta^2 sw
        num = swte - t * swe
        den = swtt - 2.0 * t * swt + t * t * sw
        ramp = np.where(onset & (den > 1e-300), num**2 / np.where(den > 1e-300, den, 1.0), 0.0)
        glr = np.maximum(step.max(axis=1), ramp.max(axis=1))
        hit = have & (glr > cfg.glr_threshold)
        alarm = state["alarm"] | hit
        reason = np.where(state["alarm"], state["alarm_reason"], np.where(hit, 2, 0))
        return {**state, "ref_e": ref_e, "ref_w": ref_w, "ref_t": ref_t, "glr": np.where(have, glr, state["glr"]),
                "alarm": alarm, "alarm_reason": reason}
