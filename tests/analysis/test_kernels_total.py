"""Raw total-family kernels (TOTDEV, MTOTDEV, TTOTDEV, HTOTDEV) against allantools, Stable32's tables,
the NIST SP 1065 1000-point test suite, their numpy twins, and the invariances of their definitions."""

from __future__ import annotations

import gzip
import itertools
from pathlib import Path

import allantools
import numpy as np
import pytest
from _helpers import assert_close_printed

from chronofuse.analysis.stability import kernels_reflected as kr
from chronofuse.analysis.stability import kernels_total as kt
from chronofuse.analysis.stability.taus import averaging_factors

RAW = {
    "totdev": (kt.totdev_raw, kt.totdev_numpy, kt.max_m_totdev, allantools.totdev),
    "mtotdev": (kt.mtotdev_raw, kt.mtotdev_numpy, kt.max_m_mtotdev, allantools.mtotdev),
    "ttotdev": (kt.ttotdev_raw, kt.ttotdev_numpy, kt.max_m_ttotdev, allantools.ttotdev),
    "htotdev": (kt.htotdev_raw, kt.htotdev_numpy, kt.max_m_htotdev, allantools.htotdev),
}


def read_table_with_marked_rows(path: Path) -> dict[str, np.ndarray]:
    """Stable32 table rows ``AF Tau # Alpha Min Sigma Max``, including the rows Stable32 marks with '#'.

    Stable32 comments out rows whose confidence interval it deems unreliable; their sigma is still
    the computed value, so the raw-value comparisons use them too.
    """
    rows = []
    for line in path.read_text().splitlines():
        fields = line.lstrip("#").split()
        if len(fields) == 7:
            try:
                rows.append([float(f) for f in fields])
            except ValueError:
                continue
    arr = np.array(rows)
    return {"af": arr[:, 0].astype(np.int64), "n": arr[:, 2].astype(np.int64), "alpha": arr[:, 3].astype(int), "dev": arr[:, 5]}


@pytest.fixture(scope="module")
def gps_slice(data_dir) -> np.ndarray:
    """The first 700 s of the GPS 1PPS-vs-H-maser record (phase in s, 1 Hz)."""
    with gzip.open(data_dir / "stability" / "gps" / "gps_1pps_phase_data.txt.gz", "rt") as f:
        values = (line for line in f if line.strip() and not line.startswith("#"))
        return np.array([float(v) for v in itertools.islice(values, 700)])


