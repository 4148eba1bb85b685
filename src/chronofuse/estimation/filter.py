"""A linear Kalman filter on the estimation interface: ``KalmanFilter(F, Q, H, R, x0, P0)``.

Each epoch is :func:`~chronofuse.estimation.kalman.predict` then
:func:`~chronofuse.estimation.kalman.update` (the order of filterpy's ``batch_filter``), so ``x0``, ``P0``
describe the state one step before the first measurement. ``run`` moves all trials together through the
same two functions that ``step`` calls for one trial; it keeps the priors, posteriors, innovations, their
covariances and the squared Mahalanobis distances (the diagnostics an anomaly detector needs), and a
:class:`FilterResult` is what :func:`~chronofuse.estimation.rts.rts_smooth` smooths.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from chronofuse.estimation.interface import FrozenResult
from chronofuse.estimation.kalman import predict, update
from chronofuse.validation import check_array


@dataclass(frozen=True)
class FilterStep(FrozenResult):
    """One epoch of one trial: prior ``x_prior`` (n,), ``P_prior`` (n, n); posterior ``x``, ``P``; innovation
    ``y`` (m,), ``S`` (m, m), squared Mahalanobis distance ``d2``; ``skipped`` (the measurement was missing)."""

    x_prior: np.ndarray
    P_prior: np.ndarray
    x: np.ndarray
    P: np.ndarray
    y: np.ndarray
    S: np.ndarray
    d2: float
    skipped: bool


@dataclass(frozen=True)
class FilterResult(FrozenResult):
    """``run``'s result; arrays read-only with leading axes (trials, steps): ``x_prior``, ``x`` (.., n),
    ``P_prior``, ``P`` (.., n, n), ``y`` (.., m), ``S`` (.., m, m), ``d2`` and ``skipped`` (trials, steps)."""

    x_prior: np.ndarray
    P_prior: np.ndarray
    x: np.ndarray
    P: np.ndarray
    y: np.ndarray
    S: np.ndarray
    d2: np.ndarray
    skipped: np.ndarray


def _square(a, name: str, size: int | None = None) -> np.ndarray:
    a = check_array(a, name, ndim=2)
    if a.shape[0] != a.shape[1] or (size is not None and a.shape[0] != size):
        want = "square" if size is None else f"({size}, {size})"
        raise ValueError(f"{name} has shape {a.shape}, must be {want}")
    return a


class KalmanFilter:
    """Linear Kalman filter with constant ``F`` (n, n), ``Q`` (n, n), ``H`` (m, n), ``R`` (m, m).

    ``x0`` (n,) and ``P0`` (n, n): the state and covariance one step before the first measurement. ``fit``
    checks the shapes (there is nothing to learn) and stores them as ``F_`` ... ``P0_``.
    """

    inputs: ClassVar[tuple[str, ...]] = ()

    def __init__(self, F, Q, H, R, x0, P0):
        self.F = F
        self.Q = Q
        self.H = H
        self.R = R
        self.x0 = x0
        self.P0 = P0

    def fit(self, train=None) -> KalmanFilter:
        """Validate the model's shapes; ``train`` is not used (the model is given). Returns self."""
        self.F_ = _square(self.F, "F")
        n = self.F_.shape[0]
        self.Q_ = _square(self.Q, "Q", n)
        self.H_ = check_array(self.H, "H", ndim=2)
        if self.H_.shape[1] != n:
            raise ValueError(f"H has shape {self.H_.shape}, must be (m, {n})")
        self.R_ = _square(self.R, "R", self.H_.shape[0])
        self.x0_ = check_array(self.x0, "x0", ndim=1)
        if self.x0_.shape != (n,):
            raise ValueError(f"x0 has shape {self.x0_.shape}, must be ({n},)")
        self.P0_ = _square(self.P0, "P0", n)
        self.reset()
        return self

    def _check_fitted(self) -> None:
        if not hasattr(self, "F_"):
            raise RuntimeError("this KalmanFilter is not fitted yet: call fit() first")

    def reset(self) -> None:
        """Return the streaming state to ``x0``, ``P0``."""
        if hasattr(self, "F_"):
            self._x = self.x0_[None, :].copy()
            self._P = self.P0_[None, :, :].copy()

    def step(self, z) -> FilterStep:
        """Predict, then update with ``z`` of shape (m,) (NaN or None = missing); advances the streaming state."""
        self._check_fitted()
        m = self.H_.shape[0]
        z = np.full(m, np.nan) if z is None else check_array(z, "z", ndim=1, allow_nan=True)
        if z.shape != (m,):
            raise ValueError(f"z has shape {z.shape}, must be ({m},)")
        prior = predict(self._x, self._P, self.F_, self.Q_)
        post = update(prior.x, prior.P, z[None, :], self.H_, self.R_)
        self._x, self._P = post.x, post.P
        return FilterStep(x_prior=prior.x[0], P_prior=prior.P[0], x=post.x[0], P=post.P[0], y=post.y[0],
                          S=post.S[0], d2=float(post.d2[0]), skipped=bool(post.skipped[0]))

    def run(self, Z) -> FilterResult:
        """Filter every trial of ``Z`` (trials, steps, m), NaN = missing; the filter is not changed."""
        self._check_fitted()
        Z = check_array(Z, "Z", ndim=3, allow_nan=True)
        trials, steps, m = Z.shape
        if m != self.H_.shape[0]:
            raise ValueError(f"Z has shape {Z.shape}, its last axis must be m = {self.H_.shape[0]}")
        n = self.F_.shape[0]
        out = {name: np.empty((trials, steps) + shape) for name, shape in
               (("x_prior", (n,)), ("P_prior", (n, n)), ("x", (n,)), ("P", (n, n)), ("y", (m,)), ("S", (m, m)),
                ("d2", ()))}
        skipped = np.empty((trials, steps), dtype=bool)
        x = np.broadcast_to(self.x0_, (trials, n))
        P = np.broadcast_to(self.P0_, (trials, n, n))
        for k in range(steps):
            prior = predict(x, P, self.F_, self.Q_)
            post = update(prior.x, prior.P, Z[:, k], self.H_, self.R_)
            x, P = post.x, post.P
            out["x_prior"][:, k], out["P_prior"][:, k] = prior.x, prior.P
            out["x"][:, k], out["P"][:, k], out["y"][:, k] = post.x, post.P, post.y
            out["S"][:, k], out["d2"][:, k], skipped[:, k] = post.S, post.d2, post.skipped
        return FilterResult(skipped=skipped, **out)
