"""The swarm paper's metrics (its eqs. 47-51) on hand-computed cases, and a follower's time-error summary."""

import numpy as np
import pytest

from chronofuse.sync.metrics import convergence_epochs, overhead, rmse_s, robustness, running_rmse_s


def test_rmse_and_running_rmse_match_hand_computation():
    err = np.array([[3.0, 0.0, np.nan], [4.0, 0.0, 1.0]])
    assert rmse_s(err) == pytest.approx(np.sqrt((9 + 16 + 1) / 5))
    np.testing.assert_allclose(running_rmse_s(err), [np.sqrt(12.5), 0.0, 1.0])


def test_convergence_is_the_first_epoch_at_or_below_the_threshold():
    err = np.array([[5.0, 2.0, 0.5, 3.0, 0.1]])
    assert convergence_epochs(err, 1.0) == 2
    assert convergence_epochs(err, 1.0, start=3) == 1
    assert convergence_epochs(err, 0.01) is None


def test_robustness_and_overhead():
    nominal = np.ones((1, 4))
    stress = np.array([[1.0, 5.0, 3.0, 0.5]])
    r = robustness(nominal, stress, threshold_s=1.0, stress_end=1)
    assert r["delta_rmse_s"] == pytest.approx(np.sqrt((1 + 25 + 9 + 0.25) / 4) - 1.0)
    assert r["recovery_epochs"] == 2
    o = overhead(0.01)
    assert o == {"messages_per_s": 200.0, "bits_per_s": 38400.0}


def test_a_follower_s_white_time_error_has_normal_percentiles_and_passes_prtc_b():
    from chronofuse.sync.metrics import time_error_statistics

    sigma = 0.3e-9
    te = np.random.default_rng(7).normal(0.0, sigma, 20000)
    te[::97] = np.nan  # exchanges with no estimate are left out, not counted as zero
    s = time_error_statistics(te, rate_hz=10.0)
    assert s["rms_s"] == pytest.approx(sigma, rel=0.03)
    assert s["p50_abs_s"] == pytest.approx(0.6745 * sigma, rel=0.04)  # half-normal quantiles
    assert s["p95_abs_s"] == pytest.approx(1.9600 * sigma, rel=0.04)
    assert s["p99_abs_s"] == pytest.approx(2.5758 * sigma, rel=0.06)
    assert s["max_abs_s"] >= s["p99_abs_s"]
    # TDEV of white phase noise is sigma / sqrt(n) for n samples per averaging time.
    tau, tdev = np.array(s["tdev"]["tau_s"]), np.array(s["tdev"]["tdev_s"])
    short = (tau <= 10.0) & np.isfinite(tdev)  # a window with a missing sample has no TDEV (gap rule)
    assert short.sum() >= 5
    np.testing.assert_allclose(tdev[short], sigma / np.sqrt(tau[short] * 10.0), rtol=0.15)
    # 2000 s with gaps: every tau evaluated passes, and the taus the record cannot cover make TDEV incomplete
    assert s["mask"]["mtie_passed"] is True and s["mask"]["evaluated"] is True
    assert s["mask"]["tdev_status"] == "incomplete" and s["mask"]["tdev_passed"] is False


def test_a_follower_drifting_1_ns_per_second_fails_prtc_b_on_mtie_which_tdev_cannot_see():
    from chronofuse.sync.metrics import time_error_statistics

    t = np.arange(6000) / 10.0
    te = 1e-9 * t + np.random.default_rng(8).normal(0.0, 0.3e-9, t.size)
    s = time_error_statistics(te, rate_hz=10.0)
    mtie = dict(zip(s["mtie"]["tau_s"], s["mtie"]["mtie_s"]))
    assert max(mtie.values()) > 40e-9  # the ramp's 600 ns is far outside PRTC-B's 40 ns
    assert s["mask"]["mtie_passed"] is False and s["mask"]["evaluated"] is True
    assert s["mask"]["tdev_status"] != "fail"  # a second difference removes a constant drift
    assert time_error_statistics(te, rate_hz=10.0, mask=None).get("mask") is None


def test_a_time_error_record_with_fewer_than_four_samples_is_refused():
    from chronofuse.sync.metrics import time_error_statistics

    with pytest.raises(ValueError, match="te_s has fewer than 4"):
        time_error_statistics(np.array([1e-9, np.nan, 2e-9, np.nan, np.nan]), rate_hz=1.0)
