"""PTP-MLS: PTP offsets smoothed by moving least squares (the swarm paper's refs. [17-18]; no motion model).

The paper names the method without details; the definition used here: after exchange ``k`` fit
``z_j = a + b (t_j - t_k)`` to the last ``W`` PTP offsets (the paper's eq. 1) by weighted least squares with
the tricube weights of LOESS (Cleveland 1979), ``w_j = (1 - (age_j / W)^3)^3`` for ``age_j = k - j``
in ``0 .. W-1``, and report ``a``, the fitted value at the current exchange (causal). ``W`` is 16..64
(default 32). Fewer than two samples: the raw offset.
"""

from __future__ import annotations

import numpy as np

from chronofuse.sync.base import SyncAlgorithm
from chronofuse.sync.twoway import ptp_offset_s
from chronofuse.validation import check_scalar

__all__ = ["PtpMls", "weighted_line_at_zero"]


def weighted_line_at_zero(x: np.ndarray, z: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Intercept at ``x = 0`` of the weighted least-squares line through rows of ``(x, z)``.

    ``x``, ``z``, ``w`` of shape (trials, n); NaN ``z`` have no weight. Rows with one point return it;
    rows with none, NaN.
    """
    w = np.where(np.isnan(z), 0.0, w)
    z0 = np.where(np.isnan(z), 0.0, z)
    sw = w.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):  # a row with no valid point gives NaN
        mx = (w * x).sum(axis=1) / sw
        mz = (w * z0).sum(axis=1) / sw
    sxx = (w * (x - mx[:, None]) ** 2).sum(axis=1)
    sxz = (w * (x - mx[:, None]) * (z0 - mz[:, None])).sum(axis=1)
    slope = np.divide(sxz, sxx, out=np.zeros_like(sxz), where=sxx > 0.0)
    return mz - slope * mx


class PtpMls(SyncAlgorithm):
    """PTP offsets smoothed by a causal moving least-squares line (window ``window`` exchanges)."""

    name = "ptp-mls"

    def __init__(self, window: int = 32, interval_s: float = 0.01):
        self.window = window
        self.interval_s = interval_s

    def _check_params(self):
        check_scalar(self.window, "window", min_val=16, max_val=64, integer=True)

    def init_state(self, trials):
        return {"z": np.full((trials, int(self.window)), np.nan)}

    def update(self, state, sample):
        w_len = int(self.window)
        z = np.concatenate([state["z"][:, 1:], ptp_offset_s(sample.t_i_s, sample.t_b_s, sample.t_r_s)[:, None]], axis=1)
        age = np.arange(w_len - 1, -1, -1, dtype=np.float64)
        w = (1.0 - (age / w_len) ** 3) ** 3
        x = -age * self.interval_s
        est = weighted_line_at_zero(np.broadcast_to(x, z.shape), z, np.broadcast_to(w, z.shape))
        return {"z": z}, est
