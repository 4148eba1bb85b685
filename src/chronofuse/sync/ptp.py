"""PTP (IEEE 1588) offset from the four timestamps, with linuxptp's delay filter and PI servo.

Offset measurement (IEEE 1588-2019 section 11.3): with a per-exchange delay it is the paper's eq. (1); with
linuxptp's ``delay_filter moving_median`` of ``delay_filter_length 10`` it is ``(t2 - t1) - median of
the last 10 mean path delays``. On moving nodes the path delay changes by ``v interval / c`` per
exchange (67 ps at 2000 m/s and 10 ms), and a 10-sample median lags it by about 4.5 exchanges.

PI servo (linuxptp ``pi.c``, as published; offsets here in seconds and frequencies as fractions
instead of ns and ppb, so every gain keeps its value):

* gains from the sync interval ``T``: ``kp = min(kp_scale T^-0.3, 0.7 / T)``,
  ``ki = min(ki_scale T^0.4, 0.3 / T)``; hardware time stamping scales ``kp_scale = 0.7``,
  ``ki_scale = 0.3``;
* sample 1 is stored (UNLOCKED); sample 2 replaces the second stored one until the two are
  ``0.016 / ki`` s apart (at most 1000 s; ``FREQ_EST_MARGIN`` 0.1 %), then the drift is set from their
  slope, ``drift += (1 - drift) (o2 - o1) / (l2 - l1)``, and, on this first update, an offset larger
  than ``first_step_threshold`` (20 us) steps the clock (JUMP); otherwise LOCKED;
* then ``f = kp o + drift + ki o``; if ``|f|`` exceeds ``max_frequency`` it is clamped and the
  integral is not updated (anti-windup), else ``drift += ki o``.

The servo disciplines a correction ``u`` (the estimate of ``eps``): linuxptp's offset is the
disciplined clock minus the reference, ``o = u - z`` for the measured offset ``z``; the clock's
frequency is set to ``-f``, so ``u`` moves by ``-f T`` until the next sample, and a JUMP sets
``u -= o``. The estimate reported after exchange ``k`` is ``u`` after any step taken at ``k``.
"""

from __future__ import annotations

import warnings

import numpy as np

from chronofuse.sync.base import SyncAlgorithm
from chronofuse.sync.twoway import ptp_delay_s, ptp_offset_s
from chronofuse.validation import check_choice, check_scalar

__all__ = ["pi_gains", "PtpOffset", "PtpPiServo"]

#: linuxptp servo states (servo.h); stored per trial as small integers.
UNLOCKED, JUMP, LOCKED = 0, 1, 2
_FREQ_EST_MARGIN = 0.001
_DELAY_FILTERS = ("per-exchange", "median")


def pi_gains(interval_s: float, kp_scale: float = 0.7, ki_scale: float = 0.3) -> tuple[float, float]:
    """linuxptp ``pi_sync_interval``: ``(kp, ki)`` for sync interval ``interval_s``."""
    kp = min(kp_scale * interval_s**-0.3, 0.7 / interval_s)
    ki = min(ki_scale * interval_s**0.4, 0.3 / interval_s)
    return kp, ki


def hold_missing(missing: np.ndarray, new: dict, old: dict, clock: str) -> dict:
    """A servo without a sample keeps its state (linuxptp samples only on a measurement); only the
    disciplined clock ``clock`` keeps running at its set frequency (taken from ``new``)."""
    if not missing.any():
        return new
    out = {}
    for key, value in new.items():
        keep = old[key]
        if key == clock:
            out[key] = value
        elif value.ndim == 1:
            out[key] = np.where(missing, keep, value)
        else:
            out[key] = np.where(missing[:, None], keep, value)
    return out


def _measured_offset(state, sample, delay_filter: str, length: int):
    """(new delay history, measured offset z) for one exchange."""
    delay = ptp_delay_s(sample.t_i_s, sample.t_b_s, sample.t_r_s)
    if delay_filter == "per-exchange":
        return state["delays"], ptp_offset_s(sample.t_i_s, sample.t_b_s, sample.t_r_s)
    hist = np.concatenate([state["delays"][:, 1:], delay[:, None]], axis=1)
    with warnings.catch_warnings():  # a link with no delay in its window yet: NaN, as meant
        warnings.simplefilter("ignore", RuntimeWarning)
        med = np.nanmedian(hist[:, -min(sample.k + 1, length):], axis=1)
    return hist, sample.t_i_s - med


class PtpOffset(SyncAlgorithm):
    """The raw PTP offset of each exchange (no servo): the paper's eq. (1), or with the moving-median delay.

    Parameters
    ----------
    delay_filter : {"per-exchange", "median"}
    delay_filter_length : int
        Samples in the moving median (linuxptp default 10).
    """

    name = "ptp-raw"

    def __init__(self, delay_filter: str = "per-exchange", delay_filter_length: int = 10, interval_s: float = 0.01):
        self.interval_s = interval_s
        self.delay_filter = delay_filter
        self.delay_filter_length = delay_filter_length

    def _check_params(self):
        check_choice(self.delay_filter, "delay_filter", _DELAY_FILTERS)
        check_scalar(self.delay_filter_length, "delay_filter_length", min_val=1, integer=True)

    def init_state(self, trials):
        return {"delays": np.full((trials, int(self.delay_filter_length)), np.nan)}

    def update(self, state, sample):
        delays, z = _measured_offset(state, sample, self.delay_filter, int(self.delay_filter_length))
        return {"delays": delays}, z


