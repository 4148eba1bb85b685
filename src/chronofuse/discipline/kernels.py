"""Numba kernels of the servos and of the closed loop: the fast path beside the readable numpy twins.

The twins are the servos' own numpy cores (:meth:`chronofuse.discipline.servo.Servo.update` with
``fast=False``: the Kalman servos on ``estimation.kalman``); these kernels do the same arithmetic per
loop in compiled code (same equations, same order: predict ``x = F x``, ``P = F P F' + Q``; the Joseph-form
update; the same robust rules and DAC). Tests compare every servo kernel with its twin. The point is
speed: a Python step costs tens of microseconds of numpy overhead per second simulated, the kernels
well under one.

Modes: 0 KF, 1 weighted adaptive KF, 2 gated KF, 3 Huber KF, 4 PI, 5 null. ``step_thr < 0`` means never step.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["servo_step_kernel", "servo_step_packed", "pack_params", "close_loop_kernel", "fusion_kernel",
           "states_kernel", "MODES"]

MODES = {"kf": 0, "wakf": 1, "gated": 2, "huber": 3, "pi": 4, "null": 5}


@numba.njit(cache=True)
def _matmul(A, B):
    """``A @ B`` of small square matrices, each entry summed over ``c`` in order (the predict and Joseph steps)."""
    n = A.shape[0]
    out = np.zeros((n, n))
    for a in range(n):
        for b in range(n):
            acc = 0.0
            for c in range(n):
                acc += A[a, c] * B[c, b]
            out[a, b] = acc
    return out


@numba.njit(cache=True)
def _matmul_bt_plus(A, B, C):
    """``A @ B.T + C`` of small square matrices: ``F P F' + Q`` and the Joseph form's ``(I-KH) P (I-KH)' + K r K'``
    (each entry of the product summed in :func:`_matmul`'s order, then ``C`` added)."""
    return _matmul(A, B.T) + C


@numba.njit(cache=True)
def _one(i, zi, vi, x, P, u, started, prev_valid, window, rejects, integral, F, Q, h, r, mode, dt, steer, step_thr,
         wakf_th, lam_min, lam_max, gamma, max_rejects, huber_c, kp, ki, dac_on, gain, step_V, half, half_span,
         margin, out):
    """Advance loop ``i`` by one second; writes (adj, step, est, innov, used, near) into ``out`` (6,)."""
    if not vi:
        zi = 0.0
    jump = False
    if step_thr >= 0.0 and vi:
        jump = (not started[i]) or ((not prev_valid[i]) and abs(zi) > step_thr)
    s = -zi if jump else 0.0
    zi = zi + s
    nan = math.nan
    if mode == 5:
        y_cmd = 0.0
        est = zi if vi else nan
        innov = est
        used = vi
    elif mode == 4:
        if vi:
            integral[i] = integral[i] + ki * zi / dt
            y_cmd = -(kp * zi / dt + integral[i])
        else:
            y_cmd = -(0.0 + integral[i])
        est = zi if vi else nan
        innov = est
        used = vi
    else:
        n = F.shape[0]
        xs = x[i].copy()
        xs[0] = xs[0] + s
        xp = np.zeros(n)
        for a in range(n):
            acc = 0.0
            for b in range(n):
                acc += xs[b] * F[a, b]
            xp[a] = acc
        Pp = _matmul_bt_plus(_matmul(F, P[i]), F, Q)
        xp[0] = xp[0] + dt * u[i]
        if step_thr >= 0.0 and vi and not started[i]:
            xp[0] = zi
        hx = 0.0
        for a in range(n):
            hx += xp[a] * h[a]
        e = zi - hx
        s0 = 0.0
        for a in range(n):
            for b in range(n):
                s0 += h[a] * Pp[a, b] * h[b]
        r_k = r
        accept = vi
        if mode == 1:
            w = window.shape[1]
            for a in range(w - 1):
                window[i, a] = window[i, a + 1]
            window[i, w - 1] = e if vi else nan
            count = 0
            tot = 0.0
            for a in range(w):
                if not math.isnan(window[i, a]):
                    count += 1
                    tot += window[i, a]
            mean = tot / max(count, 1)
            var = 0.0
            for a in range(w):
                if not math.isnan(window[i, a]):
                    var += (window[i, a] - mean) ** 2
            var = var / max(count - 1, 1)
            sigma_e = math.sqrt(var) if count >= 2 else 0.0
            r_k = (lam_max if sigma_e > wakf_th else lam_min) * r
        elif mode == 2:
            outlier = vi and e * e / (s0 + r) > gamma
            reject = outlier and not (rejects[i] >= max_rejects)
            if reject:
                rejects[i] += 1
            elif vi:
                rejects[i] = 0
            accept = vi and not reject
        elif mode == 3:
            rn = abs(e if vi else 0.0) / math.sqrt(s0 + r)
            wgt = min(1.0, huber_c / max(rn, 1e-300))
            r_k = r / wgt
        if accept:
            PHt = np.zeros(n)
            for a in range(n):
                acc = 0.0
                for b in range(n):
                    acc += Pp[a, b] * h[b]
                PHt[a] = acc
            S = 0.0
            for a in range(n):
                S += h[a] * PHt[a]
            S = S + r_k
            K = PHt / S
            for a in range(n):
                xp[a] = xp[a] + K[a] * e
            IKH = np.eye(n)
            for a in range(n):
                for b in range(n):
                    IKH[a, b] -= K[a] * h[b]
            KrK = np.zeros((n, n))
            for a in range(n):
                for b in range(n):
                    KrK[a, b] = K[a] * r_k * K[b]
            Pp = _matmul_bt_plus(_matmul(IKH, Pp), IKH, KrK)
        for a in range(n):
            for b in range(a, n):
                sym = 0.5 * (Pp[a, b] + Pp[b, a])
                P[i, a, b] = sym
                P[i, b, a] = sym
            x[i, a] = xp[a]
        y_cmd = -(xp[1] + 0.5 * dt * xp[2]) - xp[0] / steer
        est = xp[0]
        innov = e if accept else nan
        used = accept
    near = False
    if dac_on:
        code = np.rint(y_cmd / gain / step_V)
        code = min(max(code, -half), half - 1.0)
        vq = code * step_V
        y_cmd = gain * vq
        near = abs(vq) >= half_span * (1.0 - margin) - step_V
    u[i] = y_cmd
    started[i] = started[i] or vi
    prev_valid[i] = vi
    out[0] = y_cmd
    out[1] = s
    out[2] = est
    out[3] = innov
    out[4] = 1.0 if used else 0.0
    out[5] = 1.0 if near else 0.0


@numba.njit(cache=True)
def servo_step_kernel(z, valid, x, P, u, started, prev_valid, window, rejects, integral, F, Q, h, r, mode, dt, steer, step_thr,
                      wakf_th, lam_min, lam_max, gamma, max_rejects, huber_c, kp, ki, dac_on, gain, step_V, half,
                      half_span, margin):
    """One second for N loops (state arrays updated in place); returns outputs (6, N)."""
    n_loops = z.shape[0]
    out = np.empty((6, n_loops))
    tmp = np.empty(6)
    for i in range(n_loops):
        _one(i, z[i], valid[i], x, P, u, started, prev_valid, window, rejects, integral, F, Q, h, r, mode, dt, steer, step_thr,
             wakf_th, lam_min, lam_max, gamma, max_rejects, huber_c, kp, ki, dac_on, gain, step_V, half, half_span,
             margin, tmp)
        for a in range(6):
            out[a, i] = tmp[a]
    return out


@numba.njit(cache=True)
def servo_step_packed(z, valid, x, P, u, started, prev_valid, window, rejects, integral, F, Q, h, p, out):
    """:func:`servo_step_kernel` for ONE loop with its scalars packed in ``p`` (float64, see
    :func:`pack_params`) and the six outputs written into ``out`` (6,): fewer arguments to pass, for the
    streaming step. Same arithmetic (the same per-loop function)."""
    _one(0, z, valid, x, P, u, started, prev_valid, window, rejects, integral, F, Q, h, p[0], int(p[1]), p[2], p[3],
         p[4], p[5], p[6], p[7], p[8], int(p[9]), p[10], p[11], p[12], p[13] != 0.0, p[14], p[15], p[16], p[17],
         p[18], out)


def pack_params(params: tuple) -> np.ndarray:
    """The scalar parameters of :func:`servo_step_kernel` (everything after ``h``) as one float64 array."""
    return np.array([float(v) for v in params], dtype=np.float64)


@numba.njit(cache=True)
def close_loop_kernel(free, ref, x, P, u, started, prev_valid, window, rejects, integral, F, Q, h, r, mode, dt, steer, step_thr,
                      wakf_th, lam_min, lam_max, gamma, max_rejects, huber_c, kp, ki, dac_on, gain, step_V, half,
                      half_span, margin):
    """The closed loop (module :mod:`.loop`) for (trials, steps); returns phase, offset and outputs (6, trials, steps)."""
    trials, steps = free.shape
    phase = np.empty((trials, steps))
    offset = np.empty((trials, steps))
    outs = np.empty((6, trials, steps))
    tmp = np.empty(6)
    for i in range(trials):
        c = 0.0
        for k in range(steps):
            xk = free[i, k] + c
            phase[i, k] = xk
            zk = xk - ref[i, k]
            vk = not math.isnan(zk)
            offset[i, k] = zk
            _one(i, zk, vk, x, P, u, started, prev_valid, window, rejects, integral, F, Q, h, r, mode, dt, steer, step_thr,
                 wakf_th, lam_min, lam_max, gamma, max_rejects, huber_c, kp, ki, dac_on, gain, step_V, half,
                 half_span, margin, tmp)
            for a in range(6):
                outs[a, i, k] = tmp[a]
            c = c + tmp[1] + dt * tmp[0]
    return phase, offset, outs


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
