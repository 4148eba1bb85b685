"""The compiled small-matrix Kalman kernel against its numpy twin (the batched core) and against filterpy."""

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter as FilterpyKF

from chronofuse.estimation import kalman, kalman_kernel
from chronofuse.estimation.process import ClockProcess


def _work(x):
    return np.full(kalman_kernel.work_size(x.shape[0]), np.nan)  # scratch: its contents must not matter


def _model(rng, n):
    F = np.eye(n) + 0.3 * rng.standard_normal((n, n))
    a = rng.standard_normal((n, n))
    Q = a @ a.T * 1e-3 + np.eye(n) * 1e-4
    b = rng.standard_normal((n, n))
    P = b @ b.T + np.eye(n)
    return rng.standard_normal(n), P, F, Q, rng.standard_normal(n), float(rng.uniform(0.1, 2.0))


@pytest.mark.parametrize("n", [1, 2, 3, 5])
@pytest.mark.parametrize("seed", range(4))
def test_predict_and_update_equal_the_numpy_twin_for_random_models(n, seed):
    rng = np.random.default_rng(seed)
    x, P, F, Q, h, r = _model(rng, n)
    z = float(rng.standard_normal())
    x_p, P_p = np.empty(n), np.empty((n, n))
    kalman_kernel.predict(x, P, F, Q, x_p, P_p, _work(x))
    prior = kalman.predict(x[None], P[None], F, Q)
    np.testing.assert_allclose(x_p, prior.x[0], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(P_p, prior.P[0], rtol=1e-12, atol=1e-14)
    x_u, P_u = np.empty(n), np.empty((n, n))
    y, S = kalman_kernel.update(x_p, P_p, z, h, r, x_u, P_u, _work(x_p))
    post = kalman.update(prior.x, prior.P, np.array([[z]]), h[None, :], np.array([[r]]))
    np.testing.assert_allclose(x_u, post.x[0], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(P_u, post.P[0], rtol=1e-10, atol=1e-12)
    assert y == pytest.approx(post.y[0, 0], rel=1e-12, abs=1e-14)
    assert S == pytest.approx(post.S[0, 0, 0], rel=1e-12)
    assert kalman_kernel.innovation_variance(P_p, h) + r == pytest.approx(S, rel=1e-12)


def test_a_missing_measurement_leaves_the_state_and_reports_the_predicted_variance_like_the_twin():
    rng = np.random.default_rng(7)
    x, P, F, Q, h, r = _model(rng, 3)
    x_u, P_u = np.empty(3), np.empty((3, 3))
    y, S = kalman_kernel.update(x, P, np.nan, h, r, x_u, P_u, _work(x))
    post = kalman.update(x[None], P[None], np.array([[np.nan]]), h[None, :], np.array([[r]]))
    assert np.isnan(y) and np.isnan(post.y[0, 0])
    assert np.array_equal(x_u, x)
    np.testing.assert_allclose(P_u, post.P[0], rtol=1e-12)
    assert S == pytest.approx(post.S[0, 0, 0], rel=1e-12)


def test_outputs_may_be_the_inputs_themselves():
    rng = np.random.default_rng(3)
    x, P, F, Q, h, r = _model(rng, 4)
    x_p, P_p = np.empty(4), np.empty((4, 4))
    kalman_kernel.predict(x, P, F, Q, x_p, P_p, _work(x))
    x2, P2 = x.copy(), P.copy()
    kalman_kernel.predict(x2, P2, F, Q, x2, P2, _work(x2))
    assert np.array_equal(x2, x_p) and np.array_equal(P2, P_p)
    x_u, P_u = np.empty(4), np.empty((4, 4))
    kalman_kernel.update(x_p, P_p, 0.3, h, r, x_u, P_u, _work(x_p))
    kalman_kernel.update(x2, P2, 0.3, h, r, x2, P2, _work(x2))
    assert np.array_equal(x2, x_u) and np.array_equal(P2, P_u)


def test_a_clock_filter_run_through_the_kernel_equals_filterpy():
    clock = ClockProcess(dt_s=1.0, h0=2e-18, hm2=1e-22, drift_psd_per_s3=1e-30, states=3)
    F, Q, h, r = clock.F, clock.Q, np.array([1.0, 0.0, 0.0]), 1e-18
    rng = np.random.default_rng(11)
    zs = np.cumsum(1e-9 * rng.standard_normal(200))
    kf = FilterpyKF(dim_x=3, dim_z=1)
    kf.x, kf.P, kf.F, kf.Q, kf.H, kf.R = np.zeros((3, 1)), np.diag([1e-14, 1e-18, 1e-26]), F, Q, h[None], np.array([[r]])
    x, P = np.zeros(3), np.diag([1e-14, 1e-18, 1e-26])
    for z in zs:
        kalman_kernel.predict(x, P, F, Q, x, P, _work(x))
        kalman_kernel.update(x, P, z, h, r, x, P, _work(x))
        kf.predict()
        kf.update(z)
    np.testing.assert_allclose(x, kf.x[:, 0], rtol=1e-8, atol=1e-8 * np.abs(kf.x).max())
    np.testing.assert_allclose(P, kf.P, rtol=1e-6, atol=1e-8 * np.abs(kf.P).max())
