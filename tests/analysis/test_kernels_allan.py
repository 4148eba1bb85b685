"""Raw Allan-family kernels (ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV) against Stable32, NIST and allantools."""

from __future__ import annotations

import functools

import allantools
import numpy as np
import pytest
from _helpers import assert_close_printed, read_stable32_table

from chronofuse.analysis.stability import kernels_allan as ka
from chronofuse.analysis.stability import kernels_differences as kd
from chronofuse.analysis.stability.convert import frequency_to_phase
from chronofuse.analysis.stability.taus import averaging_factors

STATISTICS = ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev")

# (data set, statistic) -> (Stable32 table relative to data/stability, tau spacing of that table).
TABLES = {
    **{("phasedat", s): (f"phasedat/phase_dat_{s}_octave.txt", "octave") for s in STATISTICS},
    **{("ocxo", s): (f"ocxo/{s}_octave.txt", "octave") for s in STATISTICS},
    ("gps", "adev"): ("gps/stable32_ADEV_decade.txt", "decade"),
    **{("gps", s): (f"gps/stable32_{s.upper()}_octave.txt", "octave") for s in STATISTICS if s != "adev"},
    **{("Cs5071A", s): (f"Cs5071A/{s}_decade.txt", "decade") for s in STATISTICS},
}


@functools.cache
def load_phase(data_dir, name: str) -> np.ndarray:
    """Phase in seconds (N,) of a reference data set, all sampled at 1 Hz."""
    root = data_dir / "stability"
    if name == "phasedat":
        return np.loadtxt(root / "phasedat" / "PHASE.DAT", comments="#")
    if name == "ocxo":
        return frequency_to_phase(ocxo_normalised_frequency(data_dir) - 1.0, 1.0)
    if name == "ocxo_as_stable32":
        # Stable32 integrates the normalised frequency (values near 1) as it is: its phase is a ramp up to
        # 2e4 s whose float64 rounding (~1e-12 s per sample) shows in its overlapping-statistic tables at
        # 1e-4 relative. Feeding the kernels the same running sum reproduces those tables digit for digit.
        return np.concatenate(([0.0], np.cumsum(ocxo_normalised_frequency(data_dir))))
    if name == "gps":
        return np.loadtxt(root / "gps" / "gps_1pps_phase_data.txt.gz", comments="#")
    if name == "Cs5071A":
        return np.loadtxt(root / "Cs5071A" / "5071A_phase.txt.gz", comments="#")
    raise KeyError(name)


@functools.cache
def ocxo_normalised_frequency(data_dir) -> np.ndarray:
    """The OCXO's frequency (Hz) over its 10 MHz nominal, as Stable32 normalised it (its tables' header
    "Average = 1.000000e+00"); the fractional frequency is this minus 1. Shape (19982,)."""
    f_hz = np.loadtxt(data_dir / "stability" / "ocxo" / "ocxo_frequency.txt", comments="#")
    return f_hz / 1e7


@pytest.mark.parametrize(("dataset", "statistic"), sorted(TABLES))
def test_raw_deviation_and_term_count_equal_stable32_table(data_dir, dataset, statistic):
    path, _ = TABLES[(dataset, statistic)]
    table = read_stable32_table(data_dir / "stability" / path)
    source = dataset
    loose = np.zeros(table["af"].size, dtype=bool)
    if dataset == "ocxo" and statistic in ("oadev", "mdev", "tdev", "ohdev"):
        source = "ocxo_as_stable32"
    elif dataset == "ocxo":
        # Stable32 computed the non-overlapping ADEV/HDEV of this frequency record from block means of
        # the values near 1, summed sample by sample; from m = 512 on that sum's rounding moves its
        # values by up to ~1e-4 relative (a sequential block sum reproduces them). Ours are exact there.
        loose = table["af"] >= 512
    x = load_phase(data_dir, source)
    dev, n = getattr(ka, f"{statistic}_raw")(x, table["af"].astype(np.int64), 1.0)
    np.testing.assert_array_equal(n, table["n"])
    np.testing.assert_allclose(dev[loose], table["dev"][loose], rtol=2e-4)
    assert_close_printed(dev[~loose], table["dev"][~loose], name=f"{dataset} {statistic}")


