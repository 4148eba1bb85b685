"""Multi-phase counter: the source paper's worked example exactly, and the 1/N resolution gain shown statistically."""

import numpy as np
import pytest

from chronofuse.discipline.counter import MultiPhaseCounter, multiphase_counts


def test_the_seeds_worked_example_counts_mean_and_error_are_reproduced_exactly():
    counter = MultiPhaseCounter(reference_hz=10e6, multiplier=20, n_phases=4)
    assert counter.clock_hz == 200e6
    counts = counter.counts(200000010.75 / 200e6, 0.0)
    assert counts.tolist() == [200000010, 200000011, 200000011, 200000011]
    assert counts.mean() == 200000010.75
    assert counter.count_error(counts) == 10.75
    assert counter.fractional_frequency(counts) == pytest.approx(10.75 / 200e6, rel=1e-15)


def test_the_seeds_resolution_is_one_over_n_times_the_clock():
    assert MultiPhaseCounter().resolution_s == pytest.approx(1.25e-9, rel=1e-15)


def test_one_phase_is_a_plain_counter_of_whole_ticks():
    counts = multiphase_counts(np.array([10.0, 10.3, 10.7]), np.array([0.0, 0.5, 0.5]), 1)
    assert counts[:, 0].tolist() == [10, 10, 11]


@pytest.mark.parametrize("n_phases", [1, 2, 4, 8, 16])
def test_rms_quantization_error_falls_as_one_over_n_sqrt6(n_phases):
    # Theory (module docstring): for uniform start phase u and fractional length, the mean count's error
    # is zero-mean with rms 1 / (N sqrt 6) counts. 40,000 intervals: the rms is within 2 %.
    rng = np.random.default_rng(12)
    m = 40_000
    cycles = 2e8 + rng.uniform(-50.0, 50.0, m)
    u = rng.uniform(0.0, 1.0, m)
    err = multiphase_counts(cycles, u, n_phases).mean(axis=-1) - cycles
    rms = np.sqrt(np.mean(err**2))
    theory = 1.0 / (n_phases * np.sqrt(6.0))
    assert rms == pytest.approx(theory, rel=0.03)
    assert abs(err.mean()) < 4 * theory / np.sqrt(m)


def test_four_phases_beat_one_counter_by_four_in_rms():
    rng = np.random.default_rng(5)
    cycles = 2e8 + rng.uniform(0, 20, 20_000)
    u = rng.uniform(0, 1, 20_000)
    rms = [np.sqrt(np.mean((multiphase_counts(cycles, u, n).mean(-1) - cycles) ** 2)) for n in (1, 4)]
    assert rms[0] / rms[1] == pytest.approx(4.0, rel=0.05)


def test_a_measured_interval_is_within_one_resolution_of_the_truth():
    counter = MultiPhaseCounter()
    rng = np.random.default_rng(1)
    t = 1.0 + rng.uniform(-1e-6, 1e-6, 1000)
    got = counter.measure_interval_s(t, rng.uniform(0, 1, 1000))
    assert np.all(np.abs(got - t) <= counter.resolution_s * (1 + 1e-9))
