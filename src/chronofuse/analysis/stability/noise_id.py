"""Power-law noise identification, as Stable32 does it.

For each averaging factor ``m`` the dominant power-law exponent ``alpha`` of the fractional-frequency
spectrum, ``S_y(f) ~ f**alpha``, is identified as an integer in -2..2 (Stable32's ``Alpha`` column):

1. **Lag-1 autocorrelation** (W. J. Riley and C. A. Greenhall, "Power law noise identification using
   the lag 1 autocorrelation", Proc. 18th EFTF, 2004), used when the record holds at least
   ``MIN_ACF_POINTS`` (30) frequency averages at this ``m``. The phase is turned into its ``m``-sample
   frequency averages ``z[k] = (x[(k+1)m] - x[km]) / (m tau0)`` (non-overlapped), a linear frequency
   drift is removed, and the series is differenced ``d`` times until ``delta = r1 / (1 + r1) < 0.25``
   (stationary) or ``d`` reaches ``dmax`` (2 for the Allan family, 3 for the Hadamard family);
   then ``alpha = -2 (delta + d)`` (frequency data, theta = 0), rounded to the nearest integer
   (Riley & Greenhall eqs. (2)-(6)).
2. **B1 ratio with R(n)** (J. A. Barnes, "Tables of bias functions B1 and B2", NBS TN 375, 1969;
   D. A. Howe et al., SP 1065 section 5.6), the fallback for shorter records: ``B1 = s**2 / AVAR``
   (classical variance of the ``m``-averages over the non-overlapped Allan variance) is compared with
   its expectation ``B1(N, mu)`` for each noise type, the boundaries being geometric means of
   neighbouring expectations; B1 cannot tell white from flicker PM (both ``mu = -2``), so R(n) =
   MVAR / AVAR decides between them. The AVAR in B1 is the overlapping one for the overlapping and total
   statistics (non-overlapped for ADEV and HDEV): with ~10 averages the non-overlapped AVAR alone
   scatters B1 across a boundary (SP 1065's white-FM 1000-point set at m = 100: 0.68, flicker PM; with
   the overlapping AVAR 0.98, white FM, which gives SP 1065's published HTOTDEV there).

Reproduction of Stable32 (tests/analysis/test_noise_id.py): every ``Alpha`` entry of every Stable32
table in ``tests/data/stability`` whose row has at least 30 frequency averages is reproduced exactly
(phasedat, ocxo, gps and Cs5071A, all statistics of the Allan, Hadamard and total families). Working on
frequency averages with a linear detrend matters: identifying on the decimated phase with a quadratic
detrend (allantools' choice) gives alpha = 2 instead of Stable32's 0 at m = 10000 of the Cs5071A record.
The B1/R(n) rows (fewer than 30 averages) are not all reproduced (33 of 75): Stable32's small-sample procedure is
not documented beyond "B1 and R(n)", and its answers even differ between ADEV and OADEV at the same
``m`` of the same record (ocxo m = 1024: -2 and -1), which no single B1 rule gives. The Cs5071A TOTDEV
table reports alpha = 0 at every row (also where ADEV on the same data reports 2 and 1), and the
PHASE.DAT HTOTDEV "nobias" table reports 2 everywhere: both look like a fixed alpha chosen in
Stable32, not an identification, and are not reproduced.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from chronofuse.analysis.stability.convert import fill_gaps
from chronofuse.analysis.stability.kernels_allan import _mvar_sum_of_squares_fused, allan_variance_gap_free
from chronofuse.analysis.stability.kernels_differences import SECOND, difference_sum_of_squares_fused, sum_of_squares
from chronofuse.analysis.stability.noise_acf import DELTA_STATIONARY, MIN_ACF_POINTS, NO_ACF, acf_alphas

__all__ = [
    "MIN_ACF_POINTS",
    "frequency_averages",
    "lag1_autocorrelation",
    "acf_noise_id",
    "acf_noise_id_fast",
    "b1_noise_id",
    "b1_expected",
    "identify_noise",
    "identify_noise_methods",
    "acf_noise_id_gaps",
]

def frequency_averages(x: np.ndarray, m: int) -> np.ndarray:
    """Non-overlapped ``m``-sample frequency averages of phase ``x`` (N,), in units of 1/tau0.

    ``z[k] = (x[(k+1) m] - x[k m]) / m`` for ``k = 0 .. floor((N-1)/m) - 1`` (the mean of ``m``
    consecutive first differences; the 1/tau0 scale does not matter to any ratio used here).
    """
    xd = x[::m]
    return (xd[1:] - xd[:-1]) / m  # np.diff(xd) / m, without np.diff's call overhead


def lag1_autocorrelation(z: np.ndarray) -> float:
    """Lag-1 autocorrelation ``r1 = sum (z_i - zbar)(z_{i+1} - zbar) / sum (z_i - zbar)**2``.

    Riley & Greenhall (2004) eq. (2); ``z`` of shape (n,), n >= 2.
    """
    zc = z - z.mean()
    den = sum_of_squares(zc)
    if den == 0.0:
        return 0.0
    return float(np.einsum("i,i->", zc[:-1], zc[1:])) / den


def _remove_linear(z: np.ndarray) -> np.ndarray:
    """Residual of ``z`` (n,) after a least-squares straight line (frequency offset and drift).

    Closed form on the centred abscissa ``t_k = k - (n-1)/2``: ``slope = sum t z / sum t**2``,
    ``intercept = mean(z)`` (``sum t**2 = n (n**2 - 1) / 12``).
    """
    n = z.size
    t = np.arange(n, dtype=float) - 0.5 * (n - 1)
    slope = float(np.einsum("i,i->", t, z)) / (n * (n * n - 1.0) / 12.0) if n > 1 else 0.0
    return z - z.mean() - slope * t


def acf_noise_id(x: np.ndarray, m: int, dmax: int) -> int | None:
    """Lag-1 autocorrelation noise identification at averaging factor ``m``.

    Parameters
    ----------
    x : ndarray of shape (N,)
        Gap-free phase.
    m : int
        Averaging factor.
    dmax : int
        Largest number of differences (2: Allan family, 3: Hadamard family).

    Returns
    -------
    int or None
        ``alpha`` rounded to an integer (not yet clipped to -2..2), or None when there are fewer than
        ``MIN_ACF_POINTS`` frequency averages.
    """
    z = frequency_averages(x, m)
    if z.size < MIN_ACF_POINTS:
        return None
    z = _remove_linear(z)
    d = 0
    while True:
        r1 = lag1_autocorrelation(z)
        delta = r1 / (1.0 + r1)
        if delta < DELTA_STATIONARY or d >= dmax:
            # p = -2 (delta + d) is the spectral exponent of frequency data: alpha = p (theta = 0).
            return int(-np.round(2.0 * delta)) - 2 * d
        z = np.diff(z)
        d += 1


def acf_noise_id_gaps(x: np.ndarray, m: int, dmax: int) -> int | None:
    """:func:`acf_noise_id` on phase with missing (NaN) samples, from the frequency averages that exist.

    An average ``z[k] = (x[(k+1) m] - x[k m]) / m`` needs its two end samples (the "samples" rule); the
    linear detrend is fitted to the averages present, each difference needs both of its operands, and the
    lag-1 autocorrelation is the mean product of the neighbouring pairs present over the mean square of
    the averages present (Riley & Greenhall eq. (2), which is the same without gaps). Interpolating across a gap instead draws a straight line into the record, which the ACF reads
    as low-frequency noise (white PM behind 10 % of 400-sample gaps came out as flicker PM at m = 64).
    Returns None with fewer than ``MIN_ACF_POINTS`` averages present.
    """
    z = frequency_averages(x, m)
    ok = ~np.isnan(z)
    if np.count_nonzero(ok) < MIN_ACF_POINTS:
        return None
    t = np.arange(z.size, dtype=float)
    slope, intercept = np.polyfit(t[ok], z[ok], 1)
    z = z - (intercept + slope * t)
    d = 0
    while True:
        zc = z - np.nanmean(z)
        ok = ~np.isnan(zc)
        prod = zc[:-1] * zc[1:]
        pairs = np.count_nonzero(~np.isnan(prod))
        # Mean lag-1 product over the pairs present against the mean square over the averages present
        # (with gaps there are fewer pairs than averages: summing both would pull r1 towards 0).
        den = float(np.nansum(zc * zc)) / max(np.count_nonzero(ok), 1)
        r1 = float(np.nansum(prod)) / pairs / den if den > 0 and pairs else 0.0
        delta = r1 / (1.0 + r1)
        if delta < DELTA_STATIONARY or d >= dmax:
            return int(-np.round(2.0 * delta)) - 2 * d
        z = z[1:] - z[:-1]
        d += 1


def acf_noise_id_fast(x: np.ndarray, m: int, dmax: int) -> int | None:
    """:func:`acf_noise_id` with the differencing and detrending fused into numba passes per ``d``.

    Same result (the tests compare the two); :func:`identify_noise_methods` calls its kernel once for all
    factors, where the readable twin's array passes (``np.diff``, the detrend, two dot products) and a
    Python call per factor dominated the public call's time.
    """
    alpha = int(acf_alphas(np.ascontiguousarray(x, dtype=np.float64), np.array([m], dtype=np.int64), dmax)[0])
    return None if alpha == NO_ACF else alpha


def b1_expected(n: int, mu: int) -> float:
    """Expected B1 ratio for ``n`` frequency averages and AVAR tau-exponent ``mu``.

    Barnes (1969); D. A. Howe, "The total deviation approach to long-term characterization of frequency
    stability", IEEE UFFC 47 (2000), Table 3: ``B1 = n (1 - n**mu) / (2 (n-1) (1 - 2**mu))``, whose
    ``mu -> 0`` limit is ``n ln n / (2 (n-1) ln 2)`` (it gives 1 at ``mu = -1``, ``n/2`` at ``mu = 1``).
    """
    n = float(n)
    if mu == 0:
        return n * math.log(n) / (2.0 * (n - 1.0) * math.log(2.0))
    return n * (1.0 - n**mu) / (2.0 * (n - 1.0) * (1.0 - 2.0**mu))


@numba.njit(cache=True, nogil=True, inline="always")
def _b1_expected_nb(n: float, mu: int) -> float:
    """:func:`b1_expected` in numba (the same expression)."""
    if mu == 0:
        return n * math.log(n) / (2.0 * (n - 1.0) * math.log(2.0))
    return n * (1.0 - n**mu) / (2.0 * (n - 1.0) * (1.0 - 2.0**mu))


@numba.njit(cache=True, nogil=True)
def b1_choice(x: np.ndarray, m: int, overlapping: bool) -> int:
    """The B1 step of :func:`b1_noise_id` in one numba call: the index (0..3) of the AVAR tau-exponent
    ``mu = -2, -1, 0, 1`` whose expected B1 (:func:`b1_expected`) lies nearest the record's B1 on a log scale
    (boundaries at the geometric means), or -1 with fewer than 3 frequency averages or no Allan term. B1 is
    the sample variance of the ``m``-sample frequency averages over the Allan variance (overlapping or not).
    Its readable twin is :func:`b1_ratio` (the tests compare); at 1e4 points the array version took 5 us of
    the public call per factor identified by B1."""
    n = (x.size - 1) // m
    if n < 3:
        return -1
    s, count = difference_sum_of_squares_fused(x, m, SECOND, 1 if overlapping else m)
    if count <= 0:
        return -1
    avar = s / (2.0 * count * m * m)
    if not math.isfinite(avar) or avar == 0.0:
        return -1
    total = 0.0
    for k in range(n):
        total += (x[(k + 1) * m] - x[k * m]) / m
    mean = total / n
    ss = 0.0
    for k in range(n):
        c = (x[(k + 1) * m] - x[k * m]) / m - mean
        ss += c * c
    b1 = ss / (n - 1) / avar
    chosen = 0
    previous = _b1_expected_nb(float(n), -2)
    for k in range(1, 4):
        current = _b1_expected_nb(float(n), k - 2)
        if b1 > math.sqrt(previous * current):
            chosen = k
        previous = current
    return chosen


def b1_ratio(x: np.ndarray, m: int, overlapping: bool = False) -> float | None:
    """B1 = sample variance of the ``m``-sample frequency averages / AVAR, as numpy arrays (the twin of
    :func:`b1_choice`); None with fewer than 3 averages or no Allan term."""
    z = frequency_averages(x, m)
    n = z.size
    if n < 3:
        return None
    avar = allan_variance_gap_free(x, m, overlapping)
    if not math.isfinite(avar) or avar == 0.0:
        return None
    zc = z - np.add.reduce(z) / n
    return float(np.add.reduce(zc * zc)) / (n - 1) / avar


def _rn_expected(m: int, alpha: int) -> float:
    """Expected R(n) = MVAR / AVAR at averaging factor ``m`` (SP 1065 section 5.6; IEEE 1139-2008).

    White PM: ``1/m``; flicker PM: ratio of the flicker-PM MVAR and AVAR coefficients with the
    measurement bandwidth ``f_h = 1/(2 tau0)``.
    """
    if alpha == 2:
        return 1.0 / m
    avar = (1.038 + 3.0 * np.log(2.0 * np.pi * 0.5 * m)) / (4.0 * np.pi**2)
    mvar = 3.0 * np.log(256.0 / 27.0) / (8.0 * np.pi**2)
    return mvar / avar


def _rn(x: np.ndarray, m: int) -> float:
    """R(n) = MVAR / OAVAR at factor ``m`` of a gap-free ``x`` from the kernels' numba sums directly (the
    public kernels' input checks and allocations were most of a B1 call at 1e4 points); equal to
    ``mdev_raw(x, [m])**2 / oadev_raw(x, [m])**2`` (the tests compare)."""
    msum, mcount = _mvar_sum_of_squares_fused(x, m, np.empty(x.size + 1))
    asum, acount = difference_sum_of_squares_fused(x, m, SECOND, 1)
    mvar = msum / (2.0 * m**4 * mcount)
    oavar = asum / (2.0 * m * m * acount)
    return mvar / oavar


def b1_noise_id(x: np.ndarray, m: int, overlapping: bool = False) -> int | None:
    """B1-ratio noise identification with R(n) to separate white and flicker PM.

    ``x`` (N,) gap-free phase; returns ``alpha`` in -2..2, or None when fewer than 2 frequency averages
    (or no Allan term) exist at this ``m``. ``overlapping``: the Allan variance in the ratio is the
    overlapping one (for the overlapping and total statistics; Stable32's B1 answers differ between ADEV
    and OADEV at the same ``m``, as the variance it divides by does). With n = 10 averages the
    non-overlapped AVAR has about 9 degrees of freedom and its scatter alone moves B1 across the
    white-PM/white-FM boundary: on SP 1065's white-FM 1000-point set at m = 100 it gives B1 = 0.68
    (flicker PM) where the overlapping AVAR gives 0.98 (white FM).
    """
    chosen = b1_choice(np.ascontiguousarray(x, dtype=np.float64), int(m), bool(overlapping))
    if chosen < 0:
        return None
    # (AVAR tau-exponent mu, alpha), SP 1065 Table 3: white/flicker PM (-2, decided below by R(n)),
    # white FM (-1), flicker FM (0), random walk FM (1).
    candidates = [(-2, None), (-1, 0), (0, -1), (1, -2)]
    alpha = candidates[chosen][1]
    if alpha is not None:
        return alpha
    # mu == -2: white (alpha 2) or flicker (alpha 1) PM, told apart by R(n) = MVAR / OAVAR.
    if 3 * m > x.size - 1:
        return 2
    rn = _rn(x, m)
    return 1 if rn > np.sqrt(_rn_expected(m, 2) * _rn_expected(m, 1)) else 2


def identify_noise_methods(
    x: np.ndarray, m: np.ndarray, dmax: int = 2, overlapping: bool = False, *, gaps: bool | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Identify the power-law noise ``alpha`` (integer, -2..2) at each averaging factor.

    Parameters
    ----------
    x : ndarray of shape (N,)
        Phase; NaN marks a missing sample. With gaps the lag-1 ACF uses the frequency averages present
        (:func:`acf_noise_id_gaps`) and the B1 fallback the record with its gaps interpolated.
    m : ndarray of int of shape (k,)
        Averaging factors.
    dmax : int
        2 for the Allan and total families, 3 for the Hadamard family.
    overlapping : bool
        The B1 fallback divides by the overlapping Allan variance (see :func:`b1_noise_id`).
    gaps : bool, optional
        Whether ``x`` holds a NaN, when the caller already knows (the engine does); found here otherwise.

    Returns
    -------
    alpha : ndarray of int64 of shape (k,)
        Lag-1 ACF where at least 30 frequency averages exist, else B1/R(n). Where neither applies
        (fewer than 3 averages, e.g. MTIE windows near the record length), the value identified at
        the largest identifiable averaging factor is held (0, white FM, if there is none).
    method : ndarray of str of shape (k,)
        How each alpha was found: ``"acf"``, ``"b1"`` or ``"held"``. Stable32 agrees with ``"acf"`` rows;
        its B1 rows are not always reproducible (see the tests), so intervals there are less certain.
    """
    m = np.asarray(m, dtype=np.int64)
    alpha = np.zeros(m.size, dtype=np.int64)
    method = np.full(m.size, "held", dtype="<U4")
    x = np.ascontiguousarray(x, dtype=np.float64)
    if np.isnan(np.add.reduce(x)) if gaps is None else gaps:
        by_acf = np.array([NO_ACF if (a := acf_noise_id_gaps(x, int(mj), dmax)) is None else a for mj in m],
                          dtype=np.int64)
        x = fill_gaps(x)[0]
    else:
        by_acf = acf_alphas(x, m, dmax)
    known = by_acf != NO_ACF
    method[known] = "acf"
    alpha[known] = np.minimum(np.maximum(by_acf[known], -2), 2)  # np.clip's dispatch cost 5 us here
    for j in np.flatnonzero(~known):  # too few averages for the ACF: B1/R(n)
        a = b1_noise_id(x, int(m[j]), overlapping)
        if a is not None:
            method[j] = "b1"
            alpha[j] = min(max(int(a), -2), 2)
            known[j] = True
    if not known.all():
        held = 0
        order = np.argsort(m, kind="stable")
        for j in order:
            if known[j]:
                held = alpha[j]
            else:
                alpha[j] = held
    return alpha, method


def identify_noise(x: np.ndarray, m: np.ndarray, dmax: int = 2) -> np.ndarray:
    """The ``alpha`` of :func:`identify_noise_methods` (int64, shape (k,))."""
    return identify_noise_methods(x, m, dmax)[0]
