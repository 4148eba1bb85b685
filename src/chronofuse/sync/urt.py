"""Unequal-reply-time (URT) compensation (the swarm paper's section 2.1, eqs. 17-21), and its fix.

B really transmits ``t_p = t_fixed + jitter`` after its reply stamp; the two-way offset is then biased
by ``alpha t_p`` with ``alpha = -c / (2c + v)`` (eq. 18).

``mode="paper"`` is the paper as written: from the last ``M`` (50..200) velocity-compensated offsets,
``t_p = mean(eps) / alpha`` (eqs. 19-20) and ``eps_corr = eps - alpha t_p`` (eq. 21), refreshed every
``T_update = 10 s``; before the first batch is full, the mean of all offsets so far. This removes the
whole mean of ``eps``, the true clock offset included: it is right only when the true offset is zero.
A fixed reply asymmetry is not observable from two-way timestamps alone (it trades one for one with
the offset).

``mode="calibrated"`` subtracts ``alpha t_fixed`` with ``t_fixed`` learnt by
:func:`chronofuse.sync.calibration.calibrate_urt` while both nodes know true time (GNSS time comparisons),
and keeps it through a GNSS loss.
"""

from __future__ import annotations

import numpy as np

from chronofuse.sync.twoway import urt_sensitivity
from chronofuse.validation import check_choice, check_scalar

__all__ = ["UrtCompensation"]


class UrtCompensation:
    """A causal URT-compensation stage with a pure core (``init_state`` / ``update``).

    Parameters
    ----------
    mode : {"paper", "calibrated", "none"}
    batch : int
        ``M``, offsets per batch (50..200).
    refresh_s : float
        ``T_update``, s.
    urt_fixed_s : float or array of shape (trials,)
        The calibrated fixed URT (mode "calibrated").
    """

    def __init__(self, mode: str = "paper", batch: int = 100, refresh_s: float = 10.0, urt_fixed_s=0.0):
        self.mode = mode
        self.batch = batch
        self.refresh_s = refresh_s
        self.urt_fixed_s = urt_fixed_s
        check_choice(mode, "urt_mode", ("paper", "calibrated", "none"))
        check_scalar(batch, "urt_batch", min_val=50, max_val=200, integer=True)
        check_scalar(refresh_s, "refresh_s", min_val=0.0, include_min=False)

    def init_state(self, trials: int) -> dict:
        return {"buf": np.full((trials, int(self.batch)), np.nan), "sum": np.zeros(trials),
                "count": np.zeros(trials), "tp": np.zeros(trials)}

    def update(self, state: dict, k: int, interval_s: float, eps_s: np.ndarray, velocity_m_s: np.ndarray):
        """(new state, compensated offsets (trials,), URT estimate (trials,)) after offset ``eps_s``."""
        alpha = urt_sensitivity(velocity_m_s)
        if self.mode == "none":
            return state, eps_s, np.zeros_like(eps_s)
        if self.mode == "calibrated":
            tp = np.broadcast_to(np.asarray(self.urt_fixed_s, dtype=np.float64), eps_s.shape)
            return state, eps_s - alpha * tp, tp
        m = int(self.batch)
        seen = np.isfinite(eps_s)  # a missing exchange (NaN) adds nothing to the batch statistics
        buf = np.concatenate([state["buf"][:, 1:], eps_s[:, None]], axis=1)
        total = state["sum"] + np.where(seen, eps_s, 0.0)
        count = state["count"] + seen
        refresh = max(1, int(round(self.refresh_s / interval_s)))
        with np.errstate(invalid="ignore", divide="ignore"):
            if k + 1 < m:
                tp = (total / count) / alpha  # warm-up: all offsets so far
            elif (k + 1 - m) % refresh == 0:
                n = np.isfinite(buf).sum(axis=1)
                tp = (np.where(np.isfinite(buf), buf, 0.0).sum(axis=1) / n) / alpha  # eq. (19)-(20)
            else:
                tp = state["tp"]
        tp = np.where(np.isfinite(tp), tp, state["tp"])
        return {"buf": buf, "sum": total, "count": count, "tp": tp}, eps_s - alpha * tp, tp
