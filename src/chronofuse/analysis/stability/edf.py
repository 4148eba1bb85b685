"""Equivalent degrees of freedom (EDF) of the stability variances, and chi-square confidence intervals.

- ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV: C. A. Greenhall and W. J. Riley, "Uncertainty of stability
  variances based on finite differences", Proc. 35th PTTI (2003) ("Greenhall" below): the general
  algorithm, eqs. (7)-(13) and Tables 1-3, for power-law noise ``S_y(f) ~ f**alpha``. For white PM
  (``alpha = 2``) with an unmodified variance the EDF is computed exactly from the finite sum over the
  lag correlations of the binomial difference filter; where Greenhall gives a closed form (``ceil(M/S)
  > d``) the two are the same expression, and this sum also covers ``ceil(M/S) <= d``.
- TOTDEV: NIST SP 1065 (W. J. Riley, 2008) Table 7, ``edf = b (T/tau) - c`` for white, flicker and
  random-walk FM; for white and flicker PM (not in Table 7) the simple ADEV formulas of SP 1065
  Table 5, which is what Stable32 uses there (GPS 1PPS table, alpha = 2 and 1 rows).
- MTOTDEV, TTOTDEV: Greenhall's MDEV EDF. Stable32's PHASE.DAT MTOTDEV and TTOTDEV bounds at
  m = 1..8 are exactly those of the MDEV EDF, not those of SP 1065 Table 8 (``b T/tau - c``: 1100
  degrees of freedom at m = 1 where Stable32 implies 791). At m = 16 and 32 Stable32 implies an EDF
  about 1.4 times the MDEV one, from a rule that neither Greenhall nor Table 8 gives: not reproduced
  (the interval here is wider there, i.e. conservative).
- HTOTDEV: Greenhall's OHDEV EDF (HTOTVAR is the overlapping Hadamard variance of a reflected record,
  so its EDF is at least that of OHVAR: the interval is conservative). Stable32's HTOTDEV EDF is
  10-50 % larger on PHASE.DAT and follows no published formula found: not reproduced.
- Theo1: SP 1065, Theo1 section (D. A. Howe and T. N. Tasset, "Theo1: characterization of very
  long-term frequency stability", Proc. EFTF 2004), with ``r = tau/tau0 = 0.75 m``; checked by Monte
  Carlo in the tests (no Stable32 table).

``T/tau`` is taken as ``N/m`` with ``N`` phase points, which is what Stable32 does (its TOTDEV bounds
for PHASE.DAT are reproduced with ``N = 1001``, not 1000).

Confidence interval (SP 1065 eq. (45)): ``lo = dev sqrt(edf / chi2.ppf((1+ci)/2, edf))``,
``hi = dev sqrt(edf / chi2.ppf((1-ci)/2, edf))``.

How close Stable32 is (tests/analysis/test_edf.py): with the same alpha, Stable32's Min/Max Sigma of
all six Greenhall statistics, TOTDEV and MTOTDEV/TTOTDEV (m <= 8) agree with these EDFs to within a
relative 6e-4 on the bounds, but not to the printed 5 digits. Where the EDF exceeds about 100,
Stable32's bounds are the exact chi-square bounds at ci = 0.680 instead of the 0.683 its header states
(68 of 78 such rows to printed precision, the rest within 2 units of the last digit): its large-EDF
branch evidently uses 68 %. Where the EDF is below 100, its bounds imply an EDF 0.1 % above
Greenhall's, which no simple change of ci or EDF reproduces (its own chi-square routine, presumably).
The published algorithm with the caller's ci is implemented here, not those offsets. Stable32's MTOTDEV
EDF beyond m = 8 and its HTOTDEV EDF are not reproduced (see above).

The table-based EDFs (simple ADEV, TOTDEV, the total family, Theo1) are in
:mod:`chronofuse.analysis.stability.edf_tables`; this module holds Greenhall's algorithm and the interval,
and its basic sum (eq. (10)) runs in one numba call (:mod:`chronofuse.analysis.stability.kernels_edf`),
with :func:`_basic_sum` its numpy twin.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import gammaincinv

from chronofuse.analysis.stability.kernels_edf import basic_sums, greenhall_rows

__all__ = ["greenhall_edf", "chi2_interval", "GREENHALL_PARAMETERS"]

# (d, overlapping, modified) of each Greenhall-family statistic: d = 2 Allan, d = 3 Hadamard.
GREENHALL_PARAMETERS = {
    "adev": (2, False, False),
    "oadev": (2, True, False),
    "mdev": (2, True, True),
    "tdev": (2, True, True),
    "hdev": (3, False, False),
    "ohdev": (3, True, False),
}

_J_MAX = 100  # Greenhall section 5: the sum is truncated to J_max terms beyond which tables apply.

# Greenhall Table 1 (modified variances, case 1.2): (a0, a1) by alpha (rows 2..-4) and d (columns 1..3).
_TABLE1 = {
    2: [(2.0 / 3.0, 1.0 / 3.0), (7.0 / 9.0, 1.0 / 2.0), (22.0 / 25.0, 2.0 / 3.0)],
    1: [(0.840, 0.345), (0.997, 0.616), (1.141, 0.843)],
    0: [(1.079, 0.368), (1.033, 0.607), (1.184, 0.848)],
    -1: [(None, None), (1.048, 0.534), (1.180, 0.816)],
    -2: [(None, None), (1.302, 0.535), (1.175, 0.777)],
    -3: [(None, None), (None, None), (1.194, 0.703)],
    -4: [(None, None), (None, None), (1.489, 0.702)],
}
# Greenhall Table 2 (unmodified variances, cases 2.2 and 3.2): (a0, a1).
_TABLE2 = {
    2: [(3.0 / 2.0, 1.0 / 2.0), (35.0 / 18.0, 1.0), (231.0 / 100.0, 3.0 / 2.0)],
    1: [(78.6, 25.2), (790.0, 410.0), (9950.0, 6520.0)],
    0: [(2.0 / 3.0, 1.0 / 6.0), (2.0 / 3.0, 1.0 / 3.0), (7.0 / 9.0, 1.0 / 2.0)],
    -1: [(None, None), (0.852, 0.375), (0.997, 0.617)],
    -2: [(None, None), (1.079, 0.368), (1.033, 0.607)],
    -3: [(None, None), (None, None), (1.053, 0.553)],
    -4: [(None, None), (None, None), (1.302, 0.535)],
}
# Greenhall Table 3 (flicker PM, unmodified, case 3.2/3.3): (b0, b1) by d.
_TABLE3 = [(6.0, 4.0), (15.23, 12.0), (47.8, 40.0)]
_TABLE3_ARRAY = np.array(_TABLE3)


# Greenhall Tables 1-3 as arrays indexed [2 - alpha, d - 1] (NaN where the table has no entry).
def _table_array(table: dict) -> np.ndarray:
    out = np.full((7, 3, 2), np.nan)
    for alpha, row in table.items():
        for j, (a0, a1) in enumerate(row):
            if a0 is not None:
                out[2 - alpha, j] = (a0, a1)
    return out


_TABLE1_ARRAY = _table_array(_TABLE1)
_TABLE2_ARRAY = _table_array(_TABLE2)


# sw(t) of eq. (7) is sign |t|**p (ln|t| for odd alpha), p = 3 - alpha; by row 2 - alpha (alpha = 2..-4).
_SW_SIGN = np.array([-1.0, 1.0, 1.0, -1.0, -1.0, 1.0, 1.0])
_SW_LOG = np.array([False, True, False, True, False, True, False])
_TINY = np.finfo(float).tiny  # ln(tiny) is finite: |t|**p ln|t| stays 0 at t = 0


def _sw(t: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Greenhall eq. (7): the generalized autocovariance kernel ``sw(t)`` of power-law noise.

    ``sw = -|t|, t**2 ln|t|, |t|**3, -t**4 ln|t|, -|t|**5, t**6 ln|t|, |t|**7`` for ``alpha = 2 .. -4``
    (``t**p ln|t| -> 0`` at ``t = 0``). ``t`` of shape (..., k, T, K) and the integer ``alpha`` of shape
    (k, 1, 1) (one alpha per row of arguments) broadcast together.
    """
    row = 2 - alpha
    a = np.abs(t)
    out = a ** (3.0 - alpha)
    with_log = _SW_LOG[row]
    if with_log.any():
        out *= np.where(with_log, np.log(np.maximum(a, _TINY)), 1.0)
    out *= _SW_SIGN[row]
    return out


