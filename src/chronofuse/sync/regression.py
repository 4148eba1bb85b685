"""Regression servos: linuxptp's ``linreg`` and a chrony-style runs-test regression.

**linreg** (linuxptp ``linreg.c``, M. Lichvar 2014), re-expressed in seconds and fractions: each
sample adds the point ``(x, y)`` = (free-running local time, remote time = disciplined time minus the
offset) to a ring of 64; lines are fitted to the newest 4, 8, 16, 32 and 64 points; for each size an
exponential moving average of the prediction error ``|intercept_before - y_newest|`` is kept (the
first 10 updates averaged, then smoothing 0.02); the largest size whose error is within 5 % of the
smallest (and has 10 updates) is used. The clock frequency is set to ``slope - 1`` plus
``intercept / (T corr)`` with ``corr = 1`` for sizes up to 16 points, else ``log2(size) // 2``; on the
first update an intercept beyond ``first_step_threshold`` steps the clock. Frequencies are clamped to
``max_frequency``. The disciplined clock tracks ``eps`` as in :mod:`chronofuse.sync.ptp`: the estimate
``u`` moves by ``clock_freq T`` per exchange and a step sets ``u -= offset``.

**chrony-style regression** (after chrony's ``regress.c``, ``RGR_FindBestRegression``): a line is
fitted to the newest ``n`` PTP offsets for ``n`` in 64, 48, 32, 24, 16, 12, 8 (those available) and
the largest ``n`` is kept whose residuals pass the Wald–Wolfowitz runs test (number of sign runs not
below its mean minus two standard deviations); the estimate is the line's value now. Chrony's sample
weighting by each sample's delay dispersion is left out (all exchanges here have the same SNR).
"""

from __future__ import annotations

import numpy as np

from chronofuse.sync.base import SyncAlgorithm
from chronofuse.sync.mls import weighted_line_at_zero
from chronofuse.sync.twoway import ptp_offset_s
from chronofuse.validation import check_scalar

__all__ = ["PtpLinreg", "ChronyRegression", "runs_test_passes"]

_SIZES = (2, 3, 4, 5, 6)  # log2 of the regression sizes 4..64
_MAX_POINTS = 64
_ERR_SMOOTH = 0.02
_ERR_INITIAL_UPDATES = 10
_ERR_EQUALS = 1.05


