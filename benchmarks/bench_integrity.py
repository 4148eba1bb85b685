"""HOD detector speed: batch epochs per second (n = 20) and streaming step time, against a direct loop.

The baseline is the obvious implementation timed in the same process: for every epoch, solve the
whitening triangular system of its window (``scipy.linalg.solve_triangular`` with the Cholesky factor
of ``C``) and sum the squares. It is timed on a slice of the record and scaled to the full length.
"""

from __future__ import annotations

import numpy as np
from scipy import linalg

from chronofuse.integrity.detector import HodDetector, high_order_difference
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias

from _timing import best_of

WINDOW = 20
NOISE = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=1.0)


def _direct_loop(det: HodDetector, x: np.ndarray) -> np.ndarray:
    """Baseline: per-window triangular solve (full windows only)."""
    chol = linalg.inv(det.whitener_)  # L, since whitener_ = L^-1
    df = high_order_difference(x, det.interval_s)
    out = np.full(x.size, np.nan)
    for k in range(WINDOW + 1, x.size):
        w = linalg.solve_triangular(chol, df[k - WINDOW + 1 : k + 1], lower=True, check_finite=False)
        out[k] = w @ w
    return out


def run(quick: bool = False) -> list[dict]:
    det = HodDetector(interval_s=1.0, window=WINDOW, h0=NOISE.h0, hm2=NOISE.hm2, sigma_rho_m=NOISE.sigma_rho_m).fit()
    n_batch = 200_000 if quick else 2_000_000
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=n_batch, trials=1, seed=1).measured_s[0]
    det.run(x[:1000])
    ours = best_of(lambda: det.run(x), 2 if quick else 3)
    n_base = 5_000 if quick else 20_000
    base_part = best_of(lambda: _direct_loop(det, x[:n_base]), 1)
    base = base_part * n_batch / n_base
    # the two agree
    np.testing.assert_allclose(det.run(x[:n_base]).statistic[WINDOW + 1 :], _direct_loop(det, x[:n_base])[WINDOW + 1 :],
                               rtol=1e-8)
    rate = n_batch / ours
    rows = [{
        "name": f"hod batch run, n={WINDOW}, {n_batch:,} epochs",
        "ours_s": ours,
        "baseline": "per-window solve_triangular loop (scaled from a slice)",
        "baseline_s": base,
        "ratio": base / ours,
        "target": ">= 1e6 epochs/s",
        "passed": bool(rate >= 1e6),
        "note": f"{rate:,.0f} epochs/s",
    }]

    n_step = 5_000 if quick else 20_000
    xs = x[:n_step].tolist()

    def stream():
        det.reset()
        step = det.step
        for v in xs:
            step(v)

    chol = linalg.inv(det.whitener_)

    def stream_direct():
        buf = []
        prev = [np.nan, np.nan]
        for v in xs:
            d = (v - 2 * prev[0] + prev[1])
            prev = [v, prev[0]]
            if np.isnan(d):
                continue
            buf = (buf + [d])[-WINDOW:]
            k = len(buf)
            w = linalg.solve_triangular(chol[:k, :k], np.array(buf), lower=True, check_finite=False)
            float(w @ w)

    per_step = best_of(stream, 3) / n_step
    per_step_base = best_of(stream_direct, 1) / n_step
    rows.append({
        "name": f"hod streaming step, n={WINDOW}",
        "ours_s": per_step,
        "baseline": "per-step solve_triangular on a list window",
        "baseline_s": per_step_base,
        "ratio": per_step_base / per_step,
        "target": "< 20 us per step",
        "passed": bool(per_step < 20e-6),
        "note": f"{per_step * 1e6:.2f} us/step",
    })

    from chronofuse.integrity.streaming import StreamingMonitor

    monitor = StreamingMonitor(det)

    def monitor_stream():
        monitor.reset()
        step = monitor.step
        for k, v in enumerate(xs):
            step(k, v)

    per_epoch = best_of(monitor_stream, 3) / n_step
    rows.append({
        "name": f"streaming monitor step (clock resets, latch, HOD step), n={WINDOW}",
        "ours_s": per_epoch,
        "baseline": "per-step solve_triangular on a list window",
        "baseline_s": per_step_base,
        "ratio": per_step_base / per_epoch,
        "target": "< 20 us per step",
        "passed": bool(per_epoch < 20e-6),
        "note": f"{per_epoch * 1e6:.2f} us/step",
    })
    return rows


if __name__ == "__main__":
    import sys

    for row in run(quick="--quick" in sys.argv):
        print(row)