def _allantools(name: str, x: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    _, devs, _, ns = RAW[name][3](x, rate=1.0, data_type="phase", taus=m.astype(float))
    assert devs.size == m.size  # allantools kept every factor: our ranges are within its own
    return devs, ns.astype(np.int64)


# -- allantools (the same definitions, evaluated term by term in Python) ---------------------------


@pytest.mark.parametrize("name", ["totdev", "mtotdev", "ttotdev", "htotdev"])
def test_raw_total_deviations_equal_allantools_on_phase_dat(name, phase_dat):
    raw, _, max_m, _ = RAW[name]
    m = np.unique(np.r_[averaging_factors(max_m(phase_dat.size)), 3, 5, 7, max_m(phase_dat.size)])
    if name == "ttotdev":  # allantools recomputes MTOTDEV for it: keep the slow large factors out
        m = m[m <= 64]
    dev, n = raw(phase_dat, m, 1.0)
    ref_dev, ref_n = _allantools(name, phase_dat, m)
    np.testing.assert_allclose(dev, ref_dev, rtol=1e-10, atol=0)
    np.testing.assert_array_equal(n, ref_n)


@pytest.mark.parametrize("name", ["totdev", "mtotdev", "ttotdev", "htotdev"])
def test_raw_total_deviations_equal_allantools_on_a_gps_receiver_record(name, gps_slice):
    raw, _, max_m, _ = RAW[name]
    m = np.unique(np.r_[1, 2, 3, 5, 8, 17, 32, 64, 128, max_m(gps_slice.size)])
    # A sample interval other than 1 s: the record read as if sampled at 2 Hz (phase scaled alike).
    dev, n = raw(gps_slice, m, 0.5)
    _, ref_dev, _, ref_n = RAW[name][3](gps_slice, rate=2.0, data_type="phase", taus=m * 0.5)
    np.testing.assert_allclose(dev, ref_dev, rtol=1e-10, atol=0)
    np.testing.assert_array_equal(n, ref_n)


# -- Stable32's tables for PHASE.DAT ---------------------------------------------------------------


def test_totdev_equals_stable32_table_where_white_fm_has_no_bias(phase_dat, data_dir):
    # Every row is identified as alpha = 0 (white FM), for which the TOTVAR bias 1 - a tau/T has
    # a = 0 (SP 1065): the printed sigma is the raw value, so all rows compare.
    table = read_table_with_marked_rows(data_dir / "stability" / "phasedat" / "phase_dat_totdev_octave.txt")
    assert np.all(table["alpha"] == 0)
    dev, n = kt.totdev_raw(phase_dat, table["af"], 1.0)
    assert_close_printed(dev, table["dev"], name="totdev")
    np.testing.assert_array_equal(n, table["n"])


@pytest.mark.parametrize("table_name", ["phase_dat_mtotdev_octave.txt", "phase_dat_mtotdev_octave_alpha0.txt"])
def test_mtotdev_equals_stable32_tables_which_carry_no_bias_correction(table_name, phase_dat, data_dir):
    # Stable32 1.60 prints the same MTOTDEV in both tables although their alpha columns differ
    # (rows 128 and 256): no bias factor was applied, so every row is the raw value.
    table = read_table_with_marked_rows(data_dir / "stability" / "phasedat" / table_name)
    dev, n = kt.mtotdev_raw(phase_dat, table["af"], 1.0)
    assert_close_printed(dev, table["dev"], name="mtotdev")
    np.testing.assert_array_equal(n, table["n"])


def test_ttotdev_equals_stable32_table_which_carries_no_bias_correction(phase_dat, data_dir):
    table = read_table_with_marked_rows(data_dir / "stability" / "phasedat" / "phase_dat_ttotdev_octave.txt")
    dev, n = kt.ttotdev_raw(phase_dat, table["af"], 1.0)
    assert_close_printed(dev, table["dev"], name="ttotdev")
    np.testing.assert_array_equal(n, table["n"])


def test_htotdev_equals_stable32_unbiased_table(phase_dat, data_dir):
    table = read_table_with_marked_rows(data_dir / "stability" / "phasedat" / "phase_dat_htotdev_octave_nobias.txt")
    dev, n = kt.htotdev_raw(phase_dat, table["af"], 1.0)
    assert_close_printed(dev, table["dev"], name="htotdev")
    np.testing.assert_array_equal(n, table["n"])


def test_htotdev_equals_stable32_bias_corrected_table_where_no_factor_applies(phase_dat, data_dir):
    # In the bias-corrected table the m = 1 row is the overlapping HDEV (no factor) and the alpha = 1
    # rows carry none either; the alpha = 0 (white FM) rows are raw / sqrt(0.995), Riley's factor.
    table = read_table_with_marked_rows(data_dir / "stability" / "phasedat" / "phase_dat_htotdev_octave.txt")
    dev, n = kt.htotdev_raw(phase_dat, table["af"], 1.0)
    unbiased = (table["af"] == 1) | (table["alpha"] == 1)
    assert unbiased.sum() == 3
    assert_close_printed(dev[unbiased], table["dev"][unbiased], name="htotdev, no factor")
    white_fm = ~unbiased & (table["alpha"] == 0)
    assert_close_printed(dev[white_fm] / np.sqrt(0.995), table["dev"][white_fm], name="htotdev, white FM")
    np.testing.assert_array_equal(n, table["n"])


# -- NIST SP 1065 1000-point test suite (Table 31, p. 108) ----------------------------------------
# Published values at AF = 1, 10, 100, as collected in allantools' tests/nbs14/test_nbs14_1000point.py
# (aewallin/allantools). TOTDEV is published raw ("doubly reflected TOTVAR"; white FM has no TOTVAR
# bias); MTOTDEV and TTOTDEV are published bias-corrected for white FM (factor 0.73), HTOTDEV with
# Riley's 0.995 for AF > 1. The unbiased Stable32 1.60 values come from the same file.

NBS14_AF = np.array([1, 10, 100])


def test_totdev_equals_sp1065_published_1000_point_values(nbs14_phase):
    dev, _ = kt.totdev_raw(nbs14_phase, NBS14_AF, 1.0)
    assert_close_printed(dev, [2.922319e-01, 9.134743e-02, 3.406530e-02], rel_digits=7, name="totdev")


def test_mtotdev_equals_sp1065_published_1000_point_values_after_white_fm_bias(nbs14_phase):
    dev, _ = kt.mtotdev_raw(nbs14_phase, NBS14_AF, 1.0)
    assert_close_printed(dev, [2.0664e-01, 5.5529e-02, 1.9547e-02], name="mtotdev, Stable32 unbiased")
    assert_close_printed(dev / np.sqrt(0.73), [2.418528e-01, 6.499161e-02, 2.287774e-02], rel_digits=6, name="mtotdev, published")


def test_ttotdev_equals_sp1065_published_1000_point_values_after_white_fm_bias(nbs14_phase):
    dev, _ = kt.ttotdev_raw(nbs14_phase, NBS14_AF, 1.0)
    assert_close_printed(dev, [1.1930e-01, 3.2060e-01, 1.1285e00], name="ttotdev, Stable32 unbiased")
    assert_close_printed(dev / np.sqrt(0.73), [1.396338e-01, 3.752293e-01, 1.320847e00], rel_digits=6, name="ttotdev, published")


def test_htotdev_equals_sp1065_published_1000_point_values_after_white_fm_bias(nbs14_phase):
    dev, _ = kt.htotdev_raw(nbs14_phase, NBS14_AF, 1.0)
    factor = np.sqrt([1.0, 0.995, 0.995])
    assert_close_printed(dev / factor, [2.943883e-01, 9.614787e-02, 3.058103e-02], rel_digits=6, name="htotdev")


# -- numba kernels against their numpy twins ---------------------------------------------------------


@pytest.mark.parametrize("name", ["totdev", "mtotdev", "ttotdev", "htotdev"])
def test_numba_kernels_equal_their_numpy_twins_on_phase_dat(name, phase_dat):
    raw, twin, max_m, _ = RAW[name]
    m = np.array([1, 2, 3, 4, 7, 16, 50, 128, max_m(phase_dat.size)])
    np.testing.assert_allclose(raw(phase_dat, m, 1.0)[0], twin(phase_dat, m, 1.0)[0], rtol=1e-12, atol=0)
    np.testing.assert_array_equal(raw(phase_dat, m, 1.0)[1], twin(phase_dat, m, 1.0)[1])


@pytest.mark.parametrize("offset_s", [0.0, 0.3])
def test_mtotdev_and_htotdev_keep_precision_on_random_walk_fm_with_a_large_offset(offset_s):
    # Random-walk FM wanders far from its line: prefix sums over the whole record would cancel
    # catastrophically. The twins work on the record with its offset and line removed exactly.
    rng = np.random.default_rng(20260)
    x = offset_s + 1e-12 * np.cumsum(np.cumsum(rng.standard_normal(2000)))
    reference = x - x[0]
    reference = reference - reference[-1] * np.arange(x.size) / (x.size - 1)
    m = np.array([1, 2, 3, 9, 40, 333])
    np.testing.assert_allclose(kt.mtotdev_raw(x, m, 1.0)[0], kt.mtotdev_numpy(reference, m, 1.0)[0], rtol=1e-9)
    np.testing.assert_allclose(kt.htotdev_raw(x, m, 1.0)[0], kt.htotdev_numpy(x, m, 1.0)[0], rtol=1e-9)


@pytest.mark.parametrize("m", [1, 2, 5, 12])
def test_reflected_sum_kernel_equals_its_twin_for_samples_and_for_prefix_input(m):
    rng = np.random.default_rng(m)
    y = rng.standard_normal(300) + 0.01 * np.arange(300)
    expected = kr.reflected_sum_of_squares_numpy(y, m)
    assert kr.reflected_sum_of_squares(y, m, False) == pytest.approx(expected, rel=1e-12)
    prefix = np.concatenate(([0.0], np.cumsum(y)))
    assert kr.reflected_sum_of_squares(prefix, m, True) == pytest.approx(expected, rel=1e-12)


# -- properties of the definitions -------------------------------------------------------------------


def test_mtotdev_ignores_a_phase_line_and_htotdev_ignores_a_frequency_drift(phase_dat):
    t = np.arange(phase_dat.size, dtype=float)
    m = np.array([1, 2, 3, 16, 100, 333])
    base_mtot = kt.mtotdev_raw(phase_dat, m, 1.0)[0]
    np.testing.assert_allclose(kt.mtotdev_raw(phase_dat + 5.0 + 0.25 * t, m, 1.0)[0], base_mtot, rtol=1e-9)
    base_htot = kt.htotdev_raw(phase_dat, m, 1.0)[0]
    drifting = phase_dat + 5.0 + 0.25 * t + 1e-3 * t**2  # quadratic phase: linear frequency drift
    np.testing.assert_allclose(kt.htotdev_raw(drifting, m, 1.0)[0], base_htot, rtol=1e-8)


def test_ttotdev_is_tau_over_root_three_times_mtotdev(phase_dat):
    m = np.array([1, 4, 32])
    mtot = kt.mtotdev_raw(phase_dat, m, 0.25)[0]
    np.testing.assert_allclose(kt.ttotdev_raw(phase_dat, m, 0.25)[0], m * 0.25 / np.sqrt(3.0) * mtot, rtol=1e-15)


def test_kernels_leave_their_input_unchanged(phase_dat):
    x = phase_dat.copy()
    for raw, *_ in RAW.values():
        raw(x, np.array([1, 2, 8]), 1.0)
    np.testing.assert_array_equal(x, phase_dat)


def test_averaging_factor_limits_reproduce_stable32_and_allantools_ranges(data_dir):
    # TOTDEV stops at T/2: the last octave of PHASE.DAT (1001 points) and of the GPS record
    # (241,218 points) and the last decade factor of the 5071A record (556,990) in Stable32's tables.
    assert averaging_factors(kt.max_m_totdev(1001))[-1] == 256
    assert averaging_factors(kt.max_m_totdev(241218))[-1] == 65536
    assert averaging_factors(kt.max_m_totdev(556990), "decade")[-1] == 200000
    # MTOTDEV/HTOTDEV: allantools' own limit (m <= N/3 with more than one term) on short records.
    x = np.random.default_rng(3).standard_normal(41).cumsum()
    for n_points in (38, 40, 41):
        xs = x[:n_points]
        assert allantools.mtotdev(xs, taus="all")[0][-1] == kt.max_m_mtotdev(n_points)
        assert allantools.htotdev(xs, taus="all")[0][-1] == kt.max_m_htotdev(n_points)


@pytest.mark.parametrize(
    ("x", "m", "match"),
    [
        (np.zeros((10, 2)), np.array([1]), "must be \\(N,\\)"),
        (np.r_[np.arange(20.0), np.nan], np.array([1]), "gap-free"),
        (np.arange(20.0), np.array([7]), "must be within 1..6"),
        (np.arange(20.0), np.array([1.0]), "integer"),
        (np.arange(20.0), np.int64(1), "must be \\(k,\\)"),
    ],
)
def test_kernels_reject_bad_inputs_with_the_offending_value(x, m, match):
    with pytest.raises(ValueError, match=match):
        kt.mtotdev_raw(x, m, 1.0)


def test_parallel_and_serial_drivers_give_identical_block_sums():
    # Large records run the blocks in parallel, small ones serially: same blocks, same sums.
    x = np.random.default_rng(11).standard_normal(3000).cumsum()
    for m, is_prefix in ((1, False), (7, True), (100, False)):
        n_sub = x.size - 3 * m if is_prefix else x.size - 3 * m + 1
        tables = kr._coefficient_table(m)
        serial = kr._block_sums_serial(x, n_sub, 256, m, is_prefix, *tables)
        parallel = kr._block_sums_parallel(x, n_sub, 256, m, is_prefix, *tables)
        np.testing.assert_array_equal(parallel, serial)
