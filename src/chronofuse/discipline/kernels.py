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
def states_kernel(usable, alarm, implausible, near, offset, freq_adj, params):
    """The state machine (:mod:`.states`, :func:`~.states.advance`) over (trials, steps), ``params`` from
    :meth:`~.states.StateConfig.kernel_params`; returns state and reason (int8), filtered offset, holdover
    ready (int8) and holdover sigma, each (trials, steps). Codes: FREE_RUN 0, ACQUIRING 1, LOCKED 2,
    HOLDOVER 3, RECOVERY 4, ALARM 5; reasons NONE 0, REFERENCE_USABLE 1, REFERENCE_LOST 2, LOCK_ACHIEVED 3,
    INTEGRITY_ALARM 4, TIME_ERROR_EXCURSION 5, FREQUENCY_EXCURSION 6, DAC_RAIL 7, IMPLAUSIBLE_REFERENCE 8."""
    limit, hold, a_te, f_thr, a_u, ready, model_var, horizon = (params[0], params[1], params[2], params[3],
                                                                 params[4], params[5], params[6], params[7])
    trials, steps = usable.shape
    states = np.empty((trials, steps), dtype=np.int8)
    reasons = np.zeros((trials, steps), dtype=np.int8)
    te_out = np.empty((trials, steps))
    ready_out = np.zeros((trials, steps), dtype=np.int8)
    sigma_out = np.empty((trials, steps))
    for i in range(trials):
        s = 0
        run = 0
        locked = 0
        te_f = np.nan
        u_f = np.nan
        u_var = 0.0
        for k in range(steps):
            z = offset[i, k]
            ok = usable[i, k] and not alarm[i, k] and not implausible[i, k] and math.isfinite(z)
            if ok:
                te_f = te_f + a_te * (z - te_f) if math.isfinite(te_f) else z
            else:
                te_f = np.nan
            u = freq_adj[i, k]
            if math.isfinite(u_f):
                dev = u - u_f
                u_var = (1.0 - a_u) * u_var + a_u * dev * dev
                u_f = u_f + a_u * dev
            else:
                dev = 0.0
                u_var = 0.0
                u_f = u
            te_ok = ok and abs(te_f) < limit
            f_ok = abs(dev) < f_thr
            settled = ok and te_ok and f_ok and not near[i, k]
            run = run + 1 if settled else 0
            lost = 8 if implausible[i, k] else (4 if alarm[i, k] else 2)
            broken = 7 if near[i, k] else (5 if not te_ok else 6)
            new = s
            why = 0
            if s == 0 and ok:
                new, why = 1, 1
            elif s == 1 and not ok:
                new, why = 0, lost
            elif (s == 2 or s == 5 or s == 4) and not ok:
                new, why = 3, lost
            elif s == 3 and ok:
                new, why = 4, 1
            elif s == 2 and not settled:
                new, why = 5, broken
            if (s == 1 or s == 4 or s == 5) and run >= hold:
                new, why = 2, 3
            s = new
            locked = locked + 1 if s == 2 else 0
            states[i, k] = s
            reasons[i, k] = why
            te_out[i, k] = te_f
            ready_out[i, k] = 1 if locked >= ready else 0
            if s == 2:
                t0 = te_f if ok else 0.0
                sigma_out[i, k] = math.sqrt(t0 * t0 + horizon * horizon * u_var + model_var)
            else:
                sigma_out[i, k] = np.nan
    return states, reasons, te_out, ready_out, sigma_out
