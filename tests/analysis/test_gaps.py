"""Records with gaps: which terms each rule keeps, and intervals from the terms actually used.

The truth for the coverage checks is exact, not estimated: simulated phase is white noise through a
known causal filter ``p`` (started at the first sample), so each kept term ``d_i`` (a binomial
difference of the phase at lag ``m``) has ``E[d_i**2] = sum_v P(v)**2`` with ``P`` the filter seen
through the difference; the expected Allan variance of the estimate is the mean of those over the
terms the gap rule kept.
"""

import math

import numpy as np
import pytest
from scipy.signal import fftconvolve
from scipy.stats import binomtest

from chronofuse.analysis import stability as st
from chronofuse.analysis.stability.edf import chi2_interval, greenhall_edf
from chronofuse.analysis.stability.edf_gaps import edf_from_terms, pair_counts
from chronofuse.analysis.stability.engine import kept_terms

NOMINAL = 0.683


def _frequency_filter(alpha: int, n: int) -> np.ndarray:
    """Impulse response of (1 - z)**(alpha/2) (Kasdin & Walter): fractional frequency S_y ~ f**alpha."""
    h = np.empty(n)
    h[0] = 1.0
    for k in range(1, n):
        h[k] = h[k - 1] * (k - 1 - alpha / 2) / k
    return h


def phase_filter(noise: str, n: int) -> np.ndarray:
    """Phase impulse response (n,): white PM directly, the FM noises as the running sum of frequency."""
    if noise == "white PM":
        return np.eye(1, n)[0]
    alpha = {"white FM": 0, "flicker FM": -1, "random-walk FM": -2}[noise]
    return np.concatenate(([0.0], np.cumsum(_frequency_filter(alpha, n))[:-1]))


def expected_square(p: np.ndarray, m: int, d: int, n_terms: int) -> np.ndarray:
    """E[d_i**2] (n_terms,) of the order-d lag-m difference of phase x = p * w (unit white w)."""
    weights = [(-1) ** (d - k) * math.comb(d, k) for k in range(d + 1)]
    length = n_terms + d * m
    seen = np.zeros(length)
    for k, c in enumerate(weights):
        lag = (d - k) * m
        seen[lag:] += c * p[: length - lag]
    return np.cumsum(seen**2)[np.arange(n_terms) + d * m]


