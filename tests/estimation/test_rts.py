"""The RTS smoother against the batch least-squares (information-form) solution and against filterpy."""

import numpy as np
from filterpy.kalman import rts_smoother

from chronofuse.estimation.filter import KalmanFilter
from chronofuse.estimation.rts import rts_smooth

F = np.array([[1.0, 0.5], [0.0, 1.0]])
Q = np.array([[0.02, 0.03], [0.03, 0.1]])
H = np.array([[1.0, 0.0]])
R = np.array([[0.4]])
X0 = np.array([0.3, -0.1])
P0 = np.diag([2.0, 0.5])


def _data(trials, steps, seed):
    rng = np.random.default_rng(seed)
    Z = rng.standard_normal((trials, steps, 1)) + np.linspace(0, 3, steps)[None, :, None]
    Z[0, 4] = np.nan
    return Z


def _least_squares(z):
    """The smoothed states as the mode of the joint Gaussian of (x_0 .. x_{T-1}) given all of z.

    Information form: minimise |x_0 - F x0|^2 over (F P0 F' + Q), |x_{k+1} - F x_k|^2 over Q and
    |z_k - H x_k|^2 over R; the normal equations' solution is the mean, the inverse of their matrix the
    covariance (Bierman 1977; it is what the RTS recursion computes, by a different route).
    """
    steps, n = z.shape[0], 2
    info = np.zeros((steps * n, steps * n))
    rhs = np.zeros(steps * n)

    def add(rows, a, w, target):  # residual a @ x[rows] - target with weight w
        idx = np.concatenate([np.arange(r * n, r * n + n) for r in rows])
        info[np.ix_(idx, idx)] += a.T @ w @ a
        rhs[idx] += a.T @ w @ target

    add([0], np.eye(n), np.linalg.inv(F @ P0 @ F.T + Q), F @ X0)
    qi = np.linalg.inv(Q)
    for k in range(steps - 1):
        add([k, k + 1], np.hstack([-F, np.eye(n)]), qi, np.zeros(n))
    for k in range(steps):
        if np.isfinite(z[k]).all():
            add([k], H, np.linalg.inv(R), z[k])
    cov = np.linalg.inv(info)
    mean = cov @ rhs
    return mean.reshape(steps, n), np.array([cov[k * n : k * n + n, k * n : k * n + n] for k in range(steps)])


def test_smoothed_states_and_covariances_equal_the_batch_least_squares_solution():
    Z = _data(2, 25, 1)
    res = KalmanFilter(F, Q, H, R, X0, P0).fit().run(Z)
    sm = rts_smooth(res, F)
    for i in range(2):
        mean, cov = _least_squares(Z[i])
        np.testing.assert_allclose(sm.x[i], mean, rtol=1e-9, atol=1e-10)
        np.testing.assert_allclose(sm.P[i], cov, rtol=1e-9, atol=1e-10)
    # the last epoch is the filter's own
    np.testing.assert_array_equal(sm.x[:, -1], res.x[:, -1])
    assert not sm.x.flags.writeable


def test_smoother_equals_filterpy_rts_smoother_on_one_trial():
    Z = _data(1, 40, 2)
    Z[0, 4] = 0.7  # filterpy's smoother takes no gaps
    res = KalmanFilter(F, Q, H, R, X0, P0).fit().run(Z)
    sm = rts_smooth(res, F)
    xs, ps, _, _ = rts_smoother(res.x[0][..., None].copy(), res.P[0].copy(), [F] * 40, [Q] * 40)
    np.testing.assert_allclose(sm.x[0], xs[..., 0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(sm.P[0], ps, rtol=1e-12, atol=1e-12)


def test_smoothing_never_increases_the_variance():
    Z = _data(3, 30, 3)
    res = KalmanFilter(F, Q, H, R, X0, P0).fit().run(Z)
    sm = rts_smooth(res, F)
    assert np.all(np.diagonal(sm.P, axis1=-2, axis2=-1) <= np.diagonal(res.P, axis1=-2, axis2=-1) + 1e-12)