class PtpPiServo(SyncAlgorithm):
    """PTP with linuxptp's PI servo (see the module docstring for the published algorithm).

    Parameters
    ----------
    delay_filter : {"per-exchange", "median"}
    delay_filter_length : int
    kp_scale, ki_scale : float
        linuxptp ``pi_proportional_scale`` / ``pi_integral_scale``; 0.7 / 0.3 (hardware stamps).
    first_step_threshold_s : float
        linuxptp ``first_step_threshold`` (20 us).
    max_frequency : float
        Largest frequency adjustment, fractional (linuxptp: the clock's maximum, here 1e-4 = 100 ppm).
    """

    name = "ptp"

    def __init__(self, delay_filter="per-exchange", delay_filter_length=10, kp_scale=0.7, ki_scale=0.3,
                 first_step_threshold_s=20e-6, max_frequency=1e-4, interval_s=0.01):
        self.interval_s = interval_s
        self.delay_filter = delay_filter
        self.delay_filter_length = delay_filter_length
        self.kp_scale = kp_scale
        self.ki_scale = ki_scale
        self.first_step_threshold_s = first_step_threshold_s
        self.max_frequency = max_frequency

    def _check_params(self):
        check_choice(self.delay_filter, "delay_filter", _DELAY_FILTERS)
        check_scalar(self.delay_filter_length, "delay_filter_length", min_val=1, integer=True)
        check_scalar(self.kp_scale, "kp_scale", min_val=0.0)
        check_scalar(self.ki_scale, "ki_scale", min_val=0.0, include_min=False)
        check_scalar(self.first_step_threshold_s, "first_step_threshold_s", min_val=0.0)
        check_scalar(self.max_frequency, "max_frequency", min_val=0.0, include_min=False)

    def init_state(self, trials):
        z = np.zeros(trials)
        return {
            "delays": np.full((trials, int(self.delay_filter_length)), np.nan),
            "count": np.zeros(trials, dtype=np.int64),
            "o0": z, "l0": z, "o1": z, "l1": z,
            "drift": z, "freq": z, "u": z,
            "first_update": np.ones(trials, dtype=bool),
            "servo_state": np.full(trials, UNLOCKED, dtype=np.int64),
        }

    def update(self, state, sample):
        interval = self.interval_s
        kp, ki = pi_gains(interval, self.kp_scale, self.ki_scale)
        delays, z = _measured_offset(state, sample, self.delay_filter, int(self.delay_filter_length))
        # The clock ran at -freq since the previous sample.
        u = state["u"] - state["freq"] * interval if sample.k > 0 else state["u"]
        o = u - z
        local = np.full_like(o, sample.t_s)
        count, drift, freq = state["count"].copy(), state["drift"].copy(), state["freq"].copy()
        o0, l0, o1, l1 = state["o0"].copy(), state["l0"].copy(), state["o1"].copy(), state["l1"].copy()
        first_update = state["first_update"].copy()
        servo_state = state["servo_state"].copy()

        # case 0: store the first sample.
        c0 = count == 0
        o0[c0], l0[c0] = o[c0], local[c0]
        count[c0] = 1
        servo_state[c0] = UNLOCKED
        # case 1: replace the second sample until the two are far enough apart.
        c1 = (state["count"] == 1)
        o1[c1], l1[c1] = o[c1], local[c1]
        est_interval = min(0.016 / ki, 1000.0)
        span = (l1 - l0) * (1.0 + _FREQ_EST_MARGIN)
        ready = c1 & (span >= est_interval)
        drift[ready] += (1.0 - drift[ready]) * (o1[ready] - o0[ready]) / (l1[ready] - l0[ready])
        drift[ready] = np.clip(drift[ready], -self.max_frequency, self.max_frequency)
        jump = ready & first_update & (self.first_step_threshold_s > 0.0) & (np.abs(o) > self.first_step_threshold_s)
        servo_state[c1] = UNLOCKED
        servo_state[ready] = np.where(jump[ready], JUMP, LOCKED)
        freq[ready] = drift[ready]
        count[ready] = 2
        first_update[ready] = False
        u = np.where(jump, u - o, u)
        # case 2: PI with anti-windup.
        c2 = state["count"] == 2
        ki_term = ki * o
        f = kp * o + drift + ki_term
        clamped = np.abs(f) > self.max_frequency
        freq[c2] = np.clip(f[c2], -self.max_frequency, self.max_frequency)
        drift[c2 & ~clamped] += ki_term[c2 & ~clamped]
        servo_state[c2] = LOCKED
        new = {"delays": delays, "count": count, "o0": o0, "l0": l0, "o1": o1, "l1": l1, "drift": drift,
               "freq": freq, "u": u, "first_update": first_update, "servo_state": servo_state}
        held = hold_missing(np.isnan(z), new, state, "u")
        return held, held["u"].copy()
