"""The pure Kalman core against filterpy, against a per-trial loop, and against the chi-square law of d2."""

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter as FilterpyKF
from scipy import stats

from chronofuse.estimation.kalman import predict, update
from chronofuse.estimation.process import ClockProcess

CLOCK = ClockProcess(dt_s=1.0, h0=2e-18, hm2=1e-22, drift_psd_per_s3=1e-30, states=3)
H = np.array([[1.0, 0.0, 0.0]])
R = np.array([[1e-18]])


def _batch(rng, trials=5):
    x = rng.standard_normal((trials, 3)) * [1e-8, 1e-10, 1e-13]
    a = rng.standard_normal((trials, 3, 3)) * 1e-9
    P = a @ np.swapaxes(a, 1, 2) + np.eye(3) * 1e-20
    return x, P


def test_one_predict_and_update_equal_filterpy_for_each_trial():
    rng = np.random.default_rng(1)
    x, P = _batch(rng)
    z = rng.standard_normal((5, 1)) * 1e-8
    prior = predict(x, P, CLOCK.F, CLOCK.Q)
    post = update(prior.x, prior.P, z, H, R)
    for i in range(5):
        kf = FilterpyKF(dim_x=3, dim_z=1)
        kf.x, kf.P, kf.F, kf.Q, kf.H, kf.R = x[i][:, None].copy(), P[i].copy(), CLOCK.F, CLOCK.Q, H, R
        kf.predict()
        np.testing.assert_allclose(prior.x[i], kf.x[:, 0], rtol=1e-12)
        np.testing.assert_allclose(prior.P[i], kf.P, rtol=1e-12, atol=1e-12 * np.abs(kf.P).max())
        kf.update(z[i])
        np.testing.assert_allclose(post.x[i], kf.x[:, 0], rtol=1e-12, atol=1e-12 * np.abs(kf.x).max())
        np.testing.assert_allclose(post.P[i], kf.P, rtol=1e-9, atol=1e-12 * np.abs(kf.P).max())
        np.testing.assert_allclose(post.y[i], kf.y[:, 0], rtol=1e-12)
        np.testing.assert_allclose(post.S[i], kf.S, rtol=1e-12)
        np.testing.assert_allclose(post.K[i], kf.K, rtol=1e-9)
        assert post.d2[i] == pytest.approx(kf.mahalanobis**2, rel=1e-10)


def test_a_missing_measurement_skips_that_trial_only_and_leaves_the_inputs_untouched():
    rng = np.random.default_rng(2)
    x, P = _batch(rng, 3)
    x_copy, P_copy = x.copy(), P.copy()
    z = np.array([[1e-8], [np.nan], [2e-8]])
    post = update(x, P, z, H, R)
    np.testing.assert_array_equal(x, x_copy)
    np.testing.assert_array_equal(P, P_copy)
    assert post.skipped.tolist() == [False, True, False]
    np.testing.assert_array_equal(post.x[1], x[1])
    np.testing.assert_allclose(post.P[1], P[1], rtol=1e-15)
    assert np.isnan(post.y[1]).all() and np.isnan(post.d2[1]) and (post.K[1] == 0).all()
    # the other trials are updated exactly as if alone
    alone = update(x[[0, 2]], P[[0, 2]], z[[0, 2]], H, R)
    np.testing.assert_allclose(post.x[[0, 2]], alone.x, rtol=1e-15)


def test_per_trial_model_matrices_equal_shared_ones_when_they_are_equal():
    rng = np.random.default_rng(3)
    x, P = _batch(rng, 4)
    shared = predict(x, P, CLOCK.F, CLOCK.Q)
    per_trial = predict(x, P, np.broadcast_to(CLOCK.F, (4, 3, 3)), np.broadcast_to(CLOCK.Q, (4, 3, 3)))
    np.testing.assert_allclose(per_trial.x, shared.x, rtol=1e-15)
    np.testing.assert_allclose(per_trial.P, shared.P, rtol=1e-15)


def test_mahalanobis_distance_of_a_matched_model_is_chi_square_with_m_dof():
    # d2 = y' S^-1 y ~ chi2(m), independent over steps, when the data follow the filter's own model
    # (Bar-Shalom, Li and Kirubarajan 2001, sec. 5.4)
    rng = np.random.default_rng(4)
    F = np.array([[1.0, 1.0], [0.0, 1.0]])
    Q = np.array([[0.3, 0.1], [0.1, 0.2]])
    Hm = np.eye(2)
    Rm = np.diag([0.5, 0.8])
    trials = 4000
    truth = rng.multivariate_normal(np.zeros(2), np.eye(2), trials)
    x, P = np.zeros((trials, 2)), np.broadcast_to(np.eye(2), (trials, 2, 2))
    d2 = []
    for _ in range(5):
        truth = truth @ F.T + rng.multivariate_normal(np.zeros(2), Q, trials)
        z = truth + rng.multivariate_normal(np.zeros(2), Rm, trials)
        prior = predict(x, P, F, Q)
        post = update(prior.x, prior.P, z, Hm, Rm)
        x, P = post.x, post.P
        d2.append(post.d2)
    assert stats.kstest(np.concatenate(d2), stats.chi2(2).cdf).pvalue > 1e-3


def test_shapes_other_than_the_batch_ones_are_rejected_not_reshaped():
    with pytest.raises(ValueError, match="x has shape"):
        predict(np.zeros(3), np.zeros((1, 3, 3)), CLOCK.F, CLOCK.Q)
    with pytest.raises(ValueError, match="P has shape"):
        predict(np.zeros((2, 3)), np.zeros((3, 3)), CLOCK.F, CLOCK.Q)
    with pytest.raises(ValueError, match="F has shape"):
        predict(np.zeros((2, 3)), np.zeros((2, 3, 3)), np.eye(2), CLOCK.Q)
    with pytest.raises(ValueError, match="z has shape"):
        update(np.zeros((2, 3)), np.zeros((2, 3, 3)), np.zeros(2), H, R)
