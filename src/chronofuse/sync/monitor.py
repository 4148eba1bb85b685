"""The URT monitor: is the reply delay still the one the calibration measured?

A change ``d`` of the URT after calibration moves every later offset measurement ``z1`` by ``-d/2``
(:data:`~chronofuse.sync.measurement.URT_SIGNATURE`). A clock cannot jump, so the change shows as a lasting
difference between the measurements and what the clock model predicts. Two tests look for it:

1. **Prediction test** (needs nothing but the link). The link filter itself absorbs a step within a few
   tens of exchanges (its gain is set by the clocks' noise), so its own innovations soon hide it. The
   monitor therefore runs a copy of the same filter ``lag`` exchanges behind (it is given each measurement
   ``lag`` exchanges late) and predicts the offset now from that older state (``Phi^lag``, ``Q_lag``: the
   clocks wander by picoseconds over a quarter of a second, far below the noise). The residual of each
   exchange against that prediction, ``u = (z - h x_pred) / sqrt(h P_pred h' + r)``, is N(0, 1) while
   nothing changes, and carries the whole step for ``lag`` exchanges after one. The test starts once the
   prediction has settled (its variance below ``settled`` times the exchange's: while it is larger, its
   error is common to many residuals in a row and would add up). A two-sided CUSUM (Page
   1954) on ``u`` with reference ``cusum_k`` and threshold ``cusum_h`` raises the alarm; a residual beyond
   ``+-clip`` is an outlier (an NLOS arrival) and is left out of the sums, but ``outlier_run`` of them of one
   sign in a row are a step too large for the sums (a 20 ns change) and raise the alarm. The average run
   length to a false alarm of a one-sided CUSUM ``(k, h)`` on N(0, 1) input is ``(exp(2k(h + 1.166)) -
   2k(h + 1.166) - 1) / (2 k^2)`` (Siegmund 1985): 3e8 exchanges for the defaults ``k = 0.9``, ``h = 10``,
   half of it two-sided (two weeks at 100 Hz; the tests measure the residuals' whiteness and run nominal
   links with outliers). A clock fault (a frequency step beyond the model) raises the same alarm: either way the
   link's offset no longer follows the clock model.
2. **Reference residual** (while GNSS time is there). With a reference offset ``r`` (the two nodes' GNSS
   time comparison, NaN when there is none), the residual ``e = eps_hat - r`` of the link filter's offset
   (which follows the link, the changed reply delay with it) is ``-d/2`` plus the filter's error and the
   reference's (variance ``P[eps, eps] + 2 sigma_ref^2``; one exchange's own noise would be 1.3 ns), and a
   constant from the calibration's own error. A generalized likelihood ratio over the last ``window``
   residuals (Willsky and Jones, IEEE Trans. Autom. Control 21(1), 1976) tests a step and a ramp starting at
   any of them against an unknown constant: ``max_theta (sum w g~ e)^2 / sum w g~^2`` with ``g = 1[t >=
   theta]`` (step) or ``g = (t - theta)+`` (ramp), ``g~ = g - mean_w(g)`` (the constant projected out), ``w``
   the inverse variances; an alarm when it exceeds ``glr_threshold``. On white residuals the default 40 was
   exceeded by none of 1e6 evaluations (25: 8e-6 of them; the tests measure it): at one comparison a second,
   fewer than one false alarm a year. A slow drift shows here long before it can be told from the clocks' own
   wander; how long depends on the reference's noise (docs/sync/notes.md).

The alarm is latched (a changed reply delay needs a new calibration); ``alarm_reason`` is 1 for the
prediction test, 2 for the reference test.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

__all__ = ["MonitorConfig", "UrtMonitor", "cusum_average_run_length", "lagged_model"]


class MonitorConfig(BaseModel):
    """Settings of the URT monitor (module docstring)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    enabled: bool = Field(True, description="run the monitor (switch)")
    lag: int = Field(24, ge=2, le=1000, description="how far the lagging filter runs behind (exchanges)")
    cusum_k: float = Field(0.9, gt=0.0, description="CUSUM reference value (standard deviations)")
    cusum_h: float = Field(10.0, gt=0.0, description="CUSUM threshold (standard deviations)")
    clip: float = Field(4.0, gt=0.0, description="|u| beyond which an exchange is an outlier (standard deviations)")
    outlier_run: int = Field(4, ge=2, description="outliers of one sign in a row that are a step (exchanges)")
    settled: float = Field(0.1, gt=0.0, description="test once the prediction's variance is below this share of r (dimensionless)")
    window: int = Field(300, ge=4, le=5000, description="reference residuals the GLR looks back over (comparisons)")
    glr_threshold: float = Field(40.0, gt=0.0, description="GLR alarm threshold (chi-square units)")
    reference_sigma_s: float = Field(5e-9, ge=0.0, description="each node's GNSS time error (s)")


