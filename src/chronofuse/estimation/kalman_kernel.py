"""The small-matrix Kalman kernel: predict and a scalar measurement update of ONE state, compiled with numba.

This is the compiled twin of the batched numpy core :mod:`chronofuse.estimation.kalman` (the same
equations, tested equal), for the sequential loops that run one filter per trial second by second: the
Kalman servos of :mod:`chronofuse.discipline` and the two-way link filters of :mod:`chronofuse.sync`. A
Python step on a 3 x 3 filter costs tens of microseconds of numpy overhead; these functions cost well
under one. They are plain ``@njit`` functions, called from other numba code (or from Python, for tests).

Shapes and conventions (never reshaped): state ``x`` (n,), covariance ``P`` (n, n), transition ``F``
(n, n), process noise ``Q`` (n, n), measurement row ``h`` (n,) and its variance ``r`` (a float). Results
are written into the caller's ``x_out`` (n,) and ``P_out`` (n, n), which may be the inputs themselves
(every function reads all of its inputs before it writes). Equations, as in the numpy twin::

    predict:  x- = F x                          P- = (F P) F' + Q
    update:   y = z - h' x-                     S = h' (P- h) + r         (innovation and its variance)
              K = P- h / S                      x+ = x- + K y
              P+ = (I - K h') P- (I - K h')' + K r K'     (Joseph form), then (P+ + P+') / 2

Every product is summed over its inner index in increasing order, so a caller that needs bit-for-bit
reproducible numbers (the servos' streaming and batch paths) gets them. A vector measurement with
independent errors is processed as a sequence of scalar updates (one call per component), which is the
same estimate as the joint update (Bierman, *Factorization Methods for Discrete Sequential Estimation*,
1977, ch. II).

A missing measurement (``z`` NaN) is not an update: ``x_out = x``, ``P_out`` is ``P`` symmetrized, the
innovation is NaN and its variance is still ``h' P h + r`` (what the numpy twin reports for a skipped trial).
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["predict", "update", "innovation_variance", "symmetrize"]


@numba.njit(cache=True)
def _product(A, B, out):
    """``out = A @ B`` of (n, n) matrices, each entry summed over the inner index in order (``out`` is not A or B)."""
    n = A.shape[0]
    for a in range(n):
        for b in range(n):
            acc = 0.0
            for c in range(n):
                acc += A[a, c] * B[c, b]
            out[a, b] = acc


@numba.njit(cache=True)
def _product_transposed(A, B, C, out):
    """``out = A @ B' + C``, each entry of the product summed over the inner index in order."""
    n = A.shape[0]
    for a in range(n):
        for b in range(n):
            acc = 0.0
            for c in range(n):
                acc += A[a, c] * B[b, c]
            out[a, b] = acc + C[a, b]


@numba.njit(cache=True)
def symmetrize(P, P_out):
    """``P_out = (P + P') / 2`` (``P_out`` may be ``P``)."""
    n = P.shape[0]
    for a in range(n):
        for b in range(a, n):
            sym = 0.5 * (P[a, b] + P[b, a])
            P_out[a, b] = sym
            P_out[b, a] = sym


@numba.njit(cache=True)
def predict(x, P, F, Q, x_out, P_out):
    """``x- = F x``, ``P- = (F P) F' + Q`` (module docstring); writes ``x_out`` (n,) and ``P_out`` (n, n)."""
    n = x.shape[0]
    xp = np.empty(n)
    for a in range(n):
        acc = 0.0
        for b in range(n):
            acc += F[a, b] * x[b]
        xp[a] = acc
    FP = np.empty((n, n))
    _product(F, P, FP)
    _product_transposed(FP, F, Q, P_out)
    for a in range(n):
        x_out[a] = xp[a]


@numba.njit(cache=True)
def innovation_variance(P, h):
    """``h' P h`` summed over ``a`` then ``b`` (without ``r``): the predicted measurement's own variance."""
    n = h.shape[0]
    acc = 0.0
    for a in range(n):
        for b in range(n):
            acc += h[a] * P[a, b] * h[b]
    return acc


@numba.njit(cache=True)
def update(x, P, z, h, r, x_out, P_out):
    """Scalar measurement update (module docstring); returns ``(y, S)``, the innovation and its variance.

    ``z`` NaN: no update (``x_out = x``, ``P_out`` = ``P`` symmetrized, ``y`` NaN)."""
    n = x.shape[0]
    hx = 0.0
    for a in range(n):
        hx += x[a] * h[a]
    y = z - hx
    PHt = np.empty(n)
    for a in range(n):
        acc = 0.0
        for b in range(n):
            acc += P[a, b] * h[b]
        PHt[a] = acc
    S = 0.0
    for a in range(n):
        S += h[a] * PHt[a]
    S = S + r
    if math.isnan(z):
        for a in range(n):
            x_out[a] = x[a]
        symmetrize(P, P_out)
        return math.nan, S
    K = np.empty(n)
    for a in range(n):
        K[a] = PHt[a] / S
    IKH = np.empty((n, n))
    KrK = np.empty((n, n))
    for a in range(n):
        for b in range(n):
            IKH[a, b] = (1.0 if a == b else 0.0) - K[a] * h[b]
            KrK[a, b] = K[a] * r * K[b]
    IKHP = np.empty((n, n))
    _product(IKH, P, IKHP)
    _product_transposed(IKHP, IKH, KrK, P_out)
    symmetrize(P_out, P_out)
    for a in range(n):
        x_out[a] = x[a] + K[a] * y
    return y, S
