"""Raw TIE rms and MTIE kernels against Stable32's Cs 5071A tables, allantools and a brute-force window scan."""

from __future__ import annotations

import functools

import allantools
import numpy as np
import pytest
from _helpers import assert_close_printed, read_stable32_table

from chronofuse.analysis.stability import kernels_tie as kt
from chronofuse.analysis.stability.taus import averaging_factors


@functools.cache
def cs5071a_phase(data_dir) -> np.ndarray:
    """556,990 phase samples (s) of a Cs 5071A against an H-maser, 1 Hz."""
    return np.loadtxt(data_dir / "stability" / "Cs5071A" / "5071A_phase.txt.gz", comments="#")


@functools.cache
def phasedat_phase(data_dir) -> np.ndarray:
    """Stable32's PHASE.DAT, 1001 phase samples."""
    return np.loadtxt(data_dir / "stability" / "phasedat" / "PHASE.DAT", comments="#")


@functools.cache
def gps_phase(data_dir) -> np.ndarray:
    """241,218 phase samples (s) of a GPS receiver's 1PPS against an H-maser, 1 Hz."""
    return np.loadtxt(data_dir / "stability" / "gps" / "gps_1pps_phase_data.txt.gz", comments="#")


@pytest.mark.parametrize(("statistic", "table_name"), [("mtie", "mtie_decade.txt"), ("tie_rms", "tierms_decade.txt")])
def test_raw_value_and_count_equal_stable32_cs5071a_table(data_dir, statistic, table_name):
    table = read_stable32_table(data_dir / "stability" / "Cs5071A" / table_name)
    x = cs5071a_phase(data_dir)
    dev, n = getattr(kt, f"{statistic}_raw")(x, table["af"].astype(np.int64), 1.0)
    # Stable32's "#": for TIE rms the number of differences N - m, for MTIE the number of samples N.
    np.testing.assert_array_equal(n, table["n"])
    assert_close_printed(dev, table["dev"], name=statistic)


@pytest.mark.parametrize(("statistic", "table_name"), [("mtie", "mtie_decade.txt"), ("tie_rms", "tierms_decade.txt")])
def test_max_averaging_factor_reproduces_stable32_tau_range(data_dir, statistic, table_name):
    table = read_stable32_table(data_dir / "stability" / "Cs5071A" / table_name)
    max_m = getattr(kt, f"max_m_{statistic}")(cs5071a_phase(data_dir).size)
    np.testing.assert_array_equal(averaging_factors(max_m, "decade"), table["af"])


@pytest.mark.parametrize("dataset", ["phasedat", "gps", "Cs5071A"])
def test_tie_rms_equals_allantools(data_dir, dataset):
    x = {"phasedat": phasedat_phase, "gps": gps_phase, "Cs5071A": cs5071a_phase}[dataset](data_dir)
    m = averaging_factors(kt.max_m_tie_rms(x.size), "octave")
    _, ref_dev, _, ref_n = allantools.tierms(x, rate=1.0, data_type="phase", taus=m.astype(float))
    dev, n = kt.tie_rms_raw(x, m, 1.0)
    np.testing.assert_array_equal(n, ref_n.astype(np.int64))
    np.testing.assert_allclose(dev, ref_dev, rtol=1e-10, atol=0)


def test_mtie_equals_allantools_on_phase_dat_at_every_factor(data_dir):
    x = phasedat_phase(data_dir)
    m = np.arange(1, kt.max_m_mtie(x.size) + 1)
    _, ref_dev, _, ref_n = allantools.mtie(x, rate=1.0, data_type="phase", taus=m.astype(float))
    dev, n = kt.mtie_raw(x, m, 1.0)
    np.testing.assert_array_equal(dev, ref_dev)  # maxima and minima: exact
    # allantools counts windows (N - m); Stable32's "#" (and ours) is the number of samples.
    np.testing.assert_array_equal(ref_n, x.size - m)
    assert np.all(n == x.size)


def test_mtie_equals_allantools_on_a_gps_1pps_stretch(data_dir):
    x = gps_phase(data_dir)[:20_000]
    m = averaging_factors(256, "octave")  # allantools builds an (N, m+1) window array: keep it small
    _, ref_dev, _, _ = allantools.mtie(x, rate=1.0, data_type="phase", taus=m.astype(float))
    dev, _ = kt.mtie_raw(x, m, 1.0)
    np.testing.assert_array_equal(dev, ref_dev)


def test_sparse_table_mtie_equals_window_scan_with_nan_gaps_at_every_factor():
    rng = np.random.default_rng(42)
    x = np.cumsum(rng.standard_normal(400)) * 1e-9
    x[[3, 4, 5]] = np.nan
    x[100:140] = np.nan  # a gap longer than small windows: windows of only NaN are skipped
    x[-1] = np.nan
    m = np.arange(1, kt.max_m_mtie(x.size) + 1)[::-1]  # any order
    dev, n = kt.mtie_raw(x, m, 1.0)
    ref_dev, ref_n = kt.mtie_windows_raw(x, m, 1.0)
    np.testing.assert_array_equal(dev, ref_dev)
    np.testing.assert_array_equal(n, ref_n)
    assert np.all(n == 400 - 3 - 40 - 1)


def test_sparse_table_mtie_equals_window_scan_on_phase_dat(data_dir):
    x = phasedat_phase(data_dir)
    m = np.array([1, 2, 3, 7, 8, 9, 63, 64, 65, 255, 256, 257, 500])  # around the table's 2**k levels
    np.testing.assert_array_equal(kt.mtie_raw(x, m, 1.0)[0], kt.mtie_windows_raw(x, m, 1.0)[0])