@pytest.mark.parametrize(("dataset", "statistic"), sorted(TABLES))
def test_max_averaging_factor_reproduces_stable32_tau_range(data_dir, dataset, statistic):
    path, spacing = TABLES[(dataset, statistic)]
    table = read_stable32_table(data_dir / "stability" / path)
    x = load_phase(data_dir, dataset)
    max_m = getattr(ka, f"max_m_{statistic}")(x.size)
    np.testing.assert_array_equal(averaging_factors(max_m, spacing), table["af"])


@pytest.mark.parametrize("dataset", ["phasedat", "ocxo", "gps", "Cs5071A"])
@pytest.mark.parametrize("statistic", STATISTICS)
def test_raw_deviation_equals_allantools(data_dir, dataset, statistic):
    x = load_phase(data_dir, dataset)
    m = averaging_factors(getattr(ka, f"max_m_{statistic}")(x.size), "octave")
    _, ref_dev, _, ref_n = getattr(allantools, statistic)(x, rate=1.0, data_type="phase", taus=m.astype(float))
    dev, n = getattr(ka, f"{statistic}_raw")(x, m, 1.0)
    np.testing.assert_array_equal(n, ref_n.astype(np.int64))
    np.testing.assert_allclose(dev, ref_dev, rtol=1e-10, atol=0)


# NIST SP 1065 (2008), p. 108, Table 31 (1000-point test suite, tau = 1, 10, 100 s), as transcribed in
# allantools' tests/nbs14/test_nbs14_1000point.py (github.com/aewallin/allantools).
NBS14_1000 = {
    "adev": [2.922319e-01, 9.965736e-02, 3.897804e-02],
    "oadev": [2.922319e-01, 9.159953e-02, 3.241343e-02],
    "mdev": [2.922319e-01, 6.172376e-02, 2.170921e-02],
    "tdev": [1.687202e-01, 3.563623e-01, 1.253382e00],
    "hdev": [2.943883e-01, 1.052754e-01, 3.910860e-02],
    "ohdev": [2.943883e-01, 9.581083e-02, 3.237638e-02],
}


@pytest.mark.parametrize("statistic", STATISTICS)
def test_raw_deviation_equals_nist_sp1065_1000_point_test_values(statistic, nbs14_phase):
    dev, _ = getattr(ka, f"{statistic}_raw")(nbs14_phase, np.array([1, 10, 100]), 1.0)
    published = np.array(NBS14_1000[statistic])
    # One unit in the 7th printed digit: the table truncates (HDEV(100 s) = 0.03910860560 prints 3.910860e-02).
    unit = 10.0 ** (np.floor(np.log10(published)) - 6)
    np.testing.assert_array_less(np.abs(dev - published), unit)


def brute_force_variance_sum(x: np.ndarray, m: int, statistic: str, rule: str = "span") -> tuple[float, int]:
    """Sum of squared terms and their count by direct enumeration of SP 1065's definitions, skipping any
    term whose span (first to last sample it covers) holds a NaN sample (``rule="span"``) or one of whose
    own samples is NaN (``rule="samples"``): a readable loop, independent of the kernels' vectorized forms."""
    weights = {"adev": [1, -2, 1], "oadev": [1, -2, 1], "hdev": [-1, 3, -3, 1], "ohdev": [-1, 3, -3, 1]}
    total, count = 0.0, 0
    if statistic in ("mdev", "tdev"):
        for j in range(x.size - 3 * m + 1):
            term = sum(x[i + 2 * m] - 2 * x[i + m] + x[i] for i in range(j, j + m))
            if not np.isnan(term):
                total, count = total + term**2, count + 1
        return total, count
    w = weights[statistic]
    stride = m if statistic in ("adev", "hdev") else 1
    for i in range(0, x.size - (len(w) - 1) * m, stride):
        term = sum(wk * x[i + k * m] for k, wk in enumerate(w))
        own = [x[i + k * m] for k in range(len(w))]
        gap = np.isnan(own).any() if rule == "samples" else np.isnan(x[i : i + (len(w) - 1) * m + 1]).any()
        if not gap:
            total, count = total + term**2, count + 1
    return total, count