class PtpLinreg(SyncAlgorithm):
    """PTP offsets (per-exchange delay) through linuxptp's linear-regression servo (module docstring)."""

    name = "ptp-linreg"

    def __init__(self, first_step_threshold_s=20e-6, max_frequency=1e-4, interval_s=0.01):
        self.first_step_threshold_s = first_step_threshold_s
        self.max_frequency = max_frequency
        self.interval_s = interval_s

    def _check_params(self):
        check_scalar(self.first_step_threshold_s, "first_step_threshold_s", min_val=0.0)
        check_scalar(self.max_frequency, "max_frequency", min_val=0.0, include_min=False)

    def init_state(self, trials):
        n_sizes = len(_SIZES)
        return {
            "px": np.zeros((trials, _MAX_POINTS)), "py": np.zeros((trials, _MAX_POINTS)),
            "num": np.zeros(trials, dtype=np.int64),
            "slope": np.zeros((trials, n_sizes)), "intercept": np.zeros((trials, n_sizes)),
            "err": np.zeros((trials, n_sizes)), "err_updates": np.zeros((trials, n_sizes), dtype=np.int64),
            "clock_freq": np.zeros(trials), "u": np.zeros(trials), "first_update": np.ones(trials, dtype=bool),
        }

    def update(self, state, sample):
        dt = self.interval_s
        z = ptp_offset_s(sample.t_i_s, sample.t_b_s, sample.t_r_s)
        px, py = state["px"].copy(), state["py"].copy()
        slope, intercept = state["slope"].copy(), state["intercept"].copy()
        err, err_updates = state["err"].copy(), state["err_updates"].copy()
        clock_freq, u, first_update = state["clock_freq"].copy(), state["u"].copy(), state["first_update"].copy()
        num = state["num"].copy()
        if sample.k > 0:
            # update_reference: the disciplined clock advanced dt (1 + clock_freq), the free one dt.
            y_int = dt * (1.0 + clock_freq)
            x_int = y_int / (1.0 + clock_freq)
            u = u + clock_freq * dt
            px -= x_int[:, None]
            py -= y_int[:, None]
            intercept += x_int[:, None] * slope - y_int[:, None]
        moved = {"px": px.copy(), "py": py.copy(), "intercept": intercept.copy(), "u": u.copy()}
        offset = u - z
        # add_sample: newest point at column 0 (the ring, newest first).
        px = np.concatenate([np.zeros((px.shape[0], 1)), px[:, :-1]], axis=1)
        py = np.concatenate([-offset[:, None], py[:, :-1]], axis=1)
        num = np.minimum(num + 1, _MAX_POINTS)
        y0 = -offset
        for j, size in enumerate(_SIZES):
            n = 1 << size
            ok = num >= n
            has = ok & (slope[:, j] != 0.0)
            e = np.abs(intercept[:, j] - y0)
            initial = has & (err_updates[:, j] < _ERR_INITIAL_UPDATES)
            smooth = has & ~initial
            err[initial, j] = (err[initial, j] * err_updates[initial, j] + e[initial]) / (err_updates[initial, j] + 1)
            err_updates[initial, j] += 1
            err[smooth, j] += _ERR_SMOOTH * (e[smooth] - err[smooth, j])
            x, y = px[:, :n], py[:, :n]
            sx, sy = x.sum(1), y.sum(1)
            sxy, sxx = (x * y).sum(1), (x * x).sum(1)
            den = sxx - sx * sx / n
            with np.errstate(invalid="ignore", divide="ignore"):
                new_slope = (sxy - sx * sy / n) / den
            new_slope = np.where(den > 0.0, new_slope, 1.0)
            slope[ok, j] = new_slope[ok]
            intercept[ok, j] = ((sy - new_slope * sx) / n)[ok]
        # get_best_size
        best = np.full(num.shape, -1)
        best_err = np.zeros(num.shape)
        for j in range(len(_SIZES)):
            take = ((best < 0) & (slope[:, j] != 0.0)) | (
                (best_err * _ERR_EQUALS > err[:, j]) & (err_updates[:, j] >= _ERR_INITIAL_UPDATES))
            best = np.where(take, j, best)
            best_err = np.where(take, err[:, j], best_err)
        locked = best >= 0
        rows = np.arange(num.size)
        jb = np.maximum(best, 0)
        b_slope, b_icpt = slope[rows, jb], intercept[rows, jb]
        jump = locked & first_update & (self.first_step_threshold_s > 0.0) & (np.abs(b_icpt) > self.first_step_threshold_s)
        # move_reference(0, -offset): the clock is stepped by -offset.
        shift = np.where(jump, offset, 0.0)
        py += shift[:, None]
        intercept += shift[:, None]
        u = np.where(jump, u - offset, u)
        b_icpt = intercept[rows, jb]
        size = np.array(_SIZES)[jb]
        corr = np.where(size <= 4, 1, size // 2)
        new_freq = np.clip((b_slope - 1.0) + b_icpt / dt / corr, -self.max_frequency, self.max_frequency)
        clock_freq = np.where(locked, new_freq, clock_freq)
        first_update = first_update & ~locked
        new = {"px": px, "py": py, "num": num, "slope": slope, "intercept": intercept, "err": err,
               "err_updates": err_updates, "clock_freq": clock_freq, "u": u, "first_update": first_update}
        missing = np.isnan(z)
        if missing.any():
            # No sample: time still passes (the reference moved) but nothing is added or re-fitted.
            for key, value in new.items():
                keep = moved[key] if key in moved else state[key]
                mask = missing if value.ndim == 1 else missing[:, None]
                new[key] = np.where(mask, keep, value)
        return new, new["u"].copy()


def runs_test_passes(residuals: np.ndarray) -> np.ndarray:
    """Wald–Wolfowitz runs test on each row's residual signs: runs >= mean - 2 sd (True = random)."""
    pos = residuals > 0.0
    n1 = pos.sum(axis=1)
    n2 = pos.shape[1] - n1
    n = n1 + n2
    runs = 1 + (pos[:, 1:] != pos[:, :-1]).sum(axis=1)
    mean = 2.0 * n1 * n2 / n + 1.0
    var = np.where(n > 1, (mean - 1.0) * (mean - 2.0) / np.maximum(n - 1, 1), 0.0)
    return runs >= mean - 2.0 * np.sqrt(np.maximum(var, 0.0))


class ChronyRegression(SyncAlgorithm):
    """PTP offsets smoothed by a line over the longest window that passes the runs test (module docstring)."""

    name = "ptp-chrony"
    sizes = (64, 48, 32, 24, 16, 12, 8)

    def __init__(self, interval_s=0.01):
        self.interval_s = interval_s

    def init_state(self, trials):
        return {"z": np.full((trials, self.sizes[0]), np.nan)}

    def update(self, state, sample):
        z_new = ptp_offset_s(sample.t_i_s, sample.t_b_s, sample.t_r_s)
        z = np.concatenate([state["z"][:, 1:], z_new[:, None]], axis=1)
        available = min(sample.k + 1, self.sizes[0])
        est = z_new.copy()
        chosen = np.zeros(z_new.shape, dtype=bool)
        for n in self.sizes:
            if n > available:
                continue
            x = -np.arange(n - 1, -1, -1, dtype=np.float64) * self.interval_s
            zz = z[:, -n:]
            xb = np.broadcast_to(x, zz.shape)
            w = np.ones_like(zz)
            a = weighted_line_at_zero(xb, zz, w)
            # slope from the same fit: residuals need the whole line
            xm = x.mean()
            slope = ((x - xm) * (zz - zz.mean(axis=1, keepdims=True))).sum(axis=1) / ((x - xm) ** 2).sum()
            resid = zz - (a[:, None] + slope[:, None] * x)
            take = ~chosen & runs_test_passes(resid)
            est = np.where(take, a, est)
            chosen |= take
        return {"z": z}, est
