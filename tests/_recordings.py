"""Simulated u-blox recordings (serialized by pyubx2) of a receiver clock with the events the integrity
pipeline must handle: a millisecond clock reset, a step, a ramp, a loss of fix, epochs sent out of time order
(importable as ``_recordings``)."""

from __future__ import annotations

import numpy as np
from pyubx2 import GET, UBXMessage

from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias

WEEK = 2300  # 2024-02-04
NOISE = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=1.0)
STEPS = 900


def ubx_recording(clock_bias_s, *, fix_type=None, time_acc_ns=None, week: int = WEEK, start_tow_ms: int = 100_000_000,
                  leap_s: int = 18) -> bytes:
    """One epoch per second: NAV-TIMEGPS (week, leap), NAV-SOL (fix and its ``gpsFixOK`` flag), NAV-DOP and
    NAV-CLOCK (``clkB`` the bias in whole ns, ``tAcc``). ``fix_type`` (per epoch, u-blox ``gpsFix``: 0 no fix,
    3 3-D) and ``time_acc_ns`` (per epoch) default to 3 and 10 ns; the first epoch's ``iTOW`` is ``start_tow_ms``."""
    n = len(clock_bias_s)
    fix_type = np.full(n, 3) if fix_type is None else np.asarray(fix_type)
    time_acc_ns = np.full(n, 10) if time_acc_ns is None else np.asarray(time_acc_ns)
    out = []
    for k, bias in enumerate(clock_bias_s):
        itow = start_tow_ms + k * 1000
        fix = int(fix_type[k])
        out.append(UBXMessage("NAV", "NAV-TIMEGPS", GET, iTOW=itow, fTOW=0, week=week, leapS=leap_s, towValid=1,
                              weekValid=1, leapSValid=1, tAcc=10).serialize())
        out.append(UBXMessage("NAV", "NAV-SOL", GET, iTOW=itow, fTOW=0, week=week, gpsFix=fix,
                              gpsfixOK=int(fix >= 2), wknSet=1, towSet=1, numSV=9 if fix else 0, pDOP=1.5).serialize())
        out.append(UBXMessage("NAV", "NAV-DOP", GET, iTOW=itow, gDOP=2.1, pDOP=1.5, tDOP=1.0, vDOP=1.2, hDOP=0.9,
                              nDOP=0.6, eDOP=0.6).serialize())
        out.append(UBXMessage("NAV", "NAV-CLOCK", GET, iTOW=itow, clkB=int(round(bias * 1e9)), clkD=0,
                              tAcc=int(time_acc_ns[k]), fAcc=100).serialize())
    return b"".join(out)


def _clock(seed: int, drift_s_per_s: float = 0.0) -> np.ndarray:
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=STEPS, trials=1, seed=seed).measured_s[0]
    return x + drift_s_per_s * np.arange(STEPS)


def millisecond_reset() -> bytes:
    """A free-running clock (2 us/s) kept within +-0.5 ms of GPS time by whole-millisecond jumps."""
    x = _clock(11, 2e-6) + 1e-4
    return ubx_recording(x - 1e-3 * np.floor((x + 5e-4) / 1e-3))


def step() -> bytes:
    """A 100 ns step at 600 s."""
    return ubx_recording(inject(_clock(12), Anomaly("step", 600.0, offset_s=1e-7), 1.0))


def ramp() -> bytes:
    """A 30 ns/s frequency step from 500 s for 200 s (a drag-off), then steady. (The latch holds a ramp while
    its frequency is more than 5 sigma of the trained model away from the one before: about 11 ns/s with the
    random-walk FM that 300 s of training fits here.)"""
    return ubx_recording(inject(_clock(13), Anomaly("ramp", 500.0, rate_s_per_s=3e-8, duration_s=200.0), 1.0))


def fix_loss() -> bytes:
    """The fix lost for 40 s from 500 s: the receiver coasts (its bias drifts off at 50 ns/s) with its fix
    flags off and its time accuracy growing past 100 ns."""
    x = _clock(14)
    coast = np.arange(STEPS) - 500
    lost = (coast >= 0) & (coast < 40)
    x = np.where(lost, x + 5e-8 * coast, x)
    fix = np.where(lost, 0, 3)
    tacc = np.where(lost, 40 + 5 * np.maximum(coast, 0), 10)
    return ubx_recording(x, fix_type=fix, time_acc_ns=tacc)


def _epoch_by_epoch(x: np.ndarray) -> list[bytes]:
    return [ubx_recording(x[k:k + 1], start_tow_ms=100_000_000 + k * 1000) for k in range(x.size)]


def out_of_order() -> bytes:
    """Epochs 400 and 401 sent in swapped order, and epoch 600 after 601 and 602 (within the reorder buffer
    of chronofuse.io.arrival: every epoch is put back in its place, with a warning)."""
    epochs = _epoch_by_epoch(_clock(15))
    epochs[400], epochs[401] = epochs[401], epochs[400]
    epochs[600:603] = [epochs[601], epochs[602], epochs[600]]
    return b"".join(epochs)


def late_epoch() -> bytes:
    """Epoch 500 sent after epoch 505: beyond the reorder buffer, it is left out (a gap) on every path."""
    epochs = _epoch_by_epoch(_clock(16))
    late = epochs.pop(500)
    epochs.insert(505, late)
    return b"".join(epochs)


SIMULATED = {"millisecond-reset": millisecond_reset, "step": step, "ramp": ramp, "fix-loss": fix_loss,
             "out-of-order": out_of_order, "late-epoch": late_epoch}