@pytest.mark.parametrize("rule", ["samples", "span"])
@pytest.mark.parametrize("statistic", STATISTICS)
def test_terms_a_missing_sample_removes_are_those_of_the_rule_as_by_direct_enumeration(statistic, rule):
    rng = np.random.default_rng(20240601)
    x = np.cumsum(rng.standard_normal(240)) * 1e-9 + rng.standard_normal(240) * 1e-9
    x[[17, 100, 101, 180]] = np.nan
    m = np.array([1, 2, 3, 5, 8, 13])
    dev, n = getattr(ka, f"{statistic}_raw")(x, m, 0.5, gap_rule=rule)
    scale = 6.0 if statistic in ("hdev", "ohdev") else 2.0
    for j, mj in enumerate(m):
        total, count = brute_force_variance_sum(x, int(mj), statistic, rule)
        tau_s = mj * 0.5
        if statistic in ("mdev", "tdev"):
            expected = np.sqrt(total / (2.0 * mj**2 * tau_s**2 * count))
            expected = expected * tau_s / np.sqrt(3.0) if statistic == "tdev" else expected
        else:
            expected = np.sqrt(total / (scale * count * tau_s**2))
        assert n[j] == count
        assert dev[j] == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("statistic", STATISTICS)
def test_gap_longer_than_the_lag_pools_the_two_records_either_side(statistic):
    # A NaN run of 24 samples ending at 1023: no term of lag m <= 16 can step over it, and the record after
    # it starts on the non-overlapping grid (1024 is a multiple of every m), so skipping the terms that touch
    # the gap equals pooling the statistic of the two gap-free pieces: dev**2 n = dev_a**2 n_a + dev_b**2 n_b.
    rng = np.random.default_rng(7)
    x = np.cumsum(rng.standard_normal(3000)) * 1e-9
    x[1000:1024] = np.nan
    m = np.array([1, 2, 4, 8, 16])
    kernel = getattr(ka, f"{statistic}_raw")
    dev, n = kernel(x, m, 1.0)
    dev_a, n_a = kernel(x[:1000], m, 1.0)
    dev_b, n_b = kernel(x[1024:], m, 1.0)
    np.testing.assert_array_equal(n, n_a + n_b)
    np.testing.assert_allclose(dev**2 * n, dev_a**2 * n_a + dev_b**2 * n_b, rtol=1e-12)


@pytest.mark.parametrize("statistic", STATISTICS)
def test_kernel_leaves_its_input_untouched_and_rejects_bad_shapes(statistic):
    kernel = getattr(ka, f"{statistic}_raw")
    x = np.linspace(0.0, 1e-6, 100) ** 2
    x[10] = np.nan
    before = x.copy()
    kernel(x, np.array([1, 2, 4]), 1.0)
    np.testing.assert_array_equal(x, before)
    with pytest.raises(ValueError, match="x.shape"):
        kernel(x.reshape(10, 10), np.array([1]), 1.0)
    with pytest.raises(ValueError, match="m.shape"):
        kernel(x, np.int64(1), 1.0)
    with pytest.raises(ValueError, match="tau0_s"):
        kernel(x, np.array([1]), 0.0)


def test_tdev_is_tau_over_root_three_times_mdev():
    rng = np.random.default_rng(3)
    x = rng.standard_normal(500) * 1e-9
    m = np.array([1, 2, 4, 8, 16, 32])
    mdev, n_m = ka.mdev_raw(x, m, 0.1)
    tdev, n_t = ka.tdev_raw(x, m, 0.1)
    np.testing.assert_array_equal(n_m, n_t)
    np.testing.assert_allclose(tdev, m * 0.1 / np.sqrt(3.0) * mdev, rtol=1e-14)


def test_oadev_of_white_frequency_noise_matches_theory():
    # White FM with sigma_y per tau0 sample: OADEV(tau) = sigma_y / sqrt(m) (SP 1065 Table 5; exact in expectation).
    rng = np.random.default_rng(11)
    sigma_y = 1e-11
    x = frequency_to_phase(rng.standard_normal(200_000) * sigma_y, 1.0)
    m = np.array([1, 4, 16, 64])
    dev, n = ka.oadev_raw(x, m, 1.0)
    # Relative standard error of OADEV for white FM is about sqrt(1/(2 * edf)), edf ~ N/m: a 5 % bound is loose.
    np.testing.assert_allclose(dev, sigma_y / np.sqrt(m), rtol=0.05)


