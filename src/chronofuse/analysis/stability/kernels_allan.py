"""Raw kernels of the Allan family: ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV.

Every kernel has the stability-engine signature ``name_raw(x, m, tau0_s) -> (dev, n)``:

- ``x``: phase in seconds, float64 of shape (N,); NaN marks a missing sample;
- ``m``: int64 averaging factors of shape (k,), each within ``1 <= m <= max_m_<name>(N)``;
- ``dev``: float64 (k,), the deviation without bias correction (NaN where no term is valid);
- ``n``: int64 (k,), the number of terms averaged (Stable32's ``#`` column).

All are O(N) per averaging factor: the Allan and Hadamard variances are means of squared binomial
differences of the phase taken at lag ``m``; the modified variance sums ``m`` consecutive second
differences, which is a difference of two cumulative sums. With missing (NaN) samples a term is skipped
by ``gap_rule`` (:data:`~chronofuse.analysis.stability.kernels_differences.SKIP_RULES`): ``"samples"``
(the default: only when one of its own samples is missing) or ``"span"`` (when any sample it spans is);
``n`` counts only the terms kept. An MDEV term reads every sample of ``x[j .. j+3m-1]``, so for MDEV and
TDEV the two rules are the same. Kernels never modify ``x``.

The Allan and Hadamard sums of squared lagged differences come from
:mod:`~chronofuse.analysis.stability.kernels_differences`. The MDEV sum runs here in numba loops over
contiguous slices with reassociated (vectorized) additions (``_mvar_sum_of_squares_fused``); its
readable numpy twin (the blocked ``_mvar_sum_of_squares``) is compared in the tests.

Reference: W. J. Riley, *Handbook of Frequency Stability Analysis*, NIST SP 1065 (2008), section 5.2.
The averaging-factor limits are Stable32's "stop ratios" (``max AF = N // ratio``: 5 for ADEV and HDEV,
4 for OADEV, MDEV, TDEV and OHDEV), W. J. Riley, "The Evolution of Frequency Stability Analysis
Software", Table III.
"""

from __future__ import annotations

import numba
import numpy as np

from chronofuse.analysis.stability.kernels_differences import (
    REASSOC,
    SECOND,
    THIRD,
    SKIP_RULES,
    check_kernel_inputs,
    difference_sum_of_squares_fused,
    difference_sum_of_squares_samples,
    difference_sum_of_squares_span,
    difference_sums_fused,
    lagged_difference,
    nan_prefix,
    sum_of_squares,
)

__all__ = [
    "adev_raw",
    "oadev_raw",
    "mdev_raw",
    "tdev_raw",
    "hdev_raw",
    "ohdev_raw",
    "max_m_adev",
    "max_m_oadev",
    "max_m_mdev",
    "max_m_tdev",
    "max_m_hdev",
    "max_m_ohdev",
    "allan_variance_gap_free",
    "check_gap_rule",
]

# Differences are formed and squared in blocks of this many terms, so they stay in the CPU cache
# (about 2x faster on 1e6 points than forming the whole difference array at once).
_BLOCK = 1 << 15


def allan_variance_gap_free(x: np.ndarray, m: int, overlapping: bool) -> float:
    """AVAR at factor ``m`` in units of ``tau0 = 1`` of a gap-free phase record ``x`` (N,) (no checks:
    for the noise identification, which already holds a validated, gap-filled record); NaN if no term."""
    s, count = difference_sum_of_squares_fused(x, m, SECOND, 1 if overlapping else m)
    return s / (2.0 * count * m * m) if count > 0 else np.nan


def _has_nan(x: np.ndarray) -> bool:
    """Whether ``x`` holds a NaN, by one reduction (no boolean temporary; ``x`` has no infinities)."""
    return bool(np.isnan(np.add.reduce(x))) if x.size else False


def check_gap_rule(gap_rule: str) -> str:
    """``gap_rule`` if it is one of ``SKIP_RULES``, else a ValueError naming it."""
    if gap_rule not in SKIP_RULES:
        raise ValueError(f"gap_rule == {gap_rule!r}, must be one of {list(SKIP_RULES)}")
    return gap_rule