def cusum_average_run_length(k: float, h: float) -> float:
    """Siegmund's approximation of a one-sided CUSUM's run length on N(0, 1) input (module docstring)."""
    b = h + 1.166
    return (np.exp(2.0 * k * b) - 2.0 * k * b - 1.0) / (2.0 * k * k)


def lagged_model(Phi: np.ndarray, Q: np.ndarray, lag: int) -> tuple[np.ndarray, np.ndarray]:
    """``(Phi^lag, Q_lag)`` with ``Q_lag = sum_{i < lag} Phi^i Q Phi^i'``: ``lag`` steps of the model at once."""
    A, S = np.eye(Phi.shape[0]), np.zeros_like(Q)
    for _ in range(int(lag)):
        S = Phi @ S @ Phi.T + Q
        A = Phi @ A
    return A, 0.5 * (S + S.T)


class UrtMonitor:
    """The monitor's pure core: ``init_state(trials)`` and ``update(...)`` returning a new state.

    ``Phi``, ``Q``, ``x0``, ``P0`` are the link filter's model and prior; ``gate`` its chi-square gate (acting
    once ``h P h' < gate_settled * r``) and ``restart_after`` its restart rule, which the lagging copy follows too.
    """

    def __init__(self, config: MonitorConfig, Phi, Q, x0, P0, gate: float, restart_after: int = 8,
                 gate_settled: float = 0.25):
        self.config = config
        self.Phi, self.Q, self.x0, self.P0, self.gate = Phi, Q, x0, P0, float(gate)
        self.restart_after, self.gate_settled = int(restart_after), float(gate_settled)
        self.PhiL, self.QL = lagged_model(Phi, Q, config.lag)

    def init_state(self, trials: int) -> dict:
        w, lag, n = int(self.config.window), int(self.config.lag), self.Phi.shape[0]
        return {"xd": np.broadcast_to(self.x0, (trials, n)).copy(), "Pd": np.broadcast_to(self.P0, (trials, n, n)).copy(),
                "started": np.zeros(trials, dtype=bool), "lag_run": np.zeros(trials, dtype=np.int64), "ring_z": np.full((trials, lag), np.nan),
                "ring_c": np.zeros((trials, lag)), "ring_r": np.ones((trials, lag)), "pos": np.zeros(trials),
                "neg": np.zeros(trials), "run": np.zeros(trials, dtype=np.int64), "alarm": np.zeros(trials, dtype=bool),
                "alarm_reason": np.zeros(trials, dtype=np.int64), "u": np.full(trials, np.nan),
                "ref_e": np.full((trials, w), np.nan), "ref_w": np.zeros((trials, w)), "ref_t": np.zeros((trials, w)),
                "glr": np.zeros(trials)}

    def update(self, state: dict, k: int, t_s: float, z, c, r, reference_residual_s=None, residual_var_s2=None) -> dict:
        """Exchange ``k`` (at ``t_s``): the corrected offset measurement ``z`` (trials,) (NaN: none), its skew
        coefficient ``c`` and noise variance ``r``; optionally the reference residual (NaN: none) and the
        variance of the filter's part of it."""
        cfg = self.config
        if not cfg.enabled:
            return state
        lag = int(cfg.lag)
        n = self.Phi.shape[0]
        out = dict(state)
        pos, neg, run, u = state["pos"], state["neg"], state["run"], np.full(z.shape, np.nan)
        xd, Pd = state["xd"], state["Pd"]
        if k >= lag:
            # the lagging filter takes the measurement that is now ``lag`` old (it is then at k - lag) ...
            started = state["started"]
            xd = np.where(started[:, None], xd @ self.Phi.T, xd)
            Pd = np.where(started[:, None, None], self.Phi @ Pd @ self.Phi.T + self.Q, Pd)
            xd, Pd, out["lag_run"] = _scalar_update(xd, Pd, state["ring_z"][:, 0], state["ring_c"][:, 0],
                                                    state["ring_r"][:, 0], self.gate, state["lag_run"],
                                                    self.restart_after, self.x0, self.P0, self.gate_settled)
            out["started"] = np.ones(z.size, dtype=bool)
            # ... and predicts this exchange, which is tested against it
            xp = xd @ self.PhiL.T
            Pp = self.PhiL @ Pd @ self.PhiL.T + self.QL
            h = np.ones((z.size, n))
            h[:, 1:] = np.nan_to_num(c)[:, None]
            pred_var = np.einsum("ti,tij,tj->t", h, Pp, h)
            var = pred_var + r
            resid = z - np.einsum("ti,ti->t", h, xp)
            # test once the prediction is settled: its error is common to ``lag`` residuals in a row
            ok = np.isfinite(resid) & np.isfinite(var) & (pred_var < cfg.settled * r)
            u = np.where(ok, resid / np.sqrt(np.where(ok, var, 1.0)), np.nan)
            inlier = ok & (np.abs(np.nan_to_num(u)) <= cfg.clip)
            pos = np.where(inlier, np.maximum(0.0, pos + np.nan_to_num(u) - cfg.cusum_k), pos)
            neg = np.where(inlier, np.maximum(0.0, neg - np.nan_to_num(u) - cfg.cusum_k), neg)
            # outliers of one sign in a row: +n above, -n below, reset by an inlier
            sign = np.sign(np.nan_to_num(u))
            run = np.where(ok & ~inlier, np.where(np.sign(run) == sign, run + sign, sign), np.where(inlier, 0, run))
        out["ring_z"] = np.concatenate([state["ring_z"][:, 1:], z[:, None]], axis=1)
        out["ring_c"] = np.concatenate([state["ring_c"][:, 1:], np.nan_to_num(c)[:, None]], axis=1)
        out["ring_r"] = np.concatenate([state["ring_r"][:, 1:], np.where(np.isfinite(r), r, 1.0)[:, None]], axis=1)
        hit = (pos > cfg.cusum_h) | (neg > cfg.cusum_h) | (np.abs(run) >= cfg.outlier_run)
        alarm = state["alarm"] | hit
        out.update({"xd": xd, "Pd": Pd, "pos": pos, "neg": neg, "run": run.astype(np.int64), "u": u, "alarm": alarm,
                    "alarm_reason": np.where(state["alarm"], state["alarm_reason"], np.where(hit, 1, 0))})
        if reference_residual_s is not None:
            out = self._reference(out, t_s, np.asarray(reference_residual_s, dtype=np.float64), residual_var_s2)
        return out

    def _reference(self, state, t_now, e, filter_var):
        """The GLR step/ramp test on the reference residuals (module docstring)."""
        cfg = self.config
        have = np.isfinite(e)
        if not have.any():
            return state
        var = filter_var + 2.0 * cfg.reference_sigma_s**2
        ref_e = np.where(have[:, None], np.concatenate([state["ref_e"][:, 1:], e[:, None]], axis=1), state["ref_e"])
        ref_w = np.where(have[:, None], np.concatenate([state["ref_w"][:, 1:], (1.0 / var)[:, None]], axis=1),
                         state["ref_w"])
        ref_t = np.where(have[:, None], np.concatenate([state["ref_t"][:, 1:], np.full((e.size, 1), t_now)], axis=1),
                         state["ref_t"])
        w = np.where(np.isfinite(ref_e), ref_w, 0.0)
        ee = np.nan_to_num(ref_e)
        t = np.where(w > 0, ref_t - t_now, 0.0)  # relative to now: well conditioned

        def suffix(a):  # sum over the stored epochs from each onset theta_j to the newest
            return np.cumsum(a[:, ::-1], axis=1)[:, ::-1]

        sw, swe, swt, swte, swtt = (suffix(a) for a in (w, w * ee, w * t, w * t * ee, w * t * t))
        W, WE = sw[:, :1], swe[:, :1]  # totals over the window
        onset = w > 0  # an onset is a stored residual
        safe_w = np.where(W > 0, W, 1.0)
        # step g = 1[t >= theta]: sum w g e = swe, sum w g = sum w g^2 = sw
        num = swe - sw / safe_w * WE
        den = sw - sw * sw / safe_w
        step = np.where(onset & (den > 1e-300 * W), num**2 / np.where(den > 0, den, 1.0), 0.0)
        # ramp g = (t - theta)+: sum w g e = swte - theta swe, sum w g = swt - theta sw,
        # sum w g^2 = swtt - 2 theta swt + theta^2 sw
        gsum = swt - t * sw
        num = (swte - t * swe) - gsum / safe_w * WE
        den = (swtt - 2.0 * t * swt + t * t * sw) - gsum * gsum / safe_w
        ramp = np.where(onset & (den > 1e-300), num**2 / np.where(den > 1e-300, den, 1.0), 0.0)
        glr = np.maximum(step.max(axis=1), ramp.max(axis=1))
        hit = have & (glr > cfg.glr_threshold)
        alarm = state["alarm"] | hit
        reason = np.where(state["alarm"], state["alarm_reason"], np.where(hit, 2, 0))
        return {**state, "ref_e": ref_e, "ref_w": ref_w, "ref_t": ref_t, "glr": np.where(have, glr, state["glr"]),
                "alarm": alarm, "alarm_reason": reason}


