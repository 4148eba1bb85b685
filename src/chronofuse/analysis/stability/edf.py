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
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import gammaincinv

__all__ = [
    "greenhall_edf",
    "totdev_edf",
    "mtotdev_edf",
    "simple_adev_edf",
    "htotdev_edf",
    "theo1_edf",
    "chi2_interval",
    "GREENHALL_PARAMETERS",
]

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


def _sw(t: np.ndarray, alpha: int) -> np.ndarray:
    """Greenhall eq. (7): the generalized autocovariance kernel ``sw(t)`` of power-law noise."""
    t = np.asarray(t, dtype=float)
    a = np.abs(t)
    if alpha == 2:
        return -a
    if alpha == 0:
        return a**3
    if alpha == -2:
        return -(a**5)
    if alpha == -4:
        return a**7
    if alpha not in (1, -1, -3):
        raise ValueError(f"alpha == {alpha}, must be an integer in -4..2")
    log_a = np.log(np.where(a > 0, a, 1.0))  # t**k log|t| -> 0 at t = 0
    if alpha == 1:
        return t**2 * log_a
    if alpha == -1:
        return -(t**4) * log_a
    return t**6 * log_a


def _sx(t: np.ndarray, F: float, alpha: int) -> np.ndarray:
    """Greenhall eq. (8): ``sx(t) = F**2 [2 sw(t) - sw(t - 1/F) - sw(t + 1/F)]``; ``sw(t, alpha+2)`` at F = inf."""
    if math.isinf(F):
        return _sw(t, alpha + 2)
    shifted = _sw(np.stack((t, t - 1.0 / F, t + 1.0 / F)), alpha)  # one kernel call for the three arguments
    return F**2 * (2.0 * shifted[0] - shifted[1] - shifted[2])


def _sz(t: np.ndarray, F: float, alpha: int, d: int) -> np.ndarray:
    """Greenhall eq. (9): ``sz(t) = sum_k (-1)**k C(2d, d+k) sx(t + k)``, ``k = -d..d``."""
    t = np.asarray(t, dtype=float)
    k = np.arange(-d, d + 1)
    weights = np.array([(-1) ** int(kk) * math.comb(2 * d, d + int(kk)) for kk in k], dtype=float)
    sx = _sx(t[..., None] + k, F, alpha)  # (..., 2d+1): every shift in one call
    return sx @ weights


def _sw_scalar(t: float, alpha: int) -> float:
    """:func:`_sw` of one float (no array overhead: the short sums of eq. (10) are mostly a few terms)."""
    a = abs(t)
    if alpha == 2:
        return -a
    if alpha == 0:
        return a**3
    if alpha == -2:
        return -(a**5)
    if alpha == -4:
        return a**7
    log_a = math.log(a) if a > 0 else 0.0
    if alpha == 1:
        return t * t * log_a
    if alpha == -1:
        return -(t**4) * log_a
    if alpha == -3:
        return t**6 * log_a
    raise ValueError(f"alpha == {alpha}, must be an integer in -4..2")


# (k, (-1)**k C(2d, d+k)) for k = -d..d, by d: the weights of eq. (9).
_SZ_WEIGHTS = {d: tuple((k, (-1) ** k * math.comb(2 * d, d + k)) for k in range(-d, d + 1)) for d in range(1, 4)}


def _sz_scalar(t: float, F: float, alpha: int, d: int) -> float:
    """:func:`_sz` of one float."""
    total = 0.0
    weights = _SZ_WEIGHTS[d] if d in _SZ_WEIGHTS else tuple((k, (-1) ** k * math.comb(2 * d, d + k))
                                                            for k in range(-d, d + 1))
    if math.isinf(F):
        for k, w in weights:
            total += w * _sw_scalar(t + k, alpha + 2)
        return total
    step = 1.0 / F
    for k, w in weights:
        u = t + k
        total += w * (F * F * (2.0 * _sw_scalar(u, alpha) - _sw_scalar(u - step, alpha) - _sw_scalar(u + step, alpha)))
    return total


# Up to this many terms eq. (10) is summed with Python floats; beyond, with arrays.
_SCALAR_TERMS = 8


def _basic_sum(J: float, M: float, S: float, F: float, alpha: int, d: int) -> float:
    """Greenhall eq. (10): ``sz(0)**2 + 2 sum_{j=1}^{J-1} (1 - j/M) sz(j/S)**2 + (1 - J/M) sz(J/S)**2``."""
    if J <= _SCALAR_TERMS:
        total = _sz_scalar(0.0, F, alpha, d) ** 2
        if int(J) >= 1:
            total += (1.0 - J / M) * _sz_scalar(J / S, F, alpha, d) ** 2
        for jj in range(1, int(J)):
            total += 2.0 * (1.0 - jj / M) * _sz_scalar(jj / S, F, alpha, d) ** 2
        return total
    j = np.arange(0, int(J) + 1, dtype=float)
    j[-1] = J
    sz2 = _sz(j / S, F, alpha, d) ** 2
    weights = 2.0 * (1.0 - j / M)
    weights[0] = 1.0
    weights[-1] = 1.0 - J / M
    if int(J) == 0:
        return float(sz2[0])
    return float(np.dot(weights, sz2))