def _difference_variance(
    x: np.ndarray, m: np.ndarray, tau0_s: float, order: int, scale: float, overlapping: bool, gap_rule: str
) -> tuple[np.ndarray, np.ndarray]:
    """``sum d**2 / (scale * n * (m tau0)**2)`` over the lagged differences of ``order`` at each ``m``.

    Overlapping: every start ``i``; non-overlapping: the differences of the phase decimated by ``m``
    (``x[::m]`` at lag 1), i.e. starts ``i = 0, m, 2m, ...``. With gaps, the terms ``gap_rule`` skips are
    left out.
    """
    check_gap_rule(gap_rule)
    # A decimated term can step over a gap without reading it: with gaps, every m uses the span rule.
    # Whether there are gaps is known without a pass of its own when the first factor's terms read every
    # sample (step 1 and N >= (order + 1) m): its sum comes out NaN exactly when there is a gap.
    first_reads_all = m.size and (overlapping or m[0] == 1) and x.size >= (order + 1) * int(m[0])
    sums = counts = None
    if first_reads_all or not _has_nan(x):
        sums, counts = difference_sums_fused(x, m, order, overlapping)
        if counts.size and counts[0] < 0:
            sums = counts = None
    if sums is None:  # gaps: the rule at every factor
        prefix = nan_prefix(x) if gap_rule == "span" else None
        sums = np.empty(m.size)
        counts = np.empty(m.size, dtype=np.int64)
        for j, mj in enumerate(m.tolist()):
            step = 1 if overlapping else mj
            if prefix is None:
                sums[j], counts[j] = difference_sum_of_squares_samples(x, mj, order, step)
            else:
                sums[j], counts[j] = difference_sum_of_squares_span(x, prefix, mj, order, step)
    var = np.full(m.size, np.nan)
    ok = counts > 0
    var[ok] = sums[ok] / (scale * counts[ok] * (m[ok] * tau0_s) ** 2)
    return var, counts


def adev_raw(x: np.ndarray, m: np.ndarray, tau0_s: float, gap_rule: str = "samples") -> tuple[np.ndarray, np.ndarray]:
    """Non-overlapping Allan deviation from phase, NIST SP 1065 eq. (7).

    ``AVAR(tau) = 1 / (2 (N-2) tau**2) * sum_i (x[i+2] - 2 x[i+1] + x[i])**2`` on the phase decimated
    by ``m`` (``x[i]`` taken every ``m`` samples, ``tau = m tau0``); ``n = floor((N-1)/m) - 1`` terms
    without gaps.

    Parameters
    ----------
    x : ndarray of shape (N,)
        Phase in seconds; NaN marks a missing sample (the terms ``gap_rule`` names are skipped).
    m : ndarray of int of shape (k,)
        Averaging factors, ``1 <= m <= max_m_adev(N)``.
    tau0_s : float
        Sample interval in seconds.
    gap_rule : {"samples", "span"}
        Which terms a missing sample removes (module docstring).

    Returns
    -------
    dev : ndarray of shape (k,)
        Allan deviation (dimensionless).
    n : ndarray of int of shape (k,)
        Number of second differences averaged.
    """
    x, m, tau0_s = check_kernel_inputs(x, m, tau0_s)
    var, n = _difference_variance(x, m, tau0_s, SECOND, 2.0, overlapping=False, gap_rule=gap_rule)
    return np.sqrt(var), n


def oadev_raw(x: np.ndarray, m: np.ndarray, tau0_s: float, gap_rule: str = "samples") -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Allan deviation from phase, NIST SP 1065 eq. (11).

    ``AVAR(m tau0) = 1 / (2 (m tau0)**2 (N-2m)) * sum_{i=1}^{N-2m} (x[i+2m] - 2 x[i+m] + x[i])**2``;
    ``n = N - 2m`` terms without gaps. Shapes as in :func:`adev_raw`.
    """
    x, m, tau0_s = check_kernel_inputs(x, m, tau0_s)
    var, n = _difference_variance(x, m, tau0_s, SECOND, 2.0, overlapping=True, gap_rule=gap_rule)
    return np.sqrt(var), n


def hdev_raw(x: np.ndarray, m: np.ndarray, tau0_s: float, gap_rule: str = "samples") -> tuple[np.ndarray, np.ndarray]:
    """Non-overlapping Hadamard deviation from phase, NIST SP 1065 eq. (18).

    ``HVAR(tau) = 1 / (6 tau**2 (N-3)) * sum_i (x[i+3] - 3 x[i+2] + 3 x[i+1] - x[i])**2`` on the phase
    decimated by ``m`` (``tau = m tau0``); ``n = floor((N-1)/m) - 2`` terms without gaps. Shapes as in
    :func:`adev_raw`.
    """
    x, m, tau0_s = check_kernel_inputs(x, m, tau0_s)
    var, n = _difference_variance(x, m, tau0_s, THIRD, 6.0, overlapping=False, gap_rule=gap_rule)
    return np.sqrt(var), n


def ohdev_raw(x: np.ndarray, m: np.ndarray, tau0_s: float, gap_rule: str = "samples") -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Hadamard deviation from phase, NIST SP 1065 eq. (20).

    ``HVAR(m tau0) = 1 / (6 (m tau0)**2 (N-3m)) * sum_{i=1}^{N-3m} (x[i+3m] - 3 x[i+2m] + 3 x[i+m] - x[i])**2``;
    ``n = N - 3m`` terms without gaps. Shapes as in :func:`adev_raw`.
    """
    x, m, tau0_s = check_kernel_inputs(x, m, tau0_s)
    var, n = _difference_variance(x, m, tau0_s, THIRD, 6.0, overlapping=True, gap_rule=gap_rule)
    return np.sqrt(var), n


