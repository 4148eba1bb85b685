"""The small-matrix Kalman kernel: predict and a scalar measurement update of ONE state, compiled with numba.

This is the compiled twin of the batched numpy core :mod:`chronofuse.estimation.kalman` (the same
equations, tested equal), for the sequential loops that run one filter per trial second by second: the
Kalman servos of :mod:`chronofuse.discipline` and the two-way link filters of :mod:`chronofuse.sync`. A
Python step on a 3 x 3 filter costs tens of microseconds of numpy overhead; these functions cost well
under one. They are plain ``@njit`` functions, called from other numba code (or from Python, for tests).

Shapes and conventions (never reshaped): state ``x`` (n,), covariance ``P`` (n, n), transition ``F``
(n, n), process noise ``Q`` (n, n), measurement row ``h`` (n,) and its variance ``r`` (a float). Results
are written into the caller's ``x_out`` (n,) and ``P_out`` (n, n), which may be the inputs themselves
(every function reads all of its inputs before it writes); ``work`` is the caller's scratch space
(:func:`work_size` floats, not overlapping the other arrays), so a step allocates nothing. Equations, as
in the numpy twin::

    predict:  x- = F x                          P- = (F P) F' + Q
    update:   y = z - h' x-                     S = h' (P- h) + r         (innovation and its variance)
              K = P- h / S                      x+ = x- + K y
              P+ = (I - K h') P- (I - K h')' + K r K'     (Joseph form), then (P+ + P+') / 2

Every product is summed over its inner index in increasing order, so a caller that needs bit-for-bit
reproducible numbers (the servos' streaming and batch paths) gets them. A product skips the terms whose
sparse factor (``F`` in the prediction) is zero: with finite entries adding
``0 * b`` to a sum changes no bit, and the clairvoyant servo's 19-state model (``F`` 36 non-zeros of 361)
then costs about a tenth of the dense products. A vector measurement with
independent errors is processed as a sequence of scalar updates (one call per component), which is the
same estimate as the joint update (Bierman, *Factorization Methods for Discrete Sequential Estimation*,
1977, ch. II).

The same functions on flat, row-major storage (``predict_flat``, ``update_flat``, ...: each ``(n, n)``
matrix an ``(n*n,)`` vector) serve callers that keep a whole filter in one state vector, as the servos'
compiled backends do; the two-dimensional ones call them.

A missing measurement (``z`` NaN) is not an update: ``x_out = x``, ``P_out`` is ``P`` symmetrized, the
innovation is NaN and its variance is still ``h' P h + r`` (what the numpy twin reports for a skipped trial).
"""

from __future__ import annotations

import math

import numba

__all__ = ["predict", "update", "innovation_variance", "symmetrize", "work_size", "predict_flat", "update_flat",
           "innovation_variance_flat", "symmetrize_flat"]


def work_size(n: int) -> int:
    """Floats of scratch space ``work`` that :func:`predict` and :func:`update` need for an n-state filter."""
    return 3 * n * n + 2 * n


# -- flat, row-major storage: M[a, b] is M[a * n + b] ------------------------------------------------------


@numba.njit(cache=True)
def _product(A, B, out, n):
    """``out = A @ B``, each entry summed over the inner index in order (``out`` is not A or B); the zero
    entries of ``A`` are skipped (module docstring)."""
    for a in range(n * n):
        out[a] = 0.0
    for a in range(n):
        for c in range(n):
            f = A[a * n + c]
            if f == 0.0:
                continue
            for b in range(n):
                out[a * n + b] += f * B[c * n + b]


@numba.njit(cache=True)
def _product_transposed(A, B, C, out, n):
    """``out = A @ B' + C``, each entry of the product summed over the inner index in order; the zero
    entries of ``B`` are skipped (module docstring)."""
    for a in range(n * n):
        out[a] = 0.0
    for b in range(n):
        for c in range(n):
            g = B[b * n + c]
            if g == 0.0:
                continue
            for a in range(n):
                out[a * n + b] += A[a * n + c] * g
    for a in range(n * n):
        out[a] += C[a]


