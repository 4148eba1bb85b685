"""A numba kernel for the paper's chain's streaming step, beside its readable numpy twin.

:class:`FastRvcKfChain` (registered as ``rtt-rvc-kf-numba`` and, with its BP network, ``rtt-rvc-kf-bp-numba``)
is :class:`~chronofuse.sync.chain.RvcKfChain` in the calibrated URT mode (the configuration a node runs
in real time), its per-exchange core fused into one numba kernel: RVC (the paper's eq. 9 or its exact
form), URT compensation with the calibrated fixed part, the Kalman predict/update with ``H = [1 0 0]``
(the shared compiled kernel :mod:`chronofuse.estimation.kalman_kernel`), the nine residual inputs and the BP 9-32-1 forward
pass (eqs. 39-43) with the clip and warm-up. The numpy twin is ``RvcKfChain`` itself
(tests/sync/test_fast.py compares them); the kernel exists only because a Python step costs about 100 us
and the paper claims 1-2 us.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C
from chronofuse.estimation.kalman_kernel import predict, update
from chronofuse.sync.chain import RvcKfChain
from chronofuse.validation import InputError

__all__ = ["FastRvcKfChain"]


@numba.njit(cache=True)
def _kernel(x, P, s0, v0, k, t_i, t_b, t_r, v, tp_all, dt, Q, R, P0, exact, snr_feat, w1, b1, w2, b2, use_net,
            warmup, clip_ns):
    n = x.shape[0]
    x_out = x.copy()
    P_out = P.copy()
    s0_out = s0.copy()
    v0_out = v0.copy()
    est = np.empty(n)
    feat = np.empty(9)
    F = np.eye(3)
    F[0, 1] = dt
    hrow = np.array([1.0, 0.0, 0.0])
    work = np.empty(3 * 3 * 3 + 2 * 3)  # the Kalman kernel's scratch (kalman_kernel.work_size(3))
    for i in range(n):
        tp = tp_all[i] if tp_all.size > 1 else tp_all[0]
        if exact:
            eps_rvc = (C * (t_i[i] - t_r[i] + t_b[i]) + v[i] * (t_b[i] - t_i[i])) / (2.0 * C)
        else:
            eps_rvc = (C * (t_i[i] - t_r[i] + t_b[i]) + v[i] * t_b[i]) / (2.0 * C + v[i])
        alpha = -C / (2.0 * C + v[i])
        z = eps_rvc - alpha * tp
        if k == 0 or math.isnan(x[i, 0]):  # the first exchange that arrives starts the trial's filter
            x_out[i, 0] = z
            x_out[i, 1] = 0.0
            x_out[i, 2] = v[i]
            for a in range(3):
                for b in range(3):
                    P_out[i, a, b] = P0[a, b]
            s0_out[i] = C * (t_i[i] + t_r[i] - t_b[i]) / 2.0
            v0_out[i] = v[i]
        else:
            # x- = F x, P- = F P F' + Q (the shared compiled kernel), then the control x-[2] = v_doppler
            xi = x_out[i]
            Pi = P_out[i]
            predict(x[i], P[i], F, Q, xi, Pi, work)
            if not math.isnan(v[i]):
                xi[2] = v[i]  # B u with u = v_doppler - v
            if not math.isnan(z):
                update(xi, Pi, z, hrow, R, xi, Pi, work)  # H = [1 0 0], Joseph form
        e = x_out[i, 0]
        if use_net and k >= warmup:
            feat[0] = (z - e) * 1e9
            feat[1] = x_out[i, 1] * 1e9
            feat[2] = x_out[i, 2] / 1e3
            feat[3] = snr_feat
            feat[4] = (t_i[i] + t_r[i] - t_b[i]) / 2.0 * 1e3
            feat[5] = t_b[i] * 1e3
            feat[6] = s0_out[i] / 1e5
            feat[7] = v0_out[i] / 1e3
            feat[8] = tp * 1e8
            r = b2
            for h in range(w1.shape[0]):
                acc = b1[h]
                for j in range(9):
                    acc += w1[h, j] * feat[j]
                r += w2[h] * math.tanh(acc)
            e += min(max(r, -clip_ns), clip_ns) * 1e-9
        est[i] = e
    return x_out, P_out, s0_out, v0_out, est


class FastRvcKfChain(RvcKfChain):
    """The paper's chain (URT calibrated, optional BP network) through one numba kernel.

    Same configuration as :class:`RvcKfChain`; ``residual_model`` must be a BP network (window 1).
    """

    name = "rtt-rvc-kf-numba"

    def _check_params(self):
        super()._check_params()
        if self.config.urt_mode != "calibrated":
            raise InputError(f"{{urt_mode}} == {self.config.urt_mode!r}, must be 'calibrated' for the numba chain "
                             f"({self.name})", fields=("urt_mode",))
        net = self.residual_model
        if net is not None and (net.config.kind != "bp" or not hasattr(net, "_w1")):
            raise ValueError("residual_model must be a trained BP network for the numba chain")
        self.tp_ = np.atleast_1d(np.asarray(self.config.urt_s, dtype=np.float64))
        if net is None:
            self.w_ = (np.zeros((1, 9)), np.zeros(1), np.zeros(1), 0.0)
        else:
            self.w_ = (net._w1, net._b1, net._w2, net._b2)

    def init_state(self, trials):
        return {"x": np.zeros((trials, 3)), "P": np.zeros((trials, 3, 3)), "s0": np.zeros(trials),
                "v0": np.zeros(trials)}

    def update(self, state, sample):
        w1, b1, w2, b2 = self.w_
        cfg = self.config
        tp = self.tp_ if self.tp_.size == 1 or self.tp_.size == sample.t_i_s.size else self.tp_[:1]
        x, P, s0, v0, est = _kernel(
            state["x"], state["P"], state["s0"], state["v0"], sample.k, sample.t_i_s, sample.t_b_s, sample.t_r_s,
            sample.velocity_m_s, tp, float(self.interval_s), self.Q_, float(self.R_[0, 0]), self.P0_,
            cfg.light_time == "exact", (float(cfg.snr_db) - 12.0) / 8.0, w1, b1, w2, b2,
            self.residual_model is not None, int(self.warmup_steps_), float(cfg.clip_s) * 1e9)
        return {"x": x, "P": P, "s0": s0, "v0": v0}, est
