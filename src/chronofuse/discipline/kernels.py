"""Numba kernels of the fusion and the state machine: the fast path beside their readable numpy twins.

The servos' kernels are each servo's own (one backend per module, :mod:`.servo_kernel` for what they
share); these two are the per-second loops of :mod:`.fusion` and :mod:`.states`, tested against the numpy
twins there.
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: The plausibility clip's prediction (:meth:`~.plausibility.DragMonitor._clip`): the last ``CLIP_BLOCK_S``
#: seconds' block mean and the frequency to it from the block ``CLIP_LAG_S`` seconds before.
CLIP_BLOCK_S = 8
CLIP_LAG_S = 16
#: What the clip may hide on each side: ``CLIP_MAX`` limits of excess (beyond the limit) in any
#: ``CLIP_SPACING_S`` seconds, a bucket refilled at ``CLIP_MAX / CLIP_SPACING_S`` limits a second (module
#: docstring there).
CLIP_MAX = 10.0
CLIP_SPACING_S = 64
#: The shortest refusing horizon (s) after which the loop holds over on the plausibility test's prediction: an
#: excursion refused only at 64 s or longer was slow enough for the servo to learn its frequency; a faster one
#: (a step, a pulse train, a fast drag) is refused before it could, and the servo's own holdover is better there.
PREDICTION_HOLD_W = 64

__all__ = ["fusion_kernel", "states_kernel", "plausibility_kernel"]


@numba.njit(cache=True)
def fusion_kernel(z, usable, selection, alpha, initial_var, floor_var, fresh):
    """Online inverse-variance fusion (:mod:`.fusion`) over (trials, receivers, steps); ``fresh`` (same shape):
    a receiver's variance estimate restarts that second (its weight earned anew); returns
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
                if fresh[i, j, k]:
                    ms[j] = np.nan
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
def states_kernel(usable, alarm, implausible, near, offset, freq_adj, ref_var, unresolved, params):
    """The state machine (:mod:`.states`, :func:`~.states.advance`) over (trials, steps), ``params`` from
    :meth:`~.states.StateConfig.kernel_params`; returns state and reason (int8), filtered offset, holdover
    ready (int8) and holdover sigma, each (trials, steps). Codes: FREE_RUN 0, ACQUIRING 1, LOCKED 2,
    HOLDOVER 3, RECOVERY 4, ALARM 5; reasons NONE 0, REFERENCE_USABLE 1, REFERENCE_LOST 2, LOCK_ACHIEVED 3,
    INTEGRITY_ALARM 4, TIME_ERROR_EXCURSION 5, FREQUENCY_EXCURSION 6, DAC_RAIL 7, IMPLAUSIBLE_REFERENCE 8,
    UNRESOLVED_OFFSET 9."""
    limit, hold, a_te, f_thr, a_u, ready, model_var, horizon = (params[0], params[1], params[2], params[3],
                                                                 params[4], params[5], params[6], params[7])
    threshold, k_sigma = params[8], params[9]
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
        s1 = np.nan
        s2 = np.nan
        far = False
        u_f = np.nan
        u_var = 0.0
        for k in range(steps):
            z = offset[i, k]
            ok = usable[i, k] and not alarm[i, k] and not implausible[i, k] and math.isfinite(z)
            if ok:
                level = 2.0 * s1 - s2
                big = math.isfinite(level) and abs(z - level) > threshold
                if not math.isfinite(level) or (big and far):
                    s1 = z
                    s2 = z
                else:
                    z_in = level + min(max(z - level, -threshold), threshold) if big else z
                    s1 = s1 + a_te * (z_in - s1)
                    s2 = s2 + a_te * (s1 - s2)
                far = big
            else:
                s1 = np.nan
                s2 = np.nan
                far = False
            te_f = 2.0 * s1 - s2
            u = freq_adj[i, k]
            if math.isfinite(u_f):
                dev = u - u_f
                u_var = (1.0 - a_u) * u_var + a_u * dev * dev
                u_f = u_f + a_u * dev
            else:  # the first correction, or the first after an unknown one: no deviation (unknown if u is)
                dev = u - u
                u_var = 0.0
                u_f = u
            v = ref_var[i, k]
            noise = k_sigma * math.sqrt(v) if math.isfinite(v) and v >= 0.0 else 0.0
            bare = min(limit, threshold - noise)
            lim = min(bare, threshold - noise - unresolved[i, k])
            te_ok = ok and abs(te_f) < lim
            f_ok = abs(dev) < f_thr
            settled = ok and te_ok and f_ok and not near[i, k]
            run = run + 1 if settled else 0
            lost = 8 if implausible[i, k] else (4 if alarm[i, k] else 2)
            broken = 7 if near[i, k] else ((9 if ok and abs(te_f) < bare else 5) if not te_ok else 6)
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
            elif (s == 1 or s == 4) and ok and lim <= 0.0 and unresolved[i, k] > 0.0:
                new, why = 5, 9
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


