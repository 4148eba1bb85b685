"""Numba kernels of the fusion and the state machine: the fast path beside their readable numpy twins.

The servos' kernels are each servo's own (one backend per module, :mod:`.servo_kernel` for what they
share); these two are the per-second loops of :mod:`.fusion` and :mod:`.states`, tested against the numpy
twins there.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["fusion_kernel", "states_kernel"]


@numba.njit(cache=True)
def fusion_kernel(z, usable, selection, alpha, initial_var, floor_var):
    """Online inverse-variance fusion (:mod:`.fusion`) over (trials, receivers, steps); returns
    fused (trials, steps), variance (trials, steps), weights (trials, receivers, steps)."""
    trials, receivers, steps = z.shape
    fused = np.empty((trials, steps))
    variance = np.empty((trials, steps))
    weights = np.empty((trials, receivers, steps))
    ms = np.full(receivers, np.nan)
    var = np.empty(receivers)
    w = np.empty(receivers)
    w_all = np.empty(receivers)
    zz = np.empty(receivers)
    for i in range(trials):
        ms[:] = np.nan
        for k in range(steps):
            for j in range(receivers):
                v = ms[j] if not math.isnan(ms[j]) else initial_var
                var[j] = max(v, floor_var)
                w_all[j] = 1.0 / var[j] if usable[i, j, k] else 0.0
                zz[j] = z[i, j, k] if usable[i, j, k] else 0.0
                w[j] = w_all[j]
            if selection:
                best = 0
                for j in range(1, receivers):
                    if w[j] > w[best]:
                        best = j
                for j in range(receivers):
                    if j != best:
                        w[j] = 0.0
            total = 0.0
            num = 0.0
            t_all = 0.0
            n_all = 0.0
            for j in range(receivers):
                total += w[j]
                num += w[j] * zz[j]
                t_all += w_all[j]
                n_all += w_all[j] * zz[j]
            has = total > 0.0
            fused[i, k] = num / total if has else np.nan
            variance[i, k] = 1.0 / total if has else np.nan
            for j in range(receivers):
                weights[i, j, k] = w[j] / (total if has else 1.0)
                t_others = t_all - w_all[j]
                if usable[i, j, k] and t_others > 0.0:
                    resid = zz[j] - (n_all - w_all[j] * zz[j]) / t_others
                    sample = resid * resid - 1.0 / t_others
                    if math.isnan(ms[j]):
                        ms[j] = max(sample, var[j])
                    else:
                        ms[j] = (1.0 - alpha) * ms[j] + alpha * sample
    return fused, variance, weights


@numba.njit(cache=True)
def states_kernel(usable, alarm, offset, threshold_s, hold):
    """The state machine (:mod:`.states`, :func:`~.states.advance`) over (trials, steps); returns
    state and reason, int8 (trials, steps). Codes: FREE_RUN 0, ACQUIRING 1, LOCKED 2, HOLDOVER 3,
    RECOVERY 4; reasons NONE 0, REFERENCE_USABLE 1, REFERENCE_LOST 2, LOCK_ACHIEVED 3, INTEGRITY_ALARM 4."""
    trials, steps = usable.shape
    states = np.empty((trials, steps), dtype=np.int8)
    reasons = np.zeros((trials, steps), dtype=np.int8)
    for i in range(trials):
        s = 0
        run = 0
        for k in range(steps):
            ok = usable[i, k] and not alarm[i, k]
            settled = ok and abs(offset[i, k]) < threshold_s
            run = run + 1 if settled else 0
            lost = 4 if alarm[i, k] else 2
            new = s
            why = 0
            if s == 0 and ok:
                new, why = 1, 1
            elif s == 1 and not ok:
                new, why = 0, lost
            elif s == 2 and not ok:
                new, why = 3, lost
            elif s == 3 and ok:
                new, why = 4, 1
            elif s == 4 and not ok:
                new, why = 3, lost
            if (s == 1 or s == 4) and run >= hold:
                new, why = 2, 3
            s = new
            states[i, k] = s
            reasons[i, k] = why
    return states, reasons
