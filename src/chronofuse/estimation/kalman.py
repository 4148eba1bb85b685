"""The pure Kalman core: ``predict`` and ``update`` on batches of trials, returning new arrays.

Shapes (never reshaped): states ``x`` (N, n), covariances ``P`` (N, n, n), measurements ``z``
(N, m); the model matrices ``F`` (n, n), ``Q`` (n, n), ``H`` (m, n), ``R`` (m, m) are shared by all trials,
or given per trial with a leading N axis. Equations (R. E. Kalman, "A new approach to linear filtering
and prediction problems", 1960; the covariance update in Joseph's form, Bucy and Joseph 1968, as in
filterpy)::

    predict:  x- = F x                  P- = F P F' + Q
    update:   y  = z - H x-             S  = H P- H' + R          (innovation and its covariance)
              K  = P- H' S^-1           x+ = x- + K y
              P+ = (I - K H) P- (I - K H)' + K R K'
              d2 = y' S^-1 y                                       (squared Mahalanobis distance, chi2(m) under H0)

A trial whose measurement holds a NaN is not updated (``x+ = x-``, ``P+ = P-``, ``K = 0``); its ``y``
and ``d2`` are NaN and ``S`` is still the predicted innovation covariance.

This is the readable, batched twin of the compiled one-state kernel :mod:`chronofuse.estimation.kalman_kernel`
(the same equations; tests/estimation/test_kalman_kernel.py compares them): code that runs one filter per
trial in a sequential numba loop calls the kernel, code that moves all trials together calls these.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Prediction:
    """``x`` (N, n) and ``P`` (N, n, n) after :func:`predict`."""

    x: np.ndarray
    P: np.ndarray


@dataclass(frozen=True)
class Update:
    """What :func:`update` returns: posterior ``x`` (N, n), ``P`` (N, n, n), innovation ``y`` (N, m), its
    covariance ``S`` (N, m, m), gain ``K`` (N, n, m), squared Mahalanobis distance ``d2`` (N,) and
    ``skipped`` (N,) bool (the measurement was missing)."""

    x: np.ndarray
    P: np.ndarray
    y: np.ndarray
    S: np.ndarray
    K: np.ndarray
    d2: np.ndarray
    skipped: np.ndarray


def _t(a: np.ndarray) -> np.ndarray:
    """Transpose of the last two axes."""
    return np.swapaxes(a, -1, -2)


def _check_batch(x: np.ndarray, P: np.ndarray) -> tuple[int, int]:
    if x.ndim != 2:
        raise ValueError(f"x has shape {x.shape}, must be (N, n)")
    n_trials, n = x.shape
    if P.shape != (n_trials, n, n):
        raise ValueError(f"P has shape {P.shape}, must be (N, n, n) = {(n_trials, n, n)}")
    return n_trials, n


def _check_matrix(a: np.ndarray, name: str, n_trials: int, shape: tuple[int, int]) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    if a.shape != shape and a.shape != (n_trials, *shape):
        raise ValueError(f"{name} has shape {a.shape}, must be {shape} or {(n_trials, *shape)}")
    return a


def predict(x: np.ndarray, P: np.ndarray, F: np.ndarray, Q: np.ndarray) -> Prediction:
    """``x- = F x``, ``P- = F P F' + Q`` for every trial (module docstring). Inputs are not modified."""
    x = np.asarray(x, dtype=np.float64)
    P = np.asarray(P, dtype=np.float64)
    n_trials, n = _check_batch(x, P)
    F = _check_matrix(F, "F", n_trials, (n, n))
    Q = _check_matrix(Q, "Q", n_trials, (n, n))
    x_new = np.einsum("...ij,...j->...i", F, x) if F.ndim == 3 else x @ F.T
    P_new = F @ P @ _t(F) + Q
    return Prediction(x=x_new, P=P_new)


def update(x: np.ndarray, P: np.ndarray, z: np.ndarray, H: np.ndarray, R: np.ndarray) -> Update:
    """Measurement update of every trial with ``z`` (N, m); a trial with NaN in ``z`` is skipped (module docstring)."""
    x = np.asarray(x, dtype=np.float64)
    P = np.asarray(P, dtype=np.float64)
    z = np.asarray(z, dtype=np.float64)
    n_trials, n = _check_batch(x, P)
    if z.ndim != 2 or z.shape[0] != n_trials:
        raise ValueError(f"z has shape {z.shape}, must be (N, m) with N = {n_trials}")
    m = z.shape[1]
    H = _check_matrix(H, "H", n_trials, (m, n))
    R = _check_matrix(R, "R", n_trials, (m, m))
    skipped = np.isnan(z).any(axis=1)
    hx = np.einsum("...ij,...j->...i", H, x) if H.ndim == 3 else x @ H.T
    y = z - hx  # y = z - H x-
    PHt = P @ _t(H)
    S = H @ PHt + R  # S = H P- H' + R
    S = 0.5 * (S + _t(S))
    K = _t(np.linalg.solve(S, _t(PHt)))  # K = P- H' S^-1 (S symmetric)
    K = np.where(skipped[:, None, None], 0.0, K)
    y_used = np.where(skipped[:, None], 0.0, y)
    x_new = x + np.einsum("nij,nj->ni", K, y_used)  # x+ = x- + K y
    I_KH = np.eye(n) - K @ np.broadcast_to(H, (n_trials, m, n))
    P_new = I_KH @ P @ _t(I_KH) + K @ R @ _t(K)  # Joseph form
    P_new = 0.5 * (P_new + _t(P_new))
    d2 = np.einsum("ni,ni->n", y_used, np.linalg.solve(S, y_used[..., None])[..., 0])  # d2 = y' S^-1 y
    y = np.where(skipped[:, None], np.nan, y)
    d2 = np.where(skipped, np.nan, d2)
    return Update(x=x_new, P=P_new, y=y, S=S, K=K, d2=d2, skipped=skipped)
