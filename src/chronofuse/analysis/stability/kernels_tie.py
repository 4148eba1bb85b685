"""Raw kernels of the time-interval-error statistics: TIE rms and MTIE.

Signature as for every stability kernel: ``name_raw(x, m, tau0_s) -> (dev, n)`` with phase ``x`` in
seconds (N,) (NaN marks a missing sample), averaging factors ``m`` (k,) and the sample interval
``tau0_s``; the observation interval is ``tau = m tau0``. Both statistics are in seconds.

Definitions (Stable32's, the ones its "TIE rms" and "MTIE" tables use; NIST SP 1065 section 5.2,
ITU-T Rec. G.810 Appendix II; S. Bregni, IEEE Trans. Instrum. Meas. 45(5), 1996):

- ``TIErms(m tau0) = sqrt( 1/(N-m) * sum_{i=1}^{N-m} (x[i+m] - x[i])**2 )``, ``n = N - m`` terms;
- ``MTIE(m tau0) = max_{k} ( max_{k <= i <= k+m} x[i] - min_{k <= i <= k+m} x[i] )``: the largest
  peak-to-peak phase excursion over every window of ``m + 1`` consecutive samples. Stable32's ``#``
  column for MTIE is the number of phase samples analysed (N for every tau), and so is ``n`` here.

MTIE is computed with a sparse table of window extrema (range-maximum query by doubling): the maxima
and minima over windows of ``2**k`` samples are built level by level, each in O(N) from the previous,
and a window of any length ``L`` with ``2**k <= L < 2**(k+1)`` is covered by two overlapping windows of
``2**k``. All factors are answered in one sweep, O(N log(max m) + N k) in total, so 1e6 samples at
octave factors take a fraction of a second (a per-window scan is O(N m) per factor). The levels are
built by numba loops that vectorize, the first 13 levels block by block in cache and the others in
place in two scratch arrays (:mod:`chronofuse.analysis.stability.kernels_mtie`; no temporary per level
or per factor: at 1e7 samples the array version allocated ~5 arrays of 80 MB per factor); :func:`mtie_sparse_numpy` is the
same algorithm in numpy and :func:`mtie_windows_raw` the readable brute-force twin, both compared in
the tests.
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from chronofuse.analysis.stability.kernels_differences import SKIP_RULES, check_kernel_inputs, nan_prefix, sum_of_squares
from chronofuse.analysis.stability.kernels_mtie import BLOCK, TOP_LEVEL, mtie_blocked

__all__ = ["tie_rms_raw", "mtie_raw", "mtie_sparse_numpy", "mtie_windows_raw", "max_m_tie_rms", "max_m_mtie"]


def tie_rms_raw(x: np.ndarray, m: np.ndarray, tau0_s: float, gap_rule: str = "samples") -> tuple[np.ndarray, np.ndarray]:
    """Root-mean-square time interval error ``sqrt(mean((x[i+m] - x[i])**2))`` in seconds.

    Parameters
    ----------
    x : ndarray of shape (N,)
        Phase in seconds; NaN marks a missing sample: a difference is skipped when ``x[i]`` or ``x[i+m]`` is
        missing (``gap_rule="samples"``) or when any sample of ``x[i : i + m + 1]`` is (``"span"``).
    m : ndarray of int of shape (k,)
        Averaging factors, ``1 <= m <= max_m_tie_rms(N)``.
    tau0_s : float
        Sample interval in seconds (TIE rms does not depend on it beyond ``tau = m tau0``).
    gap_rule : {"samples", "span"}
        Which differences a missing sample removes.

    Returns
    -------
    dev : ndarray of shape (k,)
        TIE rms in seconds (NaN where no difference is valid).
    n : ndarray of int of shape (k,)
        Number of differences averaged (``N - m`` without gaps).
    """
    x, m, tau0_s = check_kernel_inputs(x, m, tau0_s)
    if gap_rule not in SKIP_RULES:
        raise ValueError(f"gap_rule == {gap_rule!r}, must be one of {list(SKIP_RULES)}")
    dev = np.full(m.size, np.nan)
    n = np.zeros(m.size, dtype=np.int64)
    gaps = bool(np.isnan(x).any())
    prefix = nan_prefix(x) if gaps and gap_rule == "span" else None
    for j, mj in enumerate(m):
        mj = int(mj)
        d = x[mj:] - x[:-mj]
        s = sum_of_squares(d)
        if prefix is not None:
            d = d[prefix[mj + 1 :] == prefix[: x.size - mj]]  # no missing sample in x[i : i + m + 1]
            s = sum_of_squares(d)
        elif gaps:
            d = d[~np.isnan(d)]  # x[i] and x[i+m] both present
            s = sum_of_squares(d)
        n[j] = d.size
        if d.size:
            dev[j] = np.sqrt(s / d.size)
    return dev, n


def _largest_range(hi: np.ndarray, lo: np.ndarray) -> float:
    """``max(hi - lo)`` over windows that hold at least one sample (NaN when none does)."""
    tie = hi - lo
    peak = float(np.max(tie))
    if np.isnan(peak):
        valid = ~np.isnan(tie)
        peak = float(np.max(tie[valid])) if valid.any() else np.nan
    return peak


def mtie_raw(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Maximum time interval error over windows of ``m + 1`` samples, in seconds (sparse table, numba).

    Same definition, shapes and NaN handling as :func:`mtie_sparse_numpy` (its numpy twin).
    """
    x, m, tau0_s = check_kernel_inputs(x, m, tau0_s)
    if m.size and int(m.max()) >= x.size:
        raise ValueError(f"m == {int(m.max())}, must be < N == {x.size}")
    missing = int(np.count_nonzero(np.isnan(x)))
    n = np.full(m.size, x.size - missing, dtype=np.int64)
    window = m + 1
    return mtie_blocked(x, window, np.argsort(window, kind="stable"), missing > 0, BLOCK, TOP_LEVEL), n