@numba.njit(cache=True)
def symmetrize_flat(P, P_out):
    """``P_out = (P + P') / 2`` on flat storage (``P_out`` may be ``P``)."""
    n = int(round(math.sqrt(P.shape[0])))
    for a in range(n):
        for b in range(a, n):
            sym = 0.5 * (P[a * n + b] + P[b * n + a])
            P_out[a * n + b] = sym
            P_out[b * n + a] = sym


@numba.njit(cache=True)
def predict_flat(x, P, F, Q, x_out, P_out, work):
    """:func:`predict` on flat storage."""
    n = x.shape[0]
    xp = work[:n]
    for a in range(n):
        acc = 0.0
        for b in range(n):
            acc += F[a * n + b] * x[b]
        xp[a] = acc
    FP = work[n:n + n * n]
    _product(F, P, FP, n)
    _product_transposed(FP, F, Q, P_out, n)
    for a in range(n):
        x_out[a] = xp[a]


@numba.njit(cache=True)
def innovation_variance_flat(P, h):
    """:func:`innovation_variance` on flat storage."""
    n = h.shape[0]
    acc = 0.0
    for a in range(n):
        for b in range(n):
            acc += h[a] * P[a * n + b] * h[b]
    return acc


@numba.njit(cache=True)
def update_flat(x, P, z, h, r, x_out, P_out, work):
    """:func:`update` on flat storage; returns ``(y, S)``."""
    n = x.shape[0]
    nn = n * n
    hx = 0.0
    for a in range(n):
        hx += x[a] * h[a]
    y = z - hx
    PHt = work[:n]
    for a in range(n):
        acc = 0.0
        for b in range(n):
            acc += P[a * n + b] * h[b]
        PHt[a] = acc
    S = 0.0
    for a in range(n):
        S += h[a] * PHt[a]
    S = S + r
    if math.isnan(z):
        for a in range(n):
            x_out[a] = x[a]
        symmetrize_flat(P, P_out)
        return math.nan, S
    K = work[n:2 * n]
    for a in range(n):
        K[a] = PHt[a] / S
    IKH = work[2 * n:2 * n + nn]
    KrK = work[2 * n + nn:2 * n + 2 * nn]
    for a in range(n):
        for b in range(n):
            IKH[a * n + b] = (1.0 if a == b else 0.0) - K[a] * h[b]
            KrK[a * n + b] = K[a] * r * K[b]
    IKHP = work[2 * n + 2 * nn:2 * n + 3 * nn]
    _product(IKH, P, IKHP, n)
    _product_transposed(IKHP, IKH, KrK, P_out, n)
    symmetrize_flat(P_out, P_out)
    for a in range(n):
        x_out[a] = x[a] + K[a] * y
    return y, S


# -- (n, n) matrices ---------------------------------------------------------------------------------------


@numba.njit(cache=True)
def symmetrize(P, P_out):
    """``P_out = (P + P') / 2`` (``P_out`` may be ``P``)."""
    symmetrize_flat(P.reshape(P.size), P_out.reshape(P_out.size))


@numba.njit(cache=True)
def predict(x, P, F, Q, x_out, P_out, work):
    """``x- = F x``, ``P- = (F P) F' + Q`` (module docstring); writes ``x_out`` (n,) and ``P_out`` (n, n).

    ``work``: scratch of at least :func:`work_size` floats (overwritten), so that nothing is allocated."""
    predict_flat(x, P.reshape(P.size), F.reshape(F.size), Q.reshape(Q.size), x_out, P_out.reshape(P_out.size), work)


@numba.njit(cache=True)
def innovation_variance(P, h):
    """``h' P h`` summed over ``a`` then ``b`` (without ``r``): the predicted measurement's own variance."""
    return innovation_variance_flat(P.reshape(P.size), h)


@numba.njit(cache=True)
def update(x, P, z, h, r, x_out, P_out, work):
    """Scalar measurement update (module docstring); returns ``(y, S)``, the innovation and its variance.

    ``z`` NaN: no update (``x_out = x``, ``P_out`` = ``P`` symmetrized, ``y`` NaN). ``work``: scratch of at
    least :func:`work_size` floats (overwritten)."""
    return update_flat(x, P.reshape(P.size), z, h, r, x_out, P_out.reshape(P_out.size), work)