def _white_pm_unmodified(d: int, M: float, S: float) -> float:
    """Exact EDF of an unmodified variance for white PM: ``M**2 rho0**2 / sum_p (M - |p| S)+ rho(p)**2``.

    ``rho(p)`` is the autocorrelation of the binomial difference coefficients at lag ``p`` (in units of
    ``m``); terms ``S`` per ``m`` apart overlap at lags ``p S``. Equals Greenhall case 4 when
    ``ceil(M/S) > d`` (``a0 = C(4d, 2d)/C(2d, d)**2``, ``a1 = d/2``).
    """
    c = [(-1) ** k * math.comb(d, k) for k in range(d + 1)]
    rho = [sum(c[i] * c[i + abs(p)] for i in range(d + 1 - abs(p))) for p in range(-d, d + 1)]  # lags -d..d
    total = sum(max(M - abs(p) * S, 0.0) * rho[p + d] ** 2 for p in range(-d, d + 1))
    return M**2 * rho[d] ** 2 / total


def greenhall_edf(alpha: int, d: int, m: int, n_points: int, *, overlapping: bool, modified: bool) -> float:
    """Greenhall's EDF of a finite-difference variance (Greenhall & Riley 2003, section 5).

    Parameters
    ----------
    alpha : int
        Noise exponent, -4..2, with ``alpha + 2 d > 1``.
    d : int
        Difference order: 2 Allan, 3 Hadamard (1 for the first-difference variance).
    m : int
        Averaging factor.
    n_points : int
        Number of phase samples ``N``.
    overlapping, modified : bool
        ``S = m`` (overlapping) or 1; ``F = 1`` (modified) or ``m``.

    Returns
    -------
    float
        The EDF, NaN when the record holds no complete term (``M < 1``).
    """
    alpha, d, m = int(alpha), int(d), int(m)
    if alpha + 2 * d <= 1:
        raise ValueError(f"alpha == {alpha}, must satisfy alpha + 2 d > 1 for d == {d}")
    F = 1.0 if modified else float(m)
    S = float(m) if overlapping else 1.0
    L = m / F + m * d  # length of the filter applied to the phase, in samples
    M = 1.0 + math.floor(S * (n_points - L) / m)
    if M < 1:
        return float("nan")
    J = min(M, (d + 1) * S)
    r = M / S
    if modified:  # case 1
        if J <= _J_MAX:
            inv = _basic_sum(J, M, S, 1.0, alpha, d) / (_sz_scalar(0.0, 1.0, alpha, d) ** 2 * M)
        elif r > d + 1:
            a0, a1 = _TABLE1[alpha][d - 1]
            inv = (a0 - a1 / r) / r
        else:
            m_prime = _J_MAX / r
            inv = _basic_sum(_J_MAX, _J_MAX, m_prime, 1.0, alpha, d) / (
                _sz_scalar(0.0, 1.0, alpha, d) ** 2 * _J_MAX
            )
        return 1.0 / inv
    if alpha == 2:  # case 4, exact
        return _white_pm_unmodified(d, M, S)
    if alpha <= 0:  # case 2
        if J <= _J_MAX:
            m_prime = float(m) if m * (d + 1) <= _J_MAX else math.inf
            inv = _basic_sum(J, M, S, m_prime, alpha, d) / (_sz_scalar(0.0, m_prime, alpha, d) ** 2 * M)
        elif r > d + 1:
            a0, a1 = _TABLE2[alpha][d - 1]
            inv = (a0 - a1 / r) / r
        else:
            m_prime = _J_MAX / r
            inv = _basic_sum(_J_MAX, _J_MAX, m_prime, math.inf, alpha, d) / (
                _sz_scalar(0.0, math.inf, alpha, d) ** 2 * _J_MAX
            )
        return 1.0 / inv
    # alpha == 1, case 3
    b0, b1 = _TABLE3[d - 1]
    if J <= _J_MAX:
        inv = _basic_sum(J, M, S, float(m), 1, d) / (_sz_scalar(0.0, float(m), 1, d) ** 2 * M)
    elif r > d + 1:
        a0, a1 = _TABLE2[1][d - 1]
        inv = (a0 - a1 / r) / ((b0 + b1 * math.log(m)) ** 2 * r)
    else:
        m_prime = _J_MAX / r
        inv = _basic_sum(_J_MAX, _J_MAX, m_prime, m_prime, 1, d) / ((b0 + b1 * math.log(m)) ** 2 * _J_MAX)
    return 1.0 / inv