def test_the_edf_from_kept_terms_is_greenhalls_when_no_term_is_missing():
    """All terms kept: c(j) = M - j and the expression is Greenhall's eq. (10); equal where Greenhall sums
    exactly, and within 2 % where he truncates the sum at 100 terms or uses his Tables 1-3."""
    n = 10_000
    for d, overlapping, modified in [(2, False, False), (2, True, False), (2, True, True), (3, True, False)]:
        for alpha in (2, 1, 0, -1, -2):
            for m in (1, 2, 4, 16, 64, 256, 1024):
                terms = (n - 3 * m + 1 if modified else n - d * m if overlapping else (n - 1) // m - d + 1)
                ours = edf_from_terms(alpha, d, m, np.ones(terms, bool), overlapping=overlapping, modified=modified)
                theirs = greenhall_edf(alpha, d, m, n, overlapping=overlapping, modified=modified)
                exact = (d + 1) * (m if overlapping else 1) <= 100
                assert ours == pytest.approx(theirs, rel=1e-9 if exact else 0.02), (d, overlapping, modified, alpha, m)


def test_pair_counts_by_fft_equal_direct_counting():
    rng = np.random.default_rng(4)
    kept = rng.random(3000) > 0.2
    kept[1000:1400] = False
    counts = pair_counts(kept, 600)
    direct = [np.count_nonzero(kept[: kept.size - j] & kept[j:]) for j in range(601)]
    np.testing.assert_array_equal(counts, direct)
    np.testing.assert_array_equal(pair_counts(np.ones(5, bool), 8), [5, 4, 3, 2, 1, 0, 0, 0, 0])
    for fraction, lags in ((0.01, 12), (0.01, 384), (0.1, 48), (0.3, 1536)):  # both routes (from the missing terms, FFT)
        sparse = rng.random(16000) > fraction
        direct = [np.count_nonzero(sparse[: sparse.size - j] & sparse[j:]) for j in range(lags + 1)]
        np.testing.assert_array_equal(pair_counts(sparse, lags), direct)
    np.testing.assert_array_equal(pair_counts(np.zeros(4, bool), 6), np.zeros(7))


@pytest.mark.parametrize("statistic", ["adev", "oadev", "hdev", "ohdev", "mdev", "tdev"])
@pytest.mark.parametrize("rule", ["samples", "span"])
def test_the_term_count_is_the_number_of_terms_the_rule_keeps(statistic, rule):
    """n equals the kept terms counted by brute force: under "samples" a term goes only when one of its
    own samples is missing; under "span" when any sample it spans is; MDEV/TDEV terms read all 3m."""
    rng = np.random.default_rng(11)
    x = np.cumsum(rng.standard_normal(4000)) * 1e-9
    x[rng.choice(x.size, 40, replace=False)] = np.nan
    x[2000:2100] = np.nan
    m = np.array([1, 3, 16, 64, 200])
    res = st.compute(statistic, x, 1.0, m.astype(float), gap_rule=rule)
    d = 3 if statistic in ("hdev", "ohdev") else 2
    for j, mj in enumerate(m.tolist()):
        if statistic in ("mdev", "tdev"):
            count = sum(not np.isnan(x[i : i + 3 * mj]).any() for i in range(x.size - 3 * mj + 1))
        else:
            step = mj if statistic in ("adev", "hdev") else 1
            starts = range(0, x.size - d * mj, step)
            if rule == "samples":
                count = sum(not np.isnan(x[[i + k * mj for k in range(d + 1)]]).any() for i in starts)
            else:
                count = sum(not np.isnan(x[i : i + d * mj + 1]).any() for i in starts)
        assert res.n[j] == count == np.count_nonzero(kept_terms(statistic, x, mj, rule))
        assert res.gap_rule == rule and res.skipped == np.count_nonzero(np.isnan(x))


def test_one_percent_scattered_gaps_keep_most_terms_at_every_tau_under_the_samples_rule():
    """The measured failure: 1 % scattered NaN in 1e4 points left OADEV(256 s) 75 terms and nothing from
    512 s. Skipping only the terms whose own samples are missing keeps about 0.99**3 of them."""
    rng = np.random.default_rng(0)
    x = np.cumsum(rng.standard_normal(10_000)) * 1e-9
    x[rng.choice(x.size, 100, replace=False)] = np.nan
    taus = st.tau_grid("octave", x.size, 1.0, "oadev")
    own = st.oadev(x, 1.0, taus)
    span = st.oadev(x, 1.0, taus, gap_rule="span")
    full = x.size - 2 * taus.astype(int)
    assert own.gap_rule == "samples"
    np.testing.assert_array_less(0.95 * full, own.n)
    assert span.n[taus == 256.0][0] < 200 and np.isnan(span.dev[taus >= 512.0]).all()
    assert np.isfinite(own.dev).all() and np.isfinite(own.lo).all()


def test_an_unknown_gap_rule_is_refused_naming_the_rules():
    x = np.arange(100.0)
    with pytest.raises(ValueError, match=r"gap_rule == 'nearest', must be one of \['samples', 'span'\]"):
        st.compute("oadev", x, 1.0, [1.0], gap_rule="nearest")
    with pytest.raises(ValueError, match=r"\['window'\] for mtie"):
        st.compute("mtie", x, 1.0, [1.0], gap_rule="samples")


def _gapped(x: np.ndarray, pattern: str, rng: np.random.Generator) -> np.ndarray:
    x = x.copy()
    if pattern == "1 % scattered":
        x[rng.choice(x.size, x.size // 100, replace=False)] = np.nan
    elif pattern == "10 % scattered":
        x[rng.choice(x.size, x.size // 10, replace=False)] = np.nan
    else:  # four long gaps of 400 samples, 10 % of the record
        for start in rng.choice(x.size - 500, 4, replace=False):
            x[start : start + 400] = np.nan
    return x


# The noises' true alpha (S_y ~ f**alpha), for the interval of the EDF alone at the larger factors.
TRUE_ALPHA = {"white FM": 0, "flicker FM": -1, "random-walk FM": -2, "white PM": 2}
#: Factors where the identification misnames the noise too often for the engine's interval (docs/stability.md
#: section "Gaps", the measured coverage): there the interval of the EDF from the terms used with the true
#: alpha is checked instead, which is the EDF's own accuracy.
EDF_ONLY = (256, 512)


def _coverage(noise: str, pattern: str, factors: tuple[int, ...], trials: int, seed: int):
    """Fraction of trials whose OADEV interval holds the exact expected deviation, per factor; the same with
    the EDF of a gap-free record of N - skipped points (the former engine's rule); and, at EDF_ONLY, with
    the EDF from the terms used at the noise's true alpha."""
    n = 16384
    rng = np.random.default_rng(seed)
    p = phase_filter(noise, n)
    phases = fftconvolve(rng.standard_normal((trials, n)), p[None, :], axes=1)[:, :n] * 1e-9
    every = tuple(factors) + EDF_ONLY
    expected = {m: expected_square(p, m, 2, n - 2 * m) * 1e-18 for m in every}
    hits = np.zeros(len(factors))
    old_hits = np.zeros(len(factors))
    edf_hits = np.zeros(len(EDF_ONLY))
    for x in phases:
        x = _gapped(x, pattern, rng)
        res = st.oadev(x, 1.0, np.array(every, float))
        old_edf = greenhall_edf(res.alpha[:len(factors)], 2, np.array(factors), n - res.skipped, overlapping=True,
                                modified=False)
        old_lo, old_hi = chi2_interval(res.dev[:len(factors)], old_edf, res.ci)
        for j, m in enumerate(every):
            kept = kept_terms("oadev", x, m, "samples")
            truth = np.sqrt(np.mean(expected[m][kept]) / (2.0 * m * m))
            if j < len(factors):
                hits[j] += res.lo[j] <= truth <= res.hi[j]
                old_hits[j] += old_lo[j] <= truth <= old_hi[j]
            else:
                lo, hi = res.lo[j], res.hi[j]  # the engine's own interval where it named the noise right
                if res.alpha[j] != TRUE_ALPHA[noise]:
                    e = edf_from_terms(TRUE_ALPHA[noise], 2, m, kept, overlapping=True, modified=False)
                    lo, hi = chi2_interval(res.dev[j:j + 1], np.array([e]), res.ci)
                    lo, hi = lo[0], hi[0]
                edf_hits[j - len(factors)] += lo <= truth <= hi
    return hits.astype(int), old_hits.astype(int), edf_hits.astype(int)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("noise", "factors"),
    [
        # The factors stop at 128 (128 frequency averages, 104 of them present with 10 % gaps): at 64 averages
        # the lag-1 identification misnames white FM in 15 % of the trials with or without gaps, and the
        # interval of a misnamed noise is the wrong width (63 % coverage). White PM stops at 64: at 128
        # averages with 10 % gaps it is called flicker PM often enough for 74 % coverage (conservative).
        ("white FM", (4, 16, 64, 128)),
        ("flicker FM", (4, 16, 64, 128)),
        ("random-walk FM", (4, 16, 64, 128)),
        ("white PM", (4, 16, 64)),
    ],
)
def test_intervals_from_the_terms_used_cover_the_truth_at_the_nominal_rate_with_gaps(noise, factors):
    """1,000 trials of 16384 points per gap pattern: 1 % and 10 % scattered gaps, four 400-sample gaps.
    The 68.3 % interval must hold the exact expected OADEV in 68.3 +- 5 % of the trials; the binomial 95 %
    interval of each coverage is printed with the numbers. Factors below 4 are left out: there Greenhall's
    continuous-time model (F = m) and point-sampled phase differ by up to 15 % in EDF without any gap
    (2/3 M against 0.78 M for white FM at m = 1), a property of the EDF, not of the gaps. At m = 256 and 512
    (64 and 32 frequency averages, fewer with gaps) the identification misnames the noise in 11-57 % of the
    trials and the engine's coverage leaves the band (white FM 0.59-0.66, white PM 0.75-0.80): there the
    interval of the EDF from the terms used at the true alpha is checked, the EDF's own part."""
    trials = 1000
    for k, pattern in enumerate(("1 % scattered", "10 % scattered", "four long gaps")):
        hits, old_hits, edf_hits = _coverage(noise, pattern, factors, trials, seed=100 + k)
        for j, m in enumerate(EDF_ONLY):
            ci = binomtest(int(edf_hits[j]), trials).proportion_ci(0.95)
            message = (f"{noise}, {pattern}, m = {m}, EDF from the terms used at the true alpha: coverage "
                       f"{edf_hits[j] / trials:.3f} (95 % {ci.low:.3f}-{ci.high:.3f})")
            assert abs(edf_hits[j] / trials - NOMINAL) <= 0.05, message
        for j, m in enumerate(factors):
            ci = binomtest(int(hits[j]), trials).proportion_ci(0.95)
            message = (f"{noise}, {pattern}, m = {m}: coverage {hits[j] / trials:.3f} "
                       f"(95 % {ci.low:.3f}-{ci.high:.3f}); gap-free EDF of N - skipped {old_hits[j] / trials:.3f}")
            assert abs(hits[j] / trials - NOMINAL) <= 0.05, message
