"""The linear Kalman filter on the interface: batch equals streaming, equals filterpy, never mutates."""

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter as FilterpyKF

from chronofuse.estimation.filter import KalmanFilter
from chronofuse.estimation.interface import Estimator, compare_streaming_to_batch
from chronofuse.estimation.process import ClockProcess
from chronofuse.models.clock import two_state_clock_phase_s

CLOCK = ClockProcess(dt_s=1.0, h0=2e-18, hm2=1e-22)
H = np.array([[1.0, 0.0]])
R = np.array([[1e-16]])


def _clock_filter() -> KalmanFilter:
    return KalmanFilter(CLOCK.F, CLOCK.Q, H, R, x0=np.zeros(2), P0=np.diag([1e-14, 1e-18])).fit()


def _measurements(trials=3, steps=120, seed=0):
    rng = np.random.default_rng(seed)
    z = rng.standard_normal((3, trials, steps))
    phase = two_state_clock_phase_s(z[0], z[1], z[2], h0=CLOCK.h0, hm2=CLOCK.hm2, dt_s=1.0)
    Z = (phase + 1e-8 * rng.standard_normal(phase.shape))[..., None]
    Z[0, 30:34] = np.nan
    Z[1, 0] = np.nan
    return Z


def test_batch_run_equals_filterpy_on_each_trial_to_1e_12():
    kf = _clock_filter()
    Z = _measurements()
    res = kf.run(Z)
    for i in range(Z.shape[0]):
        ref = FilterpyKF(dim_x=2, dim_z=1)
        ref.x, ref.P, ref.F, ref.Q, ref.H, ref.R = np.zeros((2, 1)), kf.P0_.copy(), CLOCK.F, CLOCK.Q, H, R
        zs = [None if np.isnan(v[0]) else v for v in Z[i]]
        means, covs, means_p, covs_p = ref.batch_filter(zs)
        for ours, theirs in ((res.x[i], means[..., 0]), (res.x_prior[i], means_p[..., 0]), (res.P[i], covs),
                             (res.P_prior[i], covs_p)):
            scale = np.abs(theirs).max(axis=0)  # per component: phase and frequency differ by 1e8
            np.testing.assert_allclose(ours / scale, theirs / scale, rtol=1e-12, atol=1e-12)


def test_streaming_step_equals_batch_run_through_the_shared_checker():
    kf = _clock_filter()
    assert isinstance(kf, Estimator)
    assert compare_streaming_to_batch(kf, _measurements(), rtol=1e-12) == []


def test_run_over_trials_equals_one_run_per_trial():
    kf = _clock_filter()
    Z = _measurements(trials=4, steps=50, seed=3)
    whole = kf.run(Z)
    for i in range(4):
        one = kf.run(Z[i : i + 1])
        np.testing.assert_allclose(whole.x[i], one.x[0], rtol=1e-14)
        np.testing.assert_allclose(whole.d2[i], one.d2[0], rtol=1e-14, equal_nan=True)


def test_the_result_is_frozen_and_its_arrays_are_read_only():
    res = _clock_filter().run(_measurements(steps=10))
    with pytest.raises(ValueError, match="read-only"):
        res.x[0, 0, 0] = 1.0
    with pytest.raises(AttributeError):
        res.x = None


def test_bad_shapes_are_rejected_with_the_name():
    with pytest.raises(ValueError, match="Q has shape"):
        KalmanFilter(CLOCK.F, np.eye(3), H, R, np.zeros(2), np.eye(2)).fit()
    with pytest.raises(ValueError, match="Z has shape"):
        _clock_filter().run(np.zeros((2, 10)))
    with pytest.raises(RuntimeError, match="fit"):
        KalmanFilter(CLOCK.F, CLOCK.Q, H, R, np.zeros(2), np.eye(2)).run(np.zeros((1, 3, 1)))


def test_a_filter_built_on_the_clocks_phi_and_q_is_consistent_with_the_simulated_clock():
    # The truth sampler and the filter share one process model: on a simulated two-state clock the
    # normalised innovations squared are chi2(1), mean 1 (Bar-Shalom, Li and Kirubarajan 2001, sec. 5.4).
    rng = np.random.default_rng(6)
    z = rng.standard_normal((3, 200, 300))
    sigma = 1e-9
    phase = two_state_clock_phase_s(z[0], z[1], z[2], h0=CLOCK.h0, hm2=CLOCK.hm2, dt_s=1.0)
    Z = (phase + sigma * rng.standard_normal(phase.shape))[..., None]
    kf = KalmanFilter(CLOCK.F, CLOCK.Q, H, np.array([[sigma**2]]), x0=np.zeros(2), P0=np.diag([1e-30, 1e-30])).fit()
    d2 = kf.run(Z[:, 1:]).d2  # the state before the first kept epoch is the clock's zero start
    # a matched filter's innovations are white, so d2 are independent chi2(1) draws of variance 2
    assert abs(d2.mean() - 1.0) < 4 * np.sqrt(2.0 / d2.size), d2.mean()


def test_a_step_output_cannot_write_into_the_filters_state():
    kf = _clock_filter()
    out = kf.step(np.array([1e-9]))
    with pytest.raises(ValueError, match="read-only"):
        out.x[0] = 1.0
    assert kf.step(np.array([1e-9])).x_prior[0] == pytest.approx(out.x[0] + out.x[1])