def test_mtie_of_a_short_record_with_a_nan_matches_hand_computation():
    x = np.array([0.0, 1.0, np.nan, 3.0, 0.0])
    # m = 1: windows {0,1} {1} {3} {3,0} -> 1, 0, 0, 3; m = 2: {0,1} {1,3} {3,0} -> 1, 2, 3.
    dev, n = kt.mtie_raw(x, np.array([1, 2]), 1.0)
    np.testing.assert_array_equal(dev, [3.0, 3.0])
    np.testing.assert_array_equal(n, [4, 4])


def test_mtie_never_decreases_with_the_observation_interval():
    rng = np.random.default_rng(5)
    x = np.cumsum(rng.standard_normal(5000)) + rng.standard_normal(5000)
    dev, _ = kt.mtie_raw(x, np.arange(1, 2501), 1.0)
    assert np.all(np.diff(dev) >= 0)


def test_tie_rms_gap_longer_than_the_lag_pools_the_two_records_either_side():
    # No difference x[i+m] - x[i] with m <= 16 steps over a 24-sample NaN run: skipping the differences
    # that touch it equals pooling the two gap-free pieces, dev**2 n = dev_a**2 n_a + dev_b**2 n_b.
    rng = np.random.default_rng(8)
    x = np.cumsum(rng.standard_normal(3000)) * 1e-9
    x[1000:1024] = np.nan
    m = np.array([1, 2, 4, 8, 16])
    dev, n = kt.tie_rms_raw(x, m, 1.0)
    dev_a, n_a = kt.tie_rms_raw(x[:1000], m, 1.0)
    dev_b, n_b = kt.tie_rms_raw(x[1024:], m, 1.0)
    np.testing.assert_array_equal(n, n_a + n_b)
    np.testing.assert_allclose(dev**2 * n, dev_a**2 * n_a + dev_b**2 * n_b, rtol=1e-12)


@pytest.mark.parametrize("rule", ["samples", "span"])
def test_tie_rms_skips_the_differences_its_gap_rule_names_as_by_direct_enumeration(rule):
    rng = np.random.default_rng(9)
    x = rng.standard_normal(120)
    x[[10, 60]] = np.nan
    for mj in (1, 5, 30):
        def missing(i):
            return np.isnan(x[[i, i + mj]]).any() if rule == "samples" else np.isnan(x[i : i + mj + 1]).any()
        diffs = [x[i + mj] - x[i] for i in range(x.size - mj) if not missing(i)]
        dev, n = kt.tie_rms_raw(x, np.array([mj]), 1.0, gap_rule=rule)
        assert n[0] == len(diffs) < x.size - mj
        assert dev[0] == pytest.approx(np.sqrt(np.mean(np.square(diffs))), rel=1e-13)


@pytest.mark.parametrize("kernel", [kt.tie_rms_raw, kt.mtie_raw, kt.mtie_windows_raw])
def test_kernel_leaves_its_input_untouched_and_rejects_bad_shapes(kernel):
    x = np.sin(np.arange(50.0))
    x[7] = np.nan
    before = x.copy()
    kernel(x, np.array([1, 3, 10]), 1.0)
    np.testing.assert_array_equal(x, before)
    with pytest.raises(ValueError, match="x.shape"):
        kernel(x.reshape(5, 10), np.array([1]), 1.0)
    with pytest.raises(ValueError, match="m =="):
        kernel(x, np.array([0]), 1.0)


def test_mtie_rejects_a_window_longer_than_the_record():
    with pytest.raises(ValueError, match="must be < N"):
        kt.mtie_raw(np.zeros(10), np.array([10]), 1.0)


@pytest.mark.parametrize("gaps", [False, True])
def test_the_numba_sparse_table_equals_its_numpy_twin_and_the_window_scan(gaps):
    rng = np.random.default_rng(11)
    x = np.cumsum(rng.standard_normal(3000)) * 1e-9
    if gaps:
        x[[0, 7, 8, 1500]] = np.nan
    m = np.r_[averaging_factors(kt.max_m_mtie(x.size), "octave"), 3, 5, 6, 7, 99, 1000]
    ours = kt.mtie_raw(x, m, 1.0)
    np.testing.assert_array_equal(ours[0], kt.mtie_sparse_numpy(x, m, 1.0)[0])
    np.testing.assert_array_equal(ours[0], kt.mtie_windows_raw(x, m, 1.0)[0])
    np.testing.assert_array_equal(ours[1], kt.mtie_windows_raw(x, m, 1.0)[1])


@pytest.mark.parametrize("gaps", [False, True])
@pytest.mark.parametrize("block, top", [(1, 0), (5, 1), (64, 3), (100, 5), (4096, 12)])
def test_the_blocked_sparse_table_is_bit_identical_to_the_numpy_twin_whatever_the_block(gaps, block, top):
    """The first levels built block by block (kernels_mtie) must give exactly the level-by-level sweep's
    extrema, wherever the blocks cut the record and whichever windows fall on either side of the cut."""
    from chronofuse.analysis.stability.kernels_mtie import mtie_blocked

    rng = np.random.default_rng(block + top)
    x = np.cumsum(rng.standard_normal(1237)) * 1e-9
    if gaps:
        x[[0, 1, 63, 64, 65, 400, 1236]] = np.nan
    m = np.r_[averaging_factors(kt.max_m_mtie(x.size), "octave"), 2, 3, 5, 6, 7, 9, 15, 17, 31, 33, 99, 1000, 1236]
    window = m + 1
    ours = mtie_blocked(x, window, np.argsort(window, kind="stable"), gaps, block, top)
    np.testing.assert_array_equal(ours, kt.mtie_sparse_numpy(x, m, 1.0)[0])
    np.testing.assert_array_equal(ours, kt.mtie_windows_raw(x, m, 1.0)[0])