@pytest.mark.parametrize("statistic", STATISTICS)
def test_a_factor_too_large_for_the_record_gives_nan_and_no_terms(statistic):
    dev, n = getattr(ka, f"{statistic}_raw")(np.arange(10.0) ** 2, np.array([1, 9, 20]), 1.0)
    assert np.isfinite(dev[0]) and n[0] > 0
    assert np.all(np.isnan(dev[1:])) and np.all(n[1:] == 0)


def test_max_averaging_factors_follow_stable32_stop_ratios():
    assert [ka.max_m_adev(1001), ka.max_m_hdev(1001)] == [200, 200]
    assert [ka.max_m_oadev(1001), ka.max_m_mdev(1001), ka.max_m_tdev(1001), ka.max_m_ohdev(1001)] == [250] * 4
    assert ka.max_m_adev(4) == 0
    with pytest.raises(ValueError, match="n_points"):
        ka.max_m_adev(-1)


@pytest.mark.parametrize("order", [2, 3])
def test_the_fused_numba_difference_sums_equal_the_blockwise_numpy_twin(order):
    """difference_sum_of_squares_fused (one numba pass) against difference_sum_of_squares (numpy blocks),
    overlapping and decimated, with and without missing samples."""
    rng = np.random.default_rng(order)
    x = np.cumsum(rng.standard_normal(70_000)) * 1e-9
    for gaps in (False, True):
        if gaps:
            x[[5, 6, 40_000]] = np.nan
        for m in (1, 3, 64, 1000):
            for step in (1, m):
                s_num, n_num = kd.difference_sum_of_squares(x, m, order, step)
                s_fused, n_fused = kd.difference_sum_of_squares_fused(x, m, order, step)
                if gaps:
                    s_fused, n_fused = kd.difference_sum_of_squares_span(x, kd.nan_prefix(x), m, order, step)
                    s_own, n_own = kd.difference_sum_of_squares(x, m, order, step, rule="samples")
                    s_fast, n_fast = kd.difference_sum_of_squares_samples(x, m, order, step)
                    assert n_own == n_fast >= n_num and s_fast == pytest.approx(s_own, rel=1e-12)
                assert n_fused == n_num and s_fused == pytest.approx(s_num, rel=1e-12)


def test_the_fused_numba_mdev_sum_equals_the_blockwise_numpy_twin():
    rng = np.random.default_rng(31)
    x = np.cumsum(np.cumsum(rng.standard_normal(80_000))) * 1e-12 + 1e-6 * np.arange(80_000)  # a ramp too
    work, cumulative = np.empty((2, ka._BLOCK)), np.empty(x.size + 1)
    for m in (1, 2, 7, 64, 5000):
        s_num, n_num = ka._mvar_sum_of_squares(x, m, work, cumulative.copy())
        s_fused, n_fused = ka._mvar_sum_of_squares_fused(x, m, cumulative)
        assert n_fused == n_num and s_fused == pytest.approx(s_num, rel=1e-9)


def test_finite_sum_equals_numpys_sum_and_is_not_finite_exactly_when_a_sample_is_nan_or_infinite():
    rng = np.random.default_rng(8)
    x = rng.standard_normal(100_003) * 1e-9
    assert kd.finite_sum(x) == pytest.approx(float(np.add.reduce(x)), rel=1e-9, abs=1e-18)
    for bad in (np.nan, np.inf, -np.inf):
        y = x.copy()
        y[77_777] = bad
        assert not np.isfinite(kd.finite_sum(y))


def test_non_overlapping_sums_decimated_from_the_previous_factor_equal_those_from_the_whole_record():
    # difference_sums_fused takes x[::8] from x[::4] on an octave grid; a factor that the previous one
    # does not divide (12 after 8) goes back to the record. Each must equal its own one-factor sum.
    x = np.cumsum(np.random.default_rng(9).standard_normal(5000))
    m = np.array([1, 2, 4, 8, 12, 24, 5], dtype=np.int64)
    for order in (kd.SECOND, kd.THIRD):
        sums, counts = kd.difference_sums_fused(x, m, order, False)
        for j, mj in enumerate(m):
            alone, count = kd.difference_sum_of_squares(x, int(mj), order, int(mj))
            assert counts[j] == count
            assert sums[j] == pytest.approx(alone, rel=1e-12)