# SP 1065 Table 7 (TOTVAR): (b, c) for alpha = 0, -1, -2.
_TOTDEV_TABLE7 = {0: (1.50, 0.0), -1: (1.17, 0.22), -2: (0.93, 0.36)}


def simple_adev_edf(alpha: int, m: int, n_points: int) -> float:
    """Simple approximate ADEV EDF of SP 1065 Table 5 (after Howe, Allan and Barnes 1981), PM noises.

    White PM: ``(N+1)(N-2m) / (2(N-m))``; flicker PM: ``exp(sqrt(ln((N-1)/(2m)) ln((2m+1)(N-1)/4)))``,
    ``N`` phase points.
    """
    N = float(n_points)
    if alpha == 2:
        return (N + 1.0) * (N - 2.0 * m) / (2.0 * (N - m))
    if alpha == 1:
        return math.exp(math.sqrt(math.log((N - 1.0) / (2.0 * m)) * math.log((2.0 * m + 1.0) * (N - 1.0) / 4.0)))
    raise ValueError(f"alpha == {alpha}, must be 2 or 1 (white or flicker PM)")


def totdev_edf(alpha: int, m: int, n_points: int) -> float:
    """TOTDEV EDF: SP 1065 Table 7, ``b N/m - c`` (alpha 0, -1, -2); SP 1065 Table 5 for PM noise."""
    if alpha in _TOTDEV_TABLE7:
        b, c = _TOTDEV_TABLE7[alpha]
        return b * n_points / m - c
    return simple_adev_edf(alpha, m, n_points)


def mtotdev_edf(alpha: int, m: int, n_points: int) -> float:
    """MTOTDEV/TTOTDEV EDF: Greenhall's MDEV EDF (what Stable32 uses, see the module docstring)."""
    return greenhall_edf(alpha, 2, m, n_points, overlapping=True, modified=True)


def htotdev_edf(alpha: int, m: int, n_points: int) -> float:
    """HTOTDEV EDF: Greenhall's OHDEV EDF (a lower bound; SP 1065 has no HTOTDEV EDF)."""
    return greenhall_edf(alpha, 3, m, n_points, overlapping=True, modified=False)


def theo1_edf(alpha: int, m: int, n_points: int) -> float:
    """Theo1 EDF, SP 1065 Theo1 section (Howe & Tasset 2004), ``r = 0.75 m``, ``N`` phase points."""
    N = float(n_points)
    r = 0.75 * m
    if alpha == 2:
        return 0.86 * (N + 1.0) * (N - 4.0 * r / 3.0) / (N - r) * r / (r + 1.14)
    if alpha == 1:
        return (4.798 * N**2 - 6.374 * N * r + 12.387 * r) / (np.sqrt(r + 36.6) * (N - r) * (N + 0.3)) * r / (r + 0.3)
    if alpha == 0:
        return ((4.1 * N + 0.8) / r - (3.1 * N + 6.5) / N) * r**1.5 / (r**1.5 + 5.2)
    if alpha == -1:
        return (2.0 * N**2 - 1.3 * N * r - 3.5 * r) / (N * r) * r**3 / (r**3 + 2.3)
    if alpha == -2:
        return (
            (4.4 * N - 2.0)
            / (2.9 * r)
            * ((4.4 * N - 1.0) ** 2 - 8.6 * r * (4.4 * N - 1.0) + 11.4 * r**2)
            / (4.4 * N - 3.0) ** 2
        )
    raise ValueError(f"alpha == {alpha}, must be an integer in -2..2")


def chi2_interval(dev: np.ndarray, edf: np.ndarray, ci: float) -> tuple[np.ndarray, np.ndarray]:
    """Chi-square confidence interval on a deviation, SP 1065 eq. (45).

    ``dev`` and ``edf`` of shape (k,); returns ``(lo, hi)`` of shape (k,), NaN where ``edf`` is NaN or
    not positive.
    """
    dev = np.asarray(dev, dtype=float)
    edf = np.asarray(edf, dtype=float)
    lo = np.full(dev.shape, np.nan)
    hi = np.full(dev.shape, np.nan)
    ok = np.isfinite(edf) & (edf > 0) & np.isfinite(dev)
    if ok.any():
        e = edf[ok]
        # chi2.ppf(p, e) is 2 gammaincinv(e/2, p) (scipy's own definition), called directly: the
        # distribution object's argument checks cost more than the quantiles on a short tau grid.
        lo[ok] = dev[ok] * np.sqrt(e / (2.0 * gammaincinv(e / 2.0, (1.0 + ci) / 2.0)))
        hi[ok] = dev[ok] * np.sqrt(e / (2.0 * gammaincinv(e / 2.0, (1.0 - ci) / 2.0)))
    return lo, hi
