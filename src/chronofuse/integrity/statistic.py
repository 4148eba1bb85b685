"""The HOD chi-square statistic: second differences, their unbroken chains, the whitened window.

``C = toeplitz(r(0) .. r(n-1))`` (:mod:`chronofuse.integrity.noise_model`) and the whitening filter
``D = L^-1`` (``C = L L^T``, Cholesky), so ``D C D^T = I``; over the last ``n`` differences ``v``,
``T(k) = |D v|^2 = v^T C^-1 v ~ chi2(n)`` under H0, threshold ``gamma = F^-1_chi2(n)(1 - P_fa)``. With
``k < n`` differences in the chain the test uses the leading ``k x k`` blocks (module
:mod:`chronofuse.integrity.detector` gives the start-up and gap policy).

Batch speed. For all full windows at once, ``T = rowsum((V L^-T)^2)`` with ``V`` the ``(windows, n)``
sliding view of ``df``: one matrix product, computed in chunks of bounded memory; the start-up epochs are
grouped by their ``k``. These are the pure functions both the batch and the streaming paths use.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy import linalg, stats

from chronofuse.estimation.process import second_difference_series

# Windows per matrix product in the batch path: 2**15 windows of n = 20 is 5 MiB per chunk.
_CHUNK_WINDOWS = 1 << 15


def high_order_difference(clock_bias_s: np.ndarray, interval_s: float) -> np.ndarray:
    """``df(k) = (t_u(k) - 2 t_u(k-1) + t_u(k-2)) / t_s`` along the last axis.

    Shape is kept: (..., steps) -> (..., steps); the first two epochs are NaN, and any difference that
    touches a NaN epoch is NaN.
    """
    return second_difference_series(clock_bias_s, interval_s)


def chain_dof(df: np.ndarray, window: int) -> np.ndarray:
    """Degrees of freedom per epoch: the number of consecutive valid differences ending there, at most ``window``.

    ``df`` has shape (..., steps); returns int64 of the same shape (0 where ``df`` is NaN).
    """
    valid = np.isfinite(df)
    steps = df.shape[-1]
    idx = np.arange(steps)
    # index of the last invalid epoch at or before k (-1 if none): run length = k - that index
    last_bad = np.where(valid, -1, idx)
    last_bad = np.maximum.accumulate(last_bad, axis=-1)
    run = idx - last_bad
    return np.minimum(run, window).astype(np.int64)


def toeplitz_whitener(r: np.ndarray, window: int) -> np.ndarray:
    """Whitening filter ``D = L^-1`` (lower triangular, (window, window)) with ``D C D^T = I``.

    ``C = toeplitz(r(0), r(1), r(2), 0, ...)`` of size ``window``. Raises ``ValueError`` when ``C`` is
    not positive definite (all noise intensities zero, or an ``r`` no noise model can produce).
    """
    return toeplitz_whiteners(np.asarray(r, dtype=np.float64)[None, :], window)[0]


def toeplitz_whiteners(r: np.ndarray, window: int) -> np.ndarray:
    """:func:`toeplitz_whitener` of each row of ``r`` (M, >=3): (M, window, window), in one batched Cholesky
    factorisation and triangular inverse (numpy's stacked LAPACK calls; one scipy call per row cost ~1 ms)."""
    r = np.asarray(r, dtype=np.float64)
    m = r.shape[0]
    cov = np.zeros((m, window, window))
    for lag in range(min(3, window)):
        i = np.arange(window - lag)
        cov[:, i, i + lag] = r[:, lag, None]
        cov[:, i + lag, i] = r[:, lag, None]
    try:
        chol = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        bad = next(row for row in r if not _positive_definite(row, window))
        raise ValueError(
            f"the difference covariance with r = {[float(v) for v in bad[:3]]} is not positive definite: "
            "the noise parameters give no noise (all zero?)"
        ) from None
    # L^-1 by forward substitution on the identity, all rows at once (lower triangular by construction)
    inv = np.zeros_like(chol)
    eye = np.eye(window)
    for i in range(window):
        inv[:, i, :] = (eye[i] - np.einsum("mj,mjk->mk", chol[:, i, :i], inv[:, :i, :])) / chol[:, i, i, None]
    return inv


def _positive_definite(r: np.ndarray, window: int) -> bool:
    col = np.zeros(window)
    col[: min(3, window)] = r[: min(3, window)]
    try:
        np.linalg.cholesky(linalg.toeplitz(col))
    except np.linalg.LinAlgError:
        return False
    return True


def window_statistic(df: np.ndarray, dof: np.ndarray, whitener: np.ndarray) -> np.ndarray:
    """``T(k) = |D_k v_k|^2`` for every epoch, ``v_k`` the last ``dof[k]`` differences.

    ``df`` and ``dof`` have shape (..., steps) (from :func:`high_order_difference` and :func:`chain_dof`);
    ``whitener`` is (n, n). Full windows (``dof == n``) go through one chunked matrix product over a
    strided ``(windows, n)`` view; shorter windows are grouped by their ``dof = k`` and use the leading
    ``k x k`` block of ``D``. NaN where ``dof == 0``.
    """
    n = whitener.shape[0]
    lead = df.shape[:-1]
    steps = df.shape[-1]
    flat_df = np.where(np.isfinite(df), df, 0.0).reshape(-1, steps)
    flat_dof = dof.reshape(-1, steps)
    out = np.full(flat_df.shape, np.nan)
    dt = np.ascontiguousarray(whitener.T)
    if steps >= n:
        windows = sliding_window_view(flat_df, n, axis=-1)  # (rows, steps - n + 1, n), no copy
        n_win = windows.shape[1]
        per_row = max(1, _CHUNK_WINDOWS // max(n_win, 1))
        for r0 in range(0, flat_df.shape[0], per_row):
            for w0 in range(0, n_win, _CHUNK_WINDOWS):
                block = windows[r0 : r0 + per_row, w0 : w0 + _CHUNK_WINDOWS]
                w = block.reshape(-1, n) @ dt
                out[r0 : r0 + per_row, n - 1 + w0 : n - 1 + w0 + block.shape[1]] = np.einsum(
                    "ij,ij->i", w, w
                ).reshape(block.shape[:2])
    short_rows, short_cols = np.nonzero((flat_dof > 0) & (flat_dof < n))
    if short_rows.size:
        ks = flat_dof[short_rows, short_cols]
        for k in np.unique(ks):
            sel = ks == k
            rows = short_rows[sel]
            cols = short_cols[sel][:, None] + np.arange(-k + 1, 1)
            v = flat_df[rows[:, None], cols]
            w = v @ dt[:k, :k]
            out[rows, short_cols[sel]] = np.einsum("ij,ij->i", w, w)
    out[flat_dof == 0] = np.nan
    return out.reshape(lead + (steps,))


def chi2_thresholds(pfa: float, window: int) -> np.ndarray:
    """``gamma_k = F^-1_chi2(k)(1 - P_fa)`` for ``k = 0 .. window``, shape (window + 1,); ``gamma_0`` is NaN."""
    gamma = np.full(window + 1, np.nan)
    gamma[1:] = stats.chi2.isf(pfa, np.arange(1, window + 1))
    return gamma


def last_innovation(df: np.ndarray, dof: np.ndarray, whitener: np.ndarray) -> np.ndarray:
    """Last component of ``D_k v_k`` per epoch, shape of ``df``: the normalised one-step innovation of ``df``.

    It is the prediction error of ``df(k)`` from the ``k - 1`` differences before it, divided by its
    standard deviation (the last row of the inverse Cholesky factor); N(0, 1) under H0, NaN where
    ``dof == 0``.
    """
    n = whitener.shape[0]
    steps = df.shape[-1]
    flat_df = np.where(np.isfinite(df), df, 0.0).reshape(-1, steps)
    flat_dof = dof.reshape(-1, steps)
    out = np.full(flat_df.shape, np.nan)
    if steps >= n:
        full = sliding_window_view(flat_df, n, axis=-1) @ whitener[n - 1]
        out[:, n - 1 :] = full
    rows, cols = np.nonzero((flat_dof > 0) & (flat_dof < n))
    if rows.size:
        ks = flat_dof[rows, cols]
        for k in np.unique(ks):
            sel = ks == k
            idx = cols[sel][:, None] + np.arange(-k + 1, 1)
            out[rows[sel], cols[sel]] = flat_df[rows[sel][:, None], idx] @ whitener[k - 1, :k]
    out[flat_dof == 0] = np.nan
    return out.reshape(df.shape)
