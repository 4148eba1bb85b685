"""Raw Theo1 kernel against allantools, Stable32's values for the NIST SP 1065 1000-point test set,
its numpy twin, and the properties of its definition."""

from __future__ import annotations

import gzip
import itertools

import allantools
import numpy as np
import pytest
from _helpers import assert_close_printed

from chronofuse.analysis.stability import kernels_theo as kth
from chronofuse.analysis.stability.taus import averaging_factors


@pytest.fixture(scope="module")
def gps_slice(data_dir) -> np.ndarray:
    """The first 600 s of the GPS 1PPS-vs-H-maser record (phase in s, 1 Hz)."""
    with gzip.open(data_dir / "stability" / "gps" / "gps_1pps_phase_data.txt.gz", "rt") as f:
        values = (line for line in f if line.strip() and not line.startswith("#"))
        return np.array([float(v) for v in itertools.islice(values, 600)])


def _even_octaves(n_points: int) -> np.ndarray:
    m = averaging_factors(kth.max_m_theo1(n_points))
    return m[m % 2 == 0]


def test_theo1_equals_allantools_on_phase_dat(phase_dat):
    m = np.unique(np.r_[_even_octaves(phase_dat.size), 10, 100, 1000])
    dev, n = kth.theo1_raw(phase_dat, m, 1.0)
    _, ref_dev, _, ref_n = allantools.theo1(phase_dat, rate=1.0, data_type="phase", taus=m.astype(float))
    np.testing.assert_allclose(dev, ref_dev, rtol=1e-10, atol=0)
    np.testing.assert_array_equal(n, ref_n.astype(np.int64))


def test_theo1_equals_allantools_on_a_gps_receiver_record(gps_slice):
    m = np.r_[2, 6, 16, 64, 250, kth.max_m_theo1(gps_slice.size)]
    dev, n = kth.theo1_raw(gps_slice, m, 0.5)  # read as 2 Hz: checks the tau0 scaling
    _, ref_dev, _, ref_n = allantools.theo1(gps_slice, rate=2.0, data_type="phase", taus=m * 0.5)
    np.testing.assert_allclose(dev, ref_dev, rtol=1e-10, atol=0)
    np.testing.assert_array_equal(n, ref_n.astype(np.int64))


def test_theo1_equals_stable32_on_the_sp1065_1000_point_test_set(nbs14_phase):
    # Stable32, no bias correction, AF = 10, 100, 1000 (tau = 7.5, 75, 750 s), as collected in
    # allantools' tests/nbs14/test_nbs14_1000point.py (aewallin/allantools).
    dev, _ = kth.theo1_raw(nbs14_phase, np.array([10, 100, 1000]), 1.0)
    assert_close_printed(dev, [1.0757e-01, 3.1789e-02, 5.0524e-03], name="theo1")


def test_theo1_numba_kernel_equals_numpy_twin(phase_dat):
    m = np.r_[2, 4, 10, 36, 128, 500, kth.max_m_theo1(phase_dat.size)]
    dev, n = kth.theo1_raw(phase_dat, m, 1.0)
    twin_dev, twin_n = kth.theo1_numpy(phase_dat, m, 1.0)
    np.testing.assert_allclose(dev, twin_dev, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(n, twin_n)


def test_theo1_ignores_phase_offset_and_frequency_offset(phase_dat):
    # Every bracket (x_i - x_{i-d+m/2}) + (x_{i+m} - x_{i+d+m/2}) cancels a constant and a line.
    t = np.arange(phase_dat.size, dtype=float)
    m = np.array([2, 20, 200])
    shifted = phase_dat + 1e3 + 0.5 * t
    np.testing.assert_allclose(kth.theo1_raw(shifted, m, 1.0)[0], kth.theo1_raw(phase_dat, m, 1.0)[0], rtol=1e-9)


def test_theo1_of_white_fm_follows_tau_to_the_minus_one_half():
    # White FM: Theo1 is designed to equal the Allan variance, sigma_y^2(tau) = h0 / (2 tau), with tau
    # = 0.75 m tau0; the record is long enough that the estimate is within a few percent.
    rng = np.random.default_rng(7)
    y = rng.standard_normal(20000)
    x = np.concatenate(([0.0], np.cumsum(y)))
    m = np.array([4, 16, 64])
    dev, _ = kth.theo1_raw(x, m, 1.0)
    expected = 1.0 / np.sqrt(0.75 * m)  # unit-variance white frequency: sigma_y(tau) = 1/sqrt(tau)
    np.testing.assert_allclose(dev, expected, rtol=0.05)


def test_theo1_rejects_odd_and_out_of_range_factors():
    x = np.arange(30.0)
    with pytest.raises(ValueError, match="must be even"):
        kth.theo1_raw(x, np.array([2, 3]), 1.0)
    with pytest.raises(ValueError, match="must be within"):
        kth.theo1_raw(x, np.array([30]), 1.0)
    assert kth.max_m_theo1(30) == 28 and kth.max_m_theo1(31) == 30 and kth.max_m_theo1(2) == 0


def test_theo1_leaves_its_input_unchanged(phase_dat):
    x = phase_dat.copy()
    kth.theo1_raw(x, np.array([2, 8]), 1.0)
    np.testing.assert_array_equal(x, phase_dat)


def test_theo1_parallel_and_serial_drivers_agree(phase_dat):
    for m in (2, 64, 500):
        np.testing.assert_array_equal(kth._theo1_parallel(phase_dat, m), kth._theo1_serial(phase_dat, m))