def _window_sums(d: np.ndarray, m: int) -> np.ndarray:
    """Sums of ``m`` consecutive entries of ``d`` (L,), shape (max(L-m+1, 0),), from one cumulative sum."""
    if d.size < m:
        return np.empty(0)
    c = np.cumsum(d)
    sums = np.empty(d.size - m + 1)
    sums[0] = c[m - 1]
    np.subtract(c[m:], c[:-m], out=sums[1:])
    return sums


def _mvar_terms_with_gaps(x: np.ndarray, m: int) -> np.ndarray:
    """The valid MDEV terms ``sum_{i=j}^{j+m-1} (x[i+2m] - 2 x[i+m] + x[i])`` of ``x`` (N,) with NaN, shape (n,).

    With the second differences ``d`` (N-2m,), each term is a window sum of ``m`` of them (a difference
    of two cumulative sums); a term is kept only when none of its ``m`` differences is NaN, i.e. when
    none of the samples ``x[j .. j+3m-1]`` it spans is missing.
    """
    d = lagged_difference(x, m, SECOND)
    bad = np.isnan(d)
    terms = _window_sums(np.where(bad, 0.0, d), m)
    return terms[_window_sums(bad.astype(np.float64), m) == 0.0]


def _mvar_sum_of_squares(x: np.ndarray, m: int, work: np.ndarray, cumulative: np.ndarray) -> tuple[float, int]:
    """Sum of squared MDEV terms of gap-free ``x`` (N,) and their number ``N - 3m + 1`` (NaN sum if gaps).

    With the second differences ``d[i] = x[i+2m] - 2 x[i+m] + x[i]`` and their cumulative sum ``C``
    (``C[0] = 0``, into ``cumulative``, shape (>= N,)), each term ``S_j = sum_{i=j}^{j+m-1} d[i]`` is
    ``C[j+m] - C[j]``. Summing the small differences (not the phase) and differencing the sums keeps each
    term's rounding to that of its own ``m`` differences; the running-sum update
    ``S_{j+1} = S_j + third difference`` (allantools) instead lets rounding random-walk over the whole
    record, visibly so on a phase ramp (Stable32's OCXO tables). Both passes go block by block in ``work``
    (2, _BLOCK) so the differences stay in the CPU cache.
    """
    n_diff = x.size - 2 * m
    n_terms = n_diff - m + 1
    if n_terms <= 0:
        return 0.0, 0
    c = cumulative[: n_diff + 1]
    c[0] = carry = 0.0
    for start in range(0, n_diff, _BLOCK):
        stop = min(start + _BLOCK, n_diff)
        d = lagged_difference(x[start : stop + 2 * m], m, SECOND, work)
        block = c[start + 1 : stop + 1]
        np.cumsum(d, out=block)
        block += carry
        carry = float(block[-1])
    total = 0.0
    for start in range(0, n_terms, _BLOCK):
        stop = min(start + _BLOCK, n_terms)
        terms = np.subtract(c[start + m : stop + m], c[start:stop], out=work[0, : stop - start])
        total += sum_of_squares(terms)
    return total, n_terms


@numba.njit(cache=True, nogil=True)
def _mvar_cumulative(x: np.ndarray, m: int, c: np.ndarray) -> int:
    """``c[0] = 0``, ``c[i+1] = c[i] + (x[i+2m] - 2 x[i+m] + x[i])``: the running sum of the second
    differences, strictly left to right (no reassociation here); returns their number ``N - 2m``."""
    n_diff = x.size - 2 * m
    c[0] = 0.0
    a, b, e = x[2 * m : 2 * m + n_diff], x[m : m + n_diff], x[:n_diff]
    for i in range(n_diff):
        c[i + 1] = c[i] + (a[i] - 2.0 * b[i] + e[i])
    return n_diff


@numba.njit(cache=True, nogil=True, fastmath=REASSOC)
def _window_square_sum(c: np.ndarray, m: int, n_terms: int) -> float:
    """``sum_j (c[j+m] - c[j])**2`` for ``j < n_terms`` (slices; the sum vectorizes)."""
    hi, lo = c[m : m + n_terms], c[:n_terms]
    total = 0.0
    for j in range(n_terms):
        t = hi[j] - lo[j]
        total += t * t
    return total