def mtie_sparse_numpy(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Maximum time interval error over windows of ``m + 1`` samples, in seconds (sparse table).

    Parameters
    ----------
    x : ndarray of shape (N,)
        Phase in seconds; NaN samples are ignored inside a window (a window of only NaN is skipped).
    m : ndarray of int of shape (k,)
        Averaging factors, ``1 <= m <= max_m_mtie(N)``, in any order.
    tau0_s : float
        Sample interval in seconds.

    Returns
    -------
    dev : ndarray of shape (k,)
        MTIE in seconds.
    n : ndarray of int of shape (k,)
        Number of (non-NaN) phase samples analysed, Stable32's ``#`` column (N without gaps).
    """
    x, m, tau0_s = check_kernel_inputs(x, m, tau0_s)
    if m.size and int(m.max()) >= x.size:
        raise ValueError(f"m == {int(m.max())}, must be < N == {x.size}")
    dev = np.full(m.size, np.nan)
    n = np.full(m.size, int(np.count_nonzero(~np.isnan(x))), dtype=np.int64)
    window = m + 1
    level = np.floor(np.log2(window)).astype(np.int64)
    # hi[i] = max(x[i : i + 2**k]), lo[i] = min(...), NaN ignored (fmax/fmin), length N - 2**k + 1.
    hi, lo, k = x, x, 0
    for j in np.argsort(window, kind="stable"):
        length = int(window[j])
        while k < level[j]:
            half = 1 << k
            hi = np.fmax(hi[:-half], hi[half:])
            lo = np.fmin(lo[:-half], lo[half:])
            k += 1
        # A window [i, i + L) is the union of [i, i + 2**k) and [i + L - 2**k, i + L).
        shift = length - (1 << k)
        count = x.size - length + 1
        win_hi = np.fmax(hi[:count], hi[shift : shift + count])
        win_lo = np.fmin(lo[:count], lo[shift : shift + count])
        dev[j] = _largest_range(win_hi, win_lo)
    return dev, n


def mtie_windows_raw(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Readable twin of :func:`mtie_raw`: scan every window of ``m + 1`` samples (O(N m) per factor).

    Meant for small records (tests); same shapes, definitions and NaN handling as :func:`mtie_raw`.
    """
    x, m, tau0_s = check_kernel_inputs(x, m, tau0_s)
    dev = np.full(m.size, np.nan)
    n = np.full(m.size, int(np.count_nonzero(~np.isnan(x))), dtype=np.int64)
    for j, mj in enumerate(m):
        windows = sliding_window_view(x, int(mj) + 1)  # (N - m, m + 1), a view
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN windows give NaN, skipped below
            tie = np.nanmax(windows, axis=1) - np.nanmin(windows, axis=1)
        valid = ~np.isnan(tie)
        if valid.any():
            dev[j] = np.max(tie[valid])
    return dev, n


def max_m_tie_rms(n_points: int) -> int:
    """Largest TIE rms averaging factor for ``n_points`` phase samples: ``N // 4`` (Stable32)."""
    n_points = int(n_points)
    if n_points < 0:
        raise ValueError(f"n_points == {n_points}, must be >= 0")
    return n_points // 4


def max_m_mtie(n_points: int) -> int:
    """Largest MTIE averaging factor for ``n_points`` phase samples: ``N // 2`` (Stable32)."""
    n_points = int(n_points)
    if n_points < 0:
        raise ValueError(f"n_points == {n_points}, must be >= 0")
    return n_points // 2