def _sx(t: np.ndarray, F: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Greenhall eq. (8), ``sx(t) = F**2 [2 sw(t) - sw(t - 1/F) - sw(t + 1/F)]``, and its limit
    ``sx(t) = sw(t, alpha + 2)`` where ``F = inf``.

    ``t`` of shape (k, T, K) (one row of arguments per EDF), ``F`` and ``alpha`` of shape (k,). Both forms
    are ``G [c sw(t) - c' sw(t - h) - c' sw(t + h)]``: ``(G, c, c', h) = (F**2, 2, 1, 1/F)`` or ``(1, 1, 0, 0)``
    with ``alpha + 2``, so one kernel call serves every row (multiplying by 1 or 0 is exact).
    """
    infinite = np.isinf(F)[:, None, None]
    F = F[:, None, None]
    step = np.where(infinite, 0.0, 1.0 / F)
    shifted = np.empty((3,) + t.shape)  # t, t - h, t + h: one kernel call for the three
    shifted[0] = t
    np.subtract(t, step, out=shifted[1])
    np.add(t, step, out=shifted[2])
    sw = _sw(shifted, np.where(infinite, alpha[:, None, None] + 2, alpha[:, None, None]))
    side = np.where(infinite, 0.0, 1.0)
    out = sw[0] * (1.0 + side)
    out -= sw[1] * side
    out -= sw[2] * side
    out *= np.where(infinite, 1.0, F**2)
    return out


# (-1)**k C(2d, d+k) for k = -d..d, by d: the weights of eq. (9); and the shifts k.
_SZ_WEIGHTS = {d: np.array([(-1) ** k * math.comb(2 * d, d + k) for k in range(-d, d + 1)], dtype=float)
               for d in range(1, 4)}
_SZ_SHIFTS = {d: np.arange(-d, d + 1, dtype=float) for d in range(1, 4)}


def _sz(t: np.ndarray, F: np.ndarray, alpha: np.ndarray, d: int) -> np.ndarray:
    """Greenhall eq. (9): ``sz(t) = sum_k (-1)**k C(2d, d+k) sx(t + k)``, ``k = -d..d``.

    ``t`` of shape (k, T) (T arguments per row), ``F`` and ``alpha`` of shape (k,): one row per EDF.
    """
    sx = _sx(t[..., None] + _SZ_SHIFTS[d], F, alpha)  # (k, T, 2d+1)
    return sx @ _SZ_WEIGHTS[d]


def _basic_sum(J: np.ndarray, M: np.ndarray, S: np.ndarray, F: np.ndarray, alpha: np.ndarray, d: int):
    """Greenhall eq. (10), one row per EDF: ``sz(0)**2 + 2 sum_{j=1}^{J-1} (1 - j/M) sz(j/S)**2 +
    (1 - J/M) sz(J/S)**2``; and ``sz(0)**2`` (the normalization). All arguments of shape (k,), ``J >= 1``.

    Rows with fewer terms are padded with zero weights to the longest row's ``J + 1`` terms. ``J`` is a whole
    number here (``M`` and ``(d + 1) S`` are, and so is ``J_max`` in the truncated sum).
    """
    last = J.astype(np.int64)[:, None]  # the column holding the last term j = J
    j = np.arange(int(last.max()) + 1, dtype=float)
    frac = 1.0 - j / M[:, None]
    weights = np.where(j < last, 2.0 * frac, frac)
    weights[:, 0] = 1.0
    weights[j > last] = 0.0
    sz2 = _sz(j / S[:, None], F, alpha, d)
    sz2 *= sz2
    return np.einsum("kj,kj->k", weights, sz2), sz2[:, 0]


def _binomial_autocorrelation(d: int) -> np.ndarray:
    """``rho(p)``, p = -d..d: the autocorrelation of the binomial difference coefficients ``(-1)**k C(d, k)``."""
    c = [(-1) ** k * math.comb(d, k) for k in range(d + 1)]
    return np.array([sum(c[i] * c[i + abs(p)] for i in range(d + 1 - abs(p))) for p in range(-d, d + 1)], dtype=float)


_RHO_SQUARED = {d: _binomial_autocorrelation(d)[:, None] ** 2 for d in range(1, 4)}  # (2d+1, 1)
_RHO_SQUARED_FLAT = {d: np.ascontiguousarray(v[:, 0]) for d, v in _RHO_SQUARED.items()}
_LAGS = {d: np.abs(np.arange(-d, d + 1, dtype=float))[:, None] for d in range(1, 4)}


def _white_pm_unmodified(d: int, M: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Exact EDF of an unmodified variance for white PM: ``M**2 rho0**2 / sum_p (M - |p| S)+ rho(p)**2``.

    ``rho(p)`` is the autocorrelation of the binomial difference coefficients at lag ``p`` (in units of
    ``m``); terms ``S`` per ``m`` apart overlap at lags ``p S``. Equals Greenhall case 4 when
    ``ceil(M/S) > d`` (``a0 = C(4d, 2d)/C(2d, d)**2``, ``a1 = d/2``). ``M``, ``S`` of shape (k,).
    """
    rho2 = _RHO_SQUARED[d]
    total = np.sum(np.maximum(M - _LAGS[d] * S, 0.0) * rho2, axis=0)
    return M**2 * rho2[d, 0] / total


def _integer_rows(alpha, m) -> tuple[np.ndarray, np.ndarray, bool]:
    """``alpha`` and ``m`` as int64 arrays of one shape (k,), and whether both were scalars."""
    if isinstance(alpha, np.ndarray) and isinstance(m, np.ndarray) and alpha.shape == m.shape and alpha.ndim == 1 \
            and alpha.dtype == np.int64 and m.dtype == np.int64:
        return alpha, m, False  # the engine's call: nothing to convert
    scalar = np.ndim(alpha) == 0 and np.ndim(m) == 0
    alpha, m = np.broadcast_arrays(np.atleast_1d(np.asarray(alpha)), np.atleast_1d(np.asarray(m)))
    if alpha.ndim != 1:
        raise ValueError(f"alpha and m have shape {alpha.shape}, must be scalars or 1-D")
    for name, v in (("alpha", alpha), ("m", m)):
        if not np.issubdtype(v.dtype, np.integer) and not np.array_equal(v, np.round(v)):
            raise ValueError(f"{name} == {v.tolist()}, must be integers")
    return alpha.astype(np.int64), m.astype(np.int64), scalar


def greenhall_edf(alpha, d: int, m, n_points: int, *, overlapping: bool, modified: bool):
    """Greenhall's EDF of a finite-difference variance (Greenhall & Riley 2003, section 5).

    Parameters
    ----------
    alpha : int or array of int of shape (k,)
        Noise exponent, -4..2, with ``alpha + 2 d > 1``.
    d : int
        Difference order: 2 Allan, 3 Hadamard (1 for the first-difference variance).
    m : int or array of int of shape (k,)
        Averaging factor (broadcast against ``alpha``).
    n_points : int
        Number of phase samples ``N``.
    overlapping, modified : bool
        ``S = m`` (overlapping) or 1; ``F = 1`` (modified) or ``m``.

    Returns
    -------
    float or ndarray of shape (k,)
        The EDF (a float when ``alpha`` and ``m`` are scalars), NaN where the record holds no complete
        term (``M < 1``).
    """
    alpha, m, scalar = _integer_rows(alpha, m)
    d = int(d)
    if d not in _SZ_WEIGHTS:
        raise ValueError(f"d == {d}, must be 1, 2 or 3 (Greenhall's tables)")
    low, high = (int(alpha.min()), int(alpha.max())) if alpha.size else (2, 2)
    if low < -4 or high > 2 or low + 2 * d <= 1:
        raise ValueError(f"alpha == {alpha.tolist()}, must be integers in -4..2 with alpha + 2 d > 1 for d == {d}")
    # One numba loop over the rows (greenhall_rows): the array code below, its twin, took 35-56 us of a
    # 170-250 us public call at 1e4 points in some forty small-array operations.
    edf = greenhall_rows(alpha, m, int(n_points), d, bool(overlapping), bool(modified), _SZ_WEIGHTS[d],
                         _TABLE1_ARRAY if modified else _TABLE2_ARRAY, _TABLE3_ARRAY, _RHO_SQUARED_FLAT[d], _J_MAX)
    return float(edf[0]) if scalar else edf


def greenhall_edf_twin(alpha, d: int, m, n_points: int, *, overlapping: bool, modified: bool):
    """The numpy twin of :func:`greenhall_edf` (the same cases as array operations; the tests compare)."""
    alpha, m, scalar = _integer_rows(alpha, m)
    d = int(d)
    mf = m.astype(float)
    S = mf if overlapping else np.ones_like(mf)
    # Filter length L = m/F + m d in samples (F = 1 modified, m unmodified), then the number of terms M.
    L = mf * (d + 1) if modified else 1.0 + mf * d
    M = 1.0 + np.floor(S * (n_points - L) / mf)
    J = np.minimum(M, (d + 1) * S)
    r = M / S
    complete = M >= 1
    summed = J <= _J_MAX  # eq. (10) over J terms; else Tables 1-3 (r > d + 1) or eq. (10) truncated
    tabled = ~summed & (r > d + 1)
    white = complete & (alpha == 2) if not modified else np.zeros(m.size, dtype=bool)  # case 4, exact
    flicker = alpha == 1  # case 3 when unmodified: Table 3's normalization
    edf = np.full(m.size, np.nan)
    rows = np.flatnonzero(complete & ~tabled & ~white)
    if rows.size:
        a, mm, Jb, Mb, Sb = alpha[rows], mf[rows], J[rows], M[rows], S[rows]
        if modified:  # case 1: F = 1
            Fb = np.ones_like(mm)
        else:  # case 2 (alpha <= 0): F = m while m (d+1) <= J_max, else inf; case 3: F = m
            Fb = np.where((a > 0) | (mm * (d + 1) <= _J_MAX), mm, np.inf)
        truncated = ~summed[rows]
        any_truncated = bool(truncated.any())
        if any_truncated:  # eq. (10) over J_max terms at m' = J_max / r; F = 1, inf (case 2) or m' (case 3)
            m_prime = _J_MAX / r[rows]
            Jb = np.where(truncated, float(_J_MAX), Jb)
            Mb = np.where(truncated, float(_J_MAX), Mb)
            Sb = np.where(truncated, m_prime, Sb)
            if not modified:
                Fb = np.where(truncated, np.where(a > 0, m_prime, np.inf), Fb)
        total, norm = basic_sums(Jb, Mb, Sb, Fb, a, d, _SZ_WEIGHTS[d])  # _basic_sum is its numpy twin
        if not modified and any_truncated:
            b0, b1 = _TABLE3[d - 1]
            norm = np.where(truncated & flicker[rows], (b0 + b1 * np.log(mm)) ** 2, norm)
        edf[rows] = 1.0 / (total / (norm * Mb))
    rows = np.flatnonzero(complete & tabled & ~white) if tabled.any() else rows[:0]
    if rows.size:
        table = _TABLE1_ARRAY if modified else _TABLE2_ARRAY
        a0, a1 = table[2 - alpha[rows], d - 1].T
        rr = r[rows]
        inv = (a0 - a1 / rr) / rr
        if not modified and flicker[rows].any():
            b0, b1 = _TABLE3[d - 1]
            inv = np.where(flicker[rows], (a0 - a1 / rr) / ((b0 + b1 * np.log(mf[rows])) ** 2 * rr), inv)
        edf[rows] = 1.0 / inv
    if white.any():
        edf[white] = _white_pm_unmodified(d, M[white], S[white])
    return float(edf[0]) if scalar else edf


def _check_alpha(alpha: np.ndarray, allowed: tuple[int, ...]) -> None:
    """Raise when an ``alpha`` (k,) is outside ``allowed``, naming the values and what was expected."""
    if not np.isin(alpha, allowed).all():
        raise ValueError(f"alpha == {alpha.tolist()}, must be in {list(allowed)}")


def _result(edf: np.ndarray, scalar: bool):
    """The EDF as a float for scalar inputs, else the (k,) array."""
    return float(edf[0]) if scalar else edf


def chi2_interval(dev: np.ndarray, edf: np.ndarray, ci: float) -> tuple[np.ndarray, np.ndarray]:
    """Chi-square confidence interval on a deviation, SP 1065 eq. (45).

    ``dev`` and ``edf`` of shape (k,); returns ``(lo, hi)`` of shape (k,), NaN where ``edf`` is NaN or
    not positive.
    """
    dev = np.asarray(dev, dtype=float)
    edf = np.asarray(edf, dtype=float)
    ok = np.isfinite(edf) & (edf > 0) & np.isfinite(dev)
    # chi2.ppf(p, e) is 2 gammaincinv(e/2, p) (scipy's own definition), called directly and once for
    # both quantiles: the distribution object's argument checks cost more than the quantiles.
    quantiles = np.array([[(1.0 + ci) / 2.0], [(1.0 - ci) / 2.0]])
    if ok.all():  # the usual case: no row to leave out
        q = gammaincinv(edf / 2.0, quantiles)
        return dev * np.sqrt(edf / (2.0 * q[0])), dev * np.sqrt(edf / (2.0 * q[1]))
    lo = np.full(dev.shape, np.nan)
    hi = np.full(dev.shape, np.nan)
    if ok.any():
        e = edf[ok]
        q = gammaincinv(e / 2.0, quantiles)
        lo[ok] = dev[ok] * np.sqrt(e / (2.0 * q[0]))
        hi[ok] = dev[ok] * np.sqrt(e / (2.0 * q[1]))
    return lo, hi