def _mvar_sum_of_squares_fused(x: np.ndarray, m: int, cumulative: np.ndarray) -> tuple[float, int]:
    """The numba twin of :func:`_mvar_sum_of_squares` (same algorithm: running sum of the second
    differences, then differences of that sum), without blocks or temporaries."""
    n_terms = x.size - 3 * m + 1
    if n_terms <= 0:
        return 0.0, 0
    _mvar_cumulative(x, m, cumulative)
    return _window_square_sum(cumulative, m, n_terms), n_terms


def _mvar(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Modified Allan variance (k,) and term counts (k,), NIST SP 1065 eq. (14), O(N) per factor.

    Gap-free records take the blocked form (:func:`_mvar_sum_of_squares`); a record with NaN falls back
    to :func:`_mvar_terms_with_gaps`, which skips every term spanning a missing sample.
    """
    var = np.full(m.size, np.nan)
    n = np.zeros(m.size, dtype=np.int64)
    cumulative = np.empty(x.size + 1)
    for j, mj in enumerate(m):
        mj = int(mj)
        s, count = _mvar_sum_of_squares_fused(x, mj, cumulative)
        if np.isnan(s):
            terms = _mvar_terms_with_gaps(x, mj)
            s, count = sum_of_squares(terms), int(terms.size)
        n[j] = count
        if count > 0:
            tau_s = mj * tau0_s
            var[j] = s / (2.0 * mj**2 * tau_s**2 * count)
    return var, n


def mdev_raw(x: np.ndarray, m: np.ndarray, tau0_s: float, gap_rule: str = "samples") -> tuple[np.ndarray, np.ndarray]:
    """Modified Allan deviation from phase, NIST SP 1065 eq. (14).

    ``MVAR(tau) = 1 / (2 m**2 tau**2 (N-3m+1)) * sum_{j=1}^{N-3m+1} [sum_{i=j}^{j+m-1} (x[i+2m] - 2 x[i+m] + x[i])]**2``
    with ``tau = m tau0``; ``n = N - 3m + 1`` terms without gaps (a term spans ``x[j .. j+3m-1]``).
    Shapes as in :func:`adev_raw`; both gap rules skip the same terms (a term reads all its 3m samples).
    """
    x, m, tau0_s = check_kernel_inputs(x, m, tau0_s)
    check_gap_rule(gap_rule)
    var, n = _mvar(x, m, tau0_s)
    return np.sqrt(var), n


def tdev_raw(x: np.ndarray, m: np.ndarray, tau0_s: float, gap_rule: str = "samples") -> tuple[np.ndarray, np.ndarray]:
    """Time deviation in seconds, NIST SP 1065 eq. (15): ``TDEV(tau) = tau / sqrt(3) * MDEV(tau)``.

    Same terms and ``n`` as :func:`mdev_raw`; shapes as in :func:`adev_raw`.
    """
    x, m, tau0_s = check_kernel_inputs(x, m, tau0_s)
    check_gap_rule(gap_rule)
    var, n = _mvar(x, m, tau0_s)
    tau_s = m * tau0_s
    return tau_s / np.sqrt(3.0) * np.sqrt(var), n


def _max_m(n_points: int, stop_ratio: int) -> int:
    """Stable32's largest averaging factor, ``N // stop_ratio`` (0 when no factor is valid)."""
    n_points = int(n_points)
    if n_points < 0:
        raise ValueError(f"n_points == {n_points}, must be >= 0")
    return n_points // stop_ratio


def max_m_adev(n_points: int) -> int:
    """Largest ADEV averaging factor for ``n_points`` phase samples: ``N // 5`` (Stable32)."""
    return _max_m(n_points, 5)


def max_m_oadev(n_points: int) -> int:
    """Largest OADEV averaging factor for ``n_points`` phase samples: ``N // 4`` (Stable32)."""
    return _max_m(n_points, 4)


def max_m_mdev(n_points: int) -> int:
    """Largest MDEV averaging factor for ``n_points`` phase samples: ``N // 4`` (Stable32)."""
    return _max_m(n_points, 4)


def max_m_tdev(n_points: int) -> int:
    """Largest TDEV averaging factor for ``n_points`` phase samples: ``N // 4`` (Stable32)."""
    return _max_m(n_points, 4)


def max_m_hdev(n_points: int) -> int:
    """Largest HDEV averaging factor for ``n_points`` phase samples: ``N // 5`` (Stable32)."""
    return _max_m(n_points, 5)


def max_m_ohdev(n_points: int) -> int:
    """Largest OHDEV averaging factor for ``n_points`` phase samples: ``N // 4`` (Stable32)."""
    return _max_m(n_points, 4)
