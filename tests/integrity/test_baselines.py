"""Baseline detectors: single-epoch threshold, CUSUM, reference clock."""

import math

import numpy as np
import pytest
from scipy import stats

from chronofuse.estimation.interface import Estimator, compare_streaming_to_batch, pick_inputs
from chronofuse.integrity.baselines import (
    CusumDetector,
    ReferenceClockDetector,
    SingleEpochDetector,
    cusum_kernel,
    cusum_reference,
)
from chronofuse.integrity.detector import HodDetector
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias

NOISE = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=1.0)
KNOWN = dict(h0=NOISE.h0, hm2=NOISE.hm2, sigma_rho_m=NOISE.sigma_rho_m)
SIGMA_REF_S = 1e-9


def _data(steps=3000, trials=40, seed=1):
    sim = simulate_clock_bias(NOISE, interval_s=1.0, steps=steps, trials=trials, seed=seed)
    rng = np.random.default_rng(seed + 100)
    reference = sim.truth_s + SIGMA_REF_S * rng.standard_normal(sim.truth_s.shape)
    return sim, reference


def _reference_detector(pfa=1e-3, window=20):
    sigma = math.hypot(NOISE.sigma_rho_m / 299_792_458.0, SIGMA_REF_S)
    return ReferenceClockDetector(interval_s=1.0, window=window, pfa=pfa, sigma_s=sigma, offset_s=0.0).fit()


def test_single_epoch_detector_equals_the_hod_test_with_a_window_of_one():
    sim, _ = _data(steps=2000, trials=5)
    single = SingleEpochDetector(interval_s=1.0, pfa=1e-2, **KNOWN).fit().run(sim.measured_s)
    hod = HodDetector(interval_s=1.0, window=1, pfa=1e-2, **KNOWN).fit().run(sim.measured_s)
    np.testing.assert_array_equal(single.alarm, hod.alarm)
    np.testing.assert_allclose(single.statistic**2, hod.statistic, rtol=1e-12, equal_nan=True)
    assert np.nanmax(single.threshold) == pytest.approx(stats.norm.isf(0.005))


def test_cusum_numba_kernel_matches_its_python_twin():
    rng = np.random.default_rng(4)
    e = rng.standard_normal((3, 500)) + 0.3
    e[1, 100:103] = np.nan
    np.testing.assert_allclose(cusum_kernel(e, 0.5), cusum_reference(e, 0.5), rtol=0, atol=1e-12, equal_nan=True)


def test_hod_innovations_are_unit_normal_under_h0():
    sim, _ = _data(steps=3000, trials=20)
    e = HodDetector(interval_s=1.0, **KNOWN).fit().innovations(sim.measured_s)[:, 50:]
    assert np.mean(e) == pytest.approx(0.0, abs=0.02)
    assert np.var(e) == pytest.approx(1.0, abs=0.03)


def _every_detector():
    return {
        "hod": HodDetector(interval_s=1.0, window=10, **KNOWN).fit(),
        "single": SingleEpochDetector(interval_s=1.0, **KNOWN).fit(),
        "cusum": CusumDetector(interval_s=1.0, calibration_steps=20_000, **KNOWN).fit(),
        "reference": _reference_detector(),
    }


@pytest.mark.parametrize("name", ["hod", "single", "cusum", "reference"])
def test_every_detector_streams_the_same_numbers_as_its_batch_run_through_the_shared_interface(name):
    sim, reference = _data(steps=400, trials=2, seed=9)
    x = inject(sim.measured_s, Anomaly("step", 250.0, offset_s=8e-8), 1.0)
    x[0, 120] = np.nan
    x[1, 300:303] = np.nan
    reference[1, 50] = np.nan
    det = _every_detector()[name]
    assert isinstance(det, Estimator)
    inputs = pick_inputs(det, reference_s=reference)  # the reference reading only where declared
    assert list(inputs) == (["reference_s"] if name == "reference" else [])
    assert compare_streaming_to_batch(det, x, rtol=1e-9, **inputs) == []
    res = det.run(x, **inputs)
    assert res.alarm[:, 250:].any() and res.n_skipped == 4 + (name == "reference")
    with pytest.raises(ValueError, match="read-only"):
        res.alarm[0, 0] = True


@pytest.mark.parametrize("pfa", [1e-1, 1e-2])
def test_baselines_false_alarm_rate_is_near_nominal(pfa):
    sim, reference = _data(steps=5000, trials=40, seed=12)
    test = np.arange(100, 5000, 22)  # independent epochs for the single-epoch and reference tests
    single = SingleEpochDetector(interval_s=1.0, pfa=pfa, **KNOWN).fit().run(sim.measured_s).alarm[:, test]
    ref = _reference_detector(pfa).run(sim.measured_s, reference).alarm[:, test]
    for alarm in (single, ref):
        k, n = int(alarm.sum()), alarm.size
        assert stats.binom.ppf(0.005, n, pfa) <= k <= stats.binom.ppf(0.995, n, pfa)
    # CUSUM alarms are strongly correlated in time: check the per-epoch rate within 25 %
    cusum = CusumDetector(interval_s=1.0, pfa=pfa, calibration_steps=200_000, **KNOWN).fit()
    rate = cusum.run(sim.measured_s).alarm[:, 100:].mean()
    assert rate == pytest.approx(pfa, rel=0.25)


def test_reference_clock_detector_learns_offset_and_spread_and_catches_a_small_ramp():
    sim, reference = _data(steps=2000, trials=20, seed=15)
    offset = 3e-7
    det = ReferenceClockDetector(interval_s=1.0, window=20, pfa=1e-3).fit(sim.measured_s[:2] + offset, reference[:2])
    expected_sigma = math.hypot(NOISE.sigma_rho_m / 299_792_458.0, SIGMA_REF_S)
    assert det.offset_s_ == pytest.approx(offset, abs=1e-10)
    assert det.sigma_s_ == pytest.approx(expected_sigma, rel=0.05)
    y = inject(sim.measured_s + offset, Anomaly("ramp", 1000.0, rate_s_per_s=1e-10), 1.0)
    first = det.run(y, reference).first_alarm(1000)
    assert (first >= 0).all() and np.median(first - 1000) < 60
    with pytest.raises(ValueError, match="shape"):
        det.run(y, reference[:, :10])
