"""``doppler-kf``'s batch run as one numba loop, beside its numpy twin (:meth:`DopplerKf.update`).

The same arithmetic as the numpy path, exchange after exchange and trial after trial: the Kalman predict
and scalar update of the shared compiled kernel :mod:`chronofuse.estimation.kalman_kernel` (Joseph form, the
twin of :mod:`chronofuse.estimation.kalman`) with the chi-square gate, the URT
monitor's lagging filter, CUSUM and reference GLR (:mod:`chronofuse.sync.monitor`), and the node-state rules
(:mod:`chronofuse.sync.states`). The tests compare both paths on the same exchanges; the numpy path is
the readable one, this one exists because a sweep runs millions of exchanges (about 40x faster at 60
trials).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C
from chronofuse.estimation.kalman_kernel import innovation_variance, predict, update
from chronofuse.models.link_noise import DOPPLER_SIGMA_TABLE_HZ, SNR_TABLE_DB, TOA_SIGMA_TABLE_S

__all__ = ["run_doppler_kernel"]

_TOA_CODES = {"table": 0, "crb": 1, "none": 2}


@numba.njit(cache=True)
def _toa(snr, code, bw, snr_tab, toa_tab):
    if code == 2:
        return 0.0 if not math.isnan(snr) else math.nan
    if code == 0:
        return np.interp(snr, snr_tab, toa_tab)
    return 1.0 / (2.0 * math.pi * bw * math.sqrt(2.0 * 10.0 ** (snr / 10.0)))


@numba.njit(cache=True)
def _kernel(Z, ref, has_ref, Phi, Q, x0, P0, urt, cal, gate, settled_g, toa_code, bw, carrier, jitter, snr_tab, toa_tab,
            dop_tab, restart_after, mon_on, lag, PhiL, QL, ck, ch, clip, orun, settled, window, glr_thr, ref_sigma, lock_sigma, lock_hold,
            hold_after, dt):
    trials, steps, _ = Z.shape
    n = x0.size
    off = np.empty((trials, steps))
    sig = np.empty((trials, steps))
    code = np.empty((trials, steps), dtype=np.int64)
    x = np.empty(n)
    P = np.empty((n, n))
    h = np.empty(n)
    ring_e = np.empty(window)
    ring_w = np.empty(window)
    ring_t = np.empty(window)
    xd = np.empty(n)
    Pd = np.empty((n, n))
    hd = np.empty(n)
    ht = np.empty(n)
    xp = np.empty(n)
    Pp = np.empty((n, n))
    work = np.empty(3 * n * n + 2 * n)  # the Kalman kernel's scratch (kalman_kernel.work_size(n))
    lz = np.empty(lag)
    lc = np.empty(lag)
    lr = np.empty(lag)
    for i in range(trials):
        x[:] = x0
        P[:, :] = P0
        xd[:] = x0
        Pd[:, :] = P0
        started = False
        lz[:] = math.nan
        lc[:] = 0.0
        lr[:] = 1.0
        pos = 0.0
        neg = 0.0
        run = 0
        grun = 0
        lrun = 0
        alarm = False
        ring_e[:] = math.nan
        ring_w[:] = 0.0
        ring_t[:] = 0.0
        below = 0.0
        missed = 0
        st = 0
        tp = urt[i]
        cs = cal[i]
        for k in range(steps):
            t_i = Z[i, k, 0]
            t_b = Z[i, k, 1]
            t_r = Z[i, k, 2]
            vel = Z[i, k, 3]
            snr = Z[i, k, 4]
            alos = Z[i, k, 5]
            if k > 0:  # x- = Phi x, P- = Phi P Phi' + Q
                predict(x, P, Phi, Q, x, P, work)
            eps = x[0]
            z1 = (t_i - t_r + t_b) / 2.0
            known = -vel * (t_b - t_i) / (2.0 * C) + (t_i - eps) * alos / C
            z = z1 - known - (-(1.0 + vel / C) / 2.0) * tp
            c = (t_b + t_i - 2.0 * eps) / 2.0
            h[0] = 1.0
            for a in range(1, n):
                h[a] = c if not math.isnan(c) else 0.0
            toa = _toa(snr, toa_code, bw, snr_tab, toa_tab)
            sv = C * np.interp(snr, snr_tab, dop_tab) / (math.sqrt(2.0) * carrier)
            lever = (t_b - t_i) / (2.0 * C)
            r = (2.0 * toa * toa + jitter * jitter) / 4.0 + (sv * lever) ** 2
            hx = 0.0
            for a in range(n):
                hx += h[a] * x[a]
            y = z - hx
            hph = innovation_variance(P, h)
            s = hph + r
            finite = not (math.isnan(z) or math.isnan(r))
            gated = finite and hph < settled_g * r and (y * y / s > gate)  # the gate acts once settled
            if finite:
                grun = grun + 1 if gated else 0
            if grun >= restart_after:  # start again from the prior with this exchange
                grun = 0
                gated = False
                x[:] = x0
                P[:, :] = P0
            if finite and not gated:  # K = P h / s, x += K y, P = (I - K h') P (I - K h')' + K r K'
                update(x, P, z, h, r, x, P, work)
            sigma = math.sqrt(P[0, 0] + (cs * 0.5) ** 2)
            ref_e = x[0] - ref[i, k] if has_ref else math.nan
            if mon_on:
                zm = z if finite else math.nan
                cm = h[1] if n > 1 else 0.0
                if k >= lag:
                    # the lagging filter takes the measurement lag old, then predicts this exchange
                    if started:
                        predict(xd, Pd, Phi, Q, xd, Pd, work)
                    started = True
                    hd[0] = 1.0
                    for a in range(1, n):
                        hd[a] = lc[0]
                    yd = lz[0]
                    for a in range(n):
                        yd -= hd[a] * xd[a]
                    hphd = innovation_variance(Pd, hd)
                    sd = hphd + lr[0]
                    gd = (not math.isnan(yd)) and hphd < settled_g * lr[0] and yd * yd > gate * sd
                    if not math.isnan(yd):
                        lrun = lrun + 1 if gd else 0
                    if lrun >= restart_after:
                        lrun = 0
                        gd = False
                        xd[:] = x0
                        Pd[:, :] = P0
                    if (not math.isnan(lz[0])) and not gd:
                        update(xd, Pd, lz[0], hd, lr[0], xd, Pd, work)
                    predict(xd, Pd, PhiL, QL, xp, Pp, work)  # x_pred = Phi^lag xd, P_pred = Phi^lag Pd Phi^lag' + Q_lag
                    ht[0] = 1.0
                    for a in range(1, n):
                        ht[a] = cm
                    pv = innovation_variance(Pp, ht)
                    hx = 0.0
                    for a in range(n):
                        hx += ht[a] * xp[a]
                    var = pv + r
                    resid = zm - hx
                    if (not math.isnan(resid)) and (not math.isnan(var)) and pv < settled * r:
                        u = resid / math.sqrt(var)
                        if abs(u) <= clip:
                            pos = max(0.0, pos + u - ck)
                            neg = max(0.0, neg - u - ck)
                            run = 0
                        else:
                            sgn = 1 if u > 0 else -1
                            run = run + sgn if (run > 0) == (sgn > 0) and run != 0 else sgn
                for j in range(lag - 1):
                    lz[j] = lz[j + 1]
                    lc[j] = lc[j + 1]
                    lr[j] = lr[j + 1]
                lz[lag - 1] = zm
                lc[lag - 1] = cm if not math.isnan(cm) else 0.0
                lr[lag - 1] = r if not math.isnan(r) else 1.0
                if pos > ch or neg > ch or abs(run) >= orun:
                    alarm = True
                if has_ref and not math.isnan(ref_e):
                    var = P[0, 0] + 2.0 * ref_sigma * ref_sigma
                    for j in range(window - 1):
                        ring_e[j] = ring_e[j + 1]
                        ring_w[j] = ring_w[j + 1]
                        ring_t[j] = ring_t[j + 1]
                    ring_e[window - 1] = ref_e
                    ring_w[window - 1] = 1.0 / var
                    ring_t[window - 1] = k * dt
                    tw = 0.0  # totals over the window (the constant is projected out)
                    twe = 0.0
                    for j in range(window):
                        if not math.isnan(ring_e[j]):
                            tw += ring_w[j]
                            twe += ring_w[j] * ring_e[j]
                    sw = 0.0
                    swe = 0.0
                    swt = 0.0
                    swte = 0.0
                    swtt = 0.0
                    best = 0.0
                    for j in range(window - 1, -1, -1):  # onsets from the newest back
                        w = ring_w[j] if not math.isnan(ring_e[j]) else 0.0
                        e = ring_e[j] if w > 0.0 else 0.0
                        t = ring_t[j] - k * dt if w > 0.0 else 0.0
                        sw += w
                        swe += w * e
                        swt += w * t
                        swte += w * t * e
                        swtt += w * t * t
                        if w <= 0.0 or tw <= 0.0:
                            continue  # no residual stored here: not an onset
                        num = swe - sw / tw * twe
                        den = sw - sw * sw / tw
                        if den > 1e-300 * tw:
                            best = max(best, num * num / den)
                        gsum = swt - t * sw
                        num = (swte - t * swe) - gsum / tw * twe
                        den = (swtt - 2.0 * t * swt + t * t * sw) - gsum * gsum / tw
                        if den > 1e-300:
                            best = max(best, num * num / den)
                    if best > glr_thr:
                        alarm = True
            measured = finite and not gated
            missed = 0 if measured else missed + 1
            below = below + dt if (measured and sigma <= lock_sigma) else 0.0
            st = 1 if below >= lock_hold else 0
            if missed >= hold_after:
                st = 2
            if alarm:
                st = 3
            off[i, k] = x[0]
            sig[i, k] = sigma
            code[i, k] = st
    return off, sig, code


def run_doppler_kernel(kf, Z: np.ndarray, ref: np.ndarray | None):
    """``(offset_s, uncertainty_s, node_state)`` (trials, steps) of fitted ``kf`` (a DopplerKf) over ``Z``."""
    cfg = kf.config
    mon, stc = cfg.monitor, cfg.states
    trials = Z.shape[0]
    urt = np.ascontiguousarray(kf._per_trial(kf.urt_, trials), dtype=np.float64)
    cal = np.ascontiguousarray(kf._per_trial(kf.cal_sigma_, trials), dtype=np.float64)
    has_ref = ref is not None
    refa = np.ascontiguousarray(ref if has_ref else np.zeros((1, 1)), dtype=np.float64)
    return _kernel(np.ascontiguousarray(Z, dtype=np.float64), refa, has_ref, kf.Phi_, kf.Q_, kf.x0_, kf.P0_, urt, cal,
                   float(kf.gate_), float(cfg.gate_settled), _TOA_CODES[cfg.toa_model], float(cfg.rms_bandwidth_hz),
                   float(cfg.carrier_hz),
                   float(cfg.urt_jitter_s), SNR_TABLE_DB, TOA_SIGMA_TABLE_S, DOPPLER_SIGMA_TABLE_HZ,
                   int(cfg.restart_after), bool(mon.enabled),
                   int(mon.lag), kf.monitor_.PhiL, kf.monitor_.QL, float(mon.cusum_k), float(mon.cusum_h),
                   float(mon.clip), int(mon.outlier_run), float(mon.settled), int(mon.window), float(mon.glr_threshold),
                   float(mon.reference_sigma_s), float(stc.lock_sigma_s), float(stc.lock_hold_s),
                   int(stc.holdover_after), float(cfg.interval_s))