@numba.njit(cache=True)
def _block(csum, tsum, count, start, end, m, L):
    """Block mean over (end - m, end] of one series' cumulative rings, and the mean time of the samples in
    it (NaN, NaN: too early or half missing)."""
    if end - m < start - 1 or end - m < -1:
        return np.nan, np.nan
    c1 = csum[end % L]
    t1 = tsum[end % L]
    n1 = count[end % L]
    c0 = 0.0
    t0 = 0.0
    n0 = 0
    if end - m >= 0:
        c0 = csum[(end - m) % L]
        t0 = tsum[(end - m) % L]
        n0 = count[(end - m) % L]
    n = n1 - n0
    if n <= 0 or 2 * n < m:
        return np.nan, np.nan
    return (c1 - c0) / n, (t1 - t0) / n


@numba.njit(cache=True)
def _anchor(csum, tsum, count, start, end, m, horizons, L):
    """The holdover prediction's anchor (:meth:`~.plausibility.DragMonitor._anchor`): the ``m``-second block mean
    ending at ``end``, the frequency to it from the longest horizon's block before it, the block's centre and
    that frequency's span."""
    b1, c1 = _block(csum, tsum, count, start, end, m, L)
    f = np.nan
    span = 0
    for j in range(horizons.size - 1, -1, -1):
        wl = horizons[j]
        b0, c0 = _block(csum, tsum, count, start, end - wl, max(1, wl // 4), L)
        if math.isnan(f) and math.isfinite(b0):
            f = (b1 - b0) / (c1 - c0)
            span = wl
    if math.isnan(f):
        f = 0.0
    return b1, f, c1, max(span, 1)


@numba.njit(cache=True)
def _stored_block(bh, th, j, end, m, start, L):
    """:func:`_block` of horizon ``j``'s block ending at ``end``, as computed at second ``end`` and stored in the
    rings ``bh``, ``th``: the same numbers (the cumulative rings it read are not yet overwritten, and a block that
    passed the history's ``start`` then passes a later one only if it passes it now, the check made here)."""
    if end < 0 or end - m < start - 1:
        return np.nan, np.nan
    return bh[j, end % L], th[j, end % L]


@numba.njit(cache=True)
def _avar(h0, hm1, hm2, tau):
    return h0 / (2.0 * tau) + 2.0 * math.log(2.0) * hm1 + 2.0 * math.pi**2 / 3.0 * hm2 * tau


@numba.njit(cache=True)
def plausibility_kernel(y, admitted, horizons, thresholds, lever_var, block_var, gm_sigma, gm_tau, recent_var,
                        scalars):
    """The drag monitor (:mod:`.plausibility`, :meth:`~.plausibility.DragMonitor.update`) over (series, steps);
    returns plausible (int8), readmitted (int8), the statistic, the unresolved offset's bound, the holdover
    prediction while refused (NaN while trusted) and the bound a series came back from a gap with (NaN but on
    that second), each (series, steps)."""
    h0, hm1, hm2, drift, k_sigma = scalars[0], scalars[1], scalars[2], scalars[3], scalars[4]
    persist, readmit_s, ms, L = int(scalars[5]), int(scalars[6]), int(scalars[7]), int(scalars[8])
    check_var, readmit_k, recheck_gap, watch_s = scalars[9], scalars[10], int(scalars[11]), int(scalars[12])
    clip, clip_near, clip_var_f = scalars[13] != 0.0, scalars[14], scalars[15]
    n_series, steps = y.shape
    nh = horizons.size
    plausible = np.empty((n_series, steps), dtype=np.int8)
    readmitted = np.zeros((n_series, steps), dtype=np.int8)
    stat = np.empty((n_series, steps))
    unresolved_out = np.empty((n_series, steps))
    predicted_out = np.empty((n_series, steps))
    return_out = np.full((n_series, steps), np.nan)
    csum = np.zeros(L)
    tsum = np.zeros(L)
    count = np.zeros(L, dtype=np.int64)
    # Each horizon's latest block mean and mean time by second: the blocks at k - W and k - 2 W are the ones this
    # horizon computed W and 2 W seconds ago (the ring holds 4 W_max + 2 seconds).
    bh = np.empty((nh, L))
    th = np.empty((nh, L))
    for i in range(n_series):
        csum[:] = 0.0
        tsum[:] = 0.0
        count[:] = 0
        start = 0
        trusted = True
        streak = 0
        agree = 0
        anchor = 0.0
        anchor_f = 0.0
        anchor_t = 0.0
        anchor_w = 1
        anchor_j = -1
        anchor_m = 1
        last = -1
        origin = -1
        watch = -1
        gap_anchor = np.nan
        gap_f = 0.0
        gap_t = 0.0
        gap_w = 1
        clip_run = 0
        clip_off = 0
        clip_hi = CLIP_MAX
        clip_lo = CLIP_MAX
        waited = 0
        unresolved = 0.0
        for k in range(steps):
            have = admitted[i, k] and math.isfinite(y[i, k])
            yk = y[i, k]
            clip_hi = min(CLIP_MAX, clip_hi + CLIP_MAX / CLIP_SPACING_S)
            clip_lo = min(CLIP_MAX, clip_lo + CLIP_MAX / CLIP_SPACING_S)
            if clip and have:  # the sample as the test takes it (numpy twin: DragMonitor._clip)
                b1, t1 = _block(csum, tsum, count, start, k - 1, CLIP_BLOCK_S, L)
                b0, t0 = _block(csum, tsum, count, start, k - 1 - CLIP_LAG_S, CLIP_BLOCK_S, L)
                if math.isfinite(b1) and math.isfinite(b0) and k >= clip_off:
                    h = k - t1
                    pred = b1 + (b1 - b0) / (t1 - t0) * h
                    lim = (k_sigma * math.sqrt(clip_near + h * h * clip_var_f + 2.0 * h * h * _avar(h0, hm1, hm2, h))
                           + drift * h * h)
                    if yk - pred > lim:
                        clip_run = max(clip_run, 0) + 1
                    elif pred - yk > lim:
                        clip_run = min(clip_run, 0) - 1
                    else:
                        clip_run = 0
                    if abs(clip_run) >= persist:
                        clip_off = k + CLIP_BLOCK_S + CLIP_LAG_S
                        clip_run = 0
                    elif clip_run > 0 and (yk - pred) / lim - 1.0 <= clip_hi:
                        clip_hi -= (yk - pred) / lim - 1.0
                        yk = pred + lim
                    elif clip_run < 0 and (pred - yk) / lim - 1.0 <= clip_lo:
                        clip_lo -= (pred - yk) / lim - 1.0
                        yk = pred - lim
                else:
                    clip_run = 0
            c_prev = csum[(k - 1) % L] if k > 0 else 0.0
            n_prev = count[(k - 1) % L] if k > 0 else 0
            t_prev = tsum[(k - 1) % L] if k > 0 else 0.0
            csum[k % L] = c_prev + (yk if have else 0.0)
            tsum[k % L] = t_prev + (float(k) if have else 0.0)
            count[k % L] = n_prev + (1 if have else 0)
            worst = np.nan
            first_w = 0
            for j in range(nh):
                w = horizons[j]
                m = max(1, w // 4)
                b0, t0 = _block(csum, tsum, count, start, k, m, L)
                bh[j, k % L] = b0
                th[j, k % L] = t0
                b1, t1 = _stored_block(bh, th, j, k - w, m, start, L)
                b2, t2 = _stored_block(bh, th, j, k - 2 * w, m, start, L)
                ratio = abs(b0 - b1 - (b1 - b2) * (t0 - t1) / (t1 - t2)) / thresholds[j]
                if math.isfinite(ratio):
                    if not math.isfinite(worst) or ratio > worst:
                        worst = ratio
                    if ratio > 1.0:
                        first_w = w
            if have:
                streak = streak + 1 if (trusted and first_w > 0) else 0
            refuse = trusted and streak >= persist
            if refuse:
                w = first_w
                m = max(1, w // 4)
                anchor, anchor_f, anchor_t, anchor_w = _anchor(csum, tsum, count, start, k - 2 * w, m, horizons, L)
                anchor_m = m
            if not have and last == k - 1:  # the samples stop: the gap's anchor, from the history before it
                gap_anchor, gap_f, gap_t, gap_w = _anchor(csum, tsum, count, start, k - 1, ms, horizons, L)
            back = (have and trusted and not refuse and last >= 0 and k - last - 1 >= recheck_gap
                    and math.isfinite(gap_anchor))
            if back:
                anchor, anchor_f, anchor_t, anchor_w, anchor_m = gap_anchor, gap_f, gap_t, gap_w, ms
                watch = 0
            elif refuse:
                watch = -1
            anchor_j = -1
            for j in range(nh):
                if horizons[j] == anchor_w:
                    anchor_j = j
            watched = trusted and not refuse and watch >= 0
            refused = not trusted
            judged = False
            agree_now = False
            strayed = False
            first = False
            first_bound = 0.0
            hidden = 0.0
            readmit_bound = 0.0
            if refused or watched:  # the comparison with the holdover prediction: while refused, or watched
                bs, ts = _block(csum, tsum, count, start, k, ms, L)
                h = ts - anchor_t if math.isfinite(ts) else k - (ms - 1) / 2.0 - anchor_t
                wa = float(anchor_w)
                he = max(h, wa)
                h1 = max(h, 1.0)
                lever = lever_var[anchor_j] if anchor_j >= 0 else 0.0
                ablock = check_var if anchor_m == ms else 0.0
                for j in range(nh):
                    if max(1, horizons[j] // 4) == anchor_m:
                        ablock = block_var[j]
                var = (2.0 * h1 * h1 * _avar(h0, hm1, hm2, h1) + h1 * h1 * _avar(h0, hm1, hm2, wa) + check_var + ablock
                       + lever * (h1 / wa) ** 2)
                aging = drift * he * he
                judged = have and math.isfinite(bs)
                miss = abs(bs - (anchor + anchor_f * h))
                agree_now = judged and miss < readmit_k * math.sqrt(var) + aging
                strayed = judged and not miss < k_sigma * math.sqrt(var) + aging
                readmit_bound = miss + readmit_k * math.sqrt(var) + aging
                if judged:  # the frequency since the anchor (numpy twin)
                    for j in range(nh - 1, -1, -1):
                        w = horizons[j]
                        m = max(1, w // 4)
                        b1, t1 = _block(csum, tsum, count, start, k, m, L)
                        b0, t0 = _block(csum, tsum, count, start, k - w, m, L)
                        if math.isfinite(b1) and math.isfinite(b0) and t0 > origin:
                            f = (b1 - b0) / (t1 - t0)
                            var_f = (3.0 * _avar(h0, hm1, hm2, max(h, float(w))) + 2.0 * block_var[j] / (w * w)
                                     + _avar(h0, hm1, hm2, wa) + (lever / (wa * wa) if wa > 1 else 0.0))
                            f_miss = abs(f - anchor_f)
                            f_aging = drift * (max(h, 0.0) + w)
                            if f_miss > k_sigma * math.sqrt(var_f) + f_aging:
                                strayed = True
                            if f_miss >= readmit_k * math.sqrt(var_f) + f_aging:
                                agree_now = False
                            break
                if watched and watch == 0 and have:  # the first clear agreement, from one sample on
                    lo = max(k - ms, start - 1)
                    c0 = csum[lo % L] if lo >= 0 else 0.0
                    t0 = tsum[lo % L] if lo >= 0 else 0.0
                    n0 = count[lo % L] if lo >= 0 else 0
                    n = count[k % L] - n0
                    if n > 0:
                        bp = (csum[k % L] - c0) / n
                        hp = (tsum[k % L] - t0) / n - anchor_t
                        hp1 = max(hp, 1.0)
                        var_p = (2.0 * hp1 * hp1 * _avar(h0, hm1, hm2, hp1) + hp1 * hp1 * _avar(h0, hm1, hm2, wa)
                                 + recent_var[n] + ablock + lever * (hp1 / wa) ** 2)
                        tolerance = readmit_k * math.sqrt(max(var_p, 0.0)) + drift * max(hp, wa) ** 2
                        p_miss = abs(bp - (anchor + anchor_f * hp))
                        first = p_miss < tolerance
                        first_bound = p_miss + tolerance
                        alone = (2.0 * hp1 * hp1 * _avar(h0, hm1, hm2, hp1) + hp1 * hp1 * _avar(h0, hm1, hm2, wa)
                                 + ablock + lever * (hp1 / wa) ** 2)
                        hidden = readmit_k * math.sqrt(max(alone, 0.0)) + drift * max(hp, wa) ** 2
            if watched and strayed:
                refuse = True
                watch = -1
            elif first:
                watch = 1
            elif watched and judged and watch > 0:
                watch += 1
            if refuse or back:  # the frequency is measured from here on (numpy twin)
                origin = k
            if watch >= watch_s:
                watch = -1
            if not refused:
                agree = 0
            elif judged:
                agree = agree + 1 if agree_now else 0
            readmit = refused and agree >= max(readmit_s, 4 * anchor_m)
            if back:  # let back in only once the tolerance covers the miss: a bound, not a resolution (numpy twin)
                waited = 0
            if first and waited > 0:
                unresolved += first_bound
            elif first:
                return_out[i, k] = hidden
            if readmit:
                unresolved += readmit_bound
            if watched and watch == 0 and have and not first:
                waited += 1
            if readmit:  # history cleared: watched against the refusal's prediction (numpy twin)
                start = k + 1
                watch = 1
            trusted = (trusted and not refuse) or readmit
            if refuse or readmit:
                streak = 0
            if readmit:
                agree = 0
            if have:
                last = k
            # Back from a gap, the series is not trusted until its first samples agree with the prediction.
            plausible[i, k] = 1 if (trusted and watch != 0) else 0
            readmitted[i, k] = 1 if readmit else 0
            stat[i, k] = worst
            unresolved_out[i, k] = unresolved
            known = (not trusted and anchor_w >= horizons[nh - 1] // 2  # numpy twin: DragMonitor.predicted
                     and 4 * anchor_m >= PREDICTION_HOLD_W)
            predicted_out[i, k] = anchor + anchor_f * (k - anchor_t) if known else np.nan
    return plausible, readmitted, stat, unresolved_out, predicted_out, return_out