def _scalar_update(x, P, z, c, r, gate, gated_run, restart_after, x0, P0, gate_settled):
    """The lagging filter's update with ``z`` (trials,), row ``[1, c, .., c]``, variance ``r`` (Joseph form,
    gated once settled and restarted as the link filter is); trials with no measurement are left as they
    are. Returns ``(x, P, gated_run)``."""
    n = x.shape[1]
    h = np.ones_like(x)
    h[:, 1:] = c[:, None]
    Ph = np.einsum("tij,tj->ti", P, h)
    hph = np.einsum("ti,ti->t", h, Ph)
    s = hph + r
    y = z - np.einsum("ti,ti->t", h, x)
    gated = np.isfinite(y) & (y * y > gate * s) & (hph < gate_settled * r)
    run = np.where(np.isfinite(y), np.where(gated, gated_run + 1, 0), gated_run)
    restart = run >= restart_after
    run = np.where(restart, 0, run)
    if restart.any():
        x = np.where(restart[:, None], x0, x)
        P = np.where(restart[:, None, None], P0, P)
        Ph = np.einsum("tij,tj->ti", P, h)
        s = np.einsum("ti,ti->t", h, Ph) + r
        y = z - np.einsum("ti,ti->t", h, x)
    use = np.isfinite(y) & (~gated | restart)
    K = np.where(use[:, None], Ph / s[:, None], 0.0)
    x = x + K * np.where(use, y, 0.0)[:, None]
    A = np.eye(n)[None] - K[:, :, None] * h[:, None, :]
    P = A @ P @ np.swapaxes(A, 1, 2) + (K[:, :, None] * K[:, None, :]) * np.where(use, r, 0.0)[:, None, None]
    return x, 0.5 * (P + np.swapaxes(P, 1, 2)), run
