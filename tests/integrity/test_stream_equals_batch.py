"""Streaming equals batch on the whole detection pipeline, not only stage by stage: the bytes of a recording read
whole by ``detect FILE``'s reader and batch driver, and fed in small chunks through ``detect -``'s live reader
and live driver, give every column of every epoch (time tags, status, repaired bias, clock resets, detector
input, threshold, degrees of freedom, over, state, latch events) bit for bit, with one documented exception.

The exception is the statistic ``T = |D v|^2``: the batch driver computes it for every window in one matrix
product, the live driver one window at a time, and the two sum in different orders. Their difference is
bounded by the rounding of the two sums (Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd ed.,
section 3.1: a sum of n products is within ``gamma_n = n u / (1 - n u)`` of its exact value in units of
``sum |a_i b_i|``, ``u = 2**-53``): with ``w = D v`` and ``m = |D| |v|``, each of the two ``T`` is within
``gamma_n (2 sum |w_i| m_i + sum w_i^2) + O(u^2)`` of the exact one, so they are within twice that of each
other. The test holds every epoch to that bound (under 1e-12 of the threshold; the differences seen are about
1e-15 of ``T``, a few units in the last place), and the verdicts to equality.
"""

from __future__ import annotations

import numpy as np
import pytest

from chronofuse.integrity.live import StreamDetection
from chronofuse.integrity.watch import DetectionSettings, watch_record
from chronofuse.io.clockbias import read_clock_bias

from _recordings import SIMULATED  # noqa: E402

EXACT = ("t_ns", "valid", "clock_bias_s", "status", "gated_bias_s", "repaired_bias_s", "clock_reset_s",
         "detector_input_s", "threshold", "dof", "over", "state", "latch_event")


def _bound(x: np.ndarray, dof: np.ndarray, whitener: np.ndarray, interval_s: float) -> np.ndarray:
    """The rounding bound of the module docstring for every epoch's statistic (NaN where untested)."""
    n = whitener.shape[0]
    df = np.full(x.size, np.nan)
    df[2:] = (x[2:] - 2.0 * x[1:-1] + x[:-2]) / interval_s
    out = np.full(x.size, np.nan)
    for k in np.flatnonzero(dof > 0):
        d = int(dof[k])
        v = df[k - d + 1:k + 1]
        block = whitener[:d, :d]
        w = block @ v
        m = np.abs(block) @ np.abs(v)
        gamma = n * 2.0**-53 / (1 - n * 2.0**-53)
        out[k] = 2.0 * gamma * (2.0 * np.sum(np.abs(w) * m) + np.sum(w * w))
    return out


@pytest.mark.parametrize("name", sorted(SIMULATED))
@pytest.mark.parametrize("settings", [DetectionSettings(train_s=300.0),
                                      DetectionSettings(h0=2e-18, hm2=1e-22, sigma_rho_m=1.0, window=7)],
                         ids=["trained", "given model, window 7"])
def test_the_live_path_gives_the_batch_paths_columns(name, settings, tmp_path):
    data = SIMULATED[name]()
    path = tmp_path / f"{name}.ubx"
    path.write_bytes(data)
    batch = watch_record(read_clock_bias(path), settings)
    run = StreamDetection((data[i:i + 333] for i in range(0, len(data), 333)), settings, source=str(path))
    list(run)
    live = run.clocks[None].watch.result()
    b, s = batch.result, live.result
    assert live.fitted == batch.fitted and np.array_equal(live.training, batch.training)
    for column in EXACT:
        got, want = np.asarray(s[column]), np.asarray(b[column])
        if want.dtype.kind == "f":
            assert np.array_equal(got, want, equal_nan=True), column
        else:
            assert got.tolist() == want.tolist(), column
    stat_b, stat_s = np.asarray(b["statistic"], float), np.asarray(s["statistic"], float)
    assert np.array_equal(np.isnan(stat_b), np.isnan(stat_s))
    bound = _bound(np.asarray(b["detector_input_s"], float), np.asarray(b["dof"]), batch.detector.whitener_,
                   batch.interval_s)
    tested = ~np.isnan(stat_b)
    assert tested.sum() > 500
    assert np.all(np.abs(stat_b - stat_s)[tested] <= bound[tested]), np.nanmax(np.abs(stat_b - stat_s) / bound)
    # the bound means something: under 1e-12 of the threshold (the differences seen are about 1e-15 of T)
    assert np.max(bound[tested] / np.asarray(b["threshold"], float)[tested]) < 1e-12
